// Invariant: every cloth kernel (include/ek/cloth.h), on every ISA this CPU
// runs x f32 / f64, meets EK_CLOTH_TOL_* against the double reference
// (reference/cloth/) on random inputs and the extremes (check_cloth.c):
//   a. ek_tri_rest_f64 against the Gram-Schmidt frame; zero-area, collinear,
//      repeated-corner and NaN triangles refused with the triangle named
//      and nothing written;
//   b. the triangle F, degenerate and flipped deformed triangles included;
//   c. polar32 on every family (rank 0, rank 1, -0 entries, tiny sigma2,
//      repeated, flipped, 1e+-30 and subnormal scales): reconstruction,
//      orthogonality, Uc and the stretches, R scaled by its condition; no
//      NaN for a finite F, NaN only in a non-finite F's lane;
//   d. Kabsch on random, exact, reflected, coplanar, collinear, weighted,
//      coincident and 1e+-30 sets: det R = +1, the objective as small as
//      LAPACK's, R = the reference where unique; noise-free sets give back
//      the rotation they were made with; bad offsets and weights refused;
//   e. the velocity gradients of triangles (L = Vs Ds^+) and tets (L =
//      Vs Ds^-1) with D and W, rigid and stretching motions included; a
//      collapsed tet gives NaN;
//   f. every ISA gives the scalar build's bits (the kernels use only
//      correctly rounded operations in one order: a swapped lane shows);
//      the AoSoA forms give the AoS forms' bits; 1 and 2 threads agree.
//
// Usage: test_cloth [--seed N]
#include <ek/batch.h>
#include <ek/cloth.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "check_box.h"
#include "check_cloth.h"
#include "cli.h"
#include "cloth/cloth_ref.h"

// Odd sizes, so every ISA has tail lanes.
enum { N_RANDOM = 20011, N_FAMILY = 1003, N_SETS = 2003 };

static int failures;

static double tol(int bits) { return bits == 32 ? EK_CLOTH_TOL_F32 : EK_CLOTH_TOL_F64; }
static double eps(int bits) { return bits == 32 ? 0x1p-23 : 0x1p-52; }

static void report(const char *label, double err, double budget) {
  failures += ek_check_report(label, err, budget);
}

static void check(int ok, const char *what) {
  printf("%s: %s\n", what, ok ? "PASS" : "FAIL");
  failures += !ok;
}

static double *dalloc(size_t n) { return ek_check_malloc((n ? n : 1) * sizeof(double)); }

// Every output is poisoned (ek_check_poison: NaN) right before its call:
// each ISA's call gets the buffers the previous ISA's call used (reused,
// or freed and handed back by malloc), holding right values, so an element
// a path did not write would pass. ek_check_tri_F_err and
// ek_check_velgrad_err take their maxima with fmax, which drops a NaN: an
// output not finite where the reference is fails here.
static void poison(size_t n, double *a) { ek_check_poison(a, n * sizeof(double)); }

static int nan_where_finite(size_t n, const double *out, const double *ref) {
  int bad = 0;
  for (size_t i = 0; i < n; i++)
    bad |= !isfinite(out[i]) && isfinite(ref[i]);
  return bad;
}

// The poison as it reads back: 0xFF bytes (f64), or a float's converted
// (the f32 runners): where a NaN is the right result (a non-finite
// input's lane), the poison is not.
static int is_poison(double d) {
  float pf;
  double pd, one;
  memset(&pf, 0xFF, sizeof pf);
  memset(&pd, 0xFF, sizeof pd);
  one = (double)pf;
  return !memcmp(&d, &pd, sizeof d) || !memcmp(&d, &one, sizeof d);
}

// Round to float and back where bits == 32 (the input both sides see).
static void to_prec(int bits, size_t n, double *a) {
  if (bits == 32)
    for (size_t i = 0; i < n; i++)
      a[i] = (double)(float)a[i];
}

// ---- Runners on double data (converting for f32) --------------------------

static int run_tri_F(int bits, ek_isa isa, size_t n, const double *x, const double *Dm_inv,
                     double *F) {
  ek_cloth_opts o = {.isa = isa};
  if (bits == 64)
    return ek_tri_deformation_ex_f64(n, x, Dm_inv, F, &o);
  float *a = ek_check_f32_copy(9 * n, x), *b = ek_check_f32_copy(4 * n, Dm_inv),
        *f = ek_check_f32_copy(6 * n, NULL);
  int rc = ek_tri_deformation_ex_f32(n, a, b, f, &o);
  ek_check_from_f32(6 * n, f, F);
  free(a), free(b), free(f);
  return rc;
}

