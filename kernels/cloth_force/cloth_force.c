// Cloth force driver (include/ek/cloth_force.h): argument checks, dispatch
// of the block kernels (cloth_force_block.c) and the deterministic gather;
// in the f64 build also the energy, the Hessian product, its diagonal
// blocks and the per-triangle fields, in plain double (the implicit loop's
// and the frames' paths; the explicit loop's force is the vector kernel).
// Built once per precision.
//
// Threads: the force runs as two jobs of the helper team (three, timed,
// when the phases are asked for): the membrane and hinge blocks, each
// writing its corners, then every vertex sums its corners in element order.
// No vertex is written by two threads and no sum depends on the partition:
// the same bits at any thread count. The Hessian products, the diagonal
// blocks, the fields and both energies (one job each) run on the team too:
// no OpenMP region here (omp.h for omp_get_wtime, the phase timers).
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "../elements/tri_polar.h"
#include "../elements/tris.h"
#include "../kernels.h"
#include "../real.h"
#include "../team.h"
#include "cloth_force_kernel.h"

#if defined(EK_REAL_F32)
typedef struct ek_cloth_force_args_f32 cloth_args;
#define MEMBRANE(t) ((t)->cloth_membrane_block_f32)
#define BENDING(t) ((t)->cloth_bending_block_f32)
#define MEMBRANE_ENERGY(t) ((t)->cloth_membrane_energy_block_f32)
#define MEMBRANE_HESSIAN(t) ((t)->cloth_membrane_hessian_block_f32)
#define SFX(name) name##_f32
#else
typedef struct ek_cloth_force_args_f64 cloth_args;
#define MEMBRANE(t) ((t)->cloth_membrane_block_f64)
#define BENDING(t) ((t)->cloth_bending_block_f64)
#define MEMBRANE_ENERGY(t) ((t)->cloth_membrane_energy_block_f64)
#define MEMBRANE_HESSIAN(t) ((t)->cloth_membrane_hessian_block_f64)
#define SFX(name) name##_f64
#endif
#define L EK_LANES

static double wall(void) { return omp_get_wtime(); }

// Every entry point's argument checks, in this order: cl and p, the
// parameters, then its arrays (missing: one of those named is NULL).
static int check_args(const char *fn, const ek_cloth *cl, const ek_cloth_params *p, int missing,
                      const char *arrays) {
  if (!cl || !p) {
    ek_set_error("%s: NULL cloth or parameters", fn);
    return EK_EINVAL;
  }
  if ((unsigned)p->model >= EK_MEMBRANE_COUNT || !(p->mu > 0) || !isfinite(p->mu) ||
      !(p->lambda >= 0) || !isfinite(p->lambda) || !(p->bending >= 0) || !isfinite(p->bending)) {
    ek_set_error("%s: bad parameters (model %d, mu %g, lambda %g, bending %g): need mu > 0, "
                 "lambda >= 0, bending >= 0, finite",
                 fn, (int)p->model, p->mu, p->lambda, p->bending);
    return EK_EINVAL;
  }
  if (missing) {
    ek_set_error("%s: NULL %s", fn, arrays);
    return EK_EINVAL;
  }
  return 0;
}

// f[v] = sum of the corners touching v, triangles then hinges, in element
// order. Vertices [v0, v1).
static void gather(const ek_cloth *cl, const real *tc, const real *hc, real *f, size_t v0,
                   size_t v1) {
  for (size_t v = v0; v < v1; ++v) {
    real s[3] = {0, 0, 0};
    for (size_t r = cl->tri_off[v]; r < cl->tri_off[v + 1]; ++r) {
      size_t e = (size_t)cl->tri_ref[r], t = e / 3, c = e % 3;
      const real *p = tc + ((t / L) * 9 + c * 3) * L + t % L;
      s[0] += p[0], s[1] += p[L], s[2] += p[2 * L];
    }
    for (size_t r = cl->hinge_off[v]; r < cl->hinge_off[v + 1]; ++r) {
      size_t e = (size_t)cl->hinge_ref[r], h = e / 4, c = e % 4;
      const real *p = hc + ((h / L) * 12 + c * 3) * L + h % L;
      s[0] += p[0], s[1] += p[L], s[2] += p[2 * L];
    }
    f[3 * v] = s[0], f[3 * v + 1] = s[1], f[3 * v + 2] = s[2];
  }
}

// The arguments the cloth kernels share (each reads what it needs): the
// cloth's arrays in this precision, the parameters, the positions and the
// cloth's corner buffers (tris.h: one call at a time per cloth).
static cloth_args base_args(const ek_cloth *cl, const ek_cloth_params *p, const real *x) {
  ek_cloth *mut = (ek_cloth *)cl;
  return (cloth_args){
      .tri_idx = SFX(cl->tri_idx),
      .hinge_idx = SFX(cl->hinge_idx),
      .dm_inv = SFX(cl->dm),
      .area = SFX(cl->area),
      .hinge_k = SFX(cl->hk),
      .model = p->model,
      .mu = (real)p->mu,
      .lambda = (real)p->lambda,
      .bending = (real)p->bending,
      .x = x,
      .tri_corner = SFX(mut->tri_corner),
      .hinge_corner = SFX(mut->hinge_corner),
  };
}

// The force's passes as jobs of the helper team (kernels/team.h: the caller
// never waits for a thread that has not started): chunks of CHUNK_BLOCKS
// membrane blocks, then of hinge blocks, then of GATHER_VERTS vertices.
// Every chunk writes what an OpenMP thread wrote for it: the same bits.
#define CHUNK_BLOCKS 32
#define GATHER_VERTS 1024
typedef struct {
  const ek_cloth *cl;
  const cloth_args *a;
  void (*membrane)(const cloth_args *, size_t, size_t);
  void (*bending)(const cloth_args *, size_t, size_t);
  size_t ntb, nhb, ntc, nhc; // blocks, and chunks of them
  real *f;
} force_job;

static void chunk_range(size_t n, size_t i, size_t per, size_t *b0, size_t *b1) {
  *b0 = i * per;
  *b1 = *b0 + per < n ? *b0 + per : n;
}

