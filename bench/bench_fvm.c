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
//   - fixed corotated with the warm-started polar (fvm.h polar_state,
//     default iterations; name fvm/fixed_corot_warm/...), f32 and f64,
//     thread buffers, best ISA, ~1e5 tets: the speed-up column is the
//     neo-Hookean row of the same precision, size and threads divided by
//     it (the "<= 1.5x the neo-Hookean force per tet" reads as a
//     speed-up >= 0.67); fvm/fixed_corot_warm_it1/... the same with one
//     iteration (polar_iterations = 1: in the scenes, from a guess one
//     step old, one iteration is as accurate as two). The per-tet rotations start at the identity
//     and are the converged ones after the harness's warm-up calls; the work per call does not
//     depend on the guess (a fixed iteration count).
//   - fixed corotated f32, thread buffers, ~1e5 tets on every other
//     available ISA (scalar, ...), for the vectorisation gain.
//   - the Hessian of the implicit loop (include/ek/hessian.h), thread
//     buffers, best ISA, ~1e5 tets: one product K p per model x precision
//     (name hessian/<model>/apply/...; the speed-up column is the force
//     row of the same model, precision, size and threads divided by it:
//     the "one product <= 1.2x one force evaluation" reads as a
//     speed-up >= 0.83), and the caching gradient pass (hessian/<model>/
//     gradient/..., double, cache in the row's precision) for the same,
//     and the assembly of the projected Hessian (hessian/<model>/assemble/
//     ...: element Hessians in the row's precision + the gather into CSR,
//     ek_fvm_hessian_assemble; the speed-up column is force / assembly, so
//     the "assembly <= 3x one force evaluation" reads as >= 0.33),
//     and its upper block triangle in the row's precision (hessian/<model>/
//     assemble_upper/..., ek_fvm_hessian_assemble_upper_*, same column).
//   - XPBD (include/ek/xpbd.h), best ISA, ~1e5 tets (the mesh of the
//     StVK force rows), tets and clusters x Gauss-Seidel and Jacobi x
//     f32/f64: ONE sweep over every constraint (ek_xpbd_iterate_* with 1
//     iteration), name xpbd/<elements>/<solver>/<isa>/<prec>/tets:N/
//     threads:T; the speed-up column is the StVK force row of the same
//     precision and threads divided by it (the issue's "one Gauss-Seidel
//     iteration over all tets <= 2x one force evaluation" reads as a
//     speed-up >= 0.5); the same rows with the stable neo-Hookean pair,
//     xpbd_snh/..., against the snh force row; and a note after the rows
//     gives sweep / force for
//     tets Gauss-Seidel per precision and thread count.
// Kept to these so the default suite's share stays small on 2 cores.
//
// Declared work per tet: the bytes a force evaluation must move, per tet:
// the element block (4 vertex indices, 9 Dm^-1 entries and V0: 16 + 10 r
// bytes, r = 4 or 8 for f32 / f64), streamed once, plus each vertex's
// position read and force written once (6 r bytes per vertex, about a
// sixth of a vertex per tet on these box meshes): 60 bytes per tet in f32
// on the 1e6 mesh. Scratch traffic a strategy adds (force buffers, corner
// arrays) is not counted: %bw is the fraction of the triad bandwidth the
// row would need if it moved only what it must. Thread buffers (the
// default) add EK_FVM_PARTS rows of 4 reals per vertex: 11.3 B per tet in
// f32 on the 1e6 mesh, read and dirtied by the kernel and read again by
// the sum, so up to ~45 B per tet more where they leave the L3
// (docs/perf.md, memory-bound paths). No flop count: P's cost
// depends on the model and its SVD.
#include <ek/fvm.h>
#include <ek/hessian.h>
#include <ek/sim/mesh.h>
#include <ek/xpbd.h>
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
  ek_tet_state *W32, *W64; // the warm polar's per-tet rotations
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
  int rc = c->f32
               ? ek_mesh_fvm_forces_ex_f32(c->mc->mesh, &c->mat, c->mc->x32, c->mc->f32, &c->opts)
               : ek_mesh_fvm_forces_ex_f64(c->mc->mesh, &c->mat, c->mc->x64, c->mc->f64, &c->opts);
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
  double h = 0.01;
  mc->mesh = ek_mesh_box(mc->n[0], mc->n[1], mc->n[2], mc->n[0] * h, mc->n[1] * h, mc->n[2] * h);
  if (!mc->mesh) {
    ek_bench_fail(b, "fvm: ek_mesh_box: %s", ek_last_error());
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
  mc->W32 = ek_tet_state_create(ek_mesh_elements(mc->mesh), 9, 0);
  mc->W64 = ek_tet_state_create(ek_mesh_elements(mc->mesh), 9, 1);
  if (!mc->R32 || !mc->R64 || !mc->W32 || !mc->W64 || ek_tet_state_set_f64(mc->R32, mc->R) ||
      ek_tet_state_set_f64(mc->R64, mc->R)) {
    ek_bench_fail(b, "fvm: per-element state: %s", ek_last_error());
    return -1;
  }
  return 0;
}

