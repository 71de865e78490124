// Input families and metrics of the cloth kernels (check_cloth.h).
#include "check_cloth.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ek/cloth.h>

#include "cloth/cloth_ref.h"
#include "svd3/svd3_ref.h"

// ---- polar32 families -----------------------------------------------------

// Random 3x2 with orthonormal columns (two columns of a random rotation).
static void random_frame(ek_rng *rng, double U[6]) {
  double Q[9];
  ek_rng_rotation(rng, Q);
  for (int i = 0; i < 3; i++)
    U[2 * i] = Q[3 * i], U[2 * i + 1] = Q[3 * i + 1];
}

// F = U diag(s1, s2) V^T, V a random 2x2 rotation.
static void with_sigma(ek_rng *rng, double s1, double s2, double F[6]) {
  double U[6], t = 6.283185307179586 * ek_rng_uniform(rng), c = cos(t), s = sin(t);
  random_frame(rng, U);
  double V[4] = {c, -s, s, c};
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 2; j++)
      F[2 * i + j] = U[2 * i] * s1 * V[2 * j] + U[2 * i + 1] * s2 * V[2 * j + 1];
}

static void gen_random(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < 6 * n; k++)
    F[k] = ek_rng_gauss(rng);
}

static void gen_plane_xy(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < n; k++) {
    for (int j = 0; j < 4; j++)
      F[6 * k + j] = ek_rng_gauss(rng);
    F[6 * k + 4] = F[6 * k + 5] = 0;
  }
}

// A triangle turned over: F = Q [M; 0] with det M < 0 (a 2D inversion,
// which in 3D is a rotation of the triangle with its normal reversed).
static void gen_flipped(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < n; k++) {
    double Q[9], M[4];
    ek_rng_rotation(rng, Q);
    for (int j = 0; j < 4; j++)
      M[j] = ek_rng_gauss(rng);
    if (M[0] * M[3] - M[1] * M[2] > 0)
      M[1] = -M[1], M[3] = -M[3];
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 2; j++)
        F[6 * k + 2 * i + j] = Q[3 * i] * M[j] + Q[3 * i + 1] * M[2 + j];
  }
}

// Exactly rank 1: f2 = alpha f1 with alpha = +-2^k (exact in any precision).
static void gen_rank1(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < n; k++) {
    double alpha = ldexp(ek_rng_uniform(rng) < 0.5 ? -1 : 1, (int)(ek_rng_next(rng) % 7) - 3);
    int swap = ek_rng_next(rng) % 2;
    for (int i = 0; i < 3; i++) {
      double a = ek_rng_gauss(rng);
      F[6 * k + 2 * i + swap] = a;
      F[6 * k + 2 * i + 1 - swap] = alpha * a;
    }
  }
}

// F = 0 with random signs of zero.
static void gen_rank0(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < 6 * n; k++)
    F[k] = ek_rng_uniform(rng) < 0.5 ? -0.0 : 0.0;
}

// The seed's -0 (slide 15): diagonal and anti-diagonal in-plane F whose
// zeros are -0, so C has -0 off-diagonal entries and one row may be all -0.
static void gen_neg_zero(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < n; k++) {
    double *f = F + 6 * k;
    for (int j = 0; j < 6; j++)
      f[j] = -0.0;
    double a = 0.5 + ek_rng_uniform(rng), b = 0.5 + ek_rng_uniform(rng);
    switch (ek_rng_next(rng) % 4) {
    case 0:
      f[0] = a, f[3] = b;
      break;
    case 1:
      f[1] = a, f[2] = -b;
      break;
    case 2:
      f[0] = a;
      break; // rank 1, second column -0
    default:
      f[4] = -a, f[3] = b;
      break;
    }
  }
}

// sigma2 / sigma1 = 10^-k, k uniform in [3, 15]: the near-collinear triangle
// (tiny eigenvalue of C).
static void gen_tiny_sigma2(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < n; k++)
    with_sigma(rng, 1, pow(10, -3 - 12 * ek_rng_uniform(rng)), F + 6 * k);
}