static void force_membrane(void *ctx, size_t i) {
  const force_job *j = ctx;
  size_t b0, b1;
  chunk_range(j->ntb, i, CHUNK_BLOCKS, &b0, &b1);
  j->membrane(j->a, b0, b1);
}

static void force_bending(void *ctx, size_t i) {
  const force_job *j = ctx;
  size_t b0, b1;
  chunk_range(j->nhb, i, CHUNK_BLOCKS, &b0, &b1);
  j->bending(j->a, b0, b1);
}

static void force_elements(void *ctx, size_t i) {
  const force_job *j = ctx;
  if (i < j->ntc)
    force_membrane(ctx, i);
  else
    force_bending(ctx, i - j->ntc);
}

static void force_gather(void *ctx, size_t i) {
  const force_job *j = ctx;
  size_t v0, v1;
  chunk_range(j->cl->nv, i, GATHER_VERTS, &v0, &v1);
  gather(j->cl, j->a->tri_corner, j->a->hinge_corner, j->f, v0, v1);
}

int EK_P(cloth_forces)(const ek_cloth *cl, const ek_cloth_params *p, const real *x, real *f,
                       const ek_cloth_force_opts *opts) {
  int rc = check_args("ek_cloth_forces", cl, p, !x || !f, "x or f");
  if (rc)
    return rc;
  const ek_kernel_table *kt = ek_kernels_resolve(opts ? opts->isa : EK_ISA_AUTO);
  if (!kt)
    return EK_EISA;
  cloth_args a = base_args(cl, p, x);
  const size_t ntb = SFX(cl->ntb), nhb = p->bending > 0 ? SFX(cl->nhb) : 0;
  if (nhb == 0 && SFX(cl->nhb) > 0) // no bending: the gather reads zeros
    memset(a.hinge_corner, 0, SFX(cl->nhb) * 12 * L * sizeof(real));
  force_job j = {cl,
                 &a,
                 MEMBRANE(kt),
                 BENDING(kt),
                 ntb,
                 nhb,
                 (ntb + CHUNK_BLOCKS - 1) / CHUNK_BLOCKS,
                 (nhb + CHUNK_BLOCKS - 1) / CHUNK_BLOCKS,
                 f};
  const size_t ngc = (cl->nv + GATHER_VERTS - 1) / GATHER_VERTS;
  const int par = cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS;
  ek_cloth_phase_times *pt = opts ? opts->phase_times : NULL;
  if (!pt) {
    ek_team_run_if(par, j.ntc + j.nhc, force_elements, &j);
    ek_team_run_if(par, ngc, force_gather, &j);
    return 0;
  }
  double t0 = wall();
  ek_team_run_if(par, j.ntc, force_membrane, &j);
  double t1 = wall();
  ek_team_run_if(par, j.nhc, force_bending, &j);
  double t2 = wall();
  ek_team_run_if(par, ngc, force_gather, &j);
  double t3 = wall();
  pt->membrane += t1 - t0;
  pt->bending += t2 - t1;
  pt->gather += t3 - t2;
  return 0;
}

// ---------------------------------------------------------------------------
// Vector forms of the energy and the Hessian product (cloth_force.h): the
// membrane through the kernels of cloth_membrane_block.c, the bending (a
// constant quadratic form, a few flops per hinge) and the sums here.

// Hinge h's bending energy k_b / 2 |sum_c k_c x_c|^2 (the hinge's constant
// quadratic form, cloth_force.h), in double: every energy path's bits.
static double hinge_energy(const ek_cloth *cl, double kb, const double *x, size_t h) {
  const int32_t *q = cl->hinges + 4 * h;
  const double *k = cl->hinge_k + 4 * h;
  double s[3] = {0, 0, 0};
  for (int c = 0; c < 4; ++c)
    for (int i = 0; i < 3; ++i)
      s[i] += k[c] * x[3 * (size_t)q[c] + i];
  return 0.5 * kb * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
}

// The triangles' part of an energy call: blocks(ctx, b0, b1) writes the
// energies of triangles [b0 L, b1 L) (caller order) into te.
typedef struct {
  void (*blocks)(const void *ctx, size_t b0, size_t b1);
  const void *ctx;
  const real *te;
  size_t ntb;
} energy_job;

static double add_tris(double sum, const real *te, size_t t0, size_t t1) {
  for (size_t t = t0; t < t1; ++t)
    sum += (double)te[t];
  return sum;
}

#if defined(EK_REAL_F64)
#define TB (EK_CLOTH_ENERGY_TRIS / L) // triangle blocks per chunk
#define HCHUNK EK_CLOTH_ENERGY_CHUNK  // hinges per chunk
#define SUB 4                         // triangle blocks per kernel call, each followed by adds
#define RATE 6                        // adds per element computed that the caller can hide
_Static_assert(EK_CLOTH_ENERGY_TRIS % L == 0, "whole blocks per triangle chunk");

