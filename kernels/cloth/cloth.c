// Driver of the cloth kernels (include/ek/cloth.h): argument checks,
// dispatch once per call, the helper team over chunks of blocks, AoS <-> AoSoA
// staging per thread (no batch-sized copy). Built once per precision
// (EK_P names); the triangle rest data is double only.
#include <ek/cloth.h>
#include <math.h>
#include <string.h>

#include "elements/tris.h"
#include "kernels.h"
#include "real.h"
#include "team.h"

#if defined(EK_REAL_F32)
typedef ek_cloth_block_f32_fn cloth_block_fn;
typedef ek_svd3_block_f32_fn svd3_block_fn;
#define FN(t, name) ((t)->name##_f32)
#else
typedef ek_cloth_block_f64_fn cloth_block_fn;
typedef ek_svd3_block_f64_fn svd3_block_fn;
#define FN(t, name) ((t)->name##_f64)
#endif

// A Kabsch set has no spread when its centred points are within
// SPREAD_EPS times its centroid's largest coordinate (8 eps: the rounding
// of a weighted mean).
#if defined(EK_REAL_F32)
#define SPREAD_EPS (8 * 0x1p-23f)
#else
#define SPREAD_EPS (8 * 0x1p-52)
#endif

// Blocks per team chunk and per staging chunk (the svd3 driver's
// choice: a chunk's inputs and outputs stay in L2).
#define CHUNK_BLOCKS 32

static const ek_kernel_table *table(const ek_cloth_opts *opts) {
  return ek_kernels_resolve(opts ? opts->isa : EK_ISA_AUTO);
}

// Two inputs and up to three outputs of a block kernel, as AoS arrays
// (item-major, `planes` values per item) or AoSoA batches.
typedef struct {
  const real *in[2];
  int in_planes[2]; // 0: input unused
  real *out[3];     // NULL: not wanted
  int out_planes[3];
} io;

// The batch checks every entry point shares (core.c): `count` items of
// `lanes` x the largest plane count values each must have a byte count
// that fits, and every array must be aligned to its element type.
static int check_io(const char *fn, size_t count, size_t lanes, const io *a) {
  int planes = 0;
  for (int k = 0; k < 2; k++)
    planes = a->in_planes[k] > planes ? a->in_planes[k] : planes;
  for (int k = 0; k < 3; k++)
    planes = a->out_planes[k] > planes ? a->out_planes[k] : planes;
  const void *arrays[5] = {a->in[0], a->in[1], a->out[0], a->out[1], a->out[2]};
  static const char *const names[5] = {"input 1", "input 2", "output 1", "output 2", "output 3"};
  return ek_batch_check(fn, count, (size_t)planes * lanes * sizeof(real), _Alignof(real), 5, arrays,
                        names);
}

// Chunks of `chunk` items of `lanes` records each, as jobs of the helper
// team (kernels/team.h: the caller never waits for a thread that has not
// started; a chunk writes its own items whoever runs it): blocks of an
// AoSoA batch (lanes = EK_LANES, aos = 0) or AoS records (lanes = 1, aos =
// 1: the kernel transposes in registers, cloth_block.c; no staging).
typedef struct {
  cloth_block_fn *block;
  size_t count, lanes, chunk;
  int aos;
  const io *a;
} chunks_job;

static void run_chunk(void *ctx, size_t i) {
  const chunks_job *j = ctx;
  const size_t i0 = i * j->chunk;
  const size_t m = j->count - i0 < j->chunk ? j->count - i0 : j->chunk;
  const real *in[2];
  real *out[3];
  for (int k = 0; k < 2; k++)
    in[k] = j->a->in[k] ? j->a->in[k] + i0 * (size_t)j->a->in_planes[k] * j->lanes : NULL;
  for (int k = 0; k < 3; k++)
    out[k] = j->a->out[k] ? j->a->out[k] + i0 * (size_t)j->a->out_planes[k] * j->lanes : NULL;
  j->block(m, j->aos, in[0], in[1], out[0], out[1], out[2]);
}

