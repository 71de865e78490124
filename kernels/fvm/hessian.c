// Driver of ek_fvm_hessian (include/ek/hessian.h): argument checks, the
// cache, dispatch, and the passes through the scatter strategies
// (scatter.c). Built once per precision: the products and diagonal blocks
// of each precision here; creation and the (double) gradient pass in the
// f64 instance.
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <ek/hessian.h>

#include "../elements/tets.h"
#include "../inline.h"
#include "../kernels.h"
#include "../material/models.h"
#include "../real.h"
#include "../team.h"
#include "hessian_kernel.h"
#include "scatter.h"

#if defined(EK_REAL_F32)
typedef struct ek_hess_args_f32 hess_args;
#define BL_IDX(bl) ((bl)->idx_f32)
#define BL_DMI(bl) ((bl)->dm_inv_f32)
#define BL_V0(bl) ((bl)->v0_f32)
#define PRECISION 32
#else
typedef struct ek_hess_args_f64 hess_args;
#define BL_IDX(bl) ((bl)->idx_f64)
#define BL_DMI(bl) ((bl)->dm_inv_f64)
#define BL_V0(bl) ((bl)->v0_f64)
#define PRECISION 64
#endif

typedef struct {
  const ek_kernel_table *kt;
  hess_args a;
} hess_ctx;

static void hess_range(const void *ctx, size_t b0, size_t b1, real *out, real *corner) {
  const hess_ctx *c = ctx;
  hess_args a = c->a;
  a.out = out;
  a.corner = corner;
  // The isotropic models' products and diagonal blocks read only the cached
  // eigensystem: one shared kernel for all of them.
  if (a.op != HESS_GRADIENT && ek_models[a.mat->model]->isotropic)
    c->kt->EK_FIELD(hessian_frame_block)(&a, b0, b1);
  else
    c->kt->EK_FIELD(hessian_block)[a.mat->model](&a, b0, b1);
}

static hess_args args_for(const ek_fvm_hessian *h, int op) {
  const ek_tet_blocks *bl = scatter_blocks(h->el, h->scatter);
  hess_args a = {.op = op,
                 .idx = BL_IDX(bl),
                 .dm_inv = BL_DMI(bl),
                 .v0 = BL_V0(bl),
                 .slot_tet = bl->slot_tet,
                 .mat = &h->mat,
                 .svd = &h->svd,
                 .project = h->project,
                 .planes = h->planes,
                 .morton_slot = h->el->morton_slot};
  return a;
}

// A product or a diagonal pass costs about what a force evaluation
// without an SVD does: the same grain (fvm.h).
static int run(const ek_fvm_hessian *h, const hess_args *a, int ncomp, int parallel, real *out) {
  hess_ctx c = {h->kt, *a};
  scatter_job j = {h->el, h->scatter, ncomp, parallel, hess_range, &c, ncomp};
  int rc = EK_P(scatter_run)(&j, out);
  if (rc == EK_ENOMEM)
    ek_set_error("ek_fvm_hessian: out of memory for scratch buffers");
  return rc;
}

static int check_cached(const ek_fvm_hessian *h, const char *fn, const void *in, const void *out) {
  if (!h || !in || !out) {
    ek_set_error("%s: NULL argument", fn);
    return EK_EINVAL;
  }
  if (h->precision != PRECISION) {
    ek_set_error("%s: this Hessian's cache is in f%d (ek_fvm_hessian_opts.precision); call the "
                 "f%d function",
                 fn, h->precision, h->precision);
    return EK_EINVAL;
  }
  if (!h->cached) {
    ek_set_error("%s: no eigensystems cached: call ek_fvm_hessian_gradient_f64 with "
                 "cache_eigensystems = 1 first",
                 fn);
    return EK_EINVAL;
  }
  return EK_OK;
}