// E = the triangles' energies summed in double in triangle order, then the
// hinges' in hinge order: one dependent chain of nt + nh adds (an add's
// latency each, 0.8 ns on Zen 4, against ~4 ns per hinge energy), the same
// bits at any thread count. One team job: each chunk takes one element
// chunk k (take) and computes EK_CLOTH_ENERGY_TRIS triangles' energies into
// te ([0, ntc)) or HCHUNK hinges' into eh ([ntc, nc)), then flags it ready
// (release). The sum is the calling thread's alone, made as its own chunks
// run: with each element it computes it adds up to RATE of the values ready
// before its chunk, and once caught up its chunk's own as computed (at 1
// thread every chunk, as before: one loop adding each as computed). It
// never waits for a chunk: what is left when the job ends (about a chunk
// per helper) it adds then. Worker w's range of the job (team.h:
// ek_team_run_ranges splits as OpenMP's static schedule) holds the w-th
// contiguous share of the triangle chunks, then hinge chunks w, w + nw, ...:
// the caller's triangles come first in the order, so it adds them as
// computed, and at 2 threads it adds the helper's triangles and hinges
// while it computes its hinges in step with the helper's; the same chunks
// on the same core call after call. A chunk the caller takes from a late
// helper's range (the team hands it the back of that range) computes the
// first element chunk still free instead, so the caller keeps adding as it
// goes: with the helper off its core for the whole call, the fixed mapping
// had left ~16 000 adds (~13 us on 64 x 64 cells) to after the job.
// Against c129528's OpenMP region (thread 0 the first share of the
// triangles, adding them, then the hinges from a shared counter) on a
// shared 2-core Zen 4, ek-bench cloth/membrane_energy/(stvk|arap)/
// (default|avx512)/f64, least samples in ns per triangle: 1 thread level
// (StVK 10.32 / 10.45), 2 threads level (StVK 5.78 / 5.78, ARAP 9.44 /
// 9.38), medians 5-10% better beside another session's load. Measured and
// dropped: the triangle chunks interleaved as the hinges' (the caller
// adding two values per triangle it computes) ~4% slower at 2 threads; all
// chunks claimed in order from one counter (ek_team_run: a chunk on another
// core each call) 7-10%; the triangles and the hinges as two jobs ~5%.
// docs/perf.md, eighteenth round.
typedef struct {
  const ek_cloth *cl;
  const energy_job *j;
  double kb;
  const double *x, *te;
  double *eh;
  atomic_uchar *ready;
  size_t ntri, nh, ntc, nc;
  size_t nw, per; // workers the job is split for; chunks per worker
  // ready[k]: FREE, TAKEN (by the thread computing it), READY (its values
  // written); below free_hint none is FREE.
  _Alignas(64) atomic_size_t free_hint;
  _Alignas(64) double s; // the caller's sum of values [0, p)
  size_t p, lc, lim;     // lc: the first chunk not seen ready; lim = its first value
} energy64_job;
enum { FREE, TAKEN, READY };

// First value (in the sum's order) of chunk k; the end for k = nc.
static size_t chunk_start(const energy64_job *e, size_t k) {
  if (k < e->ntc)
    return k * EK_CLOTH_ENERGY_TRIS;
  size_t h = (k - e->ntc) * HCHUNK;
  return e->ntri + (h < e->nh ? h : e->nh);
}

// The first chunk from lc not flagged ready (acquire: the values of those
// before it are visible).
static size_t first_unready(const energy64_job *e, size_t lc) {
  while (lc < e->nc && atomic_load_explicit(&e->ready[lc], memory_order_acquire) == READY)
    lc++;
  return lc;
}

// s + values [p, end) in the sum's order.
static double add_values(const energy64_job *e, double s, size_t p, size_t end) {
  for (; p < end && p < e->ntri; ++p)
    s += e->te[p];
  for (; p < end; ++p)
    s += e->eh[p - e->ntri];
  return s;
}

// Triangle chunk k (blocks [b0, b1)) on the calling thread: after each
// kernel call up to RATE values per triangle of those ready before the
// chunk (all triangles), and once caught up the chunk's own. The sum's
// state stays in locals (through e, every store to eh or te would reload
// it: a store-to-load latency in the chain).
static void tri_chunk_sum(energy64_job *e, size_t k, size_t b0, size_t b1) {
  const energy_job *j = e->j;
  const size_t o = chunk_start(e, k);
  double s = e->s;
  size_t p = e->p, lc = e->lc, lim = e->lim;
  for (size_t b = b0; b < b1; b += SUB) {
    const size_t be = b + SUB < b1 ? b + SUB : b1, t1 = be * L < e->ntri ? be * L : e->ntri;
    j->blocks(j->ctx, b, be);
    if (p < o) {
      size_t end = p + RATE * (t1 - b * L);
      if (end > lim)
        lc = first_unready(e, lc), lim = chunk_start(e, lc);
      end = end < lim ? end : lim;
      for (; p < end; ++p)
        s += e->te[p];
    }
    if (p >= o)
      s = add_tris(s, e->te, p, t1), p = t1;
  }
  e->s = s, e->p = p, e->lc = lc, e->lim = lim;
}

// Hinge chunk [h, h1) on the calling thread: with each hinge energy up to
// RATE values of those ready before the chunk, and once caught up the
// chunk's own as computed.
static void hinge_chunk_sum(energy64_job *e, size_t h, size_t h1) {
  const ek_cloth *cl = e->cl;
  const double kb = e->kb, *x = e->x, *te = e->te;
  const size_t ntri = e->ntri, o = ntri + h;
  double s = e->s, *eh = e->eh;
  size_t p = e->p, lc = e->lc, lim = e->lim;
  for (; h < h1 && p < o; ++h) {
    eh[h] = hinge_energy(cl, kb, x, h);
    if (p + RATE > lim)
      lc = first_unready(e, lc), lim = chunk_start(e, lc);
    const size_t end = p + RATE < lim ? p + RATE : lim;
    if (end <= ntri)
      for (; p < end; ++p)
        s += te[p];
    else
      s = add_values(e, s, p, end), p = end;
  }
  if (p >= o) { // caught up: this chunk's values so far, then each as computed
    for (; p < ntri + h; ++p)
      s += eh[p - ntri];
    for (; h < h1; ++h)
      s += hinge_energy(cl, kb, x, h);
    p = ntri + h1;
  }
  e->s = s, e->p = p, e->lc = lc, e->lim = lim;
}

static void hinge_chunk(const ek_cloth *cl, double kb, const double *x, double *eh, size_t h0,
                        size_t h1) {
  for (size_t h = h0; h < h1; ++h)
    eh[h] = hinge_energy(cl, kb, x, h);
}

// Takes chunk k if FREE, else the first FREE one; nc where none is left
// (every team chunk takes one at most, and there are at least nc of them).
static size_t take(energy64_job *e, size_t k) {
  unsigned char f = FREE;
  if (k < e->nc && atomic_compare_exchange_strong_explicit(
                       &e->ready[k], &f, TAKEN, memory_order_relaxed, memory_order_relaxed))
    return k;
  for (k = atomic_load_explicit(&e->free_hint, memory_order_relaxed); k < e->nc; ++k) {
    f = FREE;
    if (atomic_load_explicit(&e->ready[k], memory_order_relaxed) == FREE &&
        atomic_compare_exchange_strong_explicit(&e->ready[k], &f, TAKEN, memory_order_relaxed,
                                                memory_order_relaxed)) {
      atomic_store_explicit(&e->free_hint, k + 1, memory_order_relaxed);
      return k;
    }
  }
  return e->nc;
}

