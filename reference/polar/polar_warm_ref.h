// Scalar double replica of the warm-started polar iteration
// (kernels/polar/polar_warm_core.h: Mueller et al. 2016 with the Newton step
// of Kugelstadt et al. 2018's analytic polar decomposition). Not an oracle:
// the oracle of the warm polar's answer is the SVD polar, ek_polar3_ref
// (reference/svd3/svd3_ref.h). This replica exists so the kernels'
// iteration itself (guess -> quaternion, step, count) can be compared with
// the same algorithm in plain double, which catches lane mixing and
// transcription bugs that a distance to the converged answer would hide.
// Depends on nothing of ek's.
#ifndef EK_POLAR_WARM_REF_H
#define EK_POLAR_WARM_REF_H

#ifdef __cplusplus
extern "C" {
#endif

// What a f64 kernel is held to against this replica at the same iteration
// count (tests/test_polar_warm.c): max_ij |R - R_rep|. Same algorithm, so
// only rounding (FMA contraction, operation order) differs; a swapped lane
// shows as an O(1) difference.
#define EK_POLAR_WARM_REPLICA_TOL 1e-12

// R: in, the guess; out, the rotation after `iters` (>= 1) steps. A and R
// row-major 3x3. Returns 0, or -1 (R all NaN) for a non-finite A or guess
// or iters < 1.
int ek_polar_warm_ref(const double A[9], double R[9], int iters);

#ifdef __cplusplus
}
#endif
#endif
