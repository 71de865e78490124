// ek-bench family "fvm": the FVM force kernel (include/ek/fvm.h), the whole
// kernel per call: gather, F, P (SVD where the model needs one), H and
// scatter, on box meshes (ek_mesh_box) deformed by a fixed smooth field.
//
// Rows (name: fvm/<model>/<scatter>/<isa>/<prec>/tets:<N>/threads:<T>):
//   - fixed corotated, f32, best ISA: every scatter strategy at ~1e4, 1e5
//     and 1e6 tets (the target rows; the speed-up column compares
//     each strategy with the atomic baseline of the same size and threads);
//   - fixed corotated, f64, best ISA: every strategy at ~1e5 tets;
//   - every other model x precision, default strategy (thread buffers),
//     best ISA, ~1e5 tets (what each model's needs cost inside the force
//     kernel), and neo-Hookean / stable neo-Hookean f32 at ~1e6 (the
//     bandwidth-bound case);
//   - fixed corotated f32, thread buffers, ~1e5 tets on every other
//     available ISA (scalar, ...), for the vectorisation gain.
//   - the Hessian of the implicit loop (include/ek/hessian.h), thread
//     buffers, best ISA, ~1e5 tets: one product K p per model x precision
//     (name hessian/<model>/apply/...; the speed-up column is the force
//     row of the same model, precision, size and threads divided by it:
//     the "one product <= 1.2x one force evaluation" reads as a
//     speed-up >= 0.83), and the caching gradient pass (hessian/<model>/
//     gradient/..., double, cache in the row's precision) for the same.
// Kept to these so the default suite's share stays small on 2 cores.
//
// Declared work per tet: the bytes a force evaluation must move, per tet:
// the element block (4 vertex indices, 9 Dm^-1 entries and V0: 16 + 10 r
// bytes, r = 4 or 8 for f32 / f64), streamed once, plus each vertex's
// position read and force written once (6 r bytes per vertex, about a
// sixth of a vertex per tet on these box meshes): 60 bytes per tet in f32
// on the 1e6 mesh. Scratch traffic a strategy adds (force buffers, corner
// arrays) is not counted: %bw is the fraction of the triad bandwidth the
// row would need if it moved only what it must. No flop count: P's cost
// depends on the model and its SVD.
#include <ek/fvm.h>
#include <ek/hessian.h>
#include <ek/mesh.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

typedef struct {
  int n[3];      // box cells; 6 tets per cell
  ek_mesh *mesh; // built on first use
  float *x32, *f32;
  double *x64, *f64;
  double *R; // identity-free rotations for corotated linear (all tets)
  // The same as per-element state (elements.h), f32 and f64: the form the
  // simulation core hands the force kernel.
  ek_tet_state *R32, *R64;
} fvm_mesh_case;

// ~1e4, 1e5, 1e6 tets.
static fvm_mesh_case sizes[3] = {{.n = {12, 12, 12}}, {.n = {26, 26, 25}}, {.n = {55, 55, 55}}};

// Tets of a case (6 per box cell) and vertices per tet (for the bytes a
// row must move).
static size_t case_tets(const fvm_mesh_case *mc) {
  return (size_t)6 * mc->n[0] * mc->n[1] * mc->n[2];
}
static double case_verts_per_tet(const fvm_mesh_case *mc) {
  return (double)((size_t)(mc->n[0] + 1) * (mc->n[1] + 1) * (mc->n[2] + 1)) / (double)case_tets(mc);
}

typedef struct {
  fvm_mesh_case *mc;
  ek_material mat;
  ek_fvm_opts opts;
  int f32;
  ek_bench *b;
  int failed;
} fvm_ctx;

static void run_forces(void *p) {
  fvm_ctx *c = p;
  int rc = c->f32 ? ek_fvm_forces_ex_f32(c->mc->mesh, &c->mat, c->mc->x32, c->mc->f32, &c->opts)
                  : ek_fvm_forces_ex_f64(c->mc->mesh, &c->mat, c->mc->x64, c->mc->f64, &c->opts);
  if (rc < 0 && !c->failed) {
    c->failed = 1;
    ek_bench_fail(c->b, "fvm: ek_fvm_forces_ex returned %d", rc);
  }
}

