// ek_check, warm-started polar (include/ek/polar.h): its inputs (A = R* S
// with a guess near R*, and the F of a running simulation) and its error
// against the SVD polar, shared by tests/test_polar_warm.c, ek-verify's
// "polar_warm" family and ek-bench's warm polar rows.
#ifndef EK_CHECK_POLAR_WARM_H
#define EK_CHECK_POLAR_WARM_H

#include <stddef.h>

#include <ek/core.h>

#include "check.h"

#ifdef __cplusplus
extern "C" {
#endif

// R = the rotation by `angle` (radians) about the unit axis n.
void ek_check_axis_angle(const double n[3], double angle, double R[9]);

// n cases: A = R* S with R* uniform on SO(3), S = Q diag(s) Q^T (Q uniform,
// s_i uniform in [|s_min|, |s_max|]; s_min < 0 negates the smallest, an
// inverted A whose SVD polar is still R*; s_max < 0 negates the largest, an
// inverted A whose SVD polar is R* turned by 180 degrees, so the guess sits
// at a saddle of tr(R^T A)), and the guess G = E R* with E a rotation about a uniform axis
// by an angle uniform in [deg_min, deg_max] degrees. A, G: n x 9.
void ek_check_warm_cases(ek_rng *rng, size_t n, double s_min, double s_max, double deg_min,
                         double deg_max, double *A, double *G);

// max_ij |R - R_ref| of one matrix (NaN if either has a NaN).
double ek_check_rdiff9(const double R[9], const double R_ref[9]);
// max_ij |R - R_svd| with R_svd the LAPACK polar (ek_polar3_ref) of A as a
// kernel of that precision saw it (bits 32: A rounded to float); NaN if R
// has a NaN.
double ek_check_polar_error(int bits, const double A[9], const double R[9]);

// The warm polar kernel on double data (bits 32 rounds A and R to float and
// back; aosoa 1 packs and calls the AoSoA entry point). R: in, guesses;
// out, rotations. 0 or the kernel's rc.
int ek_check_run_polar_warm(int bits, int aosoa, size_t n, const double *A, double *R, ek_isa isa,
                            int iterations);

// The warm polar over a running simulation: the scene `scene_path` (its
// model replaced by fixed corotated when it takes no polar, so every scene
// has F to decompose; force kernel as the scene says, polar "svd") runs
// `steps` steps; every `stride` steps the per-tet F is taken, R starts as
// the SVD polar (LAPACK) of the first F, and each later F's R is the warm
// polar (bits, isa, iterations) from the R before: the chain a loop keeps.
// Error per tet and sample: max_ij |R_warm - R_svd| (LAPACK polar of the
// same F rounded to the precision). Returns 0 and fills max and p99 (over
// tets x samples) and the sample count, or -1 with err set.
typedef struct {
  double max, p99, max_angle_deg; // max_angle_deg: largest rotation of R_svd between samples
  size_t tets, samples;
} ek_check_warm_run;

int ek_check_polar_warm_sim(const char *scene_path, long steps, long stride, int bits, ek_isa isa,
                            int iterations, ek_check_warm_run *out, char *err, size_t errlen);

// The F (ntets x 9 per sample, double) and LAPACK polar R of the same run,
// for timing rows: *F and *R (nsamples x ntets x 9) are malloc'ed, the
// caller frees them. 0, or -1 with err set.
int ek_check_sim_F(const char *scene_path, long steps, long stride, double **F, double **R,
                   size_t *ntets, size_t *nsamples, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
