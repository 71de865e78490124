// ek-bench family "cloth": the cloth kernels (include/ek/cloth.h) against
// their baselines in the same run.
//
// Rows, for each available ISA (forced through opts.isa) x precision x
// thread count:
//   cloth/polar32/<isa>/<prec>/threads:T   ek_polar32_aosoa_* per triangle
//       (3x2 F -> R, Uc) on a cache-resident batch; baseline: the 3x3 polar
//       per tet of the same ISA, precision and threads (the target:
//       polar32 f32 per triangle <= 0.5x the 3x3 polar per tet, i.e. a
//       speed-up of >= 2 in the "vs base" column);
//   cloth/polar32_aos/<isa>/<prec>/threads:T  ek_polar32_ex_* on the same
//       numbers as AoS records (6 in, 6 + 4 out); baseline: the polar32
//       row (the AoS entry point's cost over its AoSoA kernel);
//   cloth/polar3/<isa>/<prec>/threads:T    ek_polar3_aosoa_* (the SVD's
//       polar, default options) per 3x3 matrix, the baseline above;
//   cloth/kabsch/<isa>/<prec>/threads:T    ek_kabsch_ex_* per one-ring set
//       of 6 or 7 points (covariance + the SVD's polar), AoS as a loop
//       hands them over; baseline: LAPACK per set;
// and per thread count:
//   cloth/kabsch_lapack/f64/threads:T      the double reference per set:
//       centroids, covariance, dgesvd, R = V diag(1, 1, d) U^T
//       (ek_kabsch_ref), sets split over OpenMP threads.
//   cloth/membrane_{energy,hessian}/<model>/<isa>/<prec>/threads:T  the
//       vector energy / projected Hessian product of a cloth
//       (ek_cloth_energy_ex_*, ek_cloth_hessian_apply_ex_*, membrane
//       kernels + bending + gather) per triangle, on a 64 x 64 grid (8192
//       triangles, crumpled); baseline: the default path of the same model
//       and threads,
//   cloth/membrane_{energy,hessian}/<model>/default/f64/threads:T  the
//       default ek_cloth_energy_f64 / ek_cloth_hessian_apply_f64
//       (project = 1): scalar double for ARAP, the vector kernels (auto
//       ISA, the double path's bits) for StVK.
// Inputs: seeded Gaussian F / rotated noisy point sets / a jittered grid.
#include <ek/batch.h>
#include <ek/cloth.h>
#include <ek/cloth_force.h>
#include <ek/svd3.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "cloth/cloth_ref.h"

#define CACHE_BATCH 4096
#define KABSCH_SETS 4096

typedef struct {
  int f64, polar3, aos, rc;
  ek_isa isa;
  size_t n, nblocks;
  void *F, *R, *Uc; // AoSoA batches, or AoS arrays of n records (aos)
} polar_ctx;

static void call_polar(void *p) {
  polar_ctx *c = p;
  int rc;
  if (c->polar3) {
    ek_svd3_opts o = {.isa = c->isa};
    rc = c->f64 ? ek_polar3_aosoa_f64(c->nblocks, c->F, c->R, c->Uc, &o)
                : ek_polar3_aosoa_f32(c->nblocks, c->F, c->R, c->Uc, &o);
  } else if (c->aos) {
    ek_cloth_opts o = {.isa = c->isa};
    rc = c->f64 ? ek_polar32_ex_f64(c->n, c->F, c->R, c->Uc, &o)
                : ek_polar32_ex_f32(c->n, c->F, c->R, c->Uc, &o);
  } else {
    ek_cloth_opts o = {.isa = c->isa};
    rc = c->f64 ? ek_polar32_aosoa_f64(c->nblocks, c->F, c->R, c->Uc, &o)
                : ek_polar32_aosoa_f32(c->nblocks, c->F, c->R, c->Uc, &o);
  }
  if (rc)
    c->rc = rc;
}