static int run_chunks(const char *fn, cloth_block_fn *block, size_t count, size_t lanes, int aos,
                      const io *a) {
  int rc = check_io(fn, count, lanes, a);
  if (rc)
    return rc;
  chunks_job j = {block, count, lanes, aos ? (size_t)CHUNK_BLOCKS * EK_LANES : CHUNK_BLOCKS,
                  aos,   a};
  ek_team_run_static((count + j.chunk - 1) / j.chunk, run_chunk, &j);
  return EK_OK;
}

static int run_aos(const char *fn, cloth_block_fn *block, size_t n, const io *a) {
  return run_chunks(fn, block, n, 1, 1, a);
}

static int run_blocks(const char *fn, cloth_block_fn *block, size_t nblocks, const io *a) {
  return run_chunks(fn, block, nblocks, EK_LANES, 0, a);
}

// ---- Rest data (double only) ----------------------------------------------
#if defined(EK_REAL_F64)
// The rest frame of cloth.h: t1 = E1 / |E1|, t2 = N x t1,
// Dm = [[|E1|, E2.t1], [0, E2.t2]], E2.t2 = |E1 x E2| / |E1| = 2A / |E1|.
int ek_tri_rest_f64(size_t n, const double *X, double *Dm_inv, double *area) {
  if (n && (!X || !Dm_inv)) {
    ek_set_error("ek_tri_rest_f64: X and Dm_inv must not be NULL (n = %zu)", n);
    return EK_EINVAL;
  }
  int rc = ek_batch_check("ek_tri_rest_f64", n, 9 * sizeof(double), _Alignof(double), 3,
                          (const void *[]){X, Dm_inv, area},
                          (const char *const[]){"X", "Dm_inv", "area"});
  if (rc)
    return rc;
  // Validate every triangle before writing anything.
  for (size_t t = 0; t < n; t++) {
    const double *p = X + 9 * t;
    for (int i = 0; i < 9; i++)
      if (!isfinite(p[i])) {
        ek_set_error("ek_tri_rest_f64: triangle %zu: coordinate %d is %g (not finite)", t, i, p[i]);
        return EK_EINVAL;
      }
    double twoA, lmax2;
    if (ek_tri_degenerate(p, p + 3, p + 6, &twoA, &lmax2)) {
      ek_set_error("ek_tri_rest_f64: triangle %zu is degenerate: 2 x area = %g <= %g x (longest "
                   "edge)^2 = %g",
                   t, twoA, EK_TRI_DEGENERATE_REL, EK_TRI_DEGENERATE_REL * lmax2);
      return EK_EINVAL;
    }
  }
  // The element layer's rest frame (kernels/elements/tris.c), E2.t2
  // rounded as |E1 x E2| / |E1|.
  for (size_t t = 0; t < n; t++) {
    const double *p = X + 9 * t;
    double A = ek_tri_rest_frame(p, p + 3, p + 6, EK_TRI_REST_DIRECT, Dm_inv + 4 * t);
    if (area)
      area[t] = A;
  }
  return EK_OK;
}
#endif

// ---- Triangle deformation gradient ----------------------------------------
int EK_P(tri_deformation_ex)(size_t n, const real *x, const real *Dm_inv, real *F,
                             const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  if (n && (!x || !Dm_inv || !F)) {
    ek_set_error("ek_tri_deformation: x, Dm_inv and F must not be NULL (n = %zu)", n);
    return EK_EINVAL;
  }
  io a = {.in = {x, Dm_inv}, .in_planes = {9, 4}, .out = {F}, .out_planes = {6}};
  return n ? run_aos("ek_tri_deformation", FN(t, cloth_tri_F_block), n, &a) : EK_OK;
}

int EK_P(tri_deformation)(size_t n, const real *x, const real *Dm_inv, real *F) {
  return EK_P(tri_deformation_ex)(n, x, Dm_inv, F, NULL);
}

