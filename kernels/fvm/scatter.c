// The scatter strategies (scatter.h), shared by the FVM force and the
// Hessian passes, all run as jobs of the helper team (team.h: the caller
// never waits for a thread that has not started; seventeenth round for
// COLORED, GATHER and ATOMIC, which had one OpenMP region per call).
#include <string.h>

#include "../inline.h"
#include "../kernels.h"
#include "../team.h"
#include "scatter.h"

#define L EK_LANES
#if defined(EK_REAL_F32)
#define MORTON_IDX(el) ((el)->morton.idx_f32)
#else
#define MORTON_IDX(el) ((el)->morton.idx_f64)
#endif

static _Thread_local struct {
  void *p;
  size_t bytes;
} scratch[SCATTER_SCRATCH_SLOTS];

real *EK_P(scratch_get)(int which, size_t bytes) {
  if (scratch[which].bytes < bytes) {
    ek_free(scratch[which].p);
    scratch[which].p = ek_alloc(bytes);
    scratch[which].bytes = scratch[which].p ? bytes : 0;
  }
  return scratch[which].p;
}

// Values per chunk of the team's zeroing and vertices per chunk of its
// sums (~4 us of work on Zen 4).
#define ZERO_CHUNK_VALUES 16384
#define SUM_CHUNK_VERTS 1024

// out[0 .. n) = +0, in chunks of ZERO_CHUNK_VALUES (a team job).
typedef struct {
  real *out;
  size_t n;
} zero_job;

static void zero_chunk(void *ctx, size_t i) {
  const zero_job *z = ctx;
  size_t lo = i * ZERO_CHUNK_VALUES,
         hi = lo + ZERO_CHUNK_VALUES < z->n ? lo + ZERO_CHUNK_VALUES : z->n;
  memset(z->out + lo, 0, (hi - lo) * sizeof(real));
}

static void zero_out(int parallel, real *out, size_t n) {
  zero_job z = {out, n};
  ek_team_run_static_if(parallel, (n + ZERO_CHUNK_VALUES - 1) / ZERO_CHUNK_VALUES, zero_chunk, &z);
}

// COLORED: chunks of one phase (chunk colour) share no vertex, so the
// workers split each phase's chunks and add straight into out, one team
// job per phase (a job returns when its chunks are done: the phases'
// order). A job's piece is a contiguous run of the phase's chunks, run as
// one range (a range call per mesh chunk took colored fixed corotated f32
// at 998 250 tets 1.3-1.5x as long at 1 thread: the chunks are a few
// blocks): the whole phase at 1 thread, else 4 pieces per worker so that
// one whose core is busy leaves its pieces to the other. Each vertex gets its adds in phase order,
// and within a phase from one chunk in block order, whoever runs the piece: the bits of the former
// OpenMP region (a contiguous share of the phase's chunks per thread).
typedef struct {
  const scatter_job *j;
  real *out;
  size_t c0, c1, pieces; // the phase's chunks; pieces
} colored_job;

static void colored_piece(void *ctx, size_t i) {
  const colored_job *c = ctx;
  const ek_tets *el = c->j->el;
  size_t lo, hi;
  scatter_share(c->c0, c->c1, (int)i, (int)c->pieces, &lo, &hi);
  if (lo < hi)
    c->j->range(c->j->ctx, el->chunk_slot[lo] / L, el->chunk_slot[hi] / L, c->out, NULL);
}

static void run_colored(const scatter_job *j, real *out) {
  const ek_tets *el = j->el;
  const int threads = j->parallel ? ek_team_threads() : 1;
  const size_t per_phase = threads > 1 ? 4 * (size_t)threads : 1;
  colored_job c = {j, out, 0, 0, 0};
  zero_out(j->parallel, out, el->nverts * (size_t)j->ncomp);
  for (int p = 0; p < el->nphases; p++) {
    c.c0 = el->phase_chunk[p], c.c1 = el->phase_chunk[p + 1];
    c.pieces = c.c1 - c.c0 < per_phase ? c.c1 - c.c0 : per_phase;
    ek_team_run_static_if(j->parallel, c.pieces, colored_piece, &c);
  }
}

