// The kernel part of the speed/accuracy map (`ek-bench --suite tradeoff`,
// issue 12): one point per knob setting of
//   svd3, polar3   precision (f32, f64) x sweeps on A^T A (1..6) x rsqrt
//                  (exact, approx) x exact one-sided refinement sweeps
//                  (none, 1, 2, 3) x ISA. Refine none + 4 sweeps + approx
//                  is McAdams et al. 2011 as published ("label=mcadams2011");
//   pk1/<model>    P(F) per model, precision x ISA.
// Error: per matrix (element), the number ek-verify holds against the
// budget, on ek-verify's own inputs, so the default setting's maximum is
// the number ek-verify reports for that variant (tests/test_tradeoff_map.py):
//   svd3    ek_svd3_metrics_worst: max of reconstruction, orthogonality,
//           |det - 1|, |S - S_ref| and ordering, relative to s1, +inf for a
//           wrong sign of S2 (verify/check_metrics.c), on the "random" set
//           (verify/check_svd3.c: Gaussian matrices, LAPACK reference);
//   polar3  ek_polar3_metrics_worst (recon, orth, det, sym, rdiff);
//   pk1     |P - P_ref|_max / max(|P_ref|_max, (mu + |lambda|) s^3),
//           s = max(1, |F|_max), on ek-verify's material set
//           (verify/check_material.c), mu = 1.3, lambda = 2.1, no clamp;
//           elements outside the model's domain (neo-Hookean, J <= 0) are
//           not counted.
// An output that is not finite counts as an error of +inf.
// Cost: the AoSoA kernel on a cache-resident batch of CACHE_BATCH matrices
// (the set's first ones), ns per matrix, median and minimum over short
// samples (bench/timer.h), at each thread count.
#include <ek/ek.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "check_polar_warm.h"
#include "material/material_ref.h"
#include "svd3/svd3_ref.h"
#include "timer.h"
#include "tradeoff.h"

#define CACHE_BATCH 4096
#define MAX_SWEEPS 6
// The material of the pk1 maps: ek-verify's.
#define PK1_MU 1.3
#define PK1_LAMBDA 2.1

static int isa_selected(const ek_tradeoff_opts *o, int isa) {
  return ek_isa_available((ek_isa)isa) && ((o->isa_mask >> isa) & 1);
}

static int count_isas(const ek_tradeoff_opts *o) {
  int n = 0;
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    n += isa_selected(o, isa);
  return n;
}

static ek_timer_opts timer_opts(const ek_tradeoff_opts *o) {
  ek_timer_opts t = ek_timer_defaults();
  t.min_time = o->min_time;
  t.warmup_time = o->quick ? 0.002 : 0.01;
  if (o->quick)
    t.min_sample_time = 2e-4;
  return t;
}

// ---- timing ----------------------------------------------------------------

typedef struct {
  int f64, polar;
  size_t nblocks;
  void *A, *U, *S, *V;
  ek_svd3_opts opts;
  const ek_material *mat;
  ek_isa isa;
  int rc;
} kernel_ctx;

static void call_svd(void *p) {
  kernel_ctx *c = p;
  if (c->polar)
    c->rc = c->f64 ? ek_polar3_aosoa_f64(c->nblocks, c->A, c->U, c->V, &c->opts)
                   : ek_polar3_aosoa_f32(c->nblocks, c->A, c->U, c->V, &c->opts);
  else
    c->rc = c->f64 ? ek_svd3_aosoa_f64(c->nblocks, c->A, c->U, c->S, c->V, &c->opts)
                   : ek_svd3_aosoa_f32(c->nblocks, c->A, c->U, c->S, c->V, &c->opts);
  ek_do_not_optimize(c->V);
}

static void call_pk1(void *p) {
  kernel_ctx *c = p;
  c->rc = c->f64 ? ek_material_eval_aosoa_f64(c->mat, EK_MAT_PK1, c->isa, c->nblocks, c->A, c->S,
                                              NULL, c->U, 0)
                 : ek_material_eval_aosoa_f32(c->mat, EK_MAT_PK1, c->isa, c->nblocks, c->A, c->S,
                                              NULL, c->U, 0);
  ek_do_not_optimize(c->U);
}