int EK_P(tri_deformation_aosoa)(size_t nblocks, const real *x, const real *Dm_inv, real *F,
                                const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  if (nblocks && (!x || !Dm_inv || !F)) {
    ek_set_error("ek_tri_deformation_aosoa: x, Dm_inv and F must not be NULL (nblocks = %zu)",
                 nblocks);
    return EK_EINVAL;
  }
  io a = {.in = {x, Dm_inv}, .in_planes = {9, 4}, .out = {F}, .out_planes = {6}};
  return run_blocks("ek_tri_deformation_aosoa", FN(t, cloth_tri_F_block), nblocks, &a);
}

// ---- Polar decomposition of 3x2 F -----------------------------------------
int EK_P(polar32_ex)(size_t n, const real *F, real *R, real *Uc, const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  if (n && (!F || !R)) {
    ek_set_error("ek_polar32: F and R must not be NULL (n = %zu)", n);
    return EK_EINVAL;
  }
  io a = {.in = {F}, .in_planes = {6, 0}, .out = {R, Uc}, .out_planes = {6, 4}};
  return n ? run_aos("ek_polar32", FN(t, cloth_polar32_block), n, &a) : EK_OK;
}

int EK_P(polar32)(size_t n, const real *F, real *R, real *Uc) {
  return EK_P(polar32_ex)(n, F, R, Uc, NULL);
}

int EK_P(polar32_aosoa)(size_t nblocks, const real *F, real *R, real *Uc,
                        const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  if (nblocks && (!F || !R)) {
    ek_set_error("ek_polar32_aosoa: F and R must not be NULL (nblocks = %zu)", nblocks);
    return EK_EINVAL;
  }
  io a = {.in = {F}, .in_planes = {6, 0}, .out = {R, Uc}, .out_planes = {6, 4}};
  return run_blocks("ek_polar32_aosoa", FN(t, cloth_polar32_block), nblocks, &a);
}

// ---- Triangle velocity gradient -------------------------------------------
int EK_P(tri_velocity_gradient)(size_t n, const real *x, const real *v, real *L, real *D, real *W,
                                const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  if (n && (!x || !v)) {
    ek_set_error("ek_tri_velocity_gradient: x and v must not be NULL (n = %zu)", n);
    return EK_EINVAL;
  }
  if (!L && !D && !W)
    return EK_OK;
  io a = {.in = {x, v}, .in_planes = {9, 9}, .out = {L, D, W}, .out_planes = {9, 9, 9}};
  return n ? run_aos("ek_tri_velocity_gradient", FN(t, cloth_tri_velgrad_block), n, &a) : EK_OK;
}

int EK_P(tri_velocity_gradient_aosoa)(size_t nblocks, const real *x, const real *v, real *L,
                                      real *D, real *W, const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  if (nblocks && (!x || !v)) {
    ek_set_error("ek_tri_velocity_gradient_aosoa: x and v must not be NULL (nblocks = %zu)",
                 nblocks);
    return EK_EINVAL;
  }
  io a = {.in = {x, v}, .in_planes = {9, 9}, .out = {L, D, W}, .out_planes = {9, 9, 9}};
  return run_blocks("ek_tri_velocity_gradient_aosoa", FN(t, cloth_tri_velgrad_block), nblocks, &a);
}

// ---- Tet velocity gradient ------------------------------------------------
// Caller tet order: each thread gathers a chunk's corner positions and
// velocities into its staging blocks (12 planes each), runs the kernel and
// unpacks L, D, W.
typedef struct {
  const int32_t *tets;
  const real *x, *v;
  real *out[3];
  cloth_block_fn *block;
} tet_velgrad_aos;

static void tet_velgrad_chunk(void *ctx, size_t i0, size_t m, real *const *buf) {
  const tet_velgrad_aos *c = ctx;
  real *xs = buf[0], *vs = buf[1];
  size_t nb = EK_P(aosoa_blocks)(m);
  for (size_t l = 0; l < nb * EK_LANES; l++) {
    size_t b = l / EK_LANES, lane = l % EK_LANES;
    for (int k = 0; k < 4; k++)
      for (int i = 0; i < 3; i++) {
        size_t at = (b * 12 + 3 * k + i) * EK_LANES + lane;
        if (l < m) {
          size_t vtx = (size_t)c->tets[4 * (i0 + l) + k];
          xs[at] = c->x[3 * vtx + i], vs[at] = c->v[3 * vtx + i];
        } else { // padding: a unit right-angled tet at rest
          xs[at] = (real)(k == i + 1), vs[at] = 0;
        }
      }
  }
  c->block(nb, 0, xs, vs, buf[2], buf[3], buf[4]);
  for (int k = 0; k < 3; k++)
    if (buf[2 + k])
      EK_P(aosoa_unpack)(m, 9, buf[2 + k], c->out[k] + 9 * i0);
}