int EK_P(fvm_hessian_apply)(const ek_fvm_hessian *h, const real *p, real *y) {
  int rc = check_cached(h, "ek_fvm_hessian_apply", p, y);
  if (rc < 0)
    return rc;
  hess_args a = args_for(h, HESS_APPLY);
  a.x = p;
  a.cache = h->cache;
  return run(h, &a, 3, h->el->ntets >= EK_FVM_PARALLEL_MIN_TETS, y);
}

// The product in parts (include/ek/hessian.h): scatter.c's THREAD_BUFFERS
// pass (run_buffers, unpadded rows) split at its phases, into the
// Hessian's own buffers: part p zeroes its vertex range and adds its fixed
// block share there, the rows sum the parts in part order, a part whose
// range leaves a vertex out adding a 0 unread (the same bits).
int EK_P(fvm_hessian_apply_part)(const ek_fvm_hessian *h, const real *p, int part) {
  int rc = check_cached(h, "ek_fvm_hessian_apply_part", p, p);
  if (rc < 0)
    return rc;
  if (!h->part_buf || part < 0 || part >= EK_FVM_PARTS) {
    ek_set_error("ek_fvm_hessian_apply_part: part %d of %d (the product in parts needs the "
                 "THREAD_BUFFERS scatter)",
                 part, h->part_buf ? EK_FVM_PARTS : 0);
    return EK_EINVAL;
  }
  const ek_tets *el = h->el;
  const size_t n = el->nverts * 3, nb = el->morton.nslots / EK_LANES;
  const size_t lo_v = el->part_vlo[sizeof(real) == 8][part];
  const size_t hi_v = el->part_vhi[sizeof(real) == 8][part];
  real *b = (real *)h->part_buf + (size_t)part * n;
  memset(b + lo_v * 3, 0, (hi_v - lo_v) * 3 * sizeof(real));
  size_t lo, hi;
  scatter_share(0, nb, part, EK_FVM_PARTS, &lo, &hi);
  hess_ctx c = {h->kt, args_for(h, HESS_APPLY)};
  c.a.x = p;
  c.a.cache = h->cache;
  if (lo < hi)
    hess_range(&c, lo, hi, b, NULL);
  return EK_OK;
}

void EK_P(fvm_hessian_apply_rows)(const ek_fvm_hessian *h, size_t v0, size_t v1, real *y) {
  const ek_tets *el = h->el;
  const size_t n = el->nverts * 3;
  const size_t *vlo = el->part_vlo[sizeof(real) == 8], *vhi = el->part_vhi[sizeof(real) == 8];
  const real *buf = h->part_buf;
  for (size_t v = v0; v < v1; v++)
    for (size_t k = 0; k < 3; k++) {
      real s = v >= vlo[0] && v < vhi[0] ? buf[v * 3 + k] : 0;
      for (int p = 1; p < EK_FVM_PARTS; p++)
        s += v >= vlo[p] && v < vhi[p] ? buf[(size_t)p * n + v * 3 + k] : 0;
      y[v * 3 + k] = s;
    }
}

int EK_P(fvm_hessian_diag)(const ek_fvm_hessian *h, real *blocks) {
  int rc = check_cached(h, "ek_fvm_hessian_diagonal", blocks, blocks);
  if (rc < 0)
    return rc;
  hess_args a = args_for(h, HESS_DIAG);
  a.cache = h->cache;
  return run(h, &a, 6, h->el->ntets >= EK_FVM_PARALLEL_MIN_TETS, blocks);
}

// Lower block q of a row of nb blocks, (v, w) with w < v, at dst: the
// transpose of (w, v), whose sum has the same contributions (each element
// block (c, d) is (d, c)^T to the bit: elem_store symmetrises) in the same
// slot order, so the copy has the bits that summing would give.
EK_INLINE void copy_block(const ek_fvm_hessian *h, const double *values, double *dst, int32_t nb,
                          int32_t q) {
  const int32_t w = h->bcol[q], w0 = h->bptr[w], nw = h->bptr[w + 1] - w0;
  const double *src = values + 9 * (size_t)w0 + 3 * (size_t)(h->mirror[q] - w0);
  for (int i = 0; i < 3; i++)
    for (int m = 0; m < 3; m++)
      dst[(size_t)i * 3 * (size_t)nb + (size_t)m] = src[(size_t)m * 3 * (size_t)nw + (size_t)i];
}