// AoSoA copy (9 planes) of the first `n` AoS double matrices, in the
// context's precision; NULL when out of memory.
static void *pack(int f64, size_t n, const double *aos) {
  size_t lanes = f64 ? EK_LANES_F64 : EK_LANES_F32, blocks = (n + lanes - 1) / lanes;
  size_t sz = f64 ? sizeof(double) : sizeof(float);
  void *soa = ek_alloc(blocks * lanes * 9 * sz);
  if (!soa)
    return NULL;
  int rc;
  if (f64) {
    rc = ek_aosoa_pack_f64(n, 9, aos, soa);
  } else {
    float *a = malloc(n * 9 * sizeof *a);
    if (!a) {
      ek_free(soa);
      return NULL;
    }
    ek_check_to_f32(n * 9, aos, a);
    rc = ek_aosoa_pack_f32(n, 9, a, soa);
    free(a);
  }
  if (rc) {
    ek_free(soa);
    return NULL;
  }
  return soa;
}

static void *zeroed(size_t bytes) {
  void *p = ek_alloc(bytes);
  if (p)
    memset(p, 0, bytes);
  return p;
}

// Times fn at every thread count and adds one point per count (p's other
// fields already filled). 0 or < 0.
// ctx is fn's context and *rc the kernel's return code it stores.
static int time_and_add(ek_tradeoff *t, ek_bench_fn *fn, void *ctx, const int *rc, size_t items,
                        ek_tradeoff_point *p) {
  const ek_tradeoff_opts *o = ek_tradeoff_options(t);
  ek_timer_opts topts = timer_opts(o);
  fn(ctx);
  if (*rc < 0) { // > 0: elements outside a model's domain, counted
    fprintf(stderr, "ek tradeoff: %s %s: kernel returned %d: %s\n", p->family, p->setting, *rc,
            ek_last_error());
    return -1;
  }
  for (int k = 0; k < o->nthread_counts; k++) {
    omp_set_num_threads(o->thread_counts[k]);
    ek_timing timing;
    if (ek_time(fn, ctx, items, &topts, &timing) != 0)
      return -1;
    p->threads = o->thread_counts[k];
    p->time_median = timing.stats.median;
    p->time_min = timing.stats.min;
    ek_timing_free(&timing);
    if (ek_tradeoff_add(t, p))
      return -1;
  }
  return 0;
}

// ---- svd3 and polar3 -------------------------------------------------------

static const char *const svd_metric =
    "max(recon, orth, det, sigma, order) / s1 (ek-verify's worst; +inf: wrong sign of S2)";
static const char *const polar_metric =
    "max(recon, orth, det, sym, rdiff) (ek-verify's worst, relative to s1)";

// Per-matrix error of the outputs U, S, V (polar: R in U, Ssym in V) of the
// whole set, as ek-verify's svd3 family measures it (verify_svd3.c).
static long set_errors(int polar, const ek_svd3_set *s, double budget, const double *U,
                       const double *S, const double *V, double *err) {
  long m = 0;
  for (size_t i = 0; i < s->n; i++) {
    if (s->bad[i]) // a non-finite input: not in the random set
      continue;
    const double *A = s->A + 9 * i, *Sr = s->S_ref + 3 * i;
    double w;
    if (polar) {
      ek_polar3_metrics pm;
      ek_check_polar3(A, U + 9 * i, V + 9 * i, Sr, s->R_ref + 9 * i, &pm);
      w = ek_polar3_metrics_worst(&pm);
    } else {
      ek_svd3_metrics sm;
      ek_check_svd3(A, U + 9 * i, S + 3 * i, V + 9 * i, Sr, budget, &sm);
      w = ek_svd3_metrics_worst(&sm);
    }
    err[m++] = w;
  }
  return m;
}

