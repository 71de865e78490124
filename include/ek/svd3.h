// Batched 3x3 singular value decomposition (McAdams et al. 2011 approach:
// Jacobi eigenanalysis of A^T A with quaternion-accumulated approximate
// Givens rotations, one-sided Jacobi refinement on A V, sort, Givens QR).
//
// Output convention (rotation-variant SVD):
//   A = U diag(S) V^T, V returned (not V^T), all matrices row-major;
//   det U = det V = +1; S[0] >= S[1] >= |S[2]|; S[2] < 0 exactly when
//   det A < 0 (an inverted element).
// A matrix with a NaN or infinity gives NaN in all of its U, S, V entries;
// the other matrices of the batch are untouched by it.
// Threads: chunks of blocks on the library's helper threads, as many as
// omp_get_max_threads() (OMP_NUM_THREADS), the calling thread alone inside
// an OpenMP parallel region; results are bitwise identical for any thread
// count.
// Floating-point mode (core.h): results are the same bits whatever the
// caller's FTZ/DAZ. Subnormal inputs (entries below FLT_MIN / DBL_MIN) are
// decomposed like any other scale, even with the caller's DAZ on: a tiny
// matrix is first scaled by an exact power of two, so the budgets below
// hold relative to its s1, and outputs that are subnormal (S of a tiny A)
// are returned as such, even with the caller's FTZ on. With more sweeps
// than the default, the Jacobi sweeps on A^T A flush their own subnormals
// (kernels/svd3/svd3_core.h), so more sweeps or the exact rsqrt cost their
// operations only (README, "Subnormals").
#ifndef EK_SVD3_H
#define EK_SVD3_H

#include "batch.h"
#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

// Error budgets, relative to the largest singular value of the input, max
// over matrices, for the default options: reconstruction |A - U S V^T|_max,
// orthogonality |U^T U - I|_max and |V^T V - I|_max, |det - 1|, and
// |S - S_ref|_max. Measured by ek-verify and asserted by the tests.
#define EK_SVD3_TOL_F32 2e-5
#define EK_SVD3_TOL_F64 1e-12

// Most Jacobi sweeps on A^T A an option may ask for.
#define EK_SVD3_MAX_SWEEPS 8
// Most exact one-sided refinement sweeps an option may ask for, and the
// option value that asks for none (zero already means the default).
#define EK_SVD3_MAX_REFINE 3
#define EK_SVD3_REFINE_NONE (-1)

// Options; zero means default.
//   sweeps: Jacobi sweeps on A^T A, 0 = default for the precision,
//           1..EK_SVD3_MAX_SWEEPS as given, anything else is EK_EINVAL
//           (nothing written).
//   exact_rsqrt: 0 = default (approximate for f32, exact for f64), 1 = exact
//           1/sqrt, -1 = approximate
//           (hardware estimate refined by Newton steps).
//   refine: exact one-sided Jacobi sweeps on B = A V after the sweeps on
//           A^T A: 0 = default for the precision, 1..EK_SVD3_MAX_REFINE as
//           given, EK_SVD3_REFINE_NONE = none. With none, 4 sweeps and the
//           approximate rsqrt this is the algorithm of McAdams et al. 2011
//           as published (plus ek's scaling), so that setting can be
//           measured with ek's own code.
//   isa: EK_ISA_AUTO or a forced target; one the CPU lacks gives EK_EISA.
typedef struct {
  int sweeps;
  int exact_rsqrt;
  ek_isa isa;
  int refine;
} ek_svd3_opts;

// Sweeps and rsqrt mode (1 exact, 0 approximate) used when the option is 0
// (chosen so the default meets the budget at the lowest cost).
int ek_svd3_default_sweeps_f32(void);
int ek_svd3_default_sweeps_f64(void);
int ek_svd3_default_exact_rsqrt_f32(void);
int ek_svd3_default_exact_rsqrt_f64(void);
int ek_svd3_default_refine_f32(void);
int ek_svd3_default_refine_f64(void);

// A, U, V: n row-major 3x3 matrices; S: n x 3. opts may be NULL. U or V may
// be NULL when not wanted. 0 on success, < 0 on error. Arrays aligned to
// their element type (4 / 8 bytes), and n small enough that the byte count
// does not overflow, else EK_EINVAL and nothing written (core.h).
int ek_svd3_f32(size_t n, const float *A, float *U, float *S, float *V, const ek_svd3_opts *opts);
int ek_svd3_f64(size_t n, const double *A, double *U, double *S, double *V,
                const ek_svd3_opts *opts);

// AoSoA-native forms (layout in batch.h): A, U, V have 9 planes, S has 3;
// nblocks blocks of EK_LANES_F32 / EK_LANES_F64 matrices.
int ek_svd3_aosoa_f32(size_t nblocks, const float *A, float *U, float *S, float *V,
                      const ek_svd3_opts *opts);
int ek_svd3_aosoa_f64(size_t nblocks, const double *A, double *U, double *S, double *V,
                      const ek_svd3_opts *opts);

// Polar decomposition A = R Ssym from the same SVD: R = U V^T (a rotation,
// det +1, so R is the closest rotation to A even when det A < 0) and
// Ssym = V diag(S) V^T (symmetric; indefinite for inverted A). Ssym may be
// NULL. Same options, errors and NaN behaviour as ek_svd3_*.
// For R alone from a guess (e.g. the previous time step's rotation), the
// warm-started polar (ek_polar3_warm_*, polar.h) is several times cheaper.
int ek_polar3_f32(size_t n, const float *A, float *R, float *Ssym, const ek_svd3_opts *opts);
int ek_polar3_f64(size_t n, const double *A, double *R, double *Ssym, const ek_svd3_opts *opts);
int ek_polar3_aosoa_f32(size_t nblocks, const float *A, float *R, float *Ssym,
                        const ek_svd3_opts *opts);
int ek_polar3_aosoa_f64(size_t nblocks, const double *A, double *R, double *Ssym,
                        const ek_svd3_opts *opts);

#ifdef __cplusplus
}
#endif
#endif