// Mesh and a deformed state: a smooth stretch-and-twist field, so every
// tet has a different, non-trivial F (about 10% strain), no inversion.
static int mesh_setup(ek_bench *b, fvm_mesh_case *mc) {
  if (mc->mesh)
    return 0;
  char err[256];
  double h = 0.01;
  mc->mesh = ek_mesh_box(mc->n[0], mc->n[1], mc->n[2], mc->n[0] * h, mc->n[1] * h, mc->n[2] * h,
                         err, sizeof err);
  if (!mc->mesh) {
    ek_bench_fail(b, "fvm: ek_mesh_box: %s", err);
    return -1;
  }
  size_t nv = ek_mesh_nverts(mc->mesh), nt = ek_mesh_ntets(mc->mesh);
  const double *X = ek_mesh_rest_positions(mc->mesh);
  mc->x32 = malloc(nv * 3 * sizeof(float));
  mc->f32 = malloc(nv * 3 * sizeof(float));
  mc->x64 = malloc(nv * 3 * sizeof(double));
  mc->f64 = malloc(nv * 3 * sizeof(double));
  mc->R = malloc(nt * 9 * sizeof(double));
  if (!mc->x32 || !mc->f32 || !mc->x64 || !mc->f64 || !mc->R) {
    ek_bench_fail(b, "fvm: out of memory");
    return -1;
  }
  double lz = mc->n[2] * h;
  for (size_t v = 0; v < nv; v++) {
    double px = X[v * 3], py = X[v * 3 + 1], pz = X[v * 3 + 2];
    double a = 0.3 * pz / lz, ca = cos(a), sa = sin(a);
    double x[3] = {1.05 * (ca * px - sa * py), 0.97 * (sa * px + ca * py), 1.08 * pz};
    for (int k = 0; k < 3; k++) {
      mc->x64[v * 3 + k] = x[k];
      mc->x32[v * 3 + k] = (float)x[k];
    }
  }
  // Corotated linear reads R: a small fixed rotation about z per tet.
  for (size_t e = 0; e < nt; e++) {
    double a = 0.1 * (double)(e % 7), ca = cos(a), sa = sin(a);
    double R[9] = {ca, -sa, 0, sa, ca, 0, 0, 0, 1};
    memcpy(mc->R + e * 9, R, sizeof R);
  }
  mc->R32 = ek_tet_state_create(ek_mesh_elements(mc->mesh), 9, 0);
  mc->R64 = ek_tet_state_create(ek_mesh_elements(mc->mesh), 9, 1);
  if (!mc->R32 || !mc->R64 || ek_tet_state_set_f64(mc->R32, mc->R) ||
      ek_tet_state_set_f64(mc->R64, mc->R)) {
    ek_bench_fail(b, "fvm: per-element state: %s", ek_last_error());
    return -1;
  }
  return 0;
}

static const struct {
  const char *name;
  ek_material mat;
} models[] = {
    {"linear", {EK_MODEL_LINEAR, 1e5, 4e5, 0}},
    {"stvk", {EK_MODEL_STVK, 1e5, 4e5, 0}},
    {"corot_linear", {EK_MODEL_COROTATED_LINEAR, 1e5, 4e5, 0}},
    {"fixed_corot", {EK_MODEL_FIXED_COROTATED, 1e5, 4e5, 0}},
    {"arap", {EK_MODEL_ARAP, 1e5, 0, 0}},
    {"psi_r", {EK_MODEL_PSI_R, 1e5, 0, 0}},
    {"nh", {EK_MODEL_NEO_HOOKEAN, 1e5, 4e5, 0}},
    {"snh", {EK_MODEL_STABLE_NEO_HOOKEAN, 1e5, 4e5, 0}},
};
#define FIXED_COROT 3

static const ek_scatter scatters[] = {EK_SCATTER_ATOMIC, EK_SCATTER_COLORED,
                                      EK_SCATTER_THREAD_BUFFERS, EK_SCATTER_GATHER};