static int setup_polar(ek_bench *b, polar_ctx *c) {
  int in = c->polar3 ? 9 : 6, out_sym = c->polar3 ? 9 : 4;
  size_t n = c->n = CACHE_BATCH;
  size_t sz = c->f64 ? sizeof(double) : sizeof(float);
  c->nblocks = c->f64 ? ek_aosoa_blocks_f64(n) : ek_aosoa_blocks_f32(n);
  size_t lanes = c->f64 ? EK_LANES_F64 : EK_LANES_F32;
  c->F = ek_alloc(c->nblocks * lanes * in * sz);
  c->R = ek_alloc(c->nblocks * lanes * in * sz);
  c->Uc = ek_alloc(c->nblocks * lanes * out_sym * sz);
  if (!c->F || !c->R || !c->Uc)
    return -1;
  ek_bench_rng rng;
  ek_bench_rng_init(&rng, ek_bench_seed(b));
  for (size_t i = 0; i < c->nblocks * lanes * in; i++) {
    double g = ek_bench_rng_gauss(&rng);
    if (c->f64)
      ((double *)c->F)[i] = g;
    else
      ((float *)c->F)[i] = (float)g;
  }
  return 0;
}

static void free_polar(polar_ctx *c) { ek_free(c->F), ek_free(c->R), ek_free(c->Uc); }

typedef struct {
  int f64, lapack, rc;
  ek_isa isa;
  size_t nsets, npoints;
  size_t *offsets;
  double *P, *Q, *R;
  float *Pf, *Qf, *Rf;
} kabsch_ctx;

static void call_kabsch(void *p) {
  kabsch_ctx *c = p;
  if (c->lapack) {
    long n = (long)c->nsets;
#pragma omp parallel for schedule(static)
    for (long s = 0; s < n; s++) {
      size_t k0 = c->offsets[s];
      ek_kabsch_ref(c->offsets[s + 1] - k0, c->P + 3 * k0, c->Q + 3 * k0, NULL, 0x1p-49,
                    c->R + 9 * s, NULL);
    }
    return;
  }
  ek_cloth_opts o = {.isa = c->isa};
  int rc = c->f64 ? ek_kabsch_ex_f64(c->nsets, c->offsets, c->P, c->Q, NULL, c->R, &o)
                  : ek_kabsch_ex_f32(c->nsets, c->offsets, c->Pf, c->Qf, NULL, c->Rf, &o);
  if (rc)
    c->rc = rc;
}

static int setup_kabsch(ek_bench *b, kabsch_ctx *c) {
  ek_bench_rng rng;
  ek_bench_rng_init(&rng, ek_bench_seed(b));
  c->nsets = KABSCH_SETS;
  c->offsets = malloc((c->nsets + 1) * sizeof *c->offsets);
  if (!c->offsets)
    return -1;
  c->offsets[0] = 0;
  for (size_t s = 0; s < c->nsets; s++) // one-rings: 6 or 7 points
    c->offsets[s + 1] = c->offsets[s] + 6 + s % 2;
  size_t np = c->npoints = c->offsets[c->nsets];
  c->P = malloc(3 * np * sizeof(double)), c->Q = malloc(3 * np * sizeof(double));
  c->R = malloc(9 * c->nsets * sizeof(double));
  c->Pf = malloc(3 * np * sizeof(float)), c->Qf = malloc(3 * np * sizeof(float));
  c->Rf = malloc(9 * c->nsets * sizeof(float));
  if (!c->P || !c->Q || !c->R || !c->Pf || !c->Qf || !c->Rf)
    return -1;
  for (size_t s = 0; s < c->nsets; s++) {
    double Rt[9];
    ek_rng_rotation(&rng.words, Rt);
    for (size_t k = c->offsets[s]; k < c->offsets[s + 1]; k++) {
      double *p = c->P + 3 * k, *q = c->Q + 3 * k;
      for (int i = 0; i < 3; i++)
        p[i] = ek_bench_rng_gauss(&rng);
      for (int i = 0; i < 3; i++)
        q[i] = Rt[3 * i] * p[0] + Rt[3 * i + 1] * p[1] + Rt[3 * i + 2] * p[2] +
               1e-2 * ek_bench_rng_gauss(&rng);
    }
  }
  for (size_t i = 0; i < 3 * np; i++)
    c->Pf[i] = (float)c->P[i], c->Qf[i] = (float)c->Q[i];
  return 0;
}