// The force rows' materials: every model in ek_model order (from its
// descriptor; lambda 0 where the model has no volume term), then fixed
// corotated with the warm-started polar (default iterations and one).
#define NMODELS (EK_MODEL_COUNT + 2)
#define FIXED_COROT_WARM EK_MODEL_COUNT
#define FIXED_COROT_WARM_IT1 (EK_MODEL_COUNT + 1)
static struct {
  char name[32];
  ek_material mat;
} models[NMODELS];
static int FIXED_COROT, NEO_HOOKEAN; // the headline row, the warm rows' baseline
static int STVK;                     // the force rows the XPBD sweeps are compared with
static int SNH;                      // the stable neo-Hookean XPBD rows' model and force rows

static void models_init(void) {
  for (int m = 0; m < EK_MODEL_COUNT; m++) {
    const ek_model_desc *d = ek_model_describe((ek_model)m);
    snprintf(models[m].name, sizeof models[m].name, "%s", d->name);
    models[m].mat = (ek_material){(ek_model)m, 1e5, d->volume_term ? 4e5 : 0, 0};
  }
  ek_model fc = EK_MODEL_COUNT, nh = EK_MODEL_COUNT;
  ek_model_from_name("fixed_corot", &fc);
  ek_model_from_name("nh", &nh);
  FIXED_COROT = (int)fc, NEO_HOOKEAN = (int)nh, STVK = (int)EK_XPBD_MODEL;
  SNH = (int)EK_MODEL_STABLE_NEO_HOOKEAN;
  for (int w = FIXED_COROT_WARM; w <= FIXED_COROT_WARM_IT1; w++) {
    models[w].mat = models[FIXED_COROT].mat;
    snprintf(models[w].name, sizeof models[w].name, "%s_warm%s", ek_model_describe(fc)->name,
             w == FIXED_COROT_WARM_IT1 ? "_it1" : "");
  }
}
#define IS_WARM(m) ((m) == FIXED_COROT_WARM || (m) == FIXED_COROT_WARM_IT1)

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
  snprintf(base, sizeof base, "fvm/%s/%s/%s/%s/tets:%zu/threads:%d",
           models[IS_WARM(model) ? NEO_HOOKEAN : model].name,
           ek_scatter_name(IS_WARM(model) ? s : EK_SCATTER_ATOMIC), ek_isa_name(isa), prec, ntets,
           threads);
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
    if (ek_model_need(ctx.mat.model, 0) == EK_NEEDS_R_INPUT)
      ctx.opts.R_state = f32 ? mc->R32 : mc->R64;
    if (IS_WARM(model))
      ctx.opts.polar_state = f32 ? mc->W32 : mc->W64;
    if (model == FIXED_COROT_WARM_IT1)
      ctx.opts.polar_iterations = 1;
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
  int f32, gradient; // gradient: 0 product, 1 caching gradient, 2 assembly, 3 upper
  double *values;    // the assembled K (assembly rows)
  void *uvalues;     // K's upper block triangle (assemble_upper rows)
  ek_tet_state *R;
  ek_bench *b;
  int failed;
} hess_ctx;

// The Hessian rows' state (one row at a time; freed with the meshes).
static hess_ctx hess_row_ctx;

