// ek_check for the cloth kernels (include/ek/cloth.h): the input families
// (3x2 F for polar32, point sets for Kabsch, triangles and tets with
// velocities for the velocity gradients) and the error metrics held against
// EK_CLOTH_TOL_*, shared by tests/test_cloth.c and ek-verify's cloth family.
#ifndef EK_CHECK_CLOTH_H
#define EK_CHECK_CLOTH_H

#include <stddef.h>
#include <stdint.h>

#include "check.h"

#ifdef __cplusplus
extern "C" {
#endif

// ---- polar32 ----
// A family fills n 3x2 matrices (n x 6, row-major). Flags as the SVD
// catalogue's (EK_FAMILY_F32 / _F64 / _BOTH, EK_FAMILY_NONFINITE).
typedef struct {
  const char *name;
  void (*generate)(ek_rng *rng, size_t n, double *F);
  int flags;
  const char *note;
} ek_polar32_family;

extern const ek_polar32_family ek_polar32_families[];
extern const int ek_polar32_nfamilies;

// Metrics of cloth.h's polar32 budget, relative to sigma1 = sigma_ref[0]
// (absolute for F = 0); rdiff = |R - R_ref|_max * sigma2 / sigma1 (0 when
// sigma2 = 0: no polar factor is unique there).
typedef struct {
  double recon; // |F - R Uc|_max / sigma1
  double orth;  // |R^T R - I|_max
  double uc;    // |Uc - Uc_ref|_max / sigma1, Uc's symmetry included
  double sigma; // eigenvalues of Uc against the reference's singular values
  double rdiff;
  int nonfinite;
} ek_polar32_metrics;

void ek_check_polar32(const double F[6], const double R[6], const double Uc[4],
                      const double R_ref[6], const double Uc_ref[4], const double sigma_ref[2],
                      ek_polar32_metrics *m);
double ek_polar32_metrics_worst(const ek_polar32_metrics *m);

// ---- Kabsch ----
// nsets point sets (offsets nsets + 1), P, Q, w (w NULL when the family has
// no weights); rounded to float when bits == 32.
typedef struct {
  char name[32];
  int bits; // the precision the points were rounded to
  size_t nsets, npoints;
  size_t *offsets;
  double *P, *Q, *w;
  double *R_true; // the rotation Q was made with (nsets x 9)
} ek_kabsch_set;

extern const char *const ek_kabsch_families[];
extern const int ek_kabsch_nfamilies;
void ek_kabsch_set_init(ek_kabsch_set *s, const char *family, uint64_t seed, size_t nsets,
                        int bits);
void ek_kabsch_set_free(ek_kabsch_set *s);

// What the kernels treat as no spread (cloth.h): 8 eps of the precision,
// the reference's spread_eps.
double ek_kabsch_spread_eps(int bits);

// Metrics of set s's R against the LAPACK reference (cloth.h): orth, det,
// the objective's excess over the reference's relative to its size, and
// |R - R_ref|_max (s2 + s3) / s1 where s2 + s3 > 0.
typedef struct {
  double orth, det, objective, rdiff;
  int nonfinite;
} ek_kabsch_metrics;
void ek_check_kabsch(const ek_kabsch_set *s, size_t set, const double R[9], ek_kabsch_metrics *m);
double ek_kabsch_metrics_worst(const ek_kabsch_metrics *m);

// ---- Velocity gradients and the triangle F ----
// n elements of `corners` (3 triangles, 4 tets) corners: x and v, n x
// (3 corners) values each, of a named family (ek_velgrad_families).
extern const char *const ek_velgrad_families[];
extern const int ek_velgrad_nfamilies;
void ek_velgrad_generate(const char *family, uint64_t seed, int corners, size_t n, double *x,
                         double *v);

// The error of L against L_ref in cloth.h's norm: |L - L_ref|_max /
// (|Vs|_F |G|_2 cond), G = Ds^-1 (tets) or Ds^+ (triangles), |G|_2 =
// 1 / sigma_min and cond = sigma_max / sigma_min from the reference SVD of
// Ds (the bound any computed inverse is held to, as mesh.h's EK_MESH_TOL);
// a triangle with sigma2 <= 3 eps sigma1 (eps of `bits`) is rank 1 there:
// sigma_min = sigma1. 0 when both are 0.
double ek_check_velgrad_err(int corners, int bits, const double *x, const double *v,
                            const double L[9], const double L_ref[9]);

// |F - F_ref|_max / (|Ds|_max |Dm_inv|_max) for one triangle.
double ek_check_tri_F_err(const double x[9], const double Dm_inv[4], const double F[6],
                          const double F_ref[6]);

// The kernels on double data (rounded to float and back for bits == 32),
// ISA forced: ek_polar32_ex_*, ek_kabsch_ex_*, ek_tri_velocity_gradient_*.
int ek_check_run_polar32(int bits, ek_isa isa, size_t n, const double *F, double *R, double *Uc);
int ek_check_run_kabsch(int bits, ek_isa isa, const ek_kabsch_set *s, double *R);
int ek_check_run_tri_velgrad(int bits, ek_isa isa, size_t n, const double *x, const double *v,
                             double *L, double *D, double *W);

#ifdef __cplusplus
}
#endif
#endif