static int map_svd(ek_tradeoff *t, int bits, const ek_svd3_set *set, ek_isa auto_isa) {
  const ek_tradeoff_opts *o = ek_tradeoff_options(t);
  const int f64 = bits == 64;
  const double budget = f64 ? EK_SVD3_TOL_F64 : EK_SVD3_TOL_F32;
  const int def_sweeps = f64 ? ek_svd3_default_sweeps_f64() : ek_svd3_default_sweeps_f32();
  const int def_exact = f64 ? ek_svd3_default_exact_rsqrt_f64() : ek_svd3_default_exact_rsqrt_f32();
  const int def_refine = f64 ? ek_svd3_default_refine_f64() : ek_svd3_default_refine_f32();
  const size_t n = set->n, nt = n < CACHE_BATCH ? n : CACHE_BATCH;
  const size_t lanes = f64 ? EK_LANES_F64 : EK_LANES_F32, sz = f64 ? 8 : 4;
  kernel_ctx c = {.f64 = f64, .nblocks = (nt + lanes - 1) / lanes};
  c.A = pack(f64, nt, set->A);
  c.U = zeroed(c.nblocks * lanes * 9 * sz), c.V = zeroed(c.nblocks * lanes * 9 * sz);
  c.S = zeroed(c.nblocks * lanes * 3 * sz);
  double *U = malloc(n * 9 * sizeof *U), *S = malloc(n * 3 * sizeof *S);
  double *V = malloc(n * 9 * sizeof *V), *err = malloc(n * sizeof *err);
  int rc = 0;
  if (!c.A || !c.U || !c.S || !c.V || !U || !S || !V || !err) {
    fprintf(stderr, "ek tradeoff: out of memory (svd3, %zu matrices)\n", n);
    rc = -1;
  }
  for (int polar = 0; polar < 2 && rc == 0; polar++)
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT && rc == 0; isa++) {
      if (!isa_selected(o, isa))
        continue;
      for (int sweeps = 1; sweeps <= MAX_SWEEPS && rc == 0; sweeps++)
        for (int exact = 1; exact >= 0 && rc == 0; exact--)
          for (int refine = 0; refine <= EK_SVD3_MAX_REFINE && rc == 0; refine++) {
            int is_def_knobs = sweeps == def_sweeps && exact == def_exact && refine == def_refine;
            int mcadams = refine == 0 && sweeps == 4 && !exact;
            // The default knobs run as ek-verify runs them: options zero.
            ek_svd3_opts opts = {.isa = (ek_isa)isa};
            if (!is_def_knobs) {
              opts.sweeps = sweeps;
              opts.exact_rsqrt = exact ? 1 : -1;
              opts.refine = refine ? refine : EK_SVD3_REFINE_NONE;
            }
            char setting[256], refine_text[12];
            snprintf(refine_text, sizeof refine_text, refine ? "%d" : "none", refine);
            snprintf(setting, sizeof setting, "precision=f%d;sweeps=%d;rsqrt=%s;refine=%s;isa=%s%s",
                     bits, sweeps, exact ? "exact" : "approx", refine_text,
                     ek_isa_name((ek_isa)isa),
                     mcadams        ? ";label=mcadams2011"
                     : is_def_knobs ? ";label=default"
                                    : "");
            const char *family = polar ? "polar3" : "svd3";
            ek_tradeoff_progress(t, "%s %s", family, setting);
            int krc = ek_check_run_svd3(bits, polar, n, set->A, U, S, V, &opts);
            if (krc) {
              fprintf(stderr, "ek tradeoff: %s %s: kernel returned %d: %s\n", family, setting, krc,
                      ek_last_error());
              rc = -1;
              break;
            }
            ek_tradeoff_point p = {
                .family = family,
                .setting = setting,
                .is_default = is_def_knobs && isa == (int)auto_isa,
                .time_unit = "ns/matrix",
                .error_metric = polar ? polar_metric : svd_metric,
                .budget = budget,
                .energy_drift = NAN,
            };
            long m = set_errors(polar, set, budget, U, S, V, err);
            ek_tradeoff_distribution(err, m, &p);
            c.polar = polar;
            c.opts = opts;
            rc = time_and_add(t, call_svd, &c, &c.rc, nt, &p);
          }
    }
  ek_free(c.A), ek_free(c.U), ek_free(c.S), ek_free(c.V);
  free(U), free(S), free(V), free(err);
  return rc;
}

// ---- P(F) per model ----------------------------------------------------------

static const char *const pk1_metric =
    "|P - P_ref|_max / max(|P_ref|_max, (mu + |lambda|) s^3), s = max(1, |F|_max) "
    "(ek-verify's material P)";