// ---- a. Rest frame --------------------------------------------------------
static void rest(uint64_t seed) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "rest"));
  size_t n = N_FAMILY;
  double *X = dalloc(9 * n), *Dm = dalloc(4 * n), *A = dalloc(n);
  for (size_t i = 0; i < 9 * n; i++)
    X[i] = ek_rng_gauss(&rng) * (i < 9 * n / 2 ? 1 : 1e30);
  int rc = ek_tri_rest_f64(n, X, Dm, A);
  double worst = rc ? INFINITY : 0;
  for (size_t t = 0; t < n && !rc; t++) {
    double d[4], a, m = 0;
    if (ek_tri_rest_ref(X + 9 * t, EK_TRI_DEGENERATE_REL, d, &a)) {
      worst = INFINITY;
      continue;
    }
    for (int i = 0; i < 4; i++)
      m = fmax(m, fabs(d[i]));
    for (int i = 0; i < 4; i++)
      worst = fmax(worst, fabs(Dm[4 * t + i] - d[i]) / m);
    worst = fmax(worst, fabs(A[t] - a) / a);
  }
  report("tri_rest f64: Dm_inv and area vs Gram-Schmidt", worst, EK_CLOTH_TOL_F64);
  // Refusals: the bad triangle sits at index 5 of 8 good ones.
  const char *names[] = {"repeated corner", "collinear corners", "tiny area", "NaN coordinate"};
  double bad[4][9] = {{0, 0, 0, 1, 2, 3, 1, 2, 3},
                      {0, 0, 0, 1, 1, 1, 3, 3, 3},
                      {0, 0, 0, 1, 0, 0, 0.5, 1e-13, 0},
                      {0, 0, 0, 1, 0, 0, 0, 1, NAN}};
  for (int b = 0; b < 4; b++) {
    double Xb[72], Db[32], Ab[8];
    memcpy(Xb, X, sizeof Xb);
    memcpy(Xb + 45, bad[b], sizeof bad[b]);
    for (int i = 0; i < 32; i++)
      Db[i] = -7;
    for (int i = 0; i < 8; i++)
      Ab[i] = -7;
    int r = ek_tri_rest_f64(8, Xb, Db, Ab);
    int untouched = 1;
    for (int i = 0; i < 32; i++)
      untouched &= Db[i] == -7;
    for (int i = 0; i < 8; i++)
      untouched &= Ab[i] == -7;
    const char *msg = ek_last_error();
    int named = strstr(msg, "triangle 5") != NULL;
    char what[256];
    snprintf(what, sizeof what, "tri_rest refuses %s (rc %d, nothing written %d, \"%s\")", names[b],
             r, untouched, msg);
    check(r == EK_EINVAL && untouched && named, what);
  }
  // The one degeneracy test (ek_tri_degenerate) decides alike at any scale
  // (its edges are scaled by a power of two): a right triangle is good and
  // a thin one (height 1e-13 of its base: 2A / l^2 = 1e-13) degenerate from
  // 1e-150 to 1e150, where the unscaled (2A)^2 would underflow / overflow.
  for (int e = -150; e <= 150; e += 150) {
    double sc = pow(10.0, e), P[3][3] = {{0, 0, 0}, {sc, 0, 0}, {0, sc, 0}};
    double Q[3][3] = {{0, 0, 0}, {sc, 0, 0}, {0.5 * sc, 1e-13 * sc, 0}}, a2, l2;
    int good = ek_tri_degenerate(P[0], P[1], P[2], &a2, &l2);
    int thin = ek_tri_degenerate(Q[0], Q[1], Q[2], NULL, NULL);
    char what[160];
    snprintf(what, sizeof what, "ek_tri_degenerate at scale 1e%d: right %d (2A %.3g), thin %d", e,
             good, a2, thin);
    check(!good && thin && fabs(a2 / (sc * sc) - 1) <= EK_CLOTH_TOL_F64, what);
  }
  free(X), free(Dm), free(A);
}