// The lower blocks of the rows thread t owns: cross 0, those whose mirror
// row t owns too (its sums, done); cross 1, the others (rows across the
// cut, the plan's xlow, ascending: after a barrier). Pass 0 skips them by
// walking xlow alongside.
static void copy_lower(const ek_fvm_hessian *h, double *values, int t, int cross) {
  const int32_t *x = h->xlow + 2 * (size_t)h->xptr[t], *xe = h->xlow + 2 * (size_t)h->xptr[t + 1];
  if (cross) {
    for (; x < xe; x += 2) {
      const int32_t b0 = h->bptr[x[0]], nb = h->bptr[x[0] + 1] - b0;
      copy_block(h, values, values + 9 * (size_t)b0 + 3 * (size_t)(x[1] - b0), nb, x[1]);
    }
    return;
  }
  int32_t skip = x < xe ? x[1] : -1; // the next cross block (-1: none left)
  for (size_t v = 0; v < h->el->nverts; v++) {
    if (h->row_own[v] != t)
      continue;
    const int32_t b0 = h->bptr[v], nb = h->bptr[v + 1] - b0;
    double *row = values + 9 * (size_t)b0;
    for (int32_t q = b0; q < b0 + nb && h->bcol[q] < (int32_t)v; q++) {
      if (q == skip) {
        x += 2;
        skip = x < xe ? x[1] : -1;
        continue;
      }
      copy_block(h, values, row + 3 * (size_t)(q - b0), nb, q);
    }
  }
}

// K's values (ek_fvm_hessian_assemble): per part t of the plan
// (hessian_kernel.h), the slot blocks touching its rows in ascending order;
// per block, the element Hessians of its lanes (HESS_ELEMENT) into a
// buffer that stays in L1 (144 planes), then the element blocks on or
// above the block diagonal whose row t owns added into the values through
// the plan's runs (hessian_sum: per K block, the slot block's contributions
// summed in registers in ascending slot order onto the block's partial sum,
// loaded and stored once; a block's first contribution written as 0 + e:
// the sum from 0 in ascending slot order, as a plain assembly); then the
// blocks below the diagonal copied from their mirrors (copy_lower). Each
// nonzero is summed by one part in ascending slot order, so any thread
// count gives the same bits; a block touching rows of two parts is
// computed by both (the Morton order keeps those few: 8% of the blocks at
// 2 parts on the bench's box). Why this order (docs/perf.md,
// "Hessian assembly"): the old gather per nonzero read a 58 MB element
// buffer at random, ~70% of its time.
// The parts run as chunks of the helper team (kernels/team.h): a part
// writes the same values whoever runs it, and the caller never waits for
// a helper that has not started (an OpenMP region's barriers did: a
// scheduler slice per assembly on a busy core; sim/README.md, sixteenth
// round). Job 1 the parts' sums and the lower blocks whose mirror the part
// sums, job 2 (after every sum) the lower blocks across the cuts.
// values (the scalar CSR, double) or uvalues (the upper block triangle in
// this precision: no mirror copy, ek_fvm_hessian_assemble_upper_*).
typedef struct {
  const ek_fvm_hessian *h;
  hess_args a;
  double *values;
  int iso;
} assemble_job;