// Slot 0 holds THREAD_BUFFERS' buffers. Padded rows (st > ncomp: the
// force's rows of 4, whose kernel prefetches the rows it adds into on big
// meshes, fvm_vec.h) keep them all zero between calls: the sum zeroes
// every row it reads (the rows a call's kernels add into lie inside them),
// which replaces a memset pass before each call (4 parts x nverts rows:
// 11 MB at 998 250 tets in f32, written with a read for ownership) by
// stores into lines the sum has just read (neo-Hookean f32 at 998 250
// tets, Zen 5, perf: memset and sum 6.3% of the samples before, 3.8%
// after). Unpadded rows (the Hessian passes) memset each part before its
// kernel as before: there the memset warms the part for a kernel that
// does not prefetch its rows, and the fused zeroing made the Hessian
// product ~5% slower at 998 250 tets. buffers_zero says whether slot 0 is
// all zero now (per calling thread, as the slot; a new allocation is not).
static _Thread_local int buffers_zero;

// out[v] = the parts' rows of v summed in part order (((b0 + b1) + b2) +
// b3, each part's row starting from +0 as before; a part whose vertex
// range leaves v out adds the 0 its row holds without reading it), and
// the rows read zeroed, for v in [v0, v1). Inlined with st and nc
// constants for the force's rows of 4 (one vector add per part and row).
EK_INLINE void reduce_rows(real *buf, size_t n, size_t v0, size_t v1, size_t st, size_t nc,
                           const size_t *vlo, const size_t *vhi, real *out) {
  for (size_t v = v0; v < v1; v++) {
    real s[8];
    real *b = buf + v * st;
    const int in0 = v >= vlo[0] && v < vhi[0];
    for (size_t k = 0; k < st; k++) {
      s[k] = in0 ? b[k] : 0;
      if (in0)
        b[k] = 0;
    }
    for (int p = 1; p < EK_FVM_PARTS; p++) {
      b += n;
      const int in = v >= vlo[p] && v < vhi[p];
      for (size_t k = 0; k < st; k++) {
        s[k] += in ? b[k] : 0;
        if (in)
          b[k] = 0;
      }
    }
    for (size_t k = 0; k < nc; k++)
      out[v * nc + k] = s[k];
  }
}

// out[v] for v in [v0, v1) from unpadded rows (st == nc), the buffers left
// as they are.
EK_INLINE void sum_rows(const real *buf, size_t n, size_t v0, size_t v1, size_t st, size_t nc,
                        const size_t *vlo, const size_t *vhi, real *out) {
  for (size_t v = v0; v < v1; v++)
    for (size_t k = 0; k < nc; k++) {
      real s = v >= vlo[0] && v < vhi[0] ? buf[v * st + k] : 0;
      for (int p = 1; p < EK_FVM_PARTS; p++)
        s += v >= vlo[p] && v < vhi[p] ? buf[(size_t)p * n + v * st + k] : 0;
      out[v * nc + k] = s;
    }
}

// THREAD_BUFFERS on the helper team: job 1 runs the parts (chunk p: part p
// into buffer p), job 2 the sums over fixed vertex ranges. Which worker
// runs a chunk changes nothing in what it writes.
typedef struct {
  const scatter_job *j;
  real *buf, *out;
  size_t n, nb, nv, st, nc, nsum;
  const size_t *vlo, *vhi;
  int keep_zero;
} buffers_job;

static void buffers_part(void *ctx, size_t p) {
  const buffers_job *b = ctx;
  real *bp = b->buf + p * b->n;
  if (!b->keep_zero)
    memset(bp + b->vlo[p] * b->st, 0, (b->vhi[p] - b->vlo[p]) * b->st * sizeof(real));
  size_t lo, hi;
  scatter_share(0, b->nb, (int)p, EK_FVM_PARTS, &lo, &hi);
  if (lo < hi)
    b->j->range(b->j->ctx, lo, hi, bp, NULL);
}

// out over vertices [v0, v1): the parts' rows summed in part order.
static void sum_vertices(const buffers_job *b, size_t v0, size_t v1) {
  if (!b->keep_zero)
    sum_rows(b->buf, b->n, v0, v1, b->st, b->nc, b->vlo, b->vhi, b->out);
  else if (b->st == 4 && b->nc == 3)
    reduce_rows(b->buf, b->n, v0, v1, 4, 3, b->vlo, b->vhi, b->out);
  else
    reduce_rows(b->buf, b->n, v0, v1, b->st, b->nc, b->vlo, b->vhi, b->out);
}

