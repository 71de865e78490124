// The scatter strategies (scatter.h), shared by the FVM force and the
// Hessian passes. One parallel region per call, static partitions; the
// force's THREAD_BUFFERS runs on the helper team instead (run_buffers).
#include <omp.h>
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

static void zero_out(real *out, size_t n) {
#pragma omp for schedule(static)
  for (size_t i = 0; i < n; i++)
    out[i] = 0;
}

// COLORED: chunks of one phase (chunk colour) share no vertex, so threads
// split each phase's chunks and add straight into out, with a barrier
// between phases; a chunk runs on one thread, its colour groups in order,
// its vertices in cache.
static void run_colored(const scatter_job *j, real *out) {
  const ek_tets *el = j->el;
#pragma omp parallel if (j->parallel)
  {
    int t = omp_get_thread_num(), nt = omp_get_num_threads();
    zero_out(out, el->nverts * (size_t)j->ncomp);
    for (int p = 0; p < el->nphases; p++) {
      size_t lo, hi;
      scatter_share(el->phase_chunk[p], el->phase_chunk[p + 1], t, nt, &lo, &hi);
      if (lo < hi)
        j->range(j->ctx, el->chunk_slot[lo] / L, el->chunk_slot[hi] / L, out, NULL);
#pragma omp barrier
    }
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

// THREAD_BUFFERS on the helper team (j->team): job 1 runs the parts
// (chunk p: part p into buffer p, as the OpenMP region's thread did), job 2
// the sums over fixed vertex ranges. Which thread runs a chunk changes
// nothing in what it writes: the same bits as the region.
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

// Vertices per sum chunk of the team path (~4 us of adds on Zen 4).
#define SUM_CHUNK_VERTS 1024

// THREAD_BUFFERS: EK_FVM_PARTS fixed parts of the block range, one buffer
// each; threads take parts round-robin, then out = sum of the buffers in
// part order (parallel over vertices). Part p's tets touch only the
// vertices [vlo[p], vhi[p]) (tets.h, part_vlo): the sums read its buffer
// there alone (the Hessian passes zero it there alone), and a vertex
// outside adds the 0 the buffer would have held (x + 0 is x but for x =
// -0, so the sums keep their bits). About half the vertices per part on a
// box mesh: half the reads of the sum (and of the Hessian's zeroing).
static int run_buffers(const scatter_job *j, real *out, int team) {
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
  if (team && j->parallel) {
    ek_team_run(EK_FVM_PARTS, buffers_part, &b);
    ek_team_run(b.nsum, buffers_sum, &b);
  } else {
#pragma omp parallel if (j->parallel)
    {
      int t = omp_get_thread_num(), nt = omp_get_num_threads();
      for (int p = t; p < EK_FVM_PARTS; p += nt)
        buffers_part(&b, (size_t)p);
#pragma omp barrier
      if (!keep_zero) {
        // Unpadded rows: one vertex per call in a static loop (a flat loop
        // over each thread's share ran the Hessian product ~4% slower at
        // 998 250 tets), buffers left as they are.
#pragma omp for schedule(static)
        for (size_t v = 0; v < nv; v++)
          sum_rows(buf, n, v, v + 1, st, nc, vlo, vhi, out);
      } else {
        size_t v0, v1;
        scatter_share(0, nv, t, nt, &v0, &v1);
        sum_vertices(&b, v0, v1);
      }
    }
  }
  buffers_zero = keep_zero;
  return EK_OK;
}

// GATHER: corner values of every tet into a scratch array, then each
// vertex sums its (slot, corner) list in ascending order.
static int run_gather(const scatter_job *j, real *out) {
  const ek_tets *el = j->el;
  const int nc = j->ncomp;
  size_t nb = el->morton.nslots / L;
  real *corner = EK_P(scratch_get)(1, nb * 4 * (size_t)nc * L * sizeof(real));
  if (!corner)
    return EK_ENOMEM;
#pragma omp parallel if (j->parallel)
  {
    int t = omp_get_thread_num(), nt = omp_get_num_threads();
    size_t lo, hi;
    scatter_share(0, nb, t, nt, &lo, &hi);
    if (lo < hi)
      j->range(j->ctx, lo, hi, NULL, corner);
#pragma omp barrier
#pragma omp for schedule(static)
    for (size_t v = 0; v < el->nverts; v++) {
      real s[6] = {0};
      for (int32_t e = el->vert_start[v]; e < el->vert_start[v + 1]; e++) {
        size_t slot = (size_t)el->vert_entries[e] >> 2, c = (size_t)el->vert_entries[e] & 3;
        const real *h = corner + ((slot / L) * 4 * (size_t)nc + c * (size_t)nc) * L + slot % L;
        for (int i = 0; i < nc; i++)
          s[i] += h[(size_t)i * L];
      }
      for (int i = 0; i < nc; i++)
        out[v * (size_t)nc + (size_t)i] = s[i];
    }
  }
  return EK_OK;
}

// ATOMIC (baseline): one parallel loop over all blocks; each thread
// computes corner values for a chunk into its own small buffer and adds
// them with atomics. The order of the additions depends on the schedule:
// not deterministic.
#define ATOMIC_CHUNK 64
static int run_atomic(const scatter_job *j, real *out) {
  const ek_tets *el = j->el;
  const int nc = j->ncomp;
  size_t nb = el->morton.nslots / L, cb = 4 * (size_t)nc * L;
  int err = 0;
#pragma omp parallel if (j->parallel)
  {
    real *corner = ek_alloc(ATOMIC_CHUNK * cb * sizeof(real));
    if (!corner) {
#pragma omp atomic write
      err = 1;
    }
    zero_out(out, el->nverts * (size_t)nc);
#pragma omp for schedule(static)
    for (size_t b0 = 0; b0 < nb; b0 += ATOMIC_CHUNK) {
      if (!corner)
        continue;
      size_t b1 = b0 + ATOMIC_CHUNK < nb ? b0 + ATOMIC_CHUNK : nb;
      // The range writes block b at corner + b * cb: shift the base so
      // block b0 lands at the start of the chunk buffer.
      j->range(j->ctx, b0, b1, NULL, corner - b0 * cb);
      for (size_t b = b0; b < b1; b++) {
        const int32_t *bi = MORTON_IDX(el) + b * 4 * L;
        const real *h = corner + (b - b0) * cb;
        for (int l = 0; l < L; l++) {
          if (bi[l] < 0)
            continue;
          for (int c = 0; c < 4; c++)
            for (int i = 0; i < nc; i++) {
              real *dst = out + (size_t)bi[c * L + l] * (size_t)nc + (size_t)i;
              real val = h[((size_t)c * (size_t)nc + (size_t)i) * L + (size_t)l];
#pragma omp atomic update
              *dst += val;
            }
        }
      }
    }
    ek_free(corner);
  }
  return err ? EK_ENOMEM : EK_OK;
}

int EK_P(scatter_run)(const scatter_job *j, real *out) {
  switch (j->strategy) {
  case EK_SCATTER_COLORED:
    run_colored(j, out);
    return EK_OK;
  case EK_SCATTER_THREAD_BUFFERS:
    return run_buffers(j, out, 0);
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

int EK_P(scatter_run_team)(const scatter_job *j, real *out) {
  return j->strategy == EK_SCATTER_THREAD_BUFFERS ? run_buffers(j, out, 1)
                                                  : EK_P(scatter_run)(j, out);
}