static void assemble_part(void *ctx, size_t t) {
  const assemble_job *j = ctx;
  const ek_fvm_hessian *h = j->h;
  // The part's element Hessian buffer of the plan (on the heap, not on a
  // thread's stack, which may be small): one part runs on one thread.
  real *buf = (real *)((char *)h->abuf + t * HESS_ABUF_STRIDE);
  hess_args la = j->a;
  for (int32_t g = h->tgrp[t]; g < h->tgrp[t + 1]; g++) {
    const int32_t k0 = h->tptr[t] + (g - h->tgrp[t]) * HESS_GROUP;
    const int32_t k1 = k0 + HESS_GROUP < h->tptr[t + 1] ? k0 + HESS_GROUP : h->tptr[t + 1];
    for (int32_t k = k0; k < k1; k++) {
      const size_t b = (size_t)h->tblk[k];
      la.corner = buf + (size_t)(k - k0) * 144 * EK_LANES;
      if (j->iso)
        h->kt->EK_FIELD(hessian_frame_block)(&la, b, b + 1);
      else
        h->kt->EK_FIELD(hessian_block)[la.mat->model](&la, b, b + 1);
    }
    la.asm_k = g;
    la.corner = buf;
    h->kt->EK_FIELD(hessian_sum)(&la, 0, 1);
  }
  // The blocks below the diagonal whose mirror row this part sums (done):
  // most of them, copied while other parts still sum.
  if (j->values)
    copy_lower(h, j->values, (int)t, 0);
}

// Those whose mirror another part sums (rows across the cut: at 2 parts on
// the bench's box 3 of part 0's 60 589 and 3 418 of part 1's 63 716).
static void assemble_cross(void *ctx, size_t t) {
  const assemble_job *j = ctx;
  copy_lower(j->h, j->values, (int)t, 1);
}

static int assemble(const ek_fvm_hessian *h, double *values, real *uvalues) {
  int rc = check_cached(h, uvalues ? "ek_fvm_hessian_assemble_upper" : "ek_fvm_hessian_assemble",
                        uvalues ? (const void *)uvalues : (const void *)values,
                        uvalues ? (const void *)uvalues : (const void *)values);
  if (rc < 0)
    return rc;
  const int iso = ek_models[h->mat.model]->isotropic, nt = h->plan_threads;
  // The upper triangle's element Hessians from the frame's rank-one
  // columns (HESS_ELEMENT_R1, isotropic models); the CSR's keep theirs.
  assemble_job j = {h, args_for(h, uvalues && iso ? HESS_ELEMENT_R1 : HESS_ELEMENT), values, iso};
  j.a.cache = h->cache;
  j.a.values = values;
  j.a.uvalues = uvalues;
  j.a.asm_h = h;
  _Static_assert((size_t)HESS_GROUP * EK_LANES * 144 * sizeof(real) == HESS_ABUF_BYTES,
                 "the plan's element Hessian buffers");
  ek_team_run((size_t)nt, assemble_part, &j);
  if (values)
    ek_team_run((size_t)nt, assemble_cross, &j);
  return EK_OK;
}

int EK_P(fvm_hessian_assemble)(const ek_fvm_hessian *h, double *values) {
  return assemble(h, values, NULL);
}

// The upper block triangle (ek_fvm_hessian_assemble_upper_*): the same
// element Hessians and runs, each run summed in this precision into its
// block's 9 contiguous values (hessian_sum with uvalues); no lower blocks,
// so no mirror copy and no barrier.
int EK_P(fvm_hessian_assemble_upper_run)(const ek_fvm_hessian *h, real *values) {
  return assemble(h, NULL, values);
}

#if defined(EK_REAL_F64)
// Precision-free entry points and the gradient, built once (in the f64
// instance).

const char *ek_projection_name(ek_projection p) {
  static const char *const names[EK_PROJECT_COUNT] = {"clamp", "abs", "none"};
  return (unsigned)p < EK_PROJECT_COUNT ? names[p] : "invalid";
}