static void run_hessian(void *p) {
  hess_ctx *c = p;
  int rc = c->gradient == 3   ? (c->f32 ? ek_fvm_hessian_assemble_upper_f32(c->h, c->uvalues)
                                        : ek_fvm_hessian_assemble_upper_f64(c->h, c->uvalues))
           : c->gradient == 2 ? ek_fvm_hessian_assemble(c->h, c->values)
           : c->gradient ? ek_fvm_hessian_gradient_f64(c->h, c->mc->x64, c->R, c->mc->f64, NULL, 1)
           : c->f32      ? ek_fvm_hessian_apply_f32(c->h, c->mc->x32, c->mc->f32)
                         : ek_fvm_hessian_apply_f64(c->h, c->mc->x64, c->mc->f64);
  if (rc < 0 && !c->failed) {
    c->failed = 1;
    ek_bench_fail(c->b, "fvm: ek_fvm_hessian returned %d", rc);
  }
}

// One Hessian row (product or caching gradient pass) of a model at ~1e5
// tets, thread buffers; its baseline is the force row of the same model.
static int hessian_row(ek_bench *b, int model, ek_isa isa, int f32, int gradient, int threads) {
  static const char *const op_name[4] = {"apply", "gradient", "assemble", "assemble_upper"};
  fvm_mesh_case *mc = &sizes[1];
  size_t ntets = case_tets(mc);
  char name[EK_BENCH_NAME_MAX], base[EK_BENCH_NAME_MAX], knobs[128];
  const char *prec = f32 ? "f32" : "f64";
  snprintf(name, sizeof name, "hessian/%s/%s/%s/%s/tets:%zu/threads:%d", models[model].name,
           op_name[gradient], ek_isa_name(isa), prec, ntets, threads);
  snprintf(base, sizeof base, "fvm/%s/%s/%s/%s/tets:%zu/threads:%d", models[model].name,
           ek_scatter_name(EK_SCATTER_THREAD_BUFFERS), ek_isa_name(isa), prec, ntets, threads);
  if (!ek_bench_wants(b, name))
    return 0;
  hess_ctx *const c = &hess_row_ctx;
  if (!ek_bench_listing(b)) {
    if (mesh_setup(b, mc))
      return -1;
    ek_fvm_hessian_destroy(c->h);
    free(c->values);
    free(c->uvalues);
    memset(c, 0, sizeof *c);
    ek_fvm_hessian_opts o = {
        .scatter = EK_SCATTER_THREAD_BUFFERS, .isa = isa, .precision = f32 ? 32 : 64};
    c->h = ek_fvm_hessian_create(ek_mesh_elements(mc->mesh), &models[model].mat, &o);
    c->mc = mc;
    c->f32 = f32;
    c->gradient = gradient;
    c->b = b;
    c->R = ek_model_need(models[model].mat.model, 0) == EK_NEEDS_R_INPUT ? mc->R64 : NULL;
    // The products need a cache: one gradient pass at the deformed state.
    if (!c->h || ek_fvm_hessian_gradient_f64(c->h, mc->x64, c->R, mc->f64, NULL, 1) < 0) {
      ek_bench_fail(b, "fvm: ek_fvm_hessian: %s", ek_last_error());
      return -1;
    }
    ek_csr_pattern pat;
    if (gradient == 2 && (ek_fvm_hessian_pattern(c->h, &pat) < 0 ||
                          !(c->values = malloc(pat.nnz * sizeof(double))))) {
      ek_bench_fail(b, "fvm: ek_fvm_hessian_pattern: %s", ek_last_error());
      return -1;
    }
    ek_bsr_pattern up;
    if (gradient == 3 && (ek_fvm_hessian_pattern_upper(c->h, &up) < 0 ||
                          !(c->uvalues = malloc(9 * up.nblocks * (f32 ? 4 : 8))))) {
      ek_bench_fail(b, "fvm: ek_fvm_hessian_pattern_upper: %s", ek_last_error());
      return -1;
    }
  }
  snprintf(knobs, sizeof knobs, "model=%s;op=%s;scatter=thread_buffers;tets=%zu;cache_planes=%d",
           models[model].name, op_name[gradient], ntets,
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
                      // assembly: + the element Hessians written and
                      // read (2 x 144 values) and the map's 16 codes.
                      .bytes_per_item = gradient >= 2
                                            ? 4 * 4 + 10 * r + planes * r + 288 * r + 16 * 4
                                            : 4 * 4 + 10 * (gradient ? 8 : r) + planes * r +
                                                  6 * (gradient ? 8 : r) * verts_per_tet,
                      .baseline = base,
                      .fn = run_hessian,
                      .ctx = c};
  return ek_bench_run(b, &row);
}

// ---- XPBD sweeps --------------------------------------------------------

