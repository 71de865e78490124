// Reference cloth forces (cloth_force_ref.h). Membrane energies in the
// metric form: with Gbar = E^T E, g = Ds^T Ds and Ct = Gbar^-1 g (similar
// to C = F^T F of the kernels, so with the same invariants),
//   StVK: Et = (Ct - I)/2, Psi = mu tr(Et^2) + lambda/2 tr(Et)^2,
//         dPsi = tr(St dEt), St = 2 mu Et + lambda tr(Et) I,
//         dEt = Gbar^-1 dg / 2, dg = dDs^T Ds + Ds^T dDs, so
//         dPsi/dDs = Ds (B + B^T), B = St Gbar^-1 / 2;
//   ARAP: Psi = mu sum_i (sigma_i - 1)^2 over the two nonzero singular
//         values of F3 = Ds Gbar^-1 E^T (3x3, rank 2), dPsi/dF3 =
//         2 mu U diag(sigma_i - 1, 0) V^T, dPsi/dDs = dPsi/dF3 (Gbar^-1 E^T)^T.
// Bending: Bergou et al. 2006 sec. 4 (cloth_force.h).
#include "cloth_force_ref.h"

#include <math.h>
#include <string.h>

extern void dgesvd_(const char *jobu, const char *jobvt, const int *m, const int *n, double *a,
                    const int *lda, double *s, double *u, const int *ldu, double *vt,
                    const int *ldvt, double *work, const int *lwork, int *info);

static void cross(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}
static double dot(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

double cloth_ref_area(const double *X0, const double *X1, const double *X2) {
  double a[3], b[3], n[3];
  for (int i = 0; i < 3; ++i)
    a[i] = X1[i] - X0[i], b[i] = X2[i] - X0[i];
  cross(a, b, n);
  return 0.5 * sqrt(dot(n, n));
}

// cot of the angle between u and v, through the angle itself.
static double cot_ref(const double *u, const double *v) {
  double c[3];
  cross(u, v, c);
  return 1.0 / tan(atan2(sqrt(dot(c, c)), dot(u, v)));
}

void cloth_ref_hinge_k(const double *X, const int32_t q[4], double k[4]) {
  const double *x0 = X + 3 * q[0], *x1 = X + 3 * q[1], *x2 = X + 3 * q[2], *x3 = X + 3 * q[3];
  double e0[3], e1[3], e2[3], e3[3], e4[3], m0[3];
  for (int i = 0; i < 3; ++i) {
    e0[i] = x1[i] - x0[i], e1[i] = x2[i] - x0[i], e2[i] = x3[i] - x0[i];
    e3[i] = x2[i] - x1[i], e4[i] = x3[i] - x1[i], m0[i] = -e0[i];
  }
  double c01 = cot_ref(e0, e1), c02 = cot_ref(e0, e2), c03 = cot_ref(m0, e3), c04 = cot_ref(m0, e4);
  double A = cloth_ref_area(x0, x1, x2) + cloth_ref_area(x0, x1, x3);
  double w = sqrt(3.0 / A);
  k[0] = w * (c03 + c04);
  k[1] = w * (c01 + c02);
  k[2] = -w * (c01 + c03);
  k[3] = -w * (c02 + c04);
}

// 2x2 inverse; 3x2 columns a, b of a row-major 3x2 M: M[2i], M[2i + 1].
static void inv2(const double A[4], double B[4]) {
  double d = A[0] * A[3] - A[1] * A[2];
  B[0] = A[3] / d, B[1] = -A[1] / d, B[2] = -A[2] / d, B[3] = A[0] / d;
}
// C (2x2) = A^T B for 3x2 A, B.
static void atb32(const double *A, const double *B, double C[4]) {
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) {
      C[2 * r + c] = 0;
      for (int i = 0; i < 3; ++i)
        C[2 * r + c] += A[2 * i + r] * B[2 * i + c];
    }
}