// Chunk i of the job (worker 0, the calling thread, sums): worker w = i / per's (i % per)-th, which
// is its share's triangle chunk or, after those, hinge chunk w + nw (i % per - share); none past
// the last (the shares differ by up to one of each). Where that one is taken (its worker ran
// ahead), the first one free; and the caller's chunks from another worker's range (taken from its
// back: that worker is late, or off its core) take the first one free, so it computes them in order
// and adds them as it goes.
static void energy_chunk(void *ctx, size_t i, int worker) {
  energy64_job *e = ctx;
  const size_t w = i / e->per, q = i % e->per, t0 = e->ntc * w / e->nw,
               tw = e->ntc * (w + 1) / e->nw - t0;
  const int sums = worker == 0;
  const size_t k = take(e, sums && w > 0 ? e->nc : q < tw ? t0 + q : e->ntc + (q - tw) * e->nw + w);
  if (k >= e->nc)
    return;
  if (k < e->ntc) {
    const size_t b0 = k * TB, b1 = b0 + TB < e->j->ntb ? b0 + TB : e->j->ntb;
    if (sums)
      tri_chunk_sum(e, k, b0, b1);
    else
      e->j->blocks(e->j->ctx, b0, b1);
  } else {
    const size_t h0 = (k - e->ntc) * HCHUNK, h1 = h0 + HCHUNK < e->nh ? h0 + HCHUNK : e->nh;
    if (sums)
      hinge_chunk_sum(e, h0, h1);
    else
      hinge_chunk(e->cl, e->kb, e->x, e->eh, h0, h1);
  }
  atomic_store_explicit(&e->ready[k], READY, memory_order_release);
}

static double energy_sum(const ek_cloth *cl, const energy_job *j, double kb, const real *x,
                         int par) {
  energy64_job e = {.cl = cl,
                    .j = j,
                    .kb = kb,
                    .x = x,
                    .te = j->te,
                    .eh = cl->energy_buf,
                    .ready = cl->energy_ready,
                    .ntri = cl->nt,
                    .nh = kb > 0 ? cl->nh : 0};
  atomic_init(&e.free_hint, 0);
  e.ntc = (j->ntb + TB - 1) / TB;
  const size_t nhc = (e.nh + HCHUNK - 1) / HCHUNK;
  e.nc = e.ntc + nhc;
  // Split for the team's workers (another count, as where the team runs the
  // job on this thread alone, gives the same bits, only a longer sum after
  // the job); each share padded to the largest.
  e.nw = par ? (size_t)ek_team_threads() : 1;
  e.per = (e.ntc + e.nw - 1) / e.nw + (nhc + e.nw - 1) / e.nw;
  ek_team_run_ranges_if(par, e.per * e.nw, energy_chunk, &e);
  e.s = add_values(&e, e.s, e.p, e.ntri + e.nh); // every chunk is done and visible
  for (size_t k = 0; k < e.nc; ++k)              // cleared for the next call
    atomic_store_explicit(&e.ready[k], FREE, memory_order_relaxed);
  return e.s;
}
#else
#define EB EK_CLOTH_ENERGY_BLOCK_F32 // triangles / hinges per partial sum
#define SUB 4                        // triangle kernel blocks per call

// The f32 energy (cloth_force.h): the triangles in blocks of EB, the
// hinges in blocks of EB, each block summed in double in element order
// (from 0) by the thread that computes it; then the block sums in order,
// the triangles' then the hinges', by the calling thread. The order is
// fixed by EB alone, so any thread count gives the same bits, and no
// thread runs a chain longer than one block's (the f64 paths' single
// chain of nt + nh adds, the caller's, held f32 at ~1.5x at 2 threads).
// One team job: first the positions to double (the hinges read each 12
// times; f32 reads measured ~1 ns more per hinge) in chunks of
// 3 GATHER_VERTS, then chunk i: triangle block i and the i-th of ntp
// equal runs of hinge blocks (as the Hessian product's chunks: each
// worker's range holds its share of both). A hinge block reads the
// doubles once every conversion chunk is done, else the f32 positions,
// each converted as read (the same values: the same bits), so no chunk
// waits for another (at 2 threads ~6% of the hinge blocks, the helper's
// first). Against the former two jobs (the triangles, then the hinges)
// on a shared 2-core Zen 4, ek-bench cloth/membrane_energy/.*avx512/f32,
// 64 x 64 grid, 16 interleaved rounds at load 1-1.6, minima in ns/item:
// 1 thread StVK 9.42 (9.55 before), ARAP 12.28 (12.39); 2 threads StVK
// 5.24 (5.35), ARAP 6.74 (7.10). Chunks of 4 blocks (fewer, so a longer
// tail when one worker takes the other's last chunk) were ~4% slower at
// 2 threads.
// (Before: an OpenMP region of static contiguous shares, chosen because a
// dynamic schedule had measured ~15% more busy time per thread at 2
// threads: lines moving between cores; docs/perf.md, sixteenth round.)
typedef struct {
  const ek_cloth *cl;
  const energy_job *j;
  double kb, *xd, *ps;
  const real *x;
  size_t nh, ntri, nx, ntp, nhp, nxc, nc;
  atomic_size_t converted; // conversion chunks done
} energy32_job;

// hinge_energy on the f32 positions: (double)x[i] is xd[i] exactly. A copy
// on purpose: one form over the gathered corners for both (p[4][3]) ran the
// f64 energy 2.5x slower (StVK 26.6 against 10.5 ns per triangle, Zen 4),
// and one always-inlined body with xd or xf NULL ran the f32 energy 1.5-3%
// slower, at 1 thread too.
static double hinge_energy32(const ek_cloth *cl, double kb, const float *x, size_t h) {
  const int32_t *q = cl->hinges + 4 * h;
  const double *k = cl->hinge_k + 4 * h;
  double s[3] = {0, 0, 0};
  for (int c = 0; c < 4; ++c)
    for (int i = 0; i < 3; ++i)
      s[i] += k[c] * (double)x[3 * (size_t)q[c] + i];
  return 0.5 * kb * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
}