ek_fvm_hessian *ek_fvm_hessian_create(const ek_tets *el, const ek_material *mat,
                                      const ek_fvm_hessian_opts *opts) {
  static const char *fn = "ek_fvm_hessian_create";
  ek_fvm_hessian_opts o = {0};
  if (opts)
    o = *opts;
  if (!el || !mat) {
    ek_set_error("%s: NULL argument (elements %p, material %p)", fn, (const void *)el,
                 (const void *)mat);
    return NULL;
  }
  if (ek_material_check(mat) < 0)
    return NULL;
  if ((unsigned)o.scatter >= EK_SCATTER_COUNT) {
    ek_set_error("%s: scatter strategy %d is not a valid ek_scatter", fn, (int)o.scatter);
    return NULL;
  }
  if ((unsigned)o.projection >= EK_PROJECT_COUNT) {
    ek_set_error("%s: projection %d is not a valid ek_projection", fn, (int)o.projection);
    return NULL;
  }
  if (o.precision != 0 && o.precision != 32 && o.precision != 64) {
    ek_set_error("%s: precision %d: must be 32 or 64 (0 = 64)", fn, o.precision);
    return NULL;
  }
  ek_svd3_knobs knobs;
  if (ek_svd3_knobs_from_f64(fn, o.svd_sweeps, o.svd_exact_rsqrt, o.svd_refine, &knobs) < 0)
    return NULL;
  ek_isa isa;
  if (ek_isa_resolve(o.isa, &isa) < 0)
    return NULL;
  const ek_kernel_table *kt = ek_kernels_for(isa);
  if (!kt)
    return NULL;
  ek_fvm_hessian *h = calloc(1, sizeof *h);
  if (!h) {
    ek_set_error("%s: out of memory", fn);
    return NULL;
  }
  h->el = el;
  h->mat = *mat;
  h->scatter = o.scatter == EK_SCATTER_AUTO ? EK_SCATTER_DEFAULT : o.scatter;
  h->isa = isa;
  h->kt = kt;
  h->svd = knobs;
  // mat_frame_prepare's project: 0 exact, 1 clamp, 2 mirror.
  h->project = o.projection == EK_PROJECT_NONE ? 0 : o.projection == EK_PROJECT_ABS ? 2 : 1;
  h->precision = o.precision ? o.precision : 64;
  h->planes = ek_models[mat->model]->cache_planes;
  const size_t nslots = scatter_blocks(el, h->scatter)->nslots;
  h->cache_bytes = nslots * (size_t)h->planes * (h->precision == 32 ? 4 : 8);
  h->energy = ek_alloc(nslots * sizeof(double));
  h->cache = h->cache_bytes ? ek_alloc(h->cache_bytes) : NULL;
  if (h->scatter == EK_SCATTER_THREAD_BUFFERS)
    h->part_buf = ek_alloc(EK_FVM_PARTS * el->nverts * 3 * (h->precision == 32 ? 4 : 8) + 64);
  if (!h->energy || (h->cache_bytes && !h->cache) ||
      (h->scatter == EK_SCATTER_THREAD_BUFFERS && !h->part_buf)) {
    ek_set_error("%s: out of memory for the eigensystem cache (%zu bytes)", fn, h->cache_bytes);
    ek_fvm_hessian_destroy(h);
    return NULL;
  }
  return h;
}

void ek_fvm_hessian_destroy(ek_fvm_hessian *h) {
  if (!h)
    return;
  ek_hessian_assembly_free(h);
  ek_free(h->cache);
  ek_free(h->energy);
  ek_free(h->part_buf);
  free(h);
}

int ek_fvm_hessian_apply_parts(const ek_fvm_hessian *h, int *parallel) {
  *parallel = h && h->el->ntets >= EK_FVM_PARALLEL_MIN_TETS;
  return h && h->part_buf ? EK_FVM_PARTS : 0;
}

size_t ek_fvm_hessian_cache_bytes(const ek_fvm_hessian *h) { return h ? h->cache_bytes : 0; }
int ek_fvm_hessian_cache_planes(const ek_fvm_hessian *h) { return h ? h->planes : 0; }

// Fixed chunks of the slot range, summed in parallel, then in chunk order:
// the same bits for any thread count.
#define ENERGY_CHUNK 4096
typedef struct {
  const double *e;
  size_t n;
  double *parts;
} energy_job;