static int map_pk1(ek_tradeoff *t, int bits, ek_isa auto_isa) {
  const ek_tradeoff_opts *o = ek_tradeoff_options(t);
  const int f32 = bits == 32;
  const size_t n = (size_t)o->n, nt = n < CACHE_BATCH ? n : CACHE_BATCH;
  const size_t lanes = f32 ? EK_LANES_F32 : EK_LANES_F64, sz = f32 ? 4 : 8;
  double *F = malloc(n * 9 * sizeof *F), *R = malloc(n * 9 * sizeof *R);
  double *dF = malloc(n * 9 * sizeof *dF), *ref = malloc(n * 9 * sizeof *ref);
  double *out = malloc(n * 9 * sizeof *out), *err = malloc(n * sizeof *err);
  float *Ff = malloc(n * 9 * sizeof *Ff), *Rf = malloc(n * 9 * sizeof *Rf);
  float *dFf = malloc(n * 9 * sizeof *dFf), *Of = malloc(n * 9 * sizeof *Of);
  kernel_ctx c = {.f64 = !f32, .nblocks = (nt + lanes - 1) / lanes};
  c.U = zeroed(c.nblocks * lanes * 9 * sz);
  int rc = 0;
  if (!F || !R || !dF || !ref || !out || !err || !Ff || !Rf || !dFf || !Of || !c.U) {
    fprintf(stderr, "ek tradeoff: out of memory (pk1, %zu elements)\n", n);
    rc = -1;
  }
  if (rc == 0) {
    ek_check_material_inputs(o->seed, f32, n, F, R, dF);
    ek_check_to_f32(n * 9, F, Ff), ek_check_to_f32(n * 9, R, Rf), ek_check_to_f32(n * 9, dF, dFf);
    c.A = pack(!f32, nt, F); // F
    c.S = pack(!f32, nt, R); // R (corotated linear)
    if (!c.A || !c.S)
      rc = -1;
  }
  for (int model = 0; model < EK_MODEL_COUNT && rc == 0; model++) {
    ek_material mat = {(ek_model)model, PK1_MU, PK1_LAMBDA, 0};
    ek_material_ref mr = {model, mat.mu, mat.lambda, mat.clamp};
    const double lame = mat.mu + fabs(mat.lambda);
    for (size_t e = 0; e < n; e++)
      ek_pk1_ref(&mr, F + 9 * e, R + 9 * e, ref + 9 * e);
    char family[64];
    snprintf(family, sizeof family, "pk1/%s", ek_model_long_name((ek_model)model));
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT && rc == 0; isa++) {
      if (!isa_selected(o, isa))
        continue;
      char setting[256];
      snprintf(setting, sizeof setting, "precision=f%d;isa=%s;mu=%g;lambda=%g;clamp=0", bits,
               ek_isa_name((ek_isa)isa), mat.mu, mat.lambda);
      ek_tradeoff_progress(t, "%s %s", family, setting);
      int krc;
      if (f32) {
        krc = ek_material_eval_f32(&mat, EK_MAT_PK1, (ek_isa)isa, n, Ff, Rf, dFf, Of, 0);
        ek_check_from_f32(n * 9, Of, out);
      } else {
        krc = ek_material_eval_f64(&mat, EK_MAT_PK1, (ek_isa)isa, n, F, R, dF, out, 0);
      }
      if (krc < 0) {
        fprintf(stderr, "ek tradeoff: %s %s: kernel returned %d: %s\n", family, setting, krc,
                ek_last_error());
        rc = -1;
        break;
      }
      // The norm of verify_material.c, element by element.
      long m = 0;
      for (size_t e = 0; e < n; e++) {
        const double *r = ref + 9 * e, *got = out + 9 * e, *Fe = F + 9 * e;
        int ref_finite = 1, got_finite = 1;
        double amax_F = 0, amax_r = 0, d = 0;
        for (int q = 0; q < 9; q++) {
          ref_finite &= isfinite(r[q]) != 0, got_finite &= isfinite(got[q]) != 0;
          amax_F = fmax(amax_F, fabs(Fe[q])), amax_r = fmax(amax_r, fabs(r[q]));
          d = fmax(d, fabs(got[q] - r[q]));
        }
        if (!ref_finite) // outside the model's domain
          continue;
        const double s = fmax(1, amax_F);
        err[m++] = got_finite ? d / fmax(amax_r, lame * s * s * s) : INFINITY;
      }
      ek_tradeoff_point p = {
          .family = family,
          .setting = setting,
          .is_default = isa == (int)auto_isa,
          .time_unit = "ns/element",
          .error_metric = pk1_metric,
          .budget = f32 ? EK_PK1_TOL_F32 : EK_PK1_TOL_F64,
          .energy_drift = NAN,
      };
      ek_tradeoff_distribution(err, m, &p);
      c.mat = &mat;
      c.isa = (ek_isa)isa;
      rc = time_and_add(t, call_pk1, &c, &c.rc, nt, &p);
    }
  }
  free(F), free(R), free(dF), free(ref), free(out), free(err);
  free(Ff), free(Rf), free(dFf), free(Of);
  ek_free(c.A), ek_free(c.S), ek_free(c.U);
  return rc;
}