static void energy_chunk(void *ctx, size_t c) {
  energy32_job *e = ctx;
  if (c < e->nxc) {
    size_t i0, i1;
    chunk_range(e->nx, c, 3 * GATHER_VERTS, &i0, &i1);
    for (size_t i = i0; i < i1; ++i)
      e->xd[i] = (double)e->x[i];
    atomic_fetch_add_explicit(&e->converted, 1, memory_order_release);
    return;
  }
  c -= e->nxc;
  if (c < e->ntp) {
    // The kernel SUB blocks at a time, each followed by its adds: a
    // short chain that overlaps the next call (a block's 256 adds,
    // ~200 ns, would stall it).
    const energy_job *j = e->j;
    size_t t0 = c * EB, t1 = t0 + EB < e->ntri ? t0 + EB : e->ntri;
    double s = 0;
    for (size_t a = t0; a < t1; a += SUB * L) {
      size_t end = a + SUB * L < t1 ? a + SUB * L : t1;
      j->blocks(j->ctx, a / L, (end + L - 1) / L);
      s = add_tris(s, j->te, a, end);
    }
    e->ps[c] = s;
  }
  for (size_t k = e->nhp * c / e->nc; k < e->nhp * (c + 1) / e->nc; ++k) {
    const size_t h1 = (k + 1) * EB < e->nh ? (k + 1) * EB : e->nh;
    double s = 0;
    if (atomic_load_explicit(&e->converted, memory_order_acquire) == e->nxc)
      for (size_t h = k * EB; h < h1; ++h)
        s += hinge_energy(e->cl, e->kb, e->xd, h);
    else
      for (size_t h = k * EB; h < h1; ++h)
        s += hinge_energy32(e->cl, e->kb, e->x, h);
    e->ps[e->ntp + k] = s;
  }
}

static double energy_sum(const ek_cloth *cl, const energy_job *j, double kb, const real *x,
                         int par) {
  energy32_job e = {.cl = cl, .j = j, .kb = kb, .xd = cl->energy_buf, .x = x};
  e.ps = e.xd + 3 * cl->nv;
  e.nh = kb > 0 ? cl->nh : 0;
  e.ntri = cl->nt;
  e.nx = e.nh > 0 ? 3 * cl->nv : 0;
  e.ntp = (e.ntri + EB - 1) / EB;
  e.nhp = (e.nh + EB - 1) / EB;
  e.nxc = (e.nx + 3 * GATHER_VERTS - 1) / (3 * GATHER_VERTS);
  e.nc = e.ntp > 0 ? e.ntp : e.nhp > 0; // no triangles: one chunk of the hinges
  atomic_init(&e.converted, 0);
  ek_team_run_static_if(par, e.nxc + e.nc, energy_chunk, &e);
  double sum = 0;
  for (size_t k = 0; k < e.ntp + e.nhp; ++k)
    sum += e.ps[k];
  return sum;
}
#endif

typedef struct {
  void (*energy)(const cloth_args *, size_t, size_t);
  cloth_args a;
} kernel_job;

static void kernel_blocks(const void *ctx, size_t b0, size_t b1) {
  const kernel_job *k = ctx;
  k->energy(&k->a, b0, b1);
}

int EK_P(cloth_energy_ex)(const ek_cloth *cl, const ek_cloth_params *p, const real *x, double *E,
                          const ek_cloth_force_opts *opts) {
  int rc = check_args("ek_cloth_energy_ex", cl, p, !x || !E, "x or E");
  if (rc)
    return rc;
  const ek_kernel_table *kt = ek_kernels_resolve(opts ? opts->isa : EK_ISA_AUTO);
  if (!kt)
    return EK_EISA;
  kernel_job k = {MEMBRANE_ENERGY(kt), base_args(cl, p, x)};
  k.a.tri_energy = k.a.tri_corner; // the triangles' energies (tris.h)
  energy_job j = {kernel_blocks, &k, k.a.tri_energy, SFX(cl->ntb)};
  *E = energy_sum(cl, &j, p->bending, x, cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS);
  return 0;
}

// The Hessian product as two team jobs: chunk i its CHUNK_BLOCKS membrane
// blocks and the i-th of ntc equal runs of hinges (each writes its own
// corners: so each worker's range holds its share of both, and its
// triangles are about those its gather reads), then the gather in
// GATHER_VERTS-vertex chunks.
typedef struct {
  const ek_cloth *cl;
  const ek_cloth_params *p;
  const cloth_args *a;
  void (*hessian)(const cloth_args *, size_t, size_t);
  size_t ntb, nh, ntc;
  real *q;
} hessian_job;

static void hessian_elements(void *ctx, size_t i) {
  const hessian_job *j = ctx;
  size_t b0, b1;
  chunk_range(j->ntb, i, CHUNK_BLOCKS, &b0, &b1);
  j->hessian(j->a, b0, b1);
  // Bending: k_b Q (x) I3, Q = k k^T, in double.
  const ek_cloth *cl = j->cl;
  const real *dx = j->a->dx;
  const size_t h0 = j->nh * i / j->ntc, h1 = j->nh * (i + 1) / j->ntc;
  for (size_t h = h0; h < h1; ++h) {
    const int32_t *hq = cl->hinges + 4 * h;
    const double *k = cl->hinge_k + 4 * h;
    double s[3] = {0, 0, 0};
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i)
        s[i] += k[c] * (double)dx[3 * (size_t)hq[c] + i];
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i)
        j->a->hinge_corner[(h / L * 12 + (size_t)(c * 3 + i)) * L + h % L] =
            (real)(j->p->bending * k[c] * s[i]);
  }
}