static void buffers_sum(void *ctx, size_t i) {
  const buffers_job *b = ctx;
  size_t v0, v1;
  scatter_share(0, b->nv, (int)i, (int)b->nsum, &v0, &v1);
  sum_vertices(b, v0, v1);
}

// THREAD_BUFFERS: EK_FVM_PARTS fixed parts of the block range, one buffer
// each; threads take parts round-robin, then out = sum of the buffers in
// part order (parallel over vertices). Part p's tets touch only the
// vertices [vlo[p], vhi[p]) (tets.h, part_vlo): the sums read its buffer
// there alone (the Hessian passes zero it there alone), and a vertex
// outside adds the 0 the buffer would have held (x + 0 is x but for x =
// -0, so the sums keep their bits). About half the vertices per part on a
// box mesh: half the reads of the sum (and of the Hessian's zeroing).
static int run_buffers(const scatter_job *j, real *out) {
  const size_t nc = (size_t)j->ncomp, st = j->buf_stride ? (size_t)j->buf_stride : nc;
  size_t nv = j->el->nverts, n = nv * st, nb = j->el->morton.nslots / L;
  const size_t *vlo = j->el->part_vlo[sizeof(real) == 8], *vhi = j->el->part_vhi[sizeof(real) == 8];
  if (st > 8) {
    ek_set_error("scatter: rows of %zu values per vertex (at most 8)", st);
    return EK_EINVAL; // reduce_rows' row; scatter.h: ncomp is 3 or 6
  }
  const size_t had = scratch[0].bytes;
  real *buf = EK_P(scratch_get)(0, EK_FVM_PARTS * n * sizeof(real));
  if (!buf)
    return EK_ENOMEM;
  if (scratch[0].bytes != had)
    buffers_zero = 0;
  // Kept zero: the first call (or one after the Hessian passes) zeroes
  // the whole allocation, not only this call's 4 x nv x st: a Hessian
  // pass with rows of 6 leaves its rows beyond that extent, and a later
  // mesh's extent (or ranges) may reach them (test_scenes_hold, every
  // shipped scene in one process: twist blew up at step 3 when only the
  // extent was zeroed).
  const int keep_zero = st != nc;
  if (keep_zero && !buffers_zero)
    memset(buf, 0, scratch[0].bytes);
  buffers_job b = {
      j,   buf, out,      n, nb, nv, st, nc, (nv + SUM_CHUNK_VERTS - 1) / SUM_CHUNK_VERTS,
      vlo, vhi, keep_zero};
  ek_team_run_if(j->parallel, EK_FVM_PARTS, buffers_part, &b);
  ek_team_run_static_if(j->parallel, b.nsum, buffers_sum, &b);
  buffers_zero = keep_zero;
  return EK_OK;
}

// GATHER: corner values of every tet into a scratch array (job 1: a
// block's corners are its own), then each vertex sums its (slot, corner)
// list in ascending order (job 2: a vertex's sum is its own).
typedef struct {
  const scatter_job *j;
  real *out, *corner;
  size_t nb;
} gather_job;

// Blocks per chunk of the corner job (~15 us of a fixed corotated force's
// blocks on Zen 4; chunks of 16 ran 1T ~5% slower).
#define GATHER_CHUNK_BLOCKS 64

static void gather_corners(void *ctx, size_t i) {
  const gather_job *g = ctx;
  size_t lo = i * GATHER_CHUNK_BLOCKS,
         hi = lo + GATHER_CHUNK_BLOCKS < g->nb ? lo + GATHER_CHUNK_BLOCKS : g->nb;
  g->j->range(g->j->ctx, lo, hi, NULL, g->corner);
}

static void gather_sums(void *ctx, size_t i) {
  const gather_job *g = ctx;
  const ek_tets *el = g->j->el;
  const size_t nc = (size_t)g->j->ncomp;
  size_t v0 = i * SUM_CHUNK_VERTS,
         v1 = v0 + SUM_CHUNK_VERTS < el->nverts ? v0 + SUM_CHUNK_VERTS : el->nverts;
  for (size_t v = v0; v < v1; v++) {
    real s[6] = {0};
    for (int32_t e = el->vert_start[v]; e < el->vert_start[v + 1]; e++) {
      size_t slot = (size_t)el->vert_entries[e] >> 2, c = (size_t)el->vert_entries[e] & 3;
      const real *h = g->corner + ((slot / L) * 4 * nc + c * nc) * L + slot % L;
      for (size_t k = 0; k < nc; k++)
        s[k] += h[k * L];
    }
    for (size_t k = 0; k < nc; k++)
      g->out[v * nc + k] = s[k];
  }
}