// ---- b. Triangle F ----------------------------------------------------------
static void tri_F(uint64_t seed, ek_isa isa, int bits) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "tri_F"));
  size_t n = N_RANDOM;
  double *X = dalloc(9 * n), *x = dalloc(9 * n), *Dm = dalloc(4 * n), *F = dalloc(6 * n);
  for (size_t t = 0; t < n; t++) {
    do
      for (int i = 0; i < 9; i++)
        X[9 * t + i] = ek_rng_gauss(&rng);
    while (ek_tri_rest_f64(1, X + 9 * t, Dm + 4 * t, NULL) != EK_OK);
    int kind = t % 4; // random, collapsed (all corners equal), collinear, flipped
    for (int i = 0; i < 9; i++)
      x[9 * t + i] = ek_rng_gauss(&rng);
    for (int i = 0; i < 3; i++) {
      if (kind == 1)
        x[9 * t + 3 + i] = x[9 * t + 6 + i] = x[9 * t + i];
      if (kind == 2)
        x[9 * t + 6 + i] = 2 * x[9 * t + 3 + i] - x[9 * t + i];
      if (kind == 3) // flipped: the rest corners with 1 and 2 swapped (normal reversed)
        x[9 * t + i] = X[9 * t + i], x[9 * t + 3 + i] = X[9 * t + 6 + i],
                  x[9 * t + 6 + i] = X[9 * t + 3 + i];
    }
  }
  to_prec(bits, 9 * n, x), to_prec(bits, 4 * n, Dm);
  poison(6 * n, F);
  int rc = run_tri_F(bits, isa, n, x, Dm, F);
  double worst = rc ? INFINITY : 0;
  for (size_t t = 0; t < n && !rc; t++) {
    double Fr[6];
    ek_tri_F_ref(x + 9 * t, Dm + 4 * t, Fr);
    worst = fmax(worst, ek_check_tri_F_err(x + 9 * t, Dm + 4 * t, F + 6 * t, Fr));
    if (nan_where_finite(6, F + 6 * t, Fr))
      worst = INFINITY;
  }
  char label[96];
  snprintf(label, sizeof label, "tri_F %-6s f%d random/collapsed/collinear/flipped",
           ek_isa_name(isa), bits);
  report(label, worst, tol(bits));
  free(X), free(x), free(Dm), free(F);
}

// ---- c. polar32 -------------------------------------------------------------
static void polar32(uint64_t seed, ek_isa isa, int bits) {
  for (int f = -1; f < ek_polar32_nfamilies; f++) {
    const ek_polar32_family *fam = f < 0 ? &ek_polar32_families[0] : &ek_polar32_families[f];
    if (!(fam->flags & (bits == 32 ? EK_FAMILY_F32 : EK_FAMILY_F64)))
      continue;
    size_t n = f < 0 ? N_RANDOM : N_FAMILY;
    double *F = dalloc(6 * n), *R = dalloc(6 * n), *Uc = dalloc(4 * n);
    ek_rng rng;
    ek_rng_seed(&rng, ek_check_stream_seed(seed, f < 0 ? "polar32_random" : fam->name));
    fam->generate(&rng, n, F);
    to_prec(bits, 6 * n, F);
    poison(6 * n, R), poison(4 * n, Uc);
    int rc = ek_check_run_polar32(bits, isa, n, F, R, Uc);
    double worst = rc ? INFINITY : 0;
    int shown = 0, nan_ok = 1;
    for (size_t k = 0; k < n && !rc; k++) {
      const double *Fk = F + 6 * k;
      int finite = 1;
      for (int i = 0; i < 6; i++)
        finite &= isfinite(Fk[i]) != 0;
      if (!finite) {
        for (int i = 0; i < 6; i++)
          nan_ok &= isnan(R[6 * k + i]) && !is_poison(R[6 * k + i]);
        for (int i = 0; i < 4; i++)
          nan_ok &= isnan(Uc[4 * k + i]) && !is_poison(Uc[4 * k + i]);
        continue;
      }
      double Rr[6], Ur[4], s[2];
      ek_polar32_ref(Fk, Rr, Ur, s);
      ek_polar32_metrics m;
      ek_check_polar32(Fk, R + 6 * k, Uc + 4 * k, Rr, Ur, s, &m);
      double w = ek_polar32_metrics_worst(&m);
      if (w > tol(bits) && shown++ < 2) {
        printf("  %s #%zu: recon %.3g orth %.3g uc %.3g sigma %.3g rdiff %.3g nonfinite %d\n",
               fam->name, k, m.recon, m.orth, m.uc, m.sigma, m.rdiff, m.nonfinite);
        printf("    F     % .9g % .9g | % .9g % .9g | % .9g % .9g\n", Fk[0], Fk[1], Fk[2], Fk[3],
               Fk[4], Fk[5]);
        printf("    R     % .9g % .9g | % .9g % .9g | % .9g % .9g\n", R[6 * k], R[6 * k + 1],
               R[6 * k + 2], R[6 * k + 3], R[6 * k + 4], R[6 * k + 5]);
        printf("    R_ref % .9g % .9g | % .9g % .9g | % .9g % .9g\n", Rr[0], Rr[1], Rr[2], Rr[3],
               Rr[4], Rr[5]);
        printf("    Uc    % .9g % .9g % .9g, Uc_ref % .9g % .9g % .9g, sigma_ref % .9g % .9g\n",
               Uc[4 * k], Uc[4 * k + 1], Uc[4 * k + 3], Ur[0], Ur[1], Ur[3], s[0], s[1]);
      }
      worst = fmax(worst, w);
    }
    char label[96];
    snprintf(label, sizeof label, "polar32 %-6s f%d %-13s", ek_isa_name(isa), bits,
             f < 0 ? "random(big)" : fam->name);
    report(label, nan_ok ? worst : INFINITY, tol(bits));
    free(F), free(R), free(Uc);
  }
}