static void hessian_gather(void *ctx, size_t i) {
  const hessian_job *j = ctx;
  size_t v0, v1;
  chunk_range(j->cl->nv, i, GATHER_VERTS, &v0, &v1);
  gather(j->cl, j->a->tri_corner, j->a->hinge_corner, j->q, v0, v1);
}

int EK_P(cloth_hessian_apply_ex)(const ek_cloth *cl, const ek_cloth_params *p, const real *x,
                                 int project, const real *dx, real *q,
                                 const ek_cloth_force_opts *opts) {
  int rc = check_args("ek_cloth_hessian_apply_ex", cl, p, !x || !dx || !q, "x, dx or q");
  if (rc)
    return rc;
  const ek_kernel_table *kt = ek_kernels_resolve(opts ? opts->isa : EK_ISA_AUTO);
  if (!kt)
    return EK_EISA;
  cloth_args a = base_args(cl, p, x);
  a.dx = dx;
  a.project = project != 0;
  const size_t ntb = SFX(cl->ntb), nh = p->bending > 0 ? cl->nh : 0;
  if (nh == 0 && SFX(cl->nhb) > 0) // no bending: the gather reads zeros
    memset(a.hinge_corner, 0, SFX(cl->nhb) * 12 * L * sizeof(real));
  hessian_job j = {
      cl, p, &a, MEMBRANE_HESSIAN(kt), ntb, nh, (ntb + CHUNK_BLOCKS - 1) / CHUNK_BLOCKS, q};
  const int par = cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS;
  ek_team_run_static_if(par, j.ntc, hessian_elements, &j);
  ek_team_run_static_if(par, (cl->nv + GATHER_VERTS - 1) / GATHER_VERTS, hessian_gather, &j);
  return 0;
}

#if defined(EK_REAL_F64)
// ---------------------------------------------------------------------------
// Double paths: energy, Hessian product, diagonal blocks, fields: the
// default paths of the implicit loop and the frames. StVK's energy and
// Hessian product run the vector kernels (written in the operation order
// below, no fused operations: the same bits as this code on every ISA);
// ARAP's, the diagonal blocks and the fields stay in plain double here
// (the vector polar rounds differently from cloth_svd32_of, and their
// bits are every ARAP scene's and ek-hash row's).

// F = [x1-x0, x2-x0] Dm^-1 of triangle t (3x2 row-major).
static void tri_F(const ek_cloth *cl, const double *x, size_t t, double F[6]) {
  const int32_t *q = cl->tris + 3 * t;
  const double *D = cl->dm_inv + 4 * t;
  for (int i = 0; i < 3; ++i) {
    double e1 = x[3 * (size_t)q[1] + i] - x[3 * (size_t)q[0] + i];
    double e2 = x[3 * (size_t)q[2] + i] - x[3 * (size_t)q[0] + i];
    F[2 * i] = e1 * D[0] + e2 * D[2];
    F[2 * i + 1] = e1 * D[1] + e2 * D[3];
  }
}

static double membrane_psi(const ek_cloth_params *p, const double F[6]) {
  if (p->model == EK_MEMBRANE_STVK) {
    double C00 = F[0] * F[0] + F[2] * F[2] + F[4] * F[4];
    double C01 = F[0] * F[1] + F[2] * F[3] + F[4] * F[5];
    double C11 = F[1] * F[1] + F[3] * F[3] + F[5] * F[5];
    double E00 = 0.5 * (C00 - 1), E11 = 0.5 * (C11 - 1), E01 = 0.5 * C01;
    double tr = E00 + E11;
    return p->mu * (E00 * E00 + E11 * E11 + 2 * E01 * E01) + 0.5 * p->lambda * tr * tr;
  }
  // |F - R|^2 = sum (sigma_i - 1)^2 (F - R = U (Sigma - I) V^T).
  cloth_svd32 d;
  cloth_svd32_of(F, &d);
  return p->mu * ((d.sigma[0] - 1) * (d.sigma[0] - 1) + (d.sigma[1] - 1) * (d.sigma[1] - 1));
}

// The scalar energies A Psi(F) of triangles [b0 L, b1 L) into te.
typedef struct {
  const ek_cloth *cl;
  const ek_cloth_params *p;
  const double *x;
  double *te;
} psi_job;

static void psi_blocks(const void *ctx, size_t b0, size_t b1) {
  const psi_job *k = ctx;
  for (size_t t = b0 * L; t < b1 * L && t < k->cl->nt; ++t) {
    double F[6];
    tri_F(k->cl, k->x, t, F);
    k->te[t] = k->cl->area[t] * membrane_psi(k->p, F);
  }
}

double ek_cloth_energy_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x) {
  if (check_args("ek_cloth_energy_f64", cl, p, !x, "x"))
    return NAN;
  double E = 0;
  // StVK: the vector kernel, written in this path's operation order (the
  // same bits on every ISA). ARAP stays here: the vector kernel's polar
  // rounds differently from cloth_svd32_of.
  if (p->model == EK_MEMBRANE_STVK)
    return ek_cloth_energy_ex_f64(cl, p, x, &E, NULL) ? NAN : E;
  psi_job k = {cl, p, x, ((ek_cloth *)cl)->tri_corner_f64};
  energy_job j = {psi_blocks, &k, k.te, (cl->nt + L - 1) / L};
  return energy_sum(cl, &j, p->bending, x, cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS);
}

