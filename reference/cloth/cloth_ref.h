// Scalar double-precision oracles for the cloth kernels (include/ek/cloth.h
// states the conventions; this header depends on nothing of ek's). Each
// takes a different route from its kernel, so it can catch the kernel's
// algorithmic errors: Gram-Schmidt for the rest frame, LAPACK dgesvd for the
// polar decomposition of a 3x2 F and for Kabsch, LAPACK dgesv (LU) for the
// tet velocity gradient and dgesvd's pseudo-inverse for the triangle's.
#ifndef EK_CLOTH_REF_H
#define EK_CLOTH_REF_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

// What the references are held to by tests/test_cloth_ref.c (exact
// identities on their own outputs: reconstruction, orthogonality, the rest
// frame, rigid motions), relative to the scale of the input; ~450 eps, room
// for the products of the checks themselves (as EK_SVD3_REF_TOL).
#define EK_CLOTH_REF_TOL 1e-13

// The rest frame of cloth.h by Gram-Schmidt: t1 = E1 / |E1|,
// t2 = (E2 - (E2.t1) t1) / |...|, Dm = [[E1.t1, E2.t1], [0, E2.t2]] and its
// 2x2 inverse by the adjugate; area = |E1| (E2.t2) / 2. Returns 0, or -1
// (nothing written) if 2A <= rel (longest edge)^2 or a coordinate is not
// finite.
int ek_tri_rest_ref(const double X[9], double rel, double Dm_inv[4], double *area);

// F = [x1 - x0, x2 - x0] Dm_inv (3x2 row-major).
void ek_tri_F_ref(const double x[9], const double Dm_inv[4], double F[6]);

// Polar decomposition F = R Uc of a 3x2 F from dgesvd (on F scaled by its
// largest entry, then scaled back): F = U S V^T (thin),
// R = U V^T, Uc = V diag(S) V^T; sigma = S (descending, >= 0). For a rank-
// deficient F, dgesvd's R is one of the polar factors (none is unique).
// Returns 0, or -1 (outputs NaN) for a non-finite F or a LAPACK failure.
int ek_polar32_ref(const double F[6], double R[6], double Uc[4], double sigma[2]);

// The seed's own route (seed 003 eqs. 15-20, 2x2 and 3x2 alike): the
// eigen-decomposition of C = F^T F by LAPACK dsyev, Uc = sum sqrt(lambda_i)
// v_i v_i^T with negative eigenvalues (rounding) clamped to 0 (the seed took
// sqrt of -0 / negative eigenvalues and got NaN), R = F Uc^-1 (only where
// Uc is invertible; R is NaN otherwise). rows of F (r x 2): 2 (the seed's
// xy-projected 2x2 F) or 3. Returns 0, or -1 on a LAPACK failure.
int ek_polar_eig_ref(int rows, const double *F, double *R, double Uc[4], double sigma[2]);

// Kabsch (seed 003 eqs. 21-23): H = sum_k w_k (p_k - pbar)(q_k - qbar)^T,
// dgesvd H = U S V^T, d = sign det(V U^T), R = V diag(1, 1, d) U^T (3x3
// row-major), minimising sum_k w_k |R (p_k - pbar) - (q_k - qbar)|^2. w may
// be NULL (all 1). s: the signed singular values of M = H^T in ek's
// rotation-variant convention (s3 = d sigma3), or NULL. n == 0 or no spread
// (the centred points of P or of Q all within spread_eps times the largest
// coordinate of their centroid: coincident up to its rounding): R = I.
// Returns 0, or -1 on a LAPACK failure.
int ek_kabsch_ref(size_t n, const double *P, const double *Q, const double *w, double spread_eps,
                  double R[9], double s[3]);

// The Kabsch objective sum_k w_k |R (p_k - pbar) - (q_k - qbar)|^2, and its
// cancellation-free size sum_k w_k (|p_k - pbar|^2 + |q_k - qbar|^2).
double ek_kabsch_objective_ref(size_t n, const double *P, const double *Q, const double *w,
                               const double R[9], double *size);

// Tet velocity gradient L = Vs Ds^-1 by LU (dgesv on Ds^T L^T = Vs^T); x, v
// the 4 corners (12 values each). Returns 0, or -1 (L NaN) if Ds is exactly
// singular.
int ek_tet_velgrad_ref(const double x[12], const double v[12], double L[9]);

// Triangle velocity gradient L = Vs Ds^+ with Ds^+ from dgesvd, singular
// values <= rcond * sigma1 treated as 0; x, v the 3 corners (9 values each).
int ek_tri_velgrad_ref(const double x[9], const double v[9], double rcond, double L[9]);

// D = (L + L^T)/2, W = (L - L^T)/2 (seed 003 eqs. 30-31).
void ek_LDW_ref(const double L[9], double D[9], double W[9]);

#ifdef __cplusplus
}
#endif
#endif