int EK_P(tet_velocity_gradient)(const ek_tets *el, const real *x, const real *v, real *L, real *D,
                                real *W, const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  if (!el || !x || !v) {
    ek_set_error("ek_tet_velocity_gradient: el, x and v must not be NULL");
    return EK_EINVAL;
  }
  if (!L && !D && !W)
    return EK_OK;
  tet_velgrad_aos c = {ek_tets_vertices(el), x, v, {L, D, W}, FN(t, cloth_tet_velgrad_block)};
  const int planes[5] = {12, 12, L ? 9 : 0, D ? 9 : 0, W ? 9 : 0};
  return EK_P(staged_chunks)("ek_tet_velocity_gradient", ek_tets_count(el), CHUNK_BLOCKS, 5, planes,
                             tet_velgrad_chunk, &c);
}

// ---- Kabsch ---------------------------------------------------------------
// Per set (serially checked first, so an error writes nothing): the
// weighted centroids, the centred points of P and Q each scaled by their
// largest entry, M = sum_k (w_k / w_max) q_k p_k^T written into an AoSoA
// staging chunk; then the SVD kernel in its polar mode (R = U V^T of the
// rotation-variant SVD, det +1: seed 003 eq. 21 with d = det(V U^T)).
static int kabsch_check(size_t nsets, const size_t *offsets, const real *P, const real *Q,
                        const real *w) {
  if (nsets && (!offsets || !P || !Q)) {
    ek_set_error("ek_kabsch: offsets, P and Q must not be NULL (nsets = %zu)", nsets);
    return EK_EINVAL;
  }
  for (size_t s = 0; s < nsets; s++) {
    if (offsets[s + 1] < offsets[s]) {
      ek_set_error("ek_kabsch: offsets[%zu] = %zu < offsets[%zu] = %zu (must not decrease)", s + 1,
                   offsets[s + 1], s, offsets[s]);
      return EK_EINVAL;
    }
    if (!w)
      continue;
    double sum = 0;
    for (size_t k = offsets[s]; k < offsets[s + 1]; k++) {
      if (!(w[k] >= 0) || !isfinite(w[k])) {
        ek_set_error("ek_kabsch: set %zu: weight of point %zu is %g (must be finite and >= 0)", s,
                     k, (double)w[k]);
        return EK_EINVAL;
      }
      sum += w[k];
    }
    if (offsets[s + 1] > offsets[s] && !(sum > 0)) {
      ek_set_error("ek_kabsch: set %zu: the weights of points %zu..%zu sum to 0", s, offsets[s],
                   offsets[s + 1] - 1);
      return EK_EINVAL;
    }
  }
  return EK_OK;
}