// sigma1 = sigma2 (C a multiple of I) and nearly so.
static void gen_repeated(ek_rng *rng, size_t n, double *F) {
  for (size_t k = 0; k < n; k++) {
    double s = 0.1 + ek_rng_uniform(rng);
    double gap = k % 2 ? 0 : pow(10, -4 - 10 * ek_rng_uniform(rng));
    with_sigma(rng, s, s * (1 - gap), F + 6 * k);
  }
}

static void scaled(ek_rng *rng, size_t n, double *F, double scale) {
  gen_random(rng, n, F);
  for (size_t k = 0; k < 6 * n; k++)
    F[k] *= scale;
}
static void gen_scale_1e30(ek_rng *rng, size_t n, double *F) { scaled(rng, n, F, 1e30); }
static void gen_scale_1em30(ek_rng *rng, size_t n, double *F) { scaled(rng, n, F, 1e-30); }
static void gen_scale_1e300(ek_rng *rng, size_t n, double *F) { scaled(rng, n, F, 1e300); }
static void gen_scale_1em300(ek_rng *rng, size_t n, double *F) { scaled(rng, n, F, 1e-300); }
static void gen_subnormal_f32(ek_rng *rng, size_t n, double *F) { scaled(rng, n, F, 1e-40); }
static void gen_subnormal_f64(ek_rng *rng, size_t n, double *F) { scaled(rng, n, F, 1e-310); }

// NaN or infinity in one entry of every third matrix.
static void gen_nonfinite(ek_rng *rng, size_t n, double *F) {
  gen_random(rng, n, F);
  for (size_t k = 0; k < n; k += 3)
    F[6 * k + ek_rng_next(rng) % 6] = k % 2 ? NAN : -INFINITY;
}

const ek_polar32_family ek_polar32_families[] = {
    {"random", gen_random, EK_FAMILY_BOTH, "iid N(0,1) entries"},
    {"plane_xy", gen_plane_xy, EK_FAMILY_BOTH, "third row 0 (a flat cloth in xy)"},
    {"flipped", gen_flipped, EK_FAMILY_BOTH, "Q [M; 0], det M < 0 (normal reversed)"},
    {"rank1", gen_rank1, EK_FAMILY_BOTH, "f2 = +-2^k f1 exactly (collinear corners)"},
    {"rank0", gen_rank0, EK_FAMILY_BOTH, "F = +-0"},
    {"neg_zero", gen_neg_zero, EK_FAMILY_BOTH, "-0 entries (seed 003 slide 15)"},
    {"tiny_sigma2", gen_tiny_sigma2, EK_FAMILY_BOTH, "sigma2/sigma1 = 1e-3..1e-15"},
    {"repeated", gen_repeated, EK_FAMILY_BOTH, "sigma1 = sigma2 and nearly"},
    {"scale_1e30", gen_scale_1e30, EK_FAMILY_BOTH, "random x 1e30"},
    {"scale_1e-30", gen_scale_1em30, EK_FAMILY_BOTH, "random x 1e-30"},
    {"scale_1e300", gen_scale_1e300, EK_FAMILY_F64, "random x 1e300"},
    {"scale_1e-300", gen_scale_1em300, EK_FAMILY_F64, "random x 1e-300"},
    {"subnormal_f32", gen_subnormal_f32, EK_FAMILY_F32, "random x 1e-40 (as the SVD catalogue)"},
    {"subnormal_f64", gen_subnormal_f64, EK_FAMILY_F64, "random x 1e-310"},
    {"nonfinite", gen_nonfinite, EK_FAMILY_BOTH | EK_FAMILY_NONFINITE, "NaN / -inf in 1 of 3"},
};
const int ek_polar32_nfamilies = sizeof ek_polar32_families / sizeof ek_polar32_families[0];