static void energy_chunk(void *ctx, size_t c) {
  const energy_job *j = ctx;
  size_t hi = (c + 1) * ENERGY_CHUNK < j->n ? (c + 1) * ENERGY_CHUNK : j->n;
  double s = 0;
  for (size_t i = c * ENERGY_CHUNK; i < hi; i++)
    s += j->e[i];
  j->parts[c] = s;
}

static double sum_energy(const double *e, size_t n, int parallel) {
  size_t nc = (n + ENERGY_CHUNK - 1) / ENERGY_CHUNK;
  double part[256], *parts = nc <= 256 ? part : malloc(nc * sizeof(double));
  if (!parts) {
    double s = 0;
    for (size_t i = 0; i < n; i++)
      s += e[i];
    return s;
  }
  // On the helper team (kernels/team.h) only for 8 chunks or more (~10 us
  // of additions): below, handing chunks out costs more than the sum. The
  // chunks and their order are the same either way.
  energy_job j = {e, n, parts};
  ek_team_run_if(parallel && nc >= 8, nc, energy_chunk, &j);
  double s = 0;
  for (size_t c = 0; c < nc; c++)
    s += parts[c];
  if (parts != part)
    free(parts);
  return s;
}

int ek_fvm_hessian_gradient_f64(ek_fvm_hessian *h, const double *x, const ek_tet_state *R_state,
                                double *grad, double *energy, int cache_eigensystems) {
  static const char *fn = "ek_fvm_hessian_gradient_f64";
  if (!h || !x || !grad) {
    ek_set_error("%s: NULL argument (hessian %p, x %p, grad %p)", fn, (void *)h, (const void *)x,
                 (void *)grad);
    return EK_EINVAL;
  }
  const int corot = ek_models[h->mat.model]->needs == EK_NEEDS_R_INPUT;
  if (corot && (!R_state || R_state->el != h->el || R_state->planes != 9 || !R_state->f64)) {
    ek_set_error("%s: corotated linear needs its rotations as a 9-plane f64 state of these "
                 "elements (R_state %s)",
                 fn, R_state ? "of another shape" : "is NULL");
    return EK_EINVAL;
  }
  hess_args a = args_for(h, HESS_GRADIENT);
  a.x = x;
  a.R_planes = corot ? R_state->data : NULL;
  a.energy = h->energy;
  if (cache_eigensystems) {
    if (h->precision == 32)
      a.cache_out_f32 = h->cache;
    else
      a.cache_out = h->cache;
  }
  h->cached = 0;
  const int iso = ek_models[h->mat.model]->isotropic;
  const int svd =
      iso && (cache_eigensystems || ek_model_row_uses_sigma(h->mat.model, h->mat.clamp));
  int parallel = h->el->ntets >= (svd ? EK_FVM_PARALLEL_MIN_TETS_SVD : EK_FVM_PARALLEL_MIN_TETS);
  int rc = run(h, &a, 3, parallel, grad);
  if (rc < 0)
    return rc;
  h->cached = cache_eigensystems != 0;
  if (energy) {
    double E = sum_energy(h->energy, scatter_blocks(h->el, h->scatter)->nslots, parallel);
    *energy = isnan(E) ? INFINITY : E; // an element outside the domain: +inf
  }
  return EK_OK;
}

int ek_fvm_hessian_diagonal_f64(const ek_fvm_hessian *h, double *blocks) {
  if (!h || h->precision == 64)
    return ek_fvm_hessian_diag_f64(h, blocks);
  if (!blocks) {
    ek_set_error("ek_fvm_hessian_diagonal: NULL argument");
    return EK_EINVAL;
  }
  size_t n = h->el->nverts * 6;
  float *b = malloc(n * sizeof(float));
  if (!b) {
    ek_set_error("ek_fvm_hessian_diagonal: out of memory");
    return EK_ENOMEM;
  }
  int rc = ek_fvm_hessian_diag_f32(h, b);
  if (rc >= 0)
    for (size_t i = 0; i < n; i++)
      blocks[i] = b[i];
  free(b);
  return rc;
}
#endif
