// ek-bench family "material": P(F) and dP(F; dF) per model (include/ek/
// material.h), AoSoA-native, for each available ISA (forced) x precision x
// thread count, with the cost split against the SVD and the polar
// decomposition alone:
//   material/svd/<isa>/<prec>/threads:T        ek_svd3_aosoa_* (U, S, V)
//   material/polar/<isa>/<prec>/threads:T      ek_polar3_aosoa_* (R, Ssym)
//   material/pk1/<model>/<isa>/<prec>/threads:T
//   material/diff/<model>/...                  dP, unprojected
//   material/diff_psd/<model>/...              dP with the PSD projection
// <model> is ek_model_name(), plus nh_clamp and snh_clamp (clamp = 0.3,
// evaluated through the SVD). Speed-up baselines, so the table shows the
// issue's ratios directly: every SVD-free model's row against fixed
// corotated (same op, ISA, precision, threads; target >= 4x), and fixed
// corotated / ARAP P against the polar decomposition alone (target:
// fixed corotated within 1.3x of it). The model's own arithmetic is the
// difference between a model's P row and the polar (or SVD) row.
// Inputs: F = I + 0.1 G, G Gaussian (J > 0, so neo-Hookean is defined),
// dF Gaussian, R = I (corotated linear reads it); 4096 elements (cache
// resident: the rows time the kernels, not memory).
#include <ek/ek.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

#define MATERIAL_BATCH 4096

typedef struct {
  int f64;
  size_t nblocks;
  void *F, *R, *dF, *out, *U, *S, *V;
  ek_material m;
  ek_material_op op;
  int project;
  ek_isa isa;
  int rc;
} material_ctx;

static size_t real_size(int f64) { return f64 ? sizeof(double) : sizeof(float); }

static void call_material(void *p) {
  material_ctx *c = p;
  c->rc = c->f64 ? ek_material_eval_aosoa_f64(&c->m, c->op, c->isa, c->nblocks, c->F, c->R, c->dF,
                                              c->out, c->project)
                 : ek_material_eval_aosoa_f32(&c->m, c->op, c->isa, c->nblocks, c->F, c->R, c->dF,
                                              c->out, c->project);
  c->rc = c->rc < 0 ? c->rc : 0;
  ek_do_not_optimize(c->out);
}

static void call_svd(void *p) {
  material_ctx *c = p;
  ek_svd3_opts o = {.isa = c->isa};
  c->rc = c->f64 ? ek_svd3_aosoa_f64(c->nblocks, c->F, c->U, c->S, c->V, &o)
                 : ek_svd3_aosoa_f32(c->nblocks, c->F, c->U, c->S, c->V, &o);
  ek_do_not_optimize(c->V);
}

static void call_polar(void *p) {
  material_ctx *c = p;
  ek_svd3_opts o = {.isa = c->isa};
  c->rc = c->f64 ? ek_polar3_aosoa_f64(c->nblocks, c->F, c->U, c->V, &o)
                 : ek_polar3_aosoa_f32(c->nblocks, c->F, c->U, c->V, &o);
  ek_do_not_optimize(c->V);
}

static void free_ctx(material_ctx *c) {
  ek_free(c->F), ek_free(c->R), ek_free(c->dF), ek_free(c->out);
  ek_free(c->U), ek_free(c->S), ek_free(c->V);
}

// AoSoA inputs (every lane real: the batch is a multiple of the lanes).
static int setup(ek_bench *b, material_ctx *c, int f64) {
  memset(c, 0, sizeof *c);
  c->f64 = f64;
  const size_t lanes = f64 ? EK_LANES_F64 : EK_LANES_F32, sz = real_size(f64);
  c->nblocks = MATERIAL_BATCH / lanes;
  const size_t planes = c->nblocks * lanes;
  c->F = ek_alloc(9 * planes * sz), c->R = ek_alloc(9 * planes * sz);
  c->dF = ek_alloc(9 * planes * sz), c->out = ek_alloc(81 * planes * sz);
  c->U = ek_alloc(9 * planes * sz), c->S = ek_alloc(3 * planes * sz);
  c->V = ek_alloc(9 * planes * sz);
  if (!c->F || !c->R || !c->dF || !c->out || !c->U || !c->S || !c->V) {
    free_ctx(c);
    return -1;
  }
  memset(c->out, 0, 81 * planes * sz);
  ek_bench_rng rng;
  ek_bench_rng_init(&rng, ek_bench_seed(b) * 2 + (unsigned)f64);
  for (size_t blk = 0; blk < c->nblocks; blk++)
    for (int q = 0; q < 9; q++)
      for (size_t l = 0; l < lanes; l++) {
        size_t s = (blk * 9 + (size_t)q) * lanes + l;
        double F = (q % 4 == 0) + 0.1 * ek_bench_rng_gauss(&rng), R = q % 4 == 0;
        double dF = ek_bench_rng_gauss(&rng);
        if (f64)
          ((double *)c->F)[s] = F, ((double *)c->R)[s] = R, ((double *)c->dF)[s] = dF;
        else
          ((float *)c->F)[s] = (float)F, ((float *)c->R)[s] = (float)R,
                  ((float *)c->dF)[s] = (float)dF;
      }
  return 0;
}