void ek_check_polar32(const double F[6], const double R[6], const double Uc[4],
                      const double R_ref[6], const double Uc_ref[4], const double sigma_ref[2],
                      ek_polar32_metrics *m) {
  memset(m, 0, sizeof *m);
  for (int i = 0; i < 6; i++)
    m->nonfinite |= !isfinite(R[i]);
  for (int i = 0; i < 4; i++)
    m->nonfinite |= !isfinite(Uc[i]);
  double s1 = sigma_ref[0] > 0 ? sigma_ref[0] : 1;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 2; j++) {
      double rc = R[2 * i] * Uc[j] + R[2 * i + 1] * Uc[2 + j];
      m->recon = fmax(m->recon, fabs(F[2 * i + j] - rc) / s1);
    }
  for (int a = 0; a < 2; a++)
    for (int b = 0; b < 2; b++) {
      double d = R[a] * R[b] + R[2 + a] * R[2 + b] + R[4 + a] * R[4 + b] - (a == b);
      m->orth = fmax(m->orth, fabs(d));
    }
  for (int i = 0; i < 4; i++)
    m->uc = fmax(m->uc, fabs(Uc[i] - Uc_ref[i]) / s1);
  m->uc = fmax(m->uc, fabs(Uc[1] - Uc[2]) / s1);
  // Eigenvalues of the symmetric 2x2 Uc / s1 (scaled: no overflow or
  // underflow in the squares).
  double u[4] = {Uc[0] / s1, Uc[1] / s1, Uc[2] / s1, Uc[3] / s1};
  double mean = 0.5 * (u[0] + u[3]), d = 0.5 * (u[0] - u[3]);
  double h = sqrt(d * d + u[1] * u[2]);
  double e1 = mean + h, e2 = mean - h;
  m->sigma = fmax(fabs(e1 - sigma_ref[0] / s1), fabs(e2 - sigma_ref[1] / s1));
  if (sigma_ref[1] > 0) {
    double rd = 0;
    for (int i = 0; i < 6; i++)
      rd = fmax(rd, fabs(R[i] - R_ref[i]));
    m->rdiff = rd * sigma_ref[1] / s1;
  }
}

double ek_polar32_metrics_worst(const ek_polar32_metrics *m) {
  if (m->nonfinite)
    return INFINITY;
  return fmax(fmax(fmax(m->recon, m->orth), fmax(m->uc, m->sigma)), m->rdiff);
}

// ---- Kabsch sets ----------------------------------------------------------
const char *const ek_kabsch_families[] = {"random",      "exact",     "reflected",
                                          "coplanar",    "collinear", "scale_1e30",
                                          "scale_1e-30", "weighted",  "coincident"};
const int ek_kabsch_nfamilies = sizeof ek_kabsch_families / sizeof ek_kabsch_families[0];

static double round_to(int bits, double x) { return bits == 32 ? (double)(float)x : x; }