#define XPBD_H 1e-3 // substep of ek_xpbd_begin: sets alpha~ = 1 / (V E h^2)
#define XPBD_DENSITY 1000.0

typedef struct {
  ek_xpbd *xp;
  float *x32; // the row's own positions: the sweeps move them
  double *x64;
  int f32;
  ek_bench *b;
  int failed;
} xpbd_ctx;

// The XPBD rows' state (one row at a time; freed at the end of the family),
// and the most constraints found at rest after a row's timing (reported in
// the note: the claim that every sweep does the full work).
static xpbd_ctx xpbd_row_ctx;
static size_t xpbd_most_at_rest;

static void xpbd_ctx_free(xpbd_ctx *c) {
  ek_xpbd_destroy(c->xp);
  free(c->x32);
  free(c->x64);
  memset(c, 0, sizeof *c);
}

// One sweep, positions updated in place. The harness has no untimed reset
// between calls, so the calls keep sweeping from where the last one left
// x and lambda (no ek_xpbd_begin in between: lambda accumulates as within
// one substep). The positions converge, but the cost of a sweep does not
// depend on the values: every constraint is evaluated and projected in
// every sweep, except ones at rest (C <= EK_XPBD_C_MIN_*, whose scatter is
// skipped), and none comes to rest here, since the compliance keeps
// C_j = -alpha~_j lambda_j away from 0 at the fixed point of the 10%
// strain state; the note after the rows reports how many were skipped.
static void run_xpbd_sweep(void *p) {
  xpbd_ctx *c = p;
  int rc = c->f32 ? ek_xpbd_iterate_f32(c->xp, NULL, c->x32, 1)
                  : ek_xpbd_iterate_f64(c->xp, NULL, c->x64, 1);
  if (rc < 0 && !c->failed) {
    c->failed = 1;
    ek_bench_fail(c->b, "fvm: ek_xpbd_iterate returned %d: %s", rc, ek_last_error());
  }
}

// Constraints whose multiplier is still exactly 0: those skipped as at
// rest in every sweep so far.
static size_t xpbd_at_rest(const ek_xpbd *xp) {
  size_t n = ek_xpbd_count(xp), zero = 0;
  double *lambda = malloc(n * sizeof(double));
  if (!lambda || ek_xpbd_lambda(xp, lambda) != 0) {
    free(lambda);
    return (size_t)-1;
  }
  for (size_t j = 0; j < n; j++)
    zero += lambda[j] == 0;
  free(lambda);
  return zero;
}

// StVK's constraint rows "xpbd/...", the stable neo-Hookean pair's
// "xpbd_snh/..." (model SNH).
static void xpbd_name(char *name, size_t len, int model, ek_xpbd_elements e, ek_xpbd_solver s,
                      ek_isa isa, int f32, size_t ntets, int threads) {
  snprintf(name, len, "%s/%s/%s/%s/%s/tets:%zu/threads:%d", model == SNH ? "xpbd_snh" : "xpbd",
           ek_xpbd_elements_name(e), ek_xpbd_solver_name(s), ek_isa_name(isa), f32 ? "f32" : "f64",
           ntets, threads);
}

static void model_force_name(char *name, size_t len, int model, ek_isa isa, int f32, size_t ntets,
                             int threads) {
  snprintf(name, len, "fvm/%s/%s/%s/%s/tets:%zu/threads:%d", models[model].name,
           ek_scatter_name(EK_SCATTER_THREAD_BUFFERS), ek_isa_name(isa), f32 ? "f32" : "f64", ntets,
           threads);
}

static void stvk_force_name(char *name, size_t len, ek_isa isa, int f32, size_t ntets,
                            int threads) {
  model_force_name(name, len, STVK, isa, f32, ntets, threads);
}