// ---- d. Kabsch --------------------------------------------------------------
static void kabsch(uint64_t seed, ek_isa isa, int bits) {
  for (int f = 0; f < ek_kabsch_nfamilies; f++) {
    ek_kabsch_set s;
    ek_kabsch_set_init(&s, ek_kabsch_families[f], seed, N_SETS, bits);
    double *R = dalloc(9 * s.nsets);
    poison(9 * s.nsets, R); // a non-finite R: ek_kabsch_metrics_worst is INFINITY
    int rc = ek_check_run_kabsch(bits, isa, &s, R);
    double worst = rc ? INFINITY : 0, truth = 0;
    int exact = strcmp(s.name, "exact") == 0, coincident = strcmp(s.name, "coincident") == 0;
    for (size_t k = 0; k < s.nsets && !rc; k++) {
      ek_kabsch_metrics m;
      ek_check_kabsch(&s, k, R + 9 * k, &m);
      worst = fmax(worst, ek_kabsch_metrics_worst(&m));
      double Rr[9], sv[3] = {1, 1, 0}, cond = 1;
      size_t k0 = s.offsets[k];
      if (exact && ek_kabsch_ref(s.offsets[k + 1] - k0, s.P + 3 * k0, s.Q + 3 * k0, NULL,
                                 ek_kabsch_spread_eps(bits), Rr, sv) == 0)
        cond = (sv[1] + sv[2]) / sv[0];
      for (int i = 0; i < 9; i++) {
        if (exact) // the rotation the set was made with, times its condition
          truth = fmax(truth, fabs(R[9 * k + i] - s.R_true[9 * k + i]) * cond);
        if (coincident)
          truth = fmax(truth, fabs(R[9 * k + i] - (i % 4 == 0)));
      }
    }
    char label[96];
    snprintf(label, sizeof label, "kabsch %-6s f%d %-11s", ek_isa_name(isa), bits, s.name);
    report(label, worst, tol(bits));
    if (exact || coincident) {
      snprintf(label, sizeof label, "kabsch %-6s f%d %-11s R = %s", ek_isa_name(isa), bits, s.name,
               exact ? "the true rotation" : "I");
      // The true rotation up to the rounding of the points, in the norm of
      // cloth.h (times (s2 + s3) / s1).
      report(label, truth, tol(bits));
    }
    free(R);
    ek_kabsch_set_free(&s);
  }
}

static void kabsch_errors(void) {
  size_t off_bad[3] = {0, 4, 3}, off[3] = {0, 3, 6};
  double P[18] = {0}, Q[18] = {0}, w[6] = {1, 1, 1, 1, -1, 1}, R[18];
  for (int i = 0; i < 18; i++)
    R[i] = -7;
  int rc1 = ek_kabsch_f64(2, off_bad, P, Q, NULL, R);
  char what[256];
  snprintf(what, sizeof what, "kabsch refuses decreasing offsets (rc %d, \"%s\")", rc1,
           ek_last_error());
  check(rc1 == EK_EINVAL && strstr(ek_last_error(), "offsets[2]") && R[0] == -7, what);
  int rc2 = ek_kabsch_f64(2, off, P, Q, w, R);
  snprintf(what, sizeof what, "kabsch refuses a negative weight (rc %d, \"%s\")", rc2,
           ek_last_error());
  check(rc2 == EK_EINVAL && strstr(ek_last_error(), "set 1") &&
            strstr(ek_last_error(), "point 4") && R[0] == -7,
        what);
  double w0[6] = {0, 0, 0, 1, 1, 1};
  int rc3 = ek_kabsch_f64(2, off, P, Q, w0, R);
  snprintf(what, sizeof what, "kabsch refuses a set with zero total weight (rc %d, \"%s\")", rc3,
           ek_last_error());
  check(rc3 == EK_EINVAL && strstr(ek_last_error(), "set 0") && R[0] == -7, what);
}