static void free_kabsch(kabsch_ctx *c) {
  free(c->offsets), free(c->P), free(c->Q), free(c->R), free(c->Pf), free(c->Qf), free(c->Rf);
}

// ---- Membrane energy and Hessian product ---------------------------------
#define MEMBRANE_N 64
typedef struct {
  int f64, hessian, plain, rc; // plain: the default f64 path
  ek_isa isa;
  ek_cloth_params p;
  ek_cloth *cl;
  size_t n3;
  double *x, *dx, *q, E;
  float *xf, *dxf, *qf;
} membrane_ctx;

static void call_membrane(void *p) {
  membrane_ctx *c = p;
  ek_cloth_force_opts o = {.isa = c->isa};
  int rc = 0;
  if (c->plain && !c->hessian)
    c->E = ek_cloth_energy_f64(c->cl, &c->p, c->x), rc = isnan(c->E) ? -1 : 0;
  else if (c->plain)
    rc = ek_cloth_hessian_apply_f64(c->cl, &c->p, c->x, 1, c->dx, c->q);
  else if (!c->hessian)
    rc = c->f64 ? ek_cloth_energy_ex_f64(c->cl, &c->p, c->x, &c->E, &o)
                : ek_cloth_energy_ex_f32(c->cl, &c->p, c->xf, &c->E, &o);
  else
    rc = c->f64 ? ek_cloth_hessian_apply_ex_f64(c->cl, &c->p, c->x, 1, c->dx, c->q, &o)
                : ek_cloth_hessian_apply_ex_f32(c->cl, &c->p, c->xf, 1, c->dxf, c->qf, &o);
  if (rc)
    c->rc = rc;
}

// A jittered MEMBRANE_N^2 grid of 1 cm cells, stretched by 10% and
// crumpled by 15% of a cell.
static int setup_membrane(ek_bench *b, membrane_ctx *c) {
  const int N = MEMBRANE_N;
  const size_t nv = (size_t)(N + 1) * (N + 1), nt = 2 * (size_t)N * N;
  ek_bench_rng rng;
  ek_bench_rng_init(&rng, ek_bench_seed(b));
  double *X = malloc(3 * nv * sizeof(double));
  int32_t *T = malloc(3 * nt * sizeof(int32_t));
  c->n3 = 3 * nv;
  c->x = malloc(c->n3 * sizeof(double)), c->dx = malloc(c->n3 * sizeof(double));
  c->q = malloc(c->n3 * sizeof(double));
  c->xf = malloc(c->n3 * sizeof(float)), c->dxf = malloc(c->n3 * sizeof(float));
  c->qf = malloc(c->n3 * sizeof(float));
  if (!X || !T || !c->x || !c->dx || !c->q || !c->xf || !c->dxf || !c->qf) {
    free(X), free(T);
    return -1;
  }
  for (int j = 0; j <= N; j++)
    for (int i = 0; i <= N; i++) {
      size_t v = (size_t)j * (N + 1) + (size_t)i;
      X[3 * v] = 0.01 * i, X[3 * v + 1] = 0.01 * j, X[3 * v + 2] = 0;
      for (int k = 0; k < 3; k++)
        c->x[3 * v + k] = 1.1 * X[3 * v + k] + 0.0015 * ek_bench_rng_gauss(&rng);
    }
  size_t t = 0;
  for (int j = 0; j < N; j++)
    for (int i = 0; i < N; i++) {
      int32_t a = j * (N + 1) + i, bb = a + 1, cc = a + N + 1, d = cc + 1;
      int32_t q[6] = {a, bb, d, a, d, cc};
      memcpy(T + 3 * t, q, sizeof q);
      t += 2;
    }
  for (size_t i = 0; i < c->n3; i++) {
    c->dx[i] = ek_bench_rng_gauss(&rng);
    c->xf[i] = (float)c->x[i], c->dxf[i] = (float)c->dx[i];
  }
  c->cl = ek_cloth_create(nv, X, nt, T);
  free(X), free(T);
  return c->cl ? 0 : -1;
}