void ek_kabsch_set_init(ek_kabsch_set *s, const char *family, uint64_t seed, size_t nsets,
                        int bits) {
  memset(s, 0, sizeof *s);
  snprintf(s->name, sizeof s->name, "%s", family);
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, family));
  s->nsets = nsets;
  s->bits = bits;
  s->offsets = ek_check_malloc((nsets + 1) * sizeof *s->offsets);
  s->offsets[0] = 0;
  for (size_t k = 0; k < nsets; k++) // one-rings of 4..9 points (6-7 typical)
    s->offsets[k + 1] = s->offsets[k] + 4 + ek_rng_next(&rng) % 6;
  size_t np = s->npoints = s->offsets[nsets];
  s->P = ek_check_malloc(3 * np * sizeof(double));
  s->Q = ek_check_malloc(3 * np * sizeof(double));
  s->R_true = ek_check_malloc(9 * nsets * sizeof(double));
  int weighted = strcmp(family, "weighted") == 0;
  if (weighted)
    s->w = ek_check_malloc(np * sizeof(double));
  double scale = strcmp(family, "scale_1e30") == 0    ? 1e30
                 : strcmp(family, "scale_1e-30") == 0 ? 1e-30
                                                      : 1;
  double noise = strcmp(family, "exact") == 0 || strcmp(family, "reflected") == 0 ? 0 : 1e-2;
  for (size_t k = 0; k < nsets; k++) {
    double *Rt = s->R_true + 9 * k, t[3], dir[3], off[3], basis[9];
    ek_rng_rotation(&rng, Rt);
    ek_rng_rotation(&rng, basis);
    for (int i = 0; i < 3; i++)
      t[i] = 10 * ek_rng_gauss(&rng), dir[i] = ek_rng_gauss(&rng), off[i] = ek_rng_gauss(&rng);
    for (size_t j = s->offsets[k]; j < s->offsets[k + 1]; j++) {
      double p[3], q[3];
      for (int i = 0; i < 3; i++)
        p[i] = ek_rng_gauss(&rng);
      if (strcmp(family, "coplanar") == 0) { // in the plane of basis' first two columns
        double a = p[0], b = p[1];
        for (int i = 0; i < 3; i++)
          p[i] = a * basis[3 * i] + b * basis[3 * i + 1] + off[i];
      } else if (strcmp(family, "collinear") == 0) {
        double a = p[0];
        for (int i = 0; i < 3; i++)
          p[i] = a * dir[i] + off[i];
      } else if (strcmp(family, "coincident") == 0) {
        for (int i = 0; i < 3; i++)
          p[i] = off[i];
      }
      for (int i = 0; i < 3; i++)
        q[i] = Rt[3 * i] * p[0] + Rt[3 * i + 1] * p[1] + Rt[3 * i + 2] * p[2] + t[i] +
               noise * ek_rng_gauss(&rng);
      if (strcmp(family, "reflected") == 0) // mirrored: no rotation maps p onto q
        q[2] = -q[2];
      for (int i = 0; i < 3; i++) {
        s->P[3 * j + i] = round_to(bits, scale * p[i]);
        s->Q[3 * j + i] = round_to(bits, scale * q[i]);
      }
      if (weighted)
        s->w[j] = round_to(bits, ek_rng_uniform(&rng) < 0.2 ? 0 : ek_rng_uniform(&rng));
    }
    if (weighted) // at least one positive weight per set
      s->w[s->offsets[k]] = 1;
  }
}

void ek_kabsch_set_free(ek_kabsch_set *s) {
  free(s->offsets), free(s->P), free(s->Q), free(s->w), free(s->R_true);
  memset(s, 0, sizeof *s);
}

double ek_kabsch_spread_eps(int bits) { return 8 * (bits == 32 ? 0x1p-23 : 0x1p-52); }

void ek_check_kabsch(const ek_kabsch_set *s, size_t set, const double R[9], ek_kabsch_metrics *m) {
  memset(m, 0, sizeof *m);
  size_t k0 = s->offsets[set], n = s->offsets[set + 1] - k0;
  const double *P = s->P + 3 * k0, *Q = s->Q + 3 * k0, *w = s->w ? s->w + k0 : NULL;
  for (int i = 0; i < 9; i++)
    m->nonfinite |= !isfinite(R[i]);
  double RtR[9];
  ek_mul3_bt(R, R, RtR);
  for (int i = 0; i < 9; i++)
    m->orth = fmax(m->orth, fabs(RtR[i] - (i % 4 == 0)));
  m->det = fabs(ek_det3(R) - 1);
  double R_ref[9], sv[3], size;
  ek_kabsch_ref(n, P, Q, w, ek_kabsch_spread_eps(s->bits), R_ref, sv);
  double e = ek_kabsch_objective_ref(n, P, Q, w, R, &size);
  double e_ref = ek_kabsch_objective_ref(n, P, Q, w, R_ref, NULL);
  m->objective = size > 0 ? fmax(0, e - e_ref) / size : 0;
  if (sv[0] > 0 && sv[1] + sv[2] > 0) {
    double rd = 0;
    for (int i = 0; i < 9; i++)
      rd = fmax(rd, fabs(R[i] - R_ref[i]));
    m->rdiff = rd * (sv[1] + sv[2]) / sv[0];
  }
}