// One XPBD sweep row at ~1e5 tets. Setup as the XPBD loop would see the
// force row's state: the StVK (or stable neo-Hookean: model) material of
// the force row with the E that gives its mu and lambda; the baseline is
// that model's force row, lumped masses at density 1000, w = 1 / m, one
// ek_xpbd_begin, positions the force row's deformed ones. items = the
// mesh's tets for clusters too (a cluster per vertex), so that the
// speed-up column compares whole calls: one sweep against one force
// evaluation of the same mesh.
static int xpbd_row(ek_bench *b, int model, ek_xpbd_elements e, ek_xpbd_solver s, ek_isa isa,
                    int f32, int threads) {
  fvm_mesh_case *mc = &sizes[1];
  size_t ntets = case_tets(mc);
  char name[EK_BENCH_NAME_MAX], base[EK_BENCH_NAME_MAX], knobs[192];
  xpbd_name(name, sizeof name, model, e, s, isa, f32, ntets, threads);
  model_force_name(base, sizeof base, model, isa, f32, ntets, threads);
  if (!ek_bench_wants(b, name))
    return 0;
  xpbd_ctx *const c = &xpbd_row_ctx;
  const ek_material *mat = &models[model].mat;
  const double mu = mat->mu, la = mat->lambda, young = mu * (3 * la + 2 * mu) / (la + mu);
  if (!ek_bench_listing(b)) {
    if (mesh_setup(b, mc))
      return -1;
    xpbd_ctx_free(c);
    c->f32 = f32;
    c->b = b;
    size_t nv = ek_mesh_nverts(mc->mesh);
    const double *vol = ek_mesh_lumped_volume(mc->mesh);
    double *mass = malloc(nv * sizeof(double)), *w = malloc(nv * sizeof(double));
    if (f32)
      c->x32 = malloc(nv * 3 * sizeof(float));
    else
      c->x64 = malloc(nv * 3 * sizeof(double));
    if (!mass || !w || !(f32 ? (void *)c->x32 : (void *)c->x64)) {
      free(mass);
      free(w);
      ek_bench_fail(b, "fvm: xpbd: out of memory");
      return -1;
    }
    for (size_t v = 0; v < nv; v++) {
      mass[v] = XPBD_DENSITY * vol[v];
      w[v] = 1 / mass[v]; // every box vertex is in a tet: m > 0
    }
    if (f32)
      memcpy(c->x32, mc->x32, nv * 3 * sizeof(float));
    else
      memcpy(c->x64, mc->x64, nv * 3 * sizeof(double));
    ek_xpbd_opts o = {.elements = e, .solver = s, .isa = isa, .precision = f32 ? 32 : 64};
    c->xp = ek_xpbd_create(ek_mesh_elements(mc->mesh), mat, young, mass, &o);
    int ok = c->xp && ek_xpbd_set_weights(c->xp, w) == 0 && ek_xpbd_begin(c->xp, XPBD_H) == 0;
    free(mass);
    free(w);
    if (!ok) {
      ek_bench_fail(b, "fvm: xpbd: %s", ek_last_error());
      return -1;
    }
  }
  snprintf(knobs, sizeof knobs,
           "elements=%s;solver=%s;tets=%zu;constraints=%zu;ncolors=%d;h=%g;young=%g;"
           "iterations=1",
           ek_xpbd_elements_name(e), ek_xpbd_solver_name(s), ntets,
           c->xp ? ek_xpbd_count(c->xp) : 0, c->xp ? ek_xpbd_ncolors(c->xp) : 0, XPBD_H, young);
  // Tets: what a sweep must move per tet, as the force rows count it
  // (indices, b_k and V: 16 + 10 r bytes; each vertex's position read and
  // written once, 6 r per vertex) plus the multiplier read and written
  // (2 r). Clusters' members vary per vertex: not declared.
  double r = f32 ? 4 : 8;
  ek_bench_row row = {.name = name,
                      .family = "fvm",
                      .isa = isa,
                      .precision = f32 ? "f32" : "f64",
                      .threads = threads,
                      .knobs = knobs,
                      .items = ntets,
                      .flops_per_item = 0,
                      .bytes_per_item =
                          e == EK_XPBD_TETS ? 4 * 4 + 12 * r + 6 * r * case_verts_per_tet(mc) : 0,
                      .baseline = base,
                      .fn = run_xpbd_sweep,
                      .ctx = c};
  int rc = ek_bench_run(b, &row);
  if (!ek_bench_listing(b) && c->xp && !c->failed) {
    size_t n = xpbd_at_rest(c->xp);
    xpbd_most_at_rest = n > xpbd_most_at_rest ? n : xpbd_most_at_rest;
  }
  return rc;
}

