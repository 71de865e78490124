// Warm-started polar decomposition: the rotation R of A = R S (S
// symmetric), iterated from a guess such as the element's rotation of the
// previous time step (Mueller et al. 2016, "A robust method to extract the
// rotational part of deformations"; Newton steps of the analytic polar
// decomposition, Kugelstadt et al. 2018, "Fast corotated FEM using operator
// splitting"). The SVD-based polar (ek_polar3_*, svd3.h) needs no guess and
// is the reference: the answer here is the same R = U V^T of the
// rotation-variant SVD (det R = +1, the rotation maximising tr(R^T A)),
// reached in a few cheap iterations when the guess is close to it.
//
// Contract:
//   - R is read as the guess and overwritten with the result (row-major, in
//     place): R always comes out a rotation (orthogonal to rounding, det +1)
//     whatever the guess and however many iterations, even where it has not
//     converged. A guess that is not a rotation is replaced by a rotation
//     (its quaternion's, Shepperd's method) in the first iteration.
//   - A fixed number of iterations (no tolerance test), so every lane does
//     the same work and results are bitwise identical for any thread count.
//   - Convergence: quadratic (Newton) once the guess is within the region
//     where the Hessian tr(M) I - sym(M), M = A R^T, is positive definite
//     (for A = R* S, S near I: a guess within about 90 degrees of the
//     answer); elsewhere each iteration takes Mueller's always-ascending
//     step, so a guess far off (a rotation of more than 90 degrees between
//     two steps) needs more iterations, and a guess exactly 180 degrees off
//     (a saddle) does not move. Inverted A (det < 0) = R* Q diag(s) Q^T with
//     one s_i < 0 and a guess near R*: when the negated stretch is the
//     smallest in magnitude, R* is the SVD polar and the iteration converges
//     (slowly as s2 - |s3| -> 0, the Hessian's smallest eigenvalue); when a
//     larger one is negated, the SVD polar is R* turned by 180 degrees, the
//     guess sits at a saddle, and R stays near the guess (continuous from
//     step to step where the SVD polar jumps). A = 0 leaves the guess's
//     rotation. README "Warm-started
//     polar" has the measured errors.
//   - A or guess with a NaN or infinity: NaN in all of that matrix's R; the
//     other matrices are untouched by it.
// Threads: chunks of blocks on the library's helper threads, as many as
// omp_get_max_threads() (OMP_NUM_THREADS), the calling thread alone inside
// an OpenMP parallel region.
#ifndef EK_POLAR_H
#define EK_POLAR_H

#include "batch.h"
#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

// Error budget of the default iterations against the SVD polar,
// max_ij |R_warm - R_svd|, on the inputs ek-verify's "polar_warm" family
// and tests/test_polar_warm.c hold it to: A = R* S with S's singular values
// in [0.5, 2] and a guess within 10 degrees of R* (random), and the F and
// previous R of the cantilever and twist scenes.
#define EK_POLAR_WARM_TOL_F32 2e-5
#define EK_POLAR_WARM_TOL_F64 1e-12

#define EK_POLAR_WARM_MAX_ITERATIONS 16

// Options; zero means default.
//   iterations: 0 = default for the precision, 1..EK_POLAR_WARM_MAX_ITERATIONS
//     as given, anything else is EK_EINVAL (nothing written).
//   isa: EK_ISA_AUTO or a forced target; one the CPU lacks gives EK_EISA.
typedef struct {
  int iterations;
  ek_isa isa;
} ek_polar_warm_opts;

int ek_polar_warm_default_iterations_f32(void);
int ek_polar_warm_default_iterations_f64(void);

// A, R: n row-major 3x3 matrices (R in: the guesses, out: the rotations).
// 0 on success, < 0 on error (NULL A or R with n > 0, misaligned arrays, a
// bad option, an unavailable ISA; nothing written).
int ek_polar3_warm_f32(size_t n, const float *A, float *R, const ek_polar_warm_opts *opts);
int ek_polar3_warm_f64(size_t n, const double *A, double *R, const ek_polar_warm_opts *opts);

// AoSoA-native forms (layout in batch.h): A and R have 9 planes; padding
// lanes hold any finite matrix (the packer's identity).
int ek_polar3_warm_aosoa_f32(size_t nblocks, const float *A, float *R,
                             const ek_polar_warm_opts *opts);
int ek_polar3_warm_aosoa_f64(size_t nblocks, const double *A, double *R,
                             const ek_polar_warm_opts *opts);

#ifdef __cplusplus
}
#endif
#endif