double cloth_ref_membrane(const cloth_ref_params *p, const double E[6], const double Ds[6],
                          double dPsi_dDs[6]) {
  double Gb[4], g[4], Gi[4];
  atb32(E, E, Gb);
  atb32(Ds, Ds, g);
  inv2(Gb, Gi);
  if (p->model == 0) {
    double Ct[4] = {0, 0, 0, 0};
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c)
        for (int k = 0; k < 2; ++k)
          Ct[2 * r + c] += Gi[2 * r + k] * g[2 * k + c];
    double Et[4] = {0.5 * (Ct[0] - 1), 0.5 * Ct[1], 0.5 * Ct[2], 0.5 * (Ct[3] - 1)};
    double tr = Et[0] + Et[3];
    double trE2 = Et[0] * Et[0] + Et[1] * Et[2] + Et[2] * Et[1] + Et[3] * Et[3];
    double psi = p->mu * trE2 + 0.5 * p->lambda * tr * tr;
    if (dPsi_dDs) {
      double St[4] = {2 * p->mu * Et[0] + p->lambda * tr, 2 * p->mu * Et[1], 2 * p->mu * Et[2],
                      2 * p->mu * Et[3] + p->lambda * tr};
      double B[4] = {0, 0, 0, 0};
      for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 2; ++c)
          for (int k = 0; k < 2; ++k)
            B[2 * r + c] += 0.5 * St[2 * r + k] * Gi[2 * k + c];
      double S[4] = {B[0] + B[0], B[1] + B[2], B[2] + B[1], B[3] + B[3]};
      for (int i = 0; i < 3; ++i)
        for (int c = 0; c < 2; ++c)
          dPsi_dDs[2 * i + c] = Ds[2 * i] * S[c] + Ds[2 * i + 1] * S[2 + c];
    }
    return psi;
  }
  // ARAP through the 3x3 F3 = Ds Gplus, Gplus = Gbar^-1 E^T (2x3).
  double Gp[6];
  for (int r = 0; r < 2; ++r)
    for (int j = 0; j < 3; ++j)
      Gp[3 * r + j] = Gi[2 * r] * E[2 * j] + Gi[2 * r + 1] * E[2 * j + 1];
  double F3[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      F3[3 * i + j] = Ds[2 * i] * Gp[j] + Ds[2 * i + 1] * Gp[3 + j];
  // LAPACK is column-major: pass F3^T's storage as F3 (row-major F3 is
  // column-major F3^T), so U and V swap roles.
  double a[9], S[3], u[9], vt[9], work[64];
  memcpy(a, F3, sizeof a);
  int three = 3, lwork = 64, info = 0;
  dgesvd_("A", "A", &three, &three, a, &three, S, u, &three, vt, &three, work, &lwork, &info);
  // a = F3^T = U' S V'^T (column-major) -> F3 = V' S U'^T: F3's left
  // vectors are V' (rows of vt), its right vectors U' (columns of u).
  double psi = p->mu * ((S[0] - 1) * (S[0] - 1) + (S[1] - 1) * (S[1] - 1));
  if (dPsi_dDs) {
    double P3[9];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        // Left vector k of F3, entry i: vt column-major (k, i) = vt[k + 3 i];
        // right vector k, entry j: u column-major (j, k) = u[j + 3 k].
        P3[3 * i + j] = 0;
        for (int k = 0; k < 2; ++k)
          P3[3 * i + j] += 2 * p->mu * (S[k] - 1) * vt[k + 3 * i] * u[j + 3 * k];
      }
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 2; ++c) {
        dPsi_dDs[2 * i + c] = 0;
        for (int j = 0; j < 3; ++j)
          dPsi_dDs[2 * i + c] += P3[3 * i + j] * Gp[3 * c + j];
      }
  }
  return psi;
}

double cloth_ref_forces(const cloth_ref_params *p, size_t nverts, const double *X, size_t ntris,
                        const int32_t *tris, size_t nhinges, const int32_t *hinges, const double *x,
                        double *f) {
  if (f)
    memset(f, 0, 3 * nverts * sizeof(double));
  double energy = 0;
  for (size_t t = 0; t < ntris; ++t) {
    const int32_t *q = tris + 3 * t;
    double E[6], Ds[6], G[6];
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 2; ++c) {
        E[2 * i + c] = X[3 * q[c + 1] + i] - X[3 * q[0] + i];
        Ds[2 * i + c] = x[3 * q[c + 1] + i] - x[3 * q[0] + i];
      }
    double A = cloth_ref_area(X + 3 * q[0], X + 3 * q[1], X + 3 * q[2]);
    energy += A * cloth_ref_membrane(p, E, Ds, G);
    if (f)
      for (int i = 0; i < 3; ++i) {
        f[3 * q[1] + i] -= A * G[2 * i];
        f[3 * q[2] + i] -= A * G[2 * i + 1];
        f[3 * q[0] + i] += A * (G[2 * i] + G[2 * i + 1]);
      }
  }
  for (size_t h = 0; h < nhinges && p->bending > 0; ++h) {
    const int32_t *q = hinges + 4 * h;
    double k[4], s[3] = {0, 0, 0};
    cloth_ref_hinge_k(X, q, k);
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i)
        s[i] += k[c] * x[3 * q[c] + i];
    energy += 0.5 * p->bending * dot(s, s);
    if (f)
      for (int c = 0; c < 4; ++c)
        for (int i = 0; i < 3; ++i)
          f[3 * q[c] + i] -= p->bending * k[c] * s[i];
  }
  return energy;
}