// dP of one triangle (3x2) for dF, projected when `project` (cloth_force.h).
static void membrane_dP(const ek_cloth_params *p, const double F[6], const double dF[6],
                        int project, double dP[6]) {
  if (p->model == EK_MEMBRANE_STVK) {
    double C00 = F[0] * F[0] + F[2] * F[2] + F[4] * F[4];
    double C01 = F[0] * F[1] + F[2] * F[3] + F[4] * F[5];
    double C11 = F[1] * F[1] + F[3] * F[3] + F[5] * F[5];
    double E00 = 0.5 * (C00 - 1), E11 = 0.5 * (C11 - 1), E01 = 0.5 * C01;
    double ltr = p->lambda * (E00 + E11);
    double S00 = 2 * p->mu * E00 + ltr, S11 = 2 * p->mu * E11 + ltr, S01 = 2 * p->mu * E01;
    if (project) {
      // S's negative eigenvalues to 0 (2x2 symmetric, closed form).
      double m = 0.5 * (S00 + S11), r = hypot(0.5 * (S00 - S11), S01);
      double l0 = m + r, l1 = m - r;
      if (l1 < 0) {
        if (l0 <= 0) {
          S00 = S11 = S01 = 0;
        } else {
          // S+ = l0 v v^T, v the eigenvector of l0: (S - l1 I) / (l0 - l1)
          // is the projector onto it.
          double w = l0 / (l0 - l1);
          S00 = w * (S00 - l1), S11 = w * (S11 - l1), S01 = w * S01;
        }
      }
    }
    // dE = sym(F^T dF), dS = 2 mu dE + lambda tr(dE) I.
    double G00 = F[0] * dF[0] + F[2] * dF[2] + F[4] * dF[4];
    double G01 = F[0] * dF[1] + F[2] * dF[3] + F[4] * dF[5];
    double G10 = F[1] * dF[0] + F[3] * dF[2] + F[5] * dF[4];
    double G11 = F[1] * dF[1] + F[3] * dF[3] + F[5] * dF[5];
    double dE00 = G00, dE11 = G11, dE01 = 0.5 * (G01 + G10);
    double dltr = p->lambda * (dE00 + dE11);
    double dS00 = 2 * p->mu * dE00 + dltr, dS11 = 2 * p->mu * dE11 + dltr, dS01 = 2 * p->mu * dE01;
    for (int i = 0; i < 3; ++i) {
      dP[2 * i] = dF[2 * i] * S00 + dF[2 * i + 1] * S01 + F[2 * i] * dS00 + F[2 * i + 1] * dS01;
      dP[2 * i + 1] = dF[2 * i] * S01 + dF[2 * i + 1] * S11 + F[2 * i] * dS01 + F[2 * i + 1] * dS11;
    }
    return;
  }
  // ARAP: dP = 2 mu (dF - dR). With F = U diag(sigma) V^T, n = u0 x u1,
  // M = U^T dF V, w = n^T dF V: dF - dR = U (sym M + gamma_t skew M) V^T +
  // n sum_i gamma_i w_i v_i^T, gamma_t = 1 - 2 / (sigma0 + sigma1) (the
  // in-plane twist), gamma_i = 1 - 1 / sigma_i (out of plane); the other
  // in-plane modes keep 1. These are the eigenvalues of the F-space
  // Hessian / 2 mu (the 3x2 form of Smith et al. 2019's analysis);
  // projected, each is clamped at 0.
  cloth_svd32 d;
  cloth_svd32_of(F, &d);
  double M[4] = {0, 0, 0, 0}, w[2] = {0, 0};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 2; ++j)
          M[2 * a + b] += d.U[2 * i + a] * dF[2 * i + j] * d.V[2 * j + b];
  for (int b = 0; b < 2; ++b)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 2; ++j)
        w[b] += d.n[i] * dF[2 * i + j] * d.V[2 * j + b];
  double gt = 1 - 2 / (d.sigma[0] + d.sigma[1]);
  double g[2] = {1 - 1 / d.sigma[0], 1 - 1 / d.sigma[1]};
  if (project) {
    gt = fmax(gt, 0);
    g[0] = fmax(g[0], 0);
    g[1] = fmax(g[1], 0);
  }
  double sym = 0.5 * (M[1] + M[2]), k = 0.5 * (M[2] - M[1]);
  double N[4] = {M[0], sym - gt * k, sym + gt * k, M[3]}; // sym M + gt k J, J = [[0,-1],[1,0]]
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j) {
      double v = 0;
      for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
          v += d.U[2 * i + a] * N[2 * a + b] * d.V[2 * j + b];
      for (int b = 0; b < 2; ++b)
        v += d.n[i] * g[b] * w[b] * d.V[2 * j + b];
      dP[2 * i + j] = 2 * p->mu * v;
    }
}

// Element Hessian product of triangle t: q (3 corners x 3) = A dP Dm^-T
// spread to the corners (the gradient's pattern).
static void tri_hess(const ek_cloth *cl, const ek_cloth_params *p, const double *x, size_t t,
                     const double dxc[9], int project, double qc[9]) {
  const double *D = cl->dm_inv + 4 * t;
  double F[6], dF[6], dP[6];
  tri_F(cl, x, t, F);
  for (int i = 0; i < 3; ++i) {
    double e1 = dxc[3 + i] - dxc[i], e2 = dxc[6 + i] - dxc[i];
    dF[2 * i] = e1 * D[0] + e2 * D[2];
    dF[2 * i + 1] = e1 * D[1] + e2 * D[3];
  }
  membrane_dP(p, F, dF, project, dP);
  double A = cl->area[t];
  for (int i = 0; i < 3; ++i) {
    double g1 = A * (dP[2 * i] * D[0] + dP[2 * i + 1] * D[1]);
    double g2 = A * (dP[2 * i] * D[2] + dP[2 * i + 1] * D[3]);
    qc[3 + i] = g1;
    qc[6 + i] = g2;
    qc[i] = -(g1 + g2);
  }
}

// The plain-double Hessian product as two team jobs: chunks of
// CHUNK_BLOCKS L triangles, then of as many hinges (each writes its own
// corners), then the gather in GATHER_VERTS-vertex chunks.
typedef struct {
  const ek_cloth *cl;
  const ek_cloth_params *p;
  const double *x, *dx;
  int project;
  double *tc, *hc, *q;
} arap_job;

