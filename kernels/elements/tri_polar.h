// Internal: the polar decomposition of a 3x2 F in double, one triangle at a
// time: F = R Uc (seed 003 eqs. 15-20) through the eigen-decomposition of
// C = F^T F by one exact Jacobi rotation (Golub and Van Loan, "Matrix
// Computations", 4th ed., alg. 8.5.1, the symmetric Schur decomposition of
// a 2x2), F = U diag(sigma) V^T with U 3x2 orthonormal and sigma0 >=
// sigma1 >= 0. Rank-deficient F: U is completed to an orthonormal pair, so
// R = U V^T is orthonormal and finite.
//
// Why a second polar beside the vectorised one (tri_polar_vec.h, behind
// ek_polar32 and the vector membrane kernels): this scalar Jacobi form is
// what the default double paths have always run (ek_cloth_energy_f64,
// ek_cloth_hessian_apply_f64 / _diagonal_f64 and ek_cloth_fields_f64 for
// ARAP and the fields J, s1, s2 of every cloth frame; the cloth XPBD; the
// force kernel's slow ARAP lanes), so every cloth scene and ek-hash row
// keeps its bits; the two algorithms round differently. Retiring it means
// moving those paths to the vector kernels and re-baselining the hashes.
#ifndef EK_KERNELS_ELEMENTS_TRI_POLAR_H
#define EK_KERNELS_ELEMENTS_TRI_POLAR_H

#include <math.h>

typedef struct {
  double U[6]; // 3x2 row-major, orthonormal columns u0, u1
  double V[4]; // 2x2 row-major rotation, columns v0, v1
  double sigma[2];
  double R[6]; // U V^T, 3x2 row-major
  double n[3]; // u0 x u1
} cloth_svd32;

static inline void cloth_svd32_of(const double F[6], cloth_svd32 *d) {
  double f0[3] = {F[0], F[2], F[4]}, f1[3] = {F[1], F[3], F[5]};
  double C00 = f0[0] * f0[0] + f0[1] * f0[1] + f0[2] * f0[2];
  double C01 = f0[0] * f1[0] + f0[1] * f1[1] + f0[2] * f1[2];
  double C11 = f1[0] * f1[0] + f1[1] * f1[1] + f1[2] * f1[2];
  // Jacobi rotation [[c, s], [-s, c]] diagonalising C (Golub-Van Loan alg.
  // 8.5.1): tan = t, the smaller root of t^2 + 2 tau t - 1 = 0.
  double c = 1, s = 0, l0 = C00, l1 = C11;
  if (C01 != 0) {
    double tau = (C11 - C00) / (2 * C01);
    double t = (tau >= 0 ? 1.0 : -1.0) / (fabs(tau) + sqrt(1 + tau * tau));
    c = 1 / sqrt(1 + t * t);
    s = t * c;
    l0 = C00 - t * C01;
    l1 = C11 + t * C01;
  }
  double v0[2] = {c, -s}, v1[2] = {s, c};
  if (l1 > l0) { // sort: sigma0 >= sigma1; (v1, -v0) keeps det V = +1
    double tl = l0;
    l0 = l1;
    l1 = tl;
    double a0 = v0[0], a1 = v0[1];
    v0[0] = v1[0], v0[1] = v1[1];
    v1[0] = -a0, v1[1] = -a1;
  }
  d->sigma[0] = sqrt(fmax(l0, 0));
  d->sigma[1] = sqrt(fmax(l1, 0));
  d->V[0] = v0[0], d->V[1] = v1[0], d->V[2] = v0[1], d->V[3] = v1[1];
  double u0[3], u1[3];
  for (int i = 0; i < 3; ++i) {
    u0[i] = f0[i] * v0[0] + f1[i] * v0[1];
    u1[i] = f0[i] * v1[0] + f1[i] * v1[1];
  }
  double n0 = sqrt(u0[0] * u0[0] + u0[1] * u0[1] + u0[2] * u0[2]);
  if (!(n0 > 0) || !isfinite(n0)) {
    u0[0] = 1, u0[1] = 0, u0[2] = 0; // F = 0 (or not finite): any frame
    n0 = 1;
    if (!isfinite(d->sigma[0]))
      u0[0] = NAN;
  }
  for (int i = 0; i < 3; ++i)
    u0[i] /= n0;
  // Gram-Schmidt keeps u1 orthogonal to u0 when sigma1 << sigma0.
  double p = u0[0] * u1[0] + u0[1] * u1[1] + u0[2] * u1[2];
  for (int i = 0; i < 3; ++i)
    u1[i] -= p * u0[i];
  double n1 = sqrt(u1[0] * u1[0] + u1[1] * u1[1] + u1[2] * u1[2]);
  if (!(n1 > 1e-12 * n0 * d->sigma[0]) || n1 == 0) {
    // Rank <= 1: any unit vector orthogonal to u0 completes the frame; take
    // u0 x e_k for the axis e_k least aligned with u0.
    int k = fabs(u0[0]) <= fabs(u0[1]) && fabs(u0[0]) <= fabs(u0[2]) ? 0
            : fabs(u0[1]) <= fabs(u0[2])                             ? 1
                                                                     : 2;
    double e[3] = {0, 0, 0};
    e[k] = 1;
    u1[0] = u0[1] * e[2] - u0[2] * e[1];
    u1[1] = u0[2] * e[0] - u0[0] * e[2];
    u1[2] = u0[0] * e[1] - u0[1] * e[0];
    n1 = sqrt(u1[0] * u1[0] + u1[1] * u1[1] + u1[2] * u1[2]);
  }
  for (int i = 0; i < 3; ++i)
    u1[i] /= n1;
  for (int i = 0; i < 3; ++i) {
    d->U[2 * i] = u0[i], d->U[2 * i + 1] = u1[i];
    for (int j = 0; j < 2; ++j)
      d->R[2 * i + j] = u0[i] * d->V[2 * j] + u1[i] * d->V[2 * j + 1];
  }
  d->n[0] = u0[1] * u1[2] - u0[2] * u1[1];
  d->n[1] = u0[2] * u1[0] - u0[0] * u1[2];
  d->n[2] = u0[0] * u1[1] - u0[1] * u1[0];
}

#endif