// ---- e. Velocity gradients ----------------------------------------------------
static void tri_velgrad(uint64_t seed, ek_isa isa, int bits) {
  for (int f = 0; f < ek_velgrad_nfamilies; f++) {
    const char *fam = ek_velgrad_families[f];
    size_t n = N_FAMILY;
    double *x = dalloc(9 * n), *v = dalloc(9 * n), *L = dalloc(9 * n), *D = dalloc(9 * n),
           *W = dalloc(9 * n);
    ek_velgrad_generate(fam, seed, 3, n, x, v);
    to_prec(bits, 9 * n, x), to_prec(bits, 9 * n, v);
    poison(9 * n, L), poison(9 * n, D), poison(9 * n, W);
    int rc = ek_check_run_tri_velgrad(bits, isa, n, x, v, L, D, W);
    double worst = rc ? INFINITY : 0;
    for (size_t e = 0; e < n && !rc; e++) {
      double Lr[9], Dr[9], Wr[9];
      ek_tri_velgrad_ref(x + 9 * e, v + 9 * e, 3 * eps(bits), Lr);
      ek_LDW_ref(Lr, Dr, Wr);
      worst = fmax(worst, ek_check_velgrad_err(3, bits, x + 9 * e, v + 9 * e, L + 9 * e, Lr));
      worst = fmax(worst, ek_check_velgrad_err(3, bits, x + 9 * e, v + 9 * e, D + 9 * e, Dr));
      worst = fmax(worst, ek_check_velgrad_err(3, bits, x + 9 * e, v + 9 * e, W + 9 * e, Wr));
      if (nan_where_finite(9, L + 9 * e, Lr) || nan_where_finite(9, D + 9 * e, Dr) ||
          nan_where_finite(9, W + 9 * e, Wr))
        worst = INFINITY;
    }
    char label[96];
    snprintf(label, sizeof label, "tri L,D,W %-6s f%d %-11s", ek_isa_name(isa), bits, fam);
    report(label, worst, tol(bits));
    free(x), free(v), free(L), free(D), free(W);
  }
}