static void arap_elements(void *ctx, size_t i) {
  const arap_job *j = ctx;
  const ek_cloth *cl = j->cl;
  const size_t per = CHUNK_BLOCKS * L, ntc = (cl->nt + per - 1) / per;
  size_t e0, e1;
  if (i < ntc) {
    chunk_range(cl->nt, i, per, &e0, &e1);
    for (size_t t = e0; t < e1; ++t) {
      const int32_t *tri = cl->tris + 3 * t;
      double dxc[9], qc[9];
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k)
          dxc[3 * c + k] = j->dx[3 * (size_t)tri[c] + k];
      tri_hess(cl, j->p, j->x, t, dxc, j->project, qc);
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k)
          j->tc[(t / L * 9 + (size_t)(c * 3 + k)) * L + t % L] = qc[3 * c + k];
    }
    return;
  }
  chunk_range(cl->nh, i - ntc, per, &e0, &e1);
  for (size_t h = e0; h < e1; ++h) {
    // Bending: k_b Q (x) I3, Q = k k^T.
    const int32_t *hq = cl->hinges + 4 * h;
    const double *k = cl->hinge_k + 4 * h;
    double s[3] = {0, 0, 0};
    for (int c = 0; c < 4; ++c)
      for (int d = 0; d < 3; ++d)
        s[d] += k[c] * j->dx[3 * (size_t)hq[c] + d];
    for (int c = 0; c < 4; ++c)
      for (int d = 0; d < 3; ++d)
        j->hc[(h / L * 12 + (size_t)(c * 3 + d)) * L + h % L] = j->p->bending * k[c] * s[d];
  }
}

static void arap_gather(void *ctx, size_t i) {
  const arap_job *j = ctx;
  size_t v0, v1;
  chunk_range(j->cl->nv, i, GATHER_VERTS, &v0, &v1);
  gather(j->cl, j->tc, j->hc, j->q, v0, v1);
}

int ek_cloth_hessian_apply_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x,
                               int project, const double *dx, double *q) {
  int rc = check_args("ek_cloth_hessian_apply_f64", cl, p, !x || !dx || !q, "x, dx or q");
  if (rc)
    return rc;
  // StVK: the vector kernel, in this path's operation order (above).
  if (p->model == EK_MEMBRANE_STVK)
    return ek_cloth_hessian_apply_ex_f64(cl, p, x, project, dx, q, NULL);
  ek_cloth *mut = (ek_cloth *)cl;
  arap_job j = {cl, p, x, dx, project, mut->tri_corner_f64, mut->hinge_corner_f64, q};
  const int par = cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS;
  const size_t per = CHUNK_BLOCKS * L, ntc = (cl->nt + per - 1) / per;
  ek_team_run_static_if(par, ntc + (cl->nh + per - 1) / per, arap_elements, &j);
  ek_team_run_static_if(par, (cl->nv + GATHER_VERTS - 1) / GATHER_VERTS, arap_gather, &j);
  return 0;
}

// The diagonal blocks and the fields as team jobs (each vertex's or
// triangle's values alone): GATHER_VERTS vertices, CHUNK_BLOCKS L triangles
// per chunk.
typedef struct {
  const ek_cloth *cl;
  const ek_cloth_params *p;
  const double *x;
  double *blocks, *J, *s1, *s2, *psi;
} diag_job;

static void diag_chunk(void *ctx, size_t i) {
  const diag_job *j = ctx;
  const ek_cloth *cl = j->cl;
  const ek_cloth_params *p = j->p;
  size_t v0, v1;
  chunk_range(cl->nv, i, GATHER_VERTS, &v0, &v1);
  for (size_t v = v0; v < v1; ++v) {
    double b[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (size_t r = cl->tri_off[v]; r < cl->tri_off[v + 1]; ++r) {
      size_t e = cl->tri_ref[r], t = e / 3;
      int c = (int)(e % 3);
      for (int k = 0; k < 3; ++k) {
        double dxc[9] = {0}, qc[9];
        dxc[3 * c + k] = 1;
        tri_hess(cl, p, j->x, t, dxc, 1, qc);
        for (int d = 0; d < 3; ++d)
          b[3 * d + k] += qc[3 * c + d];
      }
    }
    for (size_t r = cl->hinge_off[v]; r < cl->hinge_off[v + 1]; ++r) {
      size_t e = cl->hinge_ref[r];
      double kk = p->bending * cl->hinge_k[e] * cl->hinge_k[e];
      for (int d = 0; d < 3; ++d)
        b[4 * d] += kk;
    }
    memcpy(j->blocks + 9 * v, b, sizeof b);
  }
}

static void fields_chunk(void *ctx, size_t i) {
  const diag_job *j = ctx;
  size_t t0, t1;
  chunk_range(j->cl->nt, i, CHUNK_BLOCKS * L, &t0, &t1);
  for (size_t t = t0; t < t1; ++t) {
    double F[6];
    tri_F(j->cl, j->x, t, F);
    cloth_svd32 d;
    cloth_svd32_of(F, &d);
    if (j->J)
      j->J[t] = d.sigma[0] * d.sigma[1];
    if (j->s1)
      j->s1[t] = d.sigma[0];
    if (j->s2)
      j->s2[t] = d.sigma[1];
    if (j->psi)
      j->psi[t] = membrane_psi(j->p, F);
  }
}

int ek_cloth_hessian_diagonal_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x,
                                  double *blocks) {
  int rc = check_args("ek_cloth_hessian_diagonal_f64", cl, p, !x || !blocks, "x or blocks");
  if (rc)
    return rc;
  // Column j of corner c's block is the corner-c part of the element
  // product with e_j at corner c. Each vertex sums its corners in element
  // order (triangles, then hinges), the order of the serial scatter this
  // replaces: the same bits, vertices in parallel.
  diag_job j = {cl, p, x, blocks, NULL, NULL, NULL, NULL};
  ek_team_run_static_if(cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS,
                        (cl->nv + GATHER_VERTS - 1) / GATHER_VERTS, diag_chunk, &j);
  return 0;
}

int ek_cloth_fields_f64(const ek_cloth *cl, const ek_cloth_params *p, const double *x, double *J,
                        double *s1, double *s2, double *psi) {
  int rc = check_args("ek_cloth_fields_f64", cl, p, !x, "x");
  if (rc)
    return rc;
  // Each triangle's values alone: any partition gives the same bits.
  diag_job j = {cl, p, x, NULL, J, s1, s2, psi};
  ek_team_run_static_if(cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS,
                        (cl->nt + CHUNK_BLOCKS * L - 1) / (CHUNK_BLOCKS * L), fields_chunk, &j);
  return 0;
}
#endif