typedef struct {
  char name[32];
  ek_model model;
  double clamp;
  int svd_free; // baseline: fixed corotated of the same op
} model_row;

// Every model in ek_model order (clamp 0), then, clamped at 0.3, each
// clampable model whose clamp adds an SVD (neo-Hookean, stable neo-Hookean).
static model_row models[2 * EK_MODEL_COUNT];

static int models_init(void) {
  int n = 0;
  for (int pass = 0; pass < 2; pass++)
    for (int m = 0; m < EK_MODEL_COUNT; m++) {
      const ek_model_desc *d = ek_model_describe((ek_model)m);
      const int svd_free = ek_model_need((ek_model)m, 0) != EK_NEEDS_POLAR;
      if (pass == 1 && !(d->clampable && svd_free))
        continue;
      models[n] = (model_row){
          .model = (ek_model)m, .clamp = pass ? 0.3 : 0, .svd_free = pass ? 0 : svd_free};
      snprintf(models[n].name, sizeof models[n].name, "%s%s", d->name, pass ? "_clamp" : "");
      n++;
    }
  return n;
}

static void run_row(ek_bench *b, ek_bench_row *row, material_ctx *c) {
  if (ek_bench_listing(b)) {
    ek_bench_run(b, row);
    return;
  }
  row->fn(c);
  if (c->rc != 0) {
    ek_bench_fail(b, "%s: the call returned %d (%s)", row->name, c->rc, ek_last_error());
    return;
  }
  row->rc = &c->rc;
  ek_bench_run(b, row);
}

int bench_material(ek_bench *b) {
  ek_isa isas[EK_ISA_COUNT];
  int nisa = ek_bench_isas(b, isas);
  int counts[EK_BENCH_MAX_THREAD_COUNTS];
  int ncounts = ek_bench_thread_counts(b, counts);
  const int listing = ek_bench_listing(b);
  const int nmodels = models_init();
  static const char *const op_names[3] = {"pk1", "diff", "diff_psd"};
  static const ek_material_op ops[3] = {EK_MAT_PK1, EK_MAT_PK1_DIFF, EK_MAT_PK1_DIFF};
  // Values moved per element: P reads F (9) and writes P (9); dP also reads
  // dF (9); corotated linear also reads R (9, not counted here).
  static const double values[3] = {18, 27, 27};

  for (int f64 = 0; f64 < 2; f64++) {
    const char *prec = f64 ? "f64" : "f32";
    material_ctx c;
    int ready = 0;
    for (int t = 0; t < ncounts; t++)
      for (int i = 0; i < nisa; i++) {
        const char *iname = ek_isa_name(isas[i]);
        char name[EK_BENCH_NAME_MAX], base[EK_BENCH_NAME_MAX], polar[EK_BENCH_NAME_MAX];
        snprintf(polar, sizeof polar, "material/polar/%s/%s/threads:%d", iname, prec, counts[t]);
        for (int k = -2; k < 3 * nmodels; k++) {
          const int svd_row = k < 0;
          const model_row *mr = svd_row ? NULL : &models[k % nmodels];
          const int op = svd_row ? 0 : k / nmodels;
          if (k == -2)
            snprintf(name, sizeof name, "material/svd/%s/%s/threads:%d", iname, prec, counts[t]);
          else if (k == -1)
            snprintf(name, sizeof name, "%s", polar);
          else
            snprintf(name, sizeof name, "material/%s/%s/%s/%s/threads:%d", op_names[op], mr->name,
                     iname, prec, counts[t]);
          if (!ek_bench_wants(b, name))
            continue;
          if (!listing && !ready) {
            if (setup(b, &c, f64) != 0) {
              ek_bench_fail(b, "%s: input setup failed", name);
              return -1;
            }
            ready = 1;
          }
          char knobs[128];
          const char *baseline = NULL;
          if (svd_row) {
            snprintf(knobs, sizeof knobs, "api=aosoa;part=%s", k == -2 ? "svd" : "polar");
          } else {
            snprintf(knobs, sizeof knobs, "api=aosoa;model=%s;clamp=%g;project=%d", mr->name,
                     mr->clamp, op == 2);
            if (mr->svd_free) {
              snprintf(base, sizeof base, "material/%s/fixed_corot/%s/%s/threads:%d", op_names[op],
                       iname, prec, counts[t]);
              baseline = base;
            } else if (op == 0) {
              baseline = polar;
            }
          }
          ek_bench_row row = {.name = name,
                              .family = "material",
                              .isa = isas[i],
                              .precision = prec,
                              .threads = counts[t],
                              .knobs = knobs,
                              .items = MATERIAL_BATCH,
                              .bytes_per_item =
                                  (svd_row ? (k == -2 ? 30 : 27) : values[op]) * real_size(f64),
                              .baseline = baseline,
                              .fn = k == -2   ? call_svd
                                    : k == -1 ? call_polar
                                              : call_material,
                              .ctx = listing ? NULL : &c};
          if (!listing) {
            c.isa = isas[i];
            if (!svd_row) {
              c.m = (ek_material){mr->model, 1.3, 2.1, mr->clamp};
              c.op = ops[op];
              c.project = op == 2;
            }
          }
          run_row(b, &row, &c);
        }
      }
    if (ready)
      free_ctx(&c);
  }
  return 0;
}