// M of one set into lane `lane` of a 9-plane block at `blk`; returns 0 when
// P or Q has no spread (the set's R is then the identity).
static int kabsch_covariance(size_t k0, size_t k1, const real *P, const real *Q, const real *w,
                             real *blk, size_t lane) {
  real wmax = 0;
  for (size_t k = k0; k < k1; k++)
    wmax = w ? (w[k] > wmax ? w[k] : wmax) : 1;
  real sw = 0, pbar[3] = {0, 0, 0}, qbar[3] = {0, 0, 0};
  for (size_t k = k0; k < k1; k++) {
    real wk = w ? w[k] / wmax : 1;
    sw += wk;
    for (int i = 0; i < 3; i++)
      pbar[i] += wk * P[3 * k + i], qbar[i] += wk * Q[3 * k + i];
  }
  real sp = 0, sq = 0, cp = 0, cq = 0;
  if (k1 > k0)
    for (int i = 0; i < 3; i++) {
      pbar[i] /= sw, qbar[i] /= sw;
      cp = (real)fmax(cp, fabs((double)pbar[i])), cq = (real)fmax(cq, fabs((double)qbar[i]));
    }
  for (size_t k = k0; k < k1; k++)
    for (int i = 0; i < 3; i++) {
      real a = (real)fabs((double)(P[3 * k + i] - pbar[i]));
      real b = (real)fabs((double)(Q[3 * k + i] - qbar[i]));
      sp = a > sp ? a : sp, sq = b > sq ? b : sq;
    }
  real M[9] = {0};
  // Points that coincide up to the rounding of their centroid have no
  // spread (the centroid of equal values need not equal them exactly).
  int spread = sp > SPREAD_EPS * cp && sq > SPREAD_EPS * cq && sp > 0 && sq > 0;
  if (spread)
    for (size_t k = k0; k < k1; k++) {
      real wk = w ? w[k] / wmax : 1, p[3], q[3];
      for (int i = 0; i < 3; i++)
        p[i] = (P[3 * k + i] - pbar[i]) / sp, q[i] = wk * ((Q[3 * k + i] - qbar[i]) / sq);
      for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
          M[3 * i + j] += q[i] * p[j];
    }
  else
    M[0] = M[4] = M[8] = 1;
  for (int i = 0; i < 9; i++)
    blk[(size_t)i * EK_LANES + lane] = M[i];
  return spread;
}

typedef struct {
  const size_t *offsets;
  const real *P, *Q, *w;
  real *R;
  svd3_block_fn *block;
  ek_svd3_knobs knobs;
} kabsch_aos;

static void kabsch_chunk(void *ctx, size_t s0, size_t ns, real *const *buf) {
  const kabsch_aos *c = ctx;
  size_t nb = EK_P(aosoa_blocks)(ns);
  for (size_t l = 0; l < nb * EK_LANES; l++) {
    real *blk = buf[0] + (l / EK_LANES) * 9 * EK_LANES;
    if (l < ns)
      kabsch_covariance(c->offsets[s0 + l], c->offsets[s0 + l + 1], c->P, c->Q, c->w, blk,
                        l % EK_LANES);
    else
      for (int i = 0; i < 9; i++)
        blk[(size_t)i * EK_LANES + l % EK_LANES] = (real)(i % 4 == 0);
  }
  c->block(nb, buf[0], buf[1], NULL, NULL, &c->knobs);
  EK_P(aosoa_unpack)(ns, 9, buf[1], c->R + 9 * s0);
}

int EK_P(kabsch_ex)(size_t nsets, const size_t *offsets, const real *P, const real *Q,
                    const real *w, real *R, const ek_cloth_opts *opts) {
  const ek_kernel_table *t = table(opts);
  if (!t)
    return EK_EISA;
  // The byte count first: kabsch_check reads offsets[0..nsets].
  int rc;
  if ((rc =
           ek_batch_check("ek_kabsch", nsets, 9 * sizeof(real), _Alignof(real), 4,
                          (const void *[]){P, Q, w, R}, (const char *const[]){"P", "Q", "w", "R"})))
    return rc;
  if ((rc = kabsch_check(nsets, offsets, P, Q, w)))
    return rc;
  if (nsets && !R) {
    ek_set_error("ek_kabsch: R must not be NULL (nsets = %zu)", nsets);
    return EK_EINVAL;
  }
  kabsch_aos c = {offsets, P, Q, w, R, FN(t, svd3_block), EK_P(svd3_default_knobs)()};
  c.knobs.polar = 1;
  return EK_P(staged_chunks)("ek_kabsch", nsets, CHUNK_BLOCKS, 2, (const int[]){9, 9}, kabsch_chunk,
                             &c);
}

int EK_P(kabsch)(size_t nsets, const size_t *offsets, const real *P, const real *Q, const real *w,
                 real *R) {
  return EK_P(kabsch_ex)(nsets, offsets, P, Q, w, R, NULL);
}
