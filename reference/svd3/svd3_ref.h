// Scalar double-precision oracles for the 3x3 SVD and polar decomposition.
//
// Convention (the same as include/ek/svd3.h, the rotation-variant SVD):
//   A = U diag(S) V^T, V returned (not V^T), all matrices row-major 3x3;
//   det U = det V = +1; S[0] >= S[1] >= |S[2]|; S[2] < 0 exactly when
//   det A < 0.
// This header depends on nothing of ek's: reference/ is an oracle that needs
// libc, libm and LAPACK only.
#ifndef EK_SVD3_REF_H
#define EK_SVD3_REF_H

#ifdef __cplusplus
extern "C" {
#endif

// What the LAPACK reference itself is held to (tests/test_svd3_ref.c):
// reconstruction |A - U S V^T|_max / s1, |U^T U - I|_max, |V^T V - I|_max,
// |det - 1| and Ssym symmetry. dgesvd is backward stable with an error of a
// small multiple of eps = 2.2e-16 (LAPACK Users' Guide, section 4.9); 1e-13
// is ~450 eps, room for the 3x3 products of the check itself.
#define EK_SVD3_REF_TOL 1e-13

// What a f64 kernel is held to against ek_svd3_mcadams_ref run with the
// kernel's own knobs (tests/test_svd3.c): |S - S_rep|_max / s1, and U, V
// entries where the singular values are apart by more than
// EK_SVD3_REPLICA_GAP * s1 (singular vectors move by ~eps / gap). Same
// algorithm, so only rounding (FMA contraction, operation order) differs;
// a swapped or mixed lane shows as an O(1) difference.
#define EK_SVD3_REPLICA_TOL 1e-12
#define EK_SVD3_REPLICA_GAP 1e-2

// LAPACK dgesvd in double, converted to ek's rotation-variant convention.
// Returns 0, or -1 (all outputs NaN) if A has a non-finite entry or LAPACK
// reports a failure (info != 0, printed to stderr).
int ek_svd3_ref(const double A[9], double U[9], double S[3], double V[9]);

// Polar decomposition from ek_svd3_ref: R = U V^T (a rotation, det +1, the
// closest rotation to A) and Ssym = V diag(S) V^T (symmetric, indefinite when
// det A < 0), so A = R Ssym. Ssym may be NULL. Returns as ek_svd3_ref.
int ek_polar3_ref(const double A[9], double R[9], double Ssym[9]);

// A plain scalar double replica of ek's kernel algorithm
// (kernels/svd3/svd3_core.h, McAdams et al. 2011 with a
// one-sided Jacobi refinement), exact 1/sqrt throughout. Not an independent
// oracle (that is ek_svd3_ref): it exists so the f64 kernels can be compared
// with the same algorithm to ~1e-12, which catches lane mixing and
// transcription bugs that a budget check alone would miss.
//   sweeps: Jacobi sweeps on A^T A (>= 0); refine: one-sided Jacobi sweeps
//   on B = A V (>= 0). Returns 0, or -1 (outputs NaN) for a non-finite A or
//   negative knobs.
int ek_svd3_mcadams_ref(const double A[9], int sweeps, int refine, double U[9], double S[3],
                        double V[9]);

#ifdef __cplusplus
}
#endif
#endif