// with_baseline: the atomic row of the same model, ISA, precision, size and
// threads exists (fixed corotated at the best ISA) and is the speed-up base.
static int one_row(ek_bench *b, int model, ek_scatter s, ek_isa isa, int f32, int size, int threads,
                   int with_baseline) {
  fvm_mesh_case *mc = &sizes[size];
  size_t ntets = case_tets(mc);
  char name[EK_BENCH_NAME_MAX], base[EK_BENCH_NAME_MAX], knobs[128];
  const char *prec = f32 ? "f32" : "f64";
  snprintf(name, sizeof name, "fvm/%s/%s/%s/%s/tets:%zu/threads:%d", models[model].name,
           ek_scatter_name(s), ek_isa_name(isa), prec, ntets, threads);
  snprintf(base, sizeof base, "fvm/%s/%s/%s/%s/tets:%zu/threads:%d", models[model].name,
           ek_scatter_name(EK_SCATTER_ATOMIC), ek_isa_name(isa), prec, ntets, threads);
  if (!ek_bench_wants(b, name))
    return 0;
  static fvm_ctx ctx;
  if (!ek_bench_listing(b)) {
    if (mesh_setup(b, mc))
      return -1;
    memset(&ctx, 0, sizeof ctx);
    ctx.mc = mc;
    ctx.mat = models[model].mat;
    ctx.opts.scatter = s;
    ctx.opts.isa = isa;
    if (ctx.mat.model == EK_MODEL_COROTATED_LINEAR)
      ctx.opts.R_state = f32 ? mc->R32 : mc->R64;
    ctx.f32 = f32;
    ctx.b = b;
  }
  snprintf(knobs, sizeof knobs, "model=%s;scatter=%s;tets=%zu;ncolors=%d", models[model].name,
           ek_scatter_name(s), ntets, mc->mesh ? ek_mesh_ncolors(mc->mesh) : 0);
  double real_bytes = f32 ? 4 : 8;
  double verts_per_tet = case_verts_per_tet(mc);
  ek_bench_row row = {.name = name,
                      .family = "fvm",
                      .isa = isa,
                      .precision = prec,
                      .threads = threads,
                      .knobs = knobs,
                      .items = ntets,
                      .flops_per_item = 0,
                      .bytes_per_item = 4 * 4 + 10 * real_bytes + 6 * real_bytes * verts_per_tet,
                      .baseline = s == EK_SCATTER_ATOMIC || !with_baseline ? NULL : base,
                      .fn = run_forces,
                      .ctx = &ctx};
  return ek_bench_run(b, &row);
}

typedef struct {
  fvm_mesh_case *mc;
  ek_fvm_hessian *h;
  int f32, gradient;
  ek_tet_state *R;
  ek_bench *b;
  int failed;
} hess_ctx;

// The Hessian rows' state (one row at a time; freed with the meshes).
static hess_ctx hess_row_ctx;

static void run_hessian(void *p) {
  hess_ctx *c = p;
  int rc = c->gradient ? ek_fvm_hessian_gradient_f64(c->h, c->mc->x64, c->R, c->mc->f64, NULL, 1)
           : c->f32    ? ek_fvm_hessian_apply_f32(c->h, c->mc->x32, c->mc->f32)
                       : ek_fvm_hessian_apply_f64(c->h, c->mc->x64, c->mc->f64);
  if (rc < 0 && !c->failed) {
    c->failed = 1;
    ek_bench_fail(c->b, "fvm: ek_fvm_hessian returned %d", rc);
  }
}

// One Hessian row (product or caching gradient pass) of a model at ~1e5
// tets, thread buffers; its baseline is the force row of the same model.
static int hessian_row(ek_bench *b, int model, ek_isa isa, int f32, int gradient, int threads) {
  fvm_mesh_case *mc = &sizes[1];
  size_t ntets = case_tets(mc);
  char name[EK_BENCH_NAME_MAX], base[EK_BENCH_NAME_MAX], knobs[128];
  const char *prec = f32 ? "f32" : "f64";
  snprintf(name, sizeof name, "hessian/%s/%s/%s/%s/tets:%zu/threads:%d", models[model].name,
           gradient ? "gradient" : "apply", ek_isa_name(isa), prec, ntets, threads);
  snprintf(base, sizeof base, "fvm/%s/%s/%s/%s/tets:%zu/threads:%d", models[model].name,
           ek_scatter_name(EK_SCATTER_THREAD_BUFFERS), ek_isa_name(isa), prec, ntets, threads);
  if (!ek_bench_wants(b, name))
    return 0;
  hess_ctx *const c = &hess_row_ctx;
  if (!ek_bench_listing(b)) {
    if (mesh_setup(b, mc))
      return -1;
    ek_fvm_hessian_destroy(c->h);
    memset(c, 0, sizeof *c);
    ek_fvm_hessian_opts o = {
        .scatter = EK_SCATTER_THREAD_BUFFERS, .isa = isa, .precision = f32 ? 32 : 64};
    c->h = ek_fvm_hessian_create(ek_mesh_elements(mc->mesh), &models[model].mat, &o);
    c->mc = mc;
    c->f32 = f32;
    c->gradient = gradient;
    c->b = b;
    c->R = models[model].mat.model == EK_MODEL_COROTATED_LINEAR ? mc->R64 : NULL;
    // The products need a cache: one gradient pass at the deformed state.
    if (!c->h || ek_fvm_hessian_gradient_f64(c->h, mc->x64, c->R, mc->f64, NULL, 1) < 0) {
      ek_bench_fail(b, "fvm: ek_fvm_hessian: %s", ek_last_error());
      return -1;
    }
  }
  snprintf(knobs, sizeof knobs, "model=%s;op=%s;scatter=thread_buffers;tets=%zu;cache_planes=%d",
           models[model].name, gradient ? "gradient" : "apply", ntets,
           c->h ? ek_fvm_hessian_cache_planes(c->h) : 0);
  double r = f32 ? 4 : 8;
  double verts_per_tet = case_verts_per_tet(mc);
  int planes = c->h ? ek_fvm_hessian_cache_planes(c->h) : 0;
  // The element block, the cache (read by a product, written by the
  // gradient pass) and each vertex's value read and written once.
  ek_bench_row row = {.name = name,
                      .family = "fvm",
                      .isa = isa,
                      .precision = prec,
                      .threads = threads,
                      .knobs = knobs,
                      .items = ntets,
                      .flops_per_item = 0,
                      .bytes_per_item = 4 * 4 + 10 * (gradient ? 8 : r) + planes * r +
                                        6 * (gradient ? 8 : r) * verts_per_tet,
                      .baseline = base,
                      .fn = run_hessian,
                      .ctx = c};
  return ek_bench_run(b, &row);
}