// Tets: a jittered box (caller order), velocities of each family.
static void tet_velgrad(uint64_t seed, ek_isa isa, int bits) {
  ek_check_box mesh;
  if (ek_check_box_create(&mesh, 6, 5, 4, 1.2, 1.0, 0.8) != 0) {
    printf("FAIL tet velgrad: %s\n", ek_last_error());
    failures++;
    return;
  }
  size_t nv = mesh.nverts, nt = mesh.ntets;
  const int32_t *tets = mesh.T;
  const ek_tets *el = mesh.el;
  const char *fams[] = {"random", "rigid", "stretch"};
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "tet_velgrad"));
  double *x = dalloc(3 * nv), *v = dalloc(3 * nv), *L = dalloc(9 * nt), *D = dalloc(9 * nt),
         *W = dalloc(9 * nt);
  for (int f = 0; f < 3; f++) {
    double w[3], c[3], r[3];
    for (int i = 0; i < 3; i++)
      w[i] = ek_rng_gauss(&rng), c[i] = ek_rng_gauss(&rng), r[i] = ek_rng_gauss(&rng);
    const double *X = mesh.X;
    for (size_t i = 0; i < nv; i++) {
      double *p = x + 3 * i, *q = v + 3 * i;
      for (int k = 0; k < 3; k++)
        p[k] = X[3 * i + k] + 0.05 * ek_rng_gauss(&rng);
      if (f == 0)
        for (int k = 0; k < 3; k++)
          q[k] = ek_rng_gauss(&rng);
      if (f == 1)
        q[0] = w[1] * p[2] - w[2] * p[1] + c[0], q[1] = w[2] * p[0] - w[0] * p[2] + c[1],
        q[2] = w[0] * p[1] - w[1] * p[0] + c[2];
      if (f == 2)
        for (int k = 0; k < 3; k++)
          q[k] = r[k] * p[k];
    }
    to_prec(bits, 3 * nv, x), to_prec(bits, 3 * nv, v);
    poison(9 * nt, L), poison(9 * nt, D), poison(9 * nt, W); // they hold the previous family's
    ek_cloth_opts o = {.isa = isa};
    int rc;
    if (bits == 64) {
      rc = ek_tet_velocity_gradient_f64(el, x, v, L, D, W, &o);
    } else {
      float *a = ek_check_f32_copy(3 * nv, x), *b = ek_check_f32_copy(3 * nv, v);
      float *l = ek_check_f32_copy(9 * nt, NULL), *d = ek_check_f32_copy(9 * nt, NULL),
            *ww = ek_check_f32_copy(9 * nt, NULL);
      rc = ek_tet_velocity_gradient_f32(el, a, b, l, d, ww, &o);
      ek_check_from_f32(9 * nt, l, L), ek_check_from_f32(9 * nt, d, D);
      ek_check_from_f32(9 * nt, ww, W);
      free(a), free(b), free(l), free(d), free(ww);
    }
    double worst = rc ? INFINITY : 0;
    for (size_t t = 0; t < nt && !rc; t++) {
      double xe[12], ve[12], Lr[9], Dr[9], Wr[9];
      for (int k = 0; k < 4; k++)
        for (int i = 0; i < 3; i++)
          xe[3 * k + i] = x[3 * tets[4 * t + k] + i], ve[3 * k + i] = v[3 * tets[4 * t + k] + i];
      ek_tet_velgrad_ref(xe, ve, Lr);
      ek_LDW_ref(Lr, Dr, Wr);
      if (f == 1) { // rigid: D = 0 and W = [omega]x exactly, not only the reference's
        double S[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0};
        for (int i = 0; i < 9; i++)
          Dr[i] = 0, Wr[i] = S[i];
      }
      worst = fmax(worst, ek_check_velgrad_err(4, bits, xe, ve, L + 9 * t, Lr));
      worst = fmax(worst, ek_check_velgrad_err(4, bits, xe, ve, D + 9 * t, Dr));
      worst = fmax(worst, ek_check_velgrad_err(4, bits, xe, ve, W + 9 * t, Wr));
      if (nan_where_finite(9, L + 9 * t, Lr) || nan_where_finite(9, D + 9 * t, Dr) ||
          nan_where_finite(9, W + 9 * t, Wr))
        worst = INFINITY;
    }
    char label[96];
    snprintf(label, sizeof label, "tet L,D,W %-6s f%d %-11s", ek_isa_name(isa), bits, fams[f]);
    report(label, worst, tol(bits));
  }
  free(x), free(v), free(L), free(D), free(W);
  ek_check_box_destroy(&mesh);
}

// A collapsed tet (det Ds = 0) gives NaN (the contract form, L only, in
// caller order).
static void tet_collapsed(void) {
  ek_check_box mesh;
  if (ek_check_box_create(&mesh, 2, 1, 1, 1, 1, 1) != 0) {
    printf("FAIL tet collapsed: %s\n", ek_last_error());
    failures++;
    return;
  }
  size_t nv = mesh.nverts, nt = mesh.ntets;
  const int32_t *tets = mesh.T;
  double *x = dalloc(3 * nv), *v = dalloc(3 * nv), *L = dalloc(9 * nt);
  memcpy(x, mesh.X, 3 * nv * sizeof(double));
  for (size_t i = 0; i < 3 * nv; i++)
    v[i] = 0.1 * (double)(i % 7);
  // Move tet 0's corner 3 onto its corner 0: every tet with both collapses.
  int32_t a = tets[0], b = tets[3];
  for (int i = 0; i < 3; i++)
    x[3 * b + i] = x[3 * a + i];
  int rc = ek_tet_velocity_gradient_f64(mesh.el, x, v, L, NULL, NULL, NULL);
  int ok = rc == EK_OK;
  size_t ncollapsed = 0;
  for (size_t t = 0; t < nt; t++) {
    int uses_a = 0, uses_b = 0;
    for (int k = 0; k < 4; k++)
      uses_a |= tets[4 * t + k] == a, uses_b |= tets[4 * t + k] == b;
    ncollapsed += uses_a && uses_b;
    for (int i = 0; i < 9; i++) {
      if (uses_a && uses_b)
        ok &= isnan(L[9 * t + i]) != 0;
      if (!uses_a && !uses_b) // untouched tets (those using only b may be flat)
        ok &= isfinite(L[9 * t + i]) != 0;
    }
  }
  ok &= ncollapsed > 0;
  check(ok, "ek_velocity_gradient_f64: tets with two corners moved onto each other give NaN, "
            "the untouched ones finite");
  free(x), free(v), free(L);
  ek_check_box_destroy(&mesh);
}