// ---- the kernel part -------------------------------------------------------

// ---- rotation: the SVD polar vs the warm-started polar ------------------------

static const char *const rotation_metric =
    "max_ij |R - R_ref|, R_ref the LAPACK polar of A rounded to the precision (ek-verify's "
    "polar_warm rdiff)";

typedef struct {
  int f64;
  size_t nblocks;
  void *A, *R;
  ek_polar_warm_opts opts;
  int rc;
} warm_ctx;

static void call_warm(void *p) {
  warm_ctx *c = p;
  // R is the guess and the answer: a fixed number of iterations, so the
  // cost does not depend on how close the guess already is.
  c->rc = c->f64 ? ek_polar3_warm_aosoa_f64(c->nblocks, c->A, c->R, &c->opts)
                 : ek_polar3_warm_aosoa_f32(c->nblocks, c->A, c->R, &c->opts);
  ek_do_not_optimize(c->R);
}

// Errors of n rotations R against the LAPACK polar of A rounded to bits.
static long rotation_errors(int bits, size_t n, const double *A, const double *R, double *err) {
  for (size_t e = 0; e < n; e++) {
    double d = ek_check_polar_error(bits, A + e * 9, R + e * 9);
    err[e] = d == d ? d : INFINITY;
  }
  return (long)n;
}

#define WARM_MAX_ITERATIONS 4