int bench_fvm(ek_bench *b) {
  ek_isa isas[EK_ISA_COUNT];
  int nisa = ek_bench_isas(b, isas);
  int counts[EK_BENCH_MAX_THREAD_COUNTS];
  int nth = ek_bench_thread_counts(b, counts);
  if (nisa < 1)
    return 0;
  ek_isa best = isas[nisa - 1];
  int rc = 0;
  for (int t = 0; t < nth; t++) {
    // Fixed corotated f32: every strategy at every size.
    for (int size = 0; size < 3; size++)
      for (size_t s = 0; s < sizeof scatters / sizeof scatters[0]; s++)
        rc |= one_row(b, FIXED_COROT, scatters[s], best, 1, size, counts[t], 1);
    // Fixed corotated f64: every strategy at 1e5.
    for (size_t s = 0; s < sizeof scatters / sizeof scatters[0]; s++)
      rc |= one_row(b, FIXED_COROT, scatters[s], best, 0, 1, counts[t], 1);
    // Every model x precision, default strategy, 1e5.
    for (size_t m = 0; m < sizeof models / sizeof models[0]; m++)
      for (int f32 = 1; f32 >= 0; f32--)
        if (!(m == FIXED_COROT))
          rc |= one_row(b, (int)m, EK_SCATTER_THREAD_BUFFERS, best, f32, 1, counts[t], 0);
    // The SVD-free neo-Hookean pair at 1e6, f32: the bandwidth-bound rows.
    for (size_t m = 0; m < sizeof models / sizeof models[0]; m++)
      if (models[m].mat.model == EK_MODEL_NEO_HOOKEAN ||
          models[m].mat.model == EK_MODEL_STABLE_NEO_HOOKEAN)
        rc |= one_row(b, (int)m, EK_SCATTER_THREAD_BUFFERS, best, 1, 2, counts[t], 0);
    // The other ISAs.
    for (int i = 0; i < nisa - 1; i++)
      rc |= one_row(b, FIXED_COROT, EK_SCATTER_THREAD_BUFFERS, isas[i], 1, 1, counts[t], 0);
    // The implicit loop's Hessian: products per model x precision, and
    // the caching gradient pass.
    for (size_t m = 0; m < sizeof models / sizeof models[0]; m++)
      for (int f32 = 1; f32 >= 0; f32--) {
        rc |= hessian_row(b, (int)m, best, f32, 0, counts[t]);
        rc |= hessian_row(b, (int)m, best, f32, 1, counts[t]);
      }
  }
  if (!ek_bench_listing(b)) {
    ek_fvm_hessian_destroy(hess_row_ctx.h);
    hess_row_ctx.h = NULL;
  }
  if (!ek_bench_listing(b))
    for (int size = 0; size < 3; size++) {
      fvm_mesh_case *mc = &sizes[size];
      ek_tet_state_destroy(mc->R32);
      ek_tet_state_destroy(mc->R64);
      mc->R32 = mc->R64 = NULL;
      ek_mesh_destroy(mc->mesh);
      free(mc->x32);
      free(mc->f32);
      free(mc->x64);
      free(mc->f64);
      free(mc->R);
      mc->mesh = NULL;
      mc->x32 = mc->f32 = NULL;
      mc->x64 = mc->f64 = mc->R = NULL;
    }
  return rc < 0 ? -1 : 0;
}