static void free_membrane(membrane_ctx *c) {
  ek_cloth_destroy(c->cl);
  free(c->x), free(c->dx), free(c->q), free(c->xf), free(c->dxf), free(c->qf);
}

// Time one row after a checked first call.
static void timed(ek_bench *b, ek_bench_row *row, int *rc) {
  if (ek_bench_listing(b)) {
    ek_bench_run(b, row);
    return;
  }
  *rc = 0;
  row->fn(row->ctx);
  if (*rc) {
    ek_bench_fail(b, "%s: the call returned %d (%s)", row->name, *rc, ek_last_error());
    return;
  }
  row->rc = rc;
  ek_bench_run(b, row);
}

int bench_cloth(ek_bench *b) {
  ek_isa isas[EK_ISA_COUNT];
  int nisa = ek_bench_isas(b, isas), counts[EK_BENCH_MAX_THREAD_COUNTS];
  int ncounts = ek_bench_thread_counts(b, counts), listing = ek_bench_listing(b);
  char name[EK_BENCH_NAME_MAX], base[EK_BENCH_NAME_MAX], lapack[EK_BENCH_NAME_MAX],
      aos_name[EK_BENCH_NAME_MAX];
  for (int ti = 0; ti < ncounts; ti++) {
    int threads = counts[ti];
    snprintf(lapack, sizeof lapack, "cloth/kabsch_lapack/f64/threads:%d", threads);
    if (ek_bench_wants(b, lapack)) {
      kabsch_ctx c = {.f64 = 1, .lapack = 1};
      if (!listing && setup_kabsch(b, &c) != 0) {
        ek_bench_fail(b, "%s: out of memory", lapack);
      } else {
        ek_bench_row row = {.name = lapack,
                            .family = "cloth",
                            .isa = EK_ISA_AUTO,
                            .isa_label = "lapack",
                            .precision = "f64",
                            .threads = threads,
                            .knobs = "api=lapack;ref=ek_kabsch_ref;points=6-7",
                            .items = KABSCH_SETS,
                            .fn = call_kabsch,
                            .ctx = &c};
        timed(b, &row, &c.rc);
      }
      free_kabsch(&c);
    }
    for (int f64 = 0; f64 <= 1; f64++) {
      const char *prec = f64 ? "f64" : "f32";
      for (int ii = 0; ii < nisa; ii++) {
        ek_isa isa = isas[ii];
        // The 3x3 polar per tet first: the baseline of the polar32 row.
        snprintf(base, sizeof base, "cloth/polar3/%s/%s/threads:%d", ek_isa_name(isa), prec,
                 threads);
        snprintf(name, sizeof name, "cloth/polar32/%s/%s/threads:%d", ek_isa_name(isa), prec,
                 threads);
        snprintf(aos_name, sizeof aos_name, "cloth/polar32_aos/%s/%s/threads:%d", ek_isa_name(isa),
                 prec, threads);
        // polar3 (the base), polar32 through AoSoA, polar32 through AoS; a
        // batch of whole blocks, so the AoS arrays fit the AoSoA buffers.
        for (int v = 0; v < 3; v++) {
          int polar3 = v == 0, aos = v == 2;
          const char *row_name = polar3 ? base : aos ? aos_name : name;
          if (!ek_bench_wants(b, row_name))
            continue;
          polar_ctx c = {.f64 = f64, .polar3 = polar3, .aos = aos, .isa = isa, .n = CACHE_BATCH};
          if (!listing && setup_polar(b, &c) != 0) {
            ek_bench_fail(b, "%s: out of memory", row_name);
            free_polar(&c);
            continue;
          }
          ek_bench_row row = {.name = row_name,
                              .family = "cloth",
                              .isa = isa,
                              .precision = prec,
                              .threads = threads,
                              .knobs = polar3 ? "api=aosoa;kernel=polar3;per=tet"
                                       : aos  ? "api=aos;kernel=polar32;per=triangle"
                                              : "api=aosoa;kernel=polar32;per=triangle",
                              .items = CACHE_BATCH,
                              .bytes_per_item = (polar3 ? 27 : 16) * (f64 ? 8.0 : 4.0),
                              .baseline = polar3 ? NULL
                                          : aos  ? name
                                                 : base,
                              .fn = call_polar,
                              .ctx = &c};
          timed(b, &row, &c.rc);
          free_polar(&c);
        }
        // The membrane rows: the default path first (their baseline).
        for (int hessian = 0; hessian <= 1; hessian++)
          for (int model = 0; model < EK_MEMBRANE_COUNT; model++) {
            const char *kind = hessian ? "membrane_hessian" : "membrane_energy";
            const char *mn = model == EK_MEMBRANE_STVK ? "stvk" : "arap";
            snprintf(base, sizeof base, "cloth/%s/%s/default/f64/threads:%d", kind, mn, threads);
            snprintf(name, sizeof name, "cloth/%s/%s/%s/%s/threads:%d", kind, mn, ek_isa_name(isa),
                     prec, threads);
            for (int plain = 1; plain >= 0; plain--) {
              const char *row_name = plain ? base : name;
              // The default path once per thread count (its first row).
              if (plain && (ii != 0 || f64))
                continue;
              if (!ek_bench_wants(b, row_name))
                continue;
              membrane_ctx c = {.f64 = f64,
                                .hessian = hessian,
                                .plain = plain,
                                .isa = isa,
                                .p = {(ek_membrane_model)model, 1e3, 5e2, 1e-3}};
              if (!listing && setup_membrane(b, &c) != 0) {
                ek_bench_fail(b, "%s: setup failed (%s)", row_name, ek_last_error());
                free_membrane(&c);
                continue;
              }
              ek_bench_row row = {.name = row_name,
                                  .family = "cloth",
                                  .isa = plain ? EK_ISA_AUTO : isa,
                                  .isa_label = plain ? "default" : NULL,
                                  .precision = plain ? "f64" : prec,
                                  .threads = threads,
                                  .knobs = plain ? "api=cloth;path=default;project=1"
                                                 : "api=cloth;path=vector;project=1",
                                  .items = 2 * MEMBRANE_N * MEMBRANE_N,
                                  .baseline = plain ? NULL : base,
                                  .fn = call_membrane,
                                  .ctx = &c};
              timed(b, &row, &c.rc);
              free_membrane(&c);
            }
          }
        snprintf(name, sizeof name, "cloth/kabsch/%s/%s/threads:%d", ek_isa_name(isa), prec,
                 threads);
        if (ek_bench_wants(b, name)) {
          kabsch_ctx c = {.f64 = f64, .isa = isa};
          if (!listing && setup_kabsch(b, &c) != 0) {
            ek_bench_fail(b, "%s: out of memory", name);
          } else {
            ek_bench_row row = {.name = name,
                                .family = "cloth",
                                .isa = isa,
                                .precision = prec,
                                .threads = threads,
                                .knobs = "api=aos;points=6-7",
                                .items = KABSCH_SETS,
                                .baseline = lapack,
                                .fn = call_kabsch,
                                .ctx = &c};
            timed(b, &row, &c.rc);
          }
          free_kabsch(&c);
        }
      }
    }
  }
  return 0;
}