double ek_kabsch_metrics_worst(const ek_kabsch_metrics *m) {
  if (m->nonfinite)
    return INFINITY;
  return fmax(fmax(m->orth, m->det), fmax(m->objective, m->rdiff));
}

// ---- Velocity-gradient elements -------------------------------------------
const char *const ek_velgrad_families[] = {"random",     "rigid",       "stretch",  "plane_xy",
                                           "scale_1e30", "scale_1e-30", "collinear"};
const int ek_velgrad_nfamilies = sizeof ek_velgrad_families / sizeof ek_velgrad_families[0];

void ek_velgrad_generate(const char *family, uint64_t seed, int corners, size_t n, double *x,
                         double *v) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, family));
  int nc = 3 * corners;
  double scale = strcmp(family, "scale_1e30") == 0    ? 1e30
                 : strcmp(family, "scale_1e-30") == 0 ? 1e-30
                                                      : 1;
  for (size_t e = 0; e < n; e++) {
    double *xe = x + nc * e, *ve = v + nc * e, omega[3], c[3], r[3];
    for (int i = 0; i < 3; i++)
      omega[i] = ek_rng_gauss(&rng), c[i] = ek_rng_gauss(&rng), r[i] = ek_rng_gauss(&rng);
    for (int k = 0; k < nc; k++)
      xe[k] = ek_rng_gauss(&rng), ve[k] = ek_rng_gauss(&rng);
    if (strcmp(family, "plane_xy") == 0)
      for (int k = 0; k < corners; k++)
        xe[3 * k + 2] = 0, ve[3 * k + 2] = 0;
    if (strcmp(family, "collinear") == 0 && corners == 3) // x2 - x0 = 2 (x1 - x0) exactly:
      for (int i = 0; i < 3; i++) {                       // quarters below 16 are exact in float
        xe[i] = 0.25 * round(4 * xe[i]);
        double d = 0.25 * round(4 * (xe[3 + i] - xe[i]));
        xe[3 + i] = xe[i] + d, xe[6 + i] = xe[i] + 2 * d;
      }
    for (int k = 0; k < corners; k++) {
      double *p = xe + 3 * k, *q = ve + 3 * k;
      if (strcmp(family, "rigid") == 0) {
        q[0] = omega[1] * p[2] - omega[2] * p[1] + c[0];
        q[1] = omega[2] * p[0] - omega[0] * p[2] + c[1];
        q[2] = omega[0] * p[1] - omega[1] * p[0] + c[2];
      } else if (strcmp(family, "stretch") == 0) {
        for (int i = 0; i < 3; i++)
          q[i] = r[i] * p[i];
      }
    }
    for (int k = 0; k < nc; k++)
      xe[k] *= scale, ve[k] *= scale;
  }
}

double ek_check_velgrad_err(int corners, int bits, const double *x, const double *v,
                            const double L[9], const double L_ref[9]) {
  double smax, smin, vs2 = 0;
  if (corners == 4) {
    double Ds[9], U[9], S[3], V[9];
    for (int k = 0; k < 3; k++)
      for (int i = 0; i < 3; i++)
        Ds[3 * i + k] = x[3 * (k + 1) + i] - x[i];
    ek_svd3_ref(Ds, U, S, V);
    smax = S[0], smin = fabs(S[2]);
  } else {
    double F[6], R[6], Uc[4], S[2];
    for (int k = 0; k < 2; k++)
      for (int i = 0; i < 3; i++)
        F[2 * i + k] = x[3 * (k + 1) + i] - x[i];
    ek_polar32_ref(F, R, Uc, S);
    double eps = bits == 32 ? FLT_EPSILON : DBL_EPSILON;
    smax = S[0], smin = S[1] > 3 * eps * S[0] ? S[1] : S[0];
  }
  for (int k = 1; k < corners; k++)
    for (int i = 0; i < 3; i++) {
      double g = v[3 * k + i] - v[i];
      vs2 += g * g;
    }
  double err = 0;
  for (int i = 0; i < 9; i++)
    err = fmax(err, fabs(L[i] - L_ref[i]));
  if (err == 0)
    return 0;
  double size = sqrt(vs2) / smin * (smax / smin);
  return size > 0 ? err / size : INFINITY;
}