static int run_gather(const scatter_job *j, real *out) {
  const ek_tets *el = j->el;
  const int nc = j->ncomp;
  size_t nb = el->morton.nslots / L;
  real *corner = EK_P(scratch_get)(1, nb * 4 * (size_t)nc * L * sizeof(real));
  if (!corner)
    return EK_ENOMEM;
  gather_job g = {j, out, corner, nb};
  ek_team_run_static_if(j->parallel, (nb + GATHER_CHUNK_BLOCKS - 1) / GATHER_CHUNK_BLOCKS,
                        gather_corners, &g);
  ek_team_run_static_if(j->parallel, (el->nverts + SUM_CHUNK_VERTS - 1) / SUM_CHUNK_VERTS,
                        gather_sums, &g);
  return EK_OK;
}

// ATOMIC (baseline): chunks of ATOMIC_CHUNK blocks on the team; a worker
// computes a chunk's corner values into its own buffer and adds them with
// atomics. The order of the additions depends on which worker runs which
// chunk when: not deterministic.
#define ATOMIC_CHUNK 64
typedef struct {
  const scatter_job *j;
  real *out, *corners; // corners: ATOMIC_CHUNK blocks per worker
  size_t nb, cb;       // blocks; reals per block's corners
} atomic_job;

static void atomic_chunk(void *ctx, size_t i, int worker) {
  const atomic_job *a = ctx;
  const ek_tets *el = a->j->el;
  const size_t nc = (size_t)a->j->ncomp, cb = a->cb;
  size_t b0 = i * ATOMIC_CHUNK, b1 = b0 + ATOMIC_CHUNK < a->nb ? b0 + ATOMIC_CHUNK : a->nb;
  real *corner = a->corners + (size_t)worker * ATOMIC_CHUNK * cb;
  // The range writes block b at corner + b * cb: shift the base so block
  // b0 lands at the start of the worker's buffer.
  a->j->range(a->j->ctx, b0, b1, NULL, corner - b0 * cb);
  for (size_t b = b0; b < b1; b++) {
    const int32_t *bi = MORTON_IDX(el) + b * 4 * L;
    const real *h = corner + (b - b0) * cb;
    for (int l = 0; l < L; l++) {
      if (bi[l] < 0)
        continue;
      for (size_t c = 0; c < 4; c++)
        for (size_t k = 0; k < nc; k++) {
          real *dst = a->out + (size_t)bi[c * L + (size_t)l] * nc + k;
          real val = h[(c * nc + k) * L + (size_t)l];
#pragma omp atomic update
          *dst += val;
        }
    }
  }
}

static int run_atomic(const scatter_job *j, real *out) {
  const ek_tets *el = j->el;
  const size_t cb = 4 * (size_t)j->ncomp * L, workers = j->parallel ? (size_t)ek_team_threads() : 1;
  real *corners = EK_P(scratch_get)(1, workers * ATOMIC_CHUNK * cb * sizeof(real));
  if (!corners)
    return EK_ENOMEM;
  atomic_job a = {j, out, corners, el->morton.nslots / L, cb};
  zero_out(j->parallel, out, el->nverts * (size_t)j->ncomp);
  ek_team_run_ranges_if(j->parallel, (a.nb + ATOMIC_CHUNK - 1) / ATOMIC_CHUNK, atomic_chunk, &a);
  return EK_OK;
}

int EK_P(scatter_run)(const scatter_job *j, real *out) {
  switch (j->strategy) {
  case EK_SCATTER_COLORED:
    run_colored(j, out);
    return EK_OK;
  case EK_SCATTER_THREAD_BUFFERS:
    return run_buffers(j, out);
  case EK_SCATTER_GATHER:
    return run_gather(j, out);
  case EK_SCATTER_ATOMIC:
    return run_atomic(j, out);
  case EK_SCATTER_AUTO:
  case EK_SCATTER_COUNT:
    break; // resolved or refused by the caller
  }
  return EK_EINVAL;
}