// One family "rotation": on ek-verify's polar_warm "random" inputs (A = R*
// S, s in [0.5, 2], a guess within 10 degrees of R*), the SVD polar at its
// default and at McAdams' setting (no guess needed) and the warm polar at
// 1..WARM_MAX_ITERATIONS iterations from the guess, per precision and ISA.
int ek_tradeoff_polar_warm(ek_tradeoff *t) {
  const ek_tradeoff_opts *o = ek_tradeoff_options(t);
  ek_isa auto_isa;
  if (ek_isa_resolve(EK_ISA_AUTO, &auto_isa) != EK_OK)
    return -1;
  const size_t n = (size_t)o->n, nt = n < CACHE_BATCH ? n : CACHE_BATCH;
  double *A = malloc(n * 9 * sizeof *A), *G = malloc(n * 9 * sizeof *G);
  double *R = malloc(n * 9 * sizeof *R), *S = malloc(n * 9 * sizeof *S);
  double *err = malloc(n * sizeof *err);
  int rc = A && G && R && S && err ? 0 : -1;
  if (rc)
    fprintf(stderr, "ek tradeoff: out of memory (rotation, %zu matrices)\n", n);
  else {
    ek_rng rng;
    ek_rng_seed(&rng, ek_check_stream_seed(o->seed, "random"));
    ek_check_warm_cases(&rng, n, 0.5, 2, 0, 10, A, G);
  }
  for (int bits = 32; bits <= 64 && rc == 0; bits += 32) {
    const int f64 = bits == 64;
    const size_t lanes = f64 ? EK_LANES_F64 : EK_LANES_F32, sz = f64 ? 8 : 4;
    const size_t nblocks = (nt + lanes - 1) / lanes;
    const int def_it =
        f64 ? ek_polar_warm_default_iterations_f64() : ek_polar_warm_default_iterations_f32();
    const double budget = f64 ? EK_POLAR_WARM_TOL_F64 : EK_POLAR_WARM_TOL_F32;
    kernel_ctx c = {.f64 = f64, .polar = 1, .nblocks = nblocks};
    warm_ctx w = {.f64 = f64, .nblocks = nblocks};
    c.A = w.A = pack(f64, nt, A);
    w.R = pack(f64, nt, G);
    c.U = zeroed(nblocks * lanes * 9 * sz), c.V = zeroed(nblocks * lanes * 9 * sz);
    if (!c.A || !w.R || !c.U || !c.V) {
      fprintf(stderr, "ek tradeoff: out of memory (rotation)\n");
      rc = -1;
    }
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT && rc == 0; isa++) {
      if (!isa_selected(o, isa))
        continue;
      // -2: the SVD polar, McAdams' setting; -1: the SVD polar, default;
      // 1..: the warm polar at that many iterations.
      for (int it = -2; it <= WARM_MAX_ITERATIONS && rc == 0; it++) {
        if (it == 0)
          continue;
        char setting[256];
        ek_tradeoff_point p = {.family = "rotation",
                               .setting = setting,
                               .time_unit = "ns/matrix",
                               .error_metric = rotation_metric,
                               .budget = budget,
                               .energy_drift = NAN};
        int krc;
        if (it < 0) {
          ek_svd3_opts so = {.isa = (ek_isa)isa};
          if (it == -2)
            so.sweeps = 4, so.exact_rsqrt = -1, so.refine = EK_SVD3_REFINE_NONE;
          snprintf(setting, sizeof setting, "precision=f%d;method=svd;isa=%s;label=%s", bits,
                   ek_isa_name((ek_isa)isa), it == -2 ? "mcadams2011" : "svd_default");
          ek_tradeoff_progress(t, "rotation %s", setting);
          krc = ek_check_run_svd3(bits, 1, n, A, R, NULL, S, &so);
          c.opts = so;
        } else {
          snprintf(setting, sizeof setting, "precision=f%d;method=warm;iterations=%d;isa=%s%s",
                   bits, it, ek_isa_name((ek_isa)isa), it == def_it ? ";label=default" : "");
          ek_tradeoff_progress(t, "rotation %s", setting);
          memcpy(R, G, n * 9 * sizeof *R);
          krc = ek_check_run_polar_warm(bits, 1, n, A, R, (ek_isa)isa, it);
          w.opts = (ek_polar_warm_opts){.iterations = it, .isa = (ek_isa)isa};
          p.is_default = it == def_it && isa == (int)auto_isa;
        }
        if (krc) {
          fprintf(stderr, "ek tradeoff: rotation %s: kernel returned %d: %s\n", setting, krc,
                  ek_last_error());
          rc = -1;
          break;
        }
        ek_tradeoff_distribution(err, rotation_errors(bits, n, A, R, err), &p);
        rc = it < 0 ? time_and_add(t, call_svd, &c, &c.rc, nt, &p)
                    : time_and_add(t, call_warm, &w, &w.rc, nt, &p);
      }
    }
    ek_free(c.A), ek_free(w.R), ek_free(c.U), ek_free(c.V);
  }
  free(A), free(G), free(R), free(S), free(err);
  return rc;
}

int ek_tradeoff_kernels(ek_tradeoff *t) {
  const ek_tradeoff_opts *o = ek_tradeoff_options(t);
  // The default setting runs on what EK_ISA_AUTO resolves to (EK_ISA may
  // force it); when --isas leaves that ISA out, the best one mapped.
  ek_isa auto_isa;
  if (ek_isa_resolve(EK_ISA_AUTO, &auto_isa) != EK_OK) {
    fprintf(stderr, "ek tradeoff: %s\n", ek_last_error());
    return -1;
  }
  if (!isa_selected(o, auto_isa))
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
      if (isa_selected(o, isa))
        auto_isa = (ek_isa)isa; // ascending: the last one selected is the best
  int nisa = count_isas(o);
  ek_tradeoff_expect(t, 2 * 2 * nisa * MAX_SWEEPS * 2 * (EK_SVD3_MAX_REFINE + 1) +
                            2 * EK_MODEL_COUNT * nisa + 2 * nisa * (2 + WARM_MAX_ITERATIONS));
  int rc = 0;
  for (int bits = 32; bits <= 64 && rc == 0; bits += 32) {
    // ek-verify's random set of this precision, with its LAPACK reference.
    ek_svd3_set set;
    ek_svd3_set_init(&set, &ek_check_families[0], "random", o->seed, (size_t)o->n, bits);
    rc = map_svd(t, bits, &set, auto_isa);
    ek_svd3_set_free(&set);
  }
  for (int bits = 32; bits <= 64 && rc == 0; bits += 32)
    rc = map_pk1(t, bits, auto_isa);
  if (rc == 0)
    rc = ek_tradeoff_polar_warm(t);
  return rc;
}