// After the XPBD rows: one tets Gauss-Seidel sweep / one StVK force
// evaluation per precision and thread count (the target: <= 2).
static void xpbd_note(ek_bench *b, ek_isa isa, const int *counts, int nth) {
  if (ek_bench_listing(b))
    return;
  size_t ntets = case_tets(&sizes[1]);
  char text[400] = "", name[EK_BENCH_NAME_MAX], base[EK_BENCH_NAME_MAX];
  size_t used = 0;
  for (int f32 = 1; f32 >= 0; f32--)
    for (int t = 0; t < nth; t++) {
      xpbd_name(name, sizeof name, STVK, EK_XPBD_TETS, EK_XPBD_GAUSS_SEIDEL, isa, f32, ntets,
                counts[t]);
      stvk_force_name(base, sizeof base, isa, f32, ntets, counts[t]);
      double sweep = ek_bench_median_ns(b, name), force = ek_bench_median_ns(b, base);
      if (isnan(sweep) || isnan(force) || used >= sizeof text)
        continue;
      used += (size_t)snprintf(text + used, sizeof text - used, "%s%s %dT %.2fx (%.1f / %.1f ns)",
                               used ? ", " : "", f32 ? "f32" : "f64", counts[t], sweep / force,
                               sweep, force);
    }
  if (used)
    ek_bench_note(b,
                  "xpbd: one Gauss-Seidel sweep over all tets / one StVK force evaluation "
                  "(%s, %zu tets; ns per tet; target <= 2x): %s; constraints at rest "
                  "(skipped) after a row's sweeps: at most %zu",
                  ek_isa_name(isa), ntets, text, xpbd_most_at_rest);
}

int bench_fvm(ek_bench *b) {
  models_init();
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
    for (int m = 0; m < NMODELS; m++)
      for (int f32 = 1; f32 >= 0; f32--)
        if (!(m == FIXED_COROT))
          rc |= one_row(b, (int)m, EK_SCATTER_THREAD_BUFFERS, best, f32, 1, counts[t], IS_WARM(m));
    // The SVD-free neo-Hookean pair at 1e6, f32: the bandwidth-bound rows.
    for (int m = 0; m < EK_MODEL_COUNT; m++)
      if (ek_model_need(models[m].mat.model, 0) == EK_NEEDS_J)
        rc |= one_row(b, (int)m, EK_SCATTER_THREAD_BUFFERS, best, 1, 2, counts[t], 0);
    // The other ISAs.
    for (int i = 0; i < nisa - 1; i++)
      rc |= one_row(b, FIXED_COROT, EK_SCATTER_THREAD_BUFFERS, isas[i], 1, 1, counts[t], 0);
    // The implicit loop's Hessian: products per model x precision, and
    // the caching gradient pass.
    for (int m = 0; m < NMODELS; m++)
      for (int f32 = 1; f32 >= 0 && !IS_WARM(m); f32--) {
        rc |= hessian_row(b, (int)m, best, f32, 0, counts[t]);
        rc |= hessian_row(b, (int)m, best, f32, 1, counts[t]);
        rc |= hessian_row(b, (int)m, best, f32, 2, counts[t]);
        rc |= hessian_row(b, (int)m, best, f32, 3, counts[t]);
      }
    // XPBD: one sweep per constraint x elements x solver x precision.
    for (int snh = 0; snh < 2; snh++)
      for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++)
        for (int sv = 0; sv < EK_XPBD_SOLVER_COUNT; sv++)
          for (int f32 = 1; f32 >= 0; f32--)
            rc |= xpbd_row(b, snh ? SNH : STVK, (ek_xpbd_elements)e, (ek_xpbd_solver)sv, best, f32,
                           counts[t]);
  }
  xpbd_note(b, best, counts, nth);
  if (!ek_bench_listing(b)) {
    ek_fvm_hessian_destroy(hess_row_ctx.h);
    hess_row_ctx.h = NULL;
    free(hess_row_ctx.values);
    hess_row_ctx.values = NULL;
    free(hess_row_ctx.uvalues);
    hess_row_ctx.uvalues = NULL;
    xpbd_ctx_free(&xpbd_row_ctx);
  }
  if (!ek_bench_listing(b))
    for (int size = 0; size < 3; size++) {
      fvm_mesh_case *mc = &sizes[size];
      ek_tet_state_destroy(mc->R32);
      ek_tet_state_destroy(mc->R64);
      ek_tet_state_destroy(mc->W32);
      ek_tet_state_destroy(mc->W64);
      mc->R32 = mc->R64 = mc->W32 = mc->W64 = NULL;
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