double ek_check_tri_F_err(const double x[9], const double Dm_inv[4], const double F[6],
                          const double F_ref[6]) {
  double ds = 0, dm = 0, err = 0;
  for (int i = 0; i < 3; i++)
    ds = fmax(ds, fmax(fabs(x[3 + i] - x[i]), fabs(x[6 + i] - x[i])));
  for (int i = 0; i < 4; i++)
    dm = fmax(dm, fabs(Dm_inv[i]));
  for (int i = 0; i < 6; i++)
    err = fmax(err, fabs(F[i] - F_ref[i]));
  return err == 0 ? 0 : err / (ds * dm);
}

// ---- Runners on double data (converting for f32) --------------------------

int ek_check_run_polar32(int bits, ek_isa isa, size_t n, const double *F, double *R, double *Uc) {
  ek_cloth_opts o = {.isa = isa};
  if (bits == 64)
    return ek_polar32_ex_f64(n, F, R, Uc, &o);
  float *f = ek_check_f32_copy(6 * n, F), *r = ek_check_f32_copy(6 * n, NULL),
        *u = ek_check_f32_copy(4 * n, NULL);
  int rc = ek_polar32_ex_f32(n, f, r, u, &o);
  ek_check_from_f32(6 * n, r, R), ek_check_from_f32(4 * n, u, Uc);
  free(f), free(r), free(u);
  return rc;
}

int ek_check_run_kabsch(int bits, ek_isa isa, const ek_kabsch_set *s, double *R) {
  ek_cloth_opts o = {.isa = isa};
  if (bits == 64)
    return ek_kabsch_ex_f64(s->nsets, s->offsets, s->P, s->Q, s->w, R, &o);
  size_t np = s->npoints;
  float *p = ek_check_f32_copy(3 * np, s->P), *q = ek_check_f32_copy(3 * np, s->Q),
        *w = s->w ? ek_check_f32_copy(np, s->w) : NULL;
  float *r = ek_check_f32_copy(9 * s->nsets, NULL);
  int rc = ek_kabsch_ex_f32(s->nsets, s->offsets, p, q, w, r, &o);
  ek_check_from_f32(9 * s->nsets, r, R);
  free(p), free(q), free(w), free(r);
  return rc;
}

int ek_check_run_tri_velgrad(int bits, ek_isa isa, size_t n, const double *x, const double *v,
                             double *L, double *D, double *W) {
  ek_cloth_opts o = {.isa = isa};
  if (bits == 64)
    return ek_tri_velocity_gradient_f64(n, x, v, L, D, W, &o);
  float *a = ek_check_f32_copy(9 * n, x), *b = ek_check_f32_copy(9 * n, v);
  float *l = ek_check_f32_copy(9 * n, NULL), *d = ek_check_f32_copy(9 * n, NULL),
        *w = ek_check_f32_copy(9 * n, NULL);
  int rc = ek_tri_velocity_gradient_f32(n, a, b, l, d, w, &o);
  ek_check_from_f32(9 * n, l, L), ek_check_from_f32(9 * n, d, D), ek_check_from_f32(9 * n, w, W);
  free(a), free(b), free(l), free(d), free(w);
  return rc;
}