// ---- f. Same bits: ISAs vs scalar, AoSoA vs AoS, 1 vs 2 threads -----------------
static void same_bits(uint64_t seed) {
  size_t n = N_RANDOM;
  double *F = dalloc(6 * n), *x = dalloc(9 * n), *v = dalloc(9 * n);
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "bits"));
  for (size_t i = 0; i < 6 * n; i++)
    F[i] = ek_rng_gauss(&rng);
  for (size_t i = 0; i < 9 * n; i++)
    x[i] = ek_rng_gauss(&rng), v[i] = ek_rng_gauss(&rng);
  double *R0 = dalloc(6 * n), *U0 = dalloc(4 * n), *L0 = dalloc(9 * n), *D0 = dalloc(9 * n),
         *W0 = dalloc(9 * n);
  double *R1 = dalloc(6 * n), *U1 = dalloc(4 * n), *L1 = dalloc(9 * n), *D1 = dalloc(9 * n),
         *W1 = dalloc(9 * n);
  // Outputs poisoned before every call: R1..W1 hold the previous ISA's
  // results, R0..W0 the other precision's.
  for (int bits = 32; bits <= 64; bits += 32) {
    poison(6 * n, R0), poison(4 * n, U0), poison(9 * n, L0), poison(9 * n, D0), poison(9 * n, W0);
    ek_check_run_polar32(bits, EK_ISA_SCALAR, n, F, R0, U0);
    ek_check_run_tri_velgrad(bits, EK_ISA_SCALAR, n, x, v, L0, D0, W0);
    for (int isa = EK_ISA_AVX2; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      poison(6 * n, R1), poison(4 * n, U1), poison(9 * n, L1), poison(9 * n, D1), poison(9 * n, W1);
      ek_check_run_polar32(bits, (ek_isa)isa, n, F, R1, U1);
      ek_check_run_tri_velgrad(bits, (ek_isa)isa, n, x, v, L1, D1, W1);
      int same = !memcmp(R0, R1, 6 * n * sizeof(double)) &&
                 !memcmp(U0, U1, 4 * n * sizeof(double)) &&
                 !memcmp(L0, L1, 9 * n * sizeof(double)) &&
                 !memcmp(D0, D1, 9 * n * sizeof(double)) && !memcmp(W0, W1, 9 * n * sizeof(double));
      char what[128];
      snprintf(what, sizeof what, "polar32, tri L/D/W f%d: %s gives the scalar build's bits", bits,
               ek_isa_name((ek_isa)isa));
      check(same, what);
    }
  }
  // AoSoA vs AoS (f32 and f64, default ISA) and 1 vs 2 threads.
  {
    float *f = ek_check_f32_copy(6 * n, F), *r = ek_check_f32_copy(6 * n, NULL),
          *u = ek_check_f32_copy(4 * n, NULL);
    float *fs = ek_aosoa_alloc_f32(n, 6), *rs = ek_aosoa_alloc_f32(n, 6),
          *us = ek_aosoa_alloc_f32(n, 4);
    float *r2 = ek_check_f32_copy(6 * n, NULL),
          *u2 = ek_check_f32_copy(4 * n, NULL); // poisoned, as r and u
    ek_check_poison(rs, ek_aosoa_size_f32(n, 6) * sizeof(float));
    ek_check_poison(us, ek_aosoa_size_f32(n, 4) * sizeof(float));
    ek_polar32_f32(n, f, r, u);
    ek_aosoa_pack_f32(n, 6, f, fs);
    ek_polar32_aosoa_f32(ek_aosoa_blocks_f32(n), fs, rs, us, NULL);
    ek_aosoa_unpack_f32(n, 6, rs, r2), ek_aosoa_unpack_f32(n, 4, us, u2);
    check(!memcmp(r, r2, 6 * n * sizeof(float)) && !memcmp(u, u2, 4 * n * sizeof(float)),
          "polar32 f32: AoSoA form gives the AoS form's bits");
    free(f), free(r), free(u), free(r2), free(u2), ek_free(fs), ek_free(rs), ek_free(us);
  }
  {
    double *xs = ek_aosoa_alloc_f64(n, 9), *vs = ek_aosoa_alloc_f64(n, 9),
           *ls = ek_aosoa_alloc_f64(n, 9);
    double *Dm = dalloc(4 * n), *Fa = dalloc(6 * n), *Fb = dalloc(6 * n);
    double *dms = ek_aosoa_alloc_f64(n, 4), *fs = ek_aosoa_alloc_f64(n, 6);
    for (size_t i = 0; i < 4 * n; i++)
      Dm[i] = ek_rng_gauss(&rng);
    // L0 and L1 both hold the ISA loop's last f64 L: poisoned, as the rest.
    poison(9 * n, L0), poison(9 * n, L1), poison(6 * n, Fa), poison(6 * n, Fb);
    ek_check_poison(ls, ek_aosoa_size_f64(n, 9) * sizeof(double));
    ek_check_poison(fs, ek_aosoa_size_f64(n, 6) * sizeof(double));
    ek_tri_velocity_gradient_f64(n, x, v, L0, NULL, NULL, NULL);
    ek_aosoa_pack_f64(n, 9, x, xs), ek_aosoa_pack_f64(n, 9, v, vs);
    ek_tri_velocity_gradient_aosoa_f64(ek_aosoa_blocks_f64(n), xs, vs, ls, NULL, NULL, NULL);
    ek_aosoa_unpack_f64(n, 9, ls, L1);
    ek_tri_deformation_f64(n, x, Dm, Fa);
    ek_aosoa_pack_f64(n, 4, Dm, dms);
    ek_tri_deformation_aosoa_f64(ek_aosoa_blocks_f64(n), xs, dms, fs, NULL);
    ek_aosoa_unpack_f64(n, 6, fs, Fb);
    check(!memcmp(L0, L1, 9 * n * sizeof(double)) && !memcmp(Fa, Fb, 6 * n * sizeof(double)),
          "tri L and F f64: AoSoA forms give the AoS forms' bits");
    ek_free(xs), ek_free(vs), ek_free(ls), ek_free(dms), ek_free(fs), free(Dm), free(Fa), free(Fb);
  }
  {
    ek_kabsch_set s;
    ek_kabsch_set_init(&s, "random", seed, N_SETS * 10, 64);
    double *Ra = dalloc(9 * s.nsets), *Rb = dalloc(9 * s.nsets);
    // Outputs poisoned first: R1 and U1 hold the ISA loop's polar32 f64,
    // the bits a 2-thread call must give, so a chunk that did not run
    // would not show.
    ek_check_poison(Ra, 9 * s.nsets * sizeof(double));
    ek_check_poison(Rb, 9 * s.nsets * sizeof(double));
    ek_check_poison(R0, 6 * n * sizeof(double)), ek_check_poison(U0, 4 * n * sizeof(double));
    ek_check_poison(R1, 6 * n * sizeof(double)), ek_check_poison(U1, 4 * n * sizeof(double));
    omp_set_num_threads(1);
    ek_kabsch_f64(s.nsets, s.offsets, s.P, s.Q, NULL, Ra);
    ek_polar32_f64(n, F, R0, U0);
    omp_set_num_threads(2);
    ek_kabsch_f64(s.nsets, s.offsets, s.P, s.Q, NULL, Rb);
    ek_polar32_f64(n, F, R1, U1);
    check(!memcmp(Ra, Rb, 9 * s.nsets * sizeof(double)) &&
              !memcmp(R0, R1, 6 * n * sizeof(double)) && !memcmp(U0, U1, 4 * n * sizeof(double)),
          "kabsch, polar32 f64: 1 and 2 threads give the same bits");
    free(Ra), free(Rb);
    ek_kabsch_set_free(&s);
  }
  free(F), free(x), free(v), free(R0), free(U0), free(L0), free(D0), free(W0), free(R1), free(U1),
      free(L1), free(D1), free(W1);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_cloth: seed %llu\n", (unsigned long long)seed);
  rest(seed);
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available((ek_isa)isa)) {
      printf("SKIP %s: not available on this CPU or build\n", ek_isa_name((ek_isa)isa));
      continue;
    }
    for (int bits = 32; bits <= 64; bits += 32) {
      tri_F(seed, (ek_isa)isa, bits);
      polar32(seed, (ek_isa)isa, bits);
      kabsch(seed, (ek_isa)isa, bits);
      tri_velgrad(seed, (ek_isa)isa, bits);
      tet_velgrad(seed, (ek_isa)isa, bits);
    }
  }
  kabsch_errors();
  tet_collapsed();
  same_bits(seed);
  printf("%s (%d failing)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
