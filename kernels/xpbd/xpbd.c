// Driver of ek_xpbd (include/ek/xpbd.h): constraint blocks for tets (from
// the element layer's coloured order) and for shape-matching clusters
// (built and coloured here), the Gauss-Seidel and Jacobi sweeps, the
// residual and the profile. Built once per
// precision: the sweeps of each precision here; creation and the
// precision-free functions in the f64 instance.
#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include <ek/xpbd.h>

#include "../elements/layer.h"
#include "../elements/tets.h"
#include "../kernels.h"
#include "../real.h"
#include "../team.h"
#include "xpbd_kernel.h"

#if defined(EK_REAL_F32)
typedef struct ek_xpbd_args_f32 xpbd_args;
#define KERNEL(t) ((t)->xpbd_block_f32)
#define PRECISION 32
#define C_MIN EK_XPBD_C_MIN_F32
#else
typedef struct ek_xpbd_args_f64 xpbd_args;
#define KERNEL(t) ((t)->xpbd_block_f64)
#define PRECISION 64
#define C_MIN EK_XPBD_C_MIN_F64
#endif

// Below this many constraints a sweep runs on the calling thread: the same
// grain as the force without an SVD (fvm.h), which costs about as much per
// element.
#define XPBD_PARALLEL_MIN 4096
// Jacobi and the one-pass operations split the blocks into fixed ranges.
#define XPBD_RANGE 32
// The flow on a busy core: a thread that waits for a chunk whose thread is
// off its core waits a scheduler slice (the flow has a wait per chunk of
// ~20-40 us). A wait that outlasts XPBD_STALL_S tells the team
// (ek_team_note_stall), which after a second stall within 0.1 s runs the
// next 50 ms of jobs on the calling thread alone: the flow's chunks in
// order, the phased sweep's bits. Zen 4, cantilever_xpbd at 2 threads
// beside two processes busy 2 ms / idle 3 ms: step median 23.7 ms without,
// 16.0 with (1 thread 14.7; quiet, 2 threads 10.1 either way: docs/perf.md,
// eighteenth round).
#define XPBD_STALL_S 0.5e-3

static int parallel_for(const ek_xpbd *xp) {
  return xp->ncons >= XPBD_PARALLEL_MIN && omp_get_max_threads() > 1;
}

static xpbd_args args_for(const ek_xpbd *xp, int op, const real *xb, real *x) {
  xpbd_args a = {.op = op,
                 .tets = xp->elements == EK_XPBD_TETS,
                 .snh = xp->model == EK_MODEL_STABLE_NEO_HOOKEAN,
                 .nmem = xp->nmem,
                 .moff = xp->moff,
                 .idx = xp->idx,
                 .bv = xp->bv,
                 .stiff = xp->stiff,
                 .lambda = xp->lambda_planes,
                 .lambda_h = xp->lambda_h_planes,
                 .mu = (real)xp->mu,
                 .lam = (real)xp->lambda,
                 .inv_young = (real)(1.0 / xp->young),
                 .h2 = (real)(xp->h * xp->h),
                 .c_min = (real)C_MIN,
                 .rest_shift = (real)(1 + 0.75 * xp->mu / xp->lambda),
                 .x = x,
                 .xb = xb,
                 .w = xp->w,
                 .wd = xp->wd,
                 .corr = NULL,
                 .sink = xp->sink};
  return a;
}

static int check(const ek_xpbd *xp, const char *fn, const void *x, int need_begin) {
  if (!xp || !x) {
    ek_set_error("%s: NULL argument", fn);
    return EK_EINVAL;
  }
  if (xp->precision != PRECISION) {
    ek_set_error("%s: these constraints are in f%d (ek_xpbd_opts.precision); call the f%d function",
                 fn, xp->precision, xp->precision);
    return EK_EINVAL;
  }
  if (need_begin && !(xp->h > 0)) {
    ek_set_error("%s: no substep: call ek_xpbd_begin first", fn);
    return EK_EINVAL;
  }
  if (need_begin && !xp->weights_set) {
    ek_set_error("%s: no inverse masses: call ek_xpbd_set_weights first", fn);
    return EK_EINVAL;
  }
  return EK_OK;
}

// The passes as jobs of the helper team (kernels/team.h: the caller never
// waits for a thread that has not started, and runs the chunks no helper
// claims): a chunk does the same work whoever runs it, so the bits are the
// same at any thread count. GATHER_VERTS vertices per chunk of the Jacobi
// gather.
#define GATHER_VERTS 1024
typedef struct {
  const ek_xpbd *xp;
  const xpbd_args *a;
  real *x;
  size_t t0, t1, per; // a phase's tasks [t0, t1), tasks per chunk
  size_t nt;          // tasks per sweep (the flow)
  int it0, spin;      // the flow's first sweep, its wait's spins
} sweep_job;

// Chunk r of one pass of `op` over every block: blocks [r R, r R + R).
static void blocks_chunk(void *ctx, size_t r) {
  const sweep_job *j = ctx;
  const size_t b0 = r * XPBD_RANGE, b1 = b0 + XPBD_RANGE;
  KERNEL(j->xp->kt)(j->a, b0, b1 < j->xp->nblocks ? b1 : j->xp->nblocks);
}

static void all_blocks(const ek_xpbd *xp, const xpbd_args *a) {
  sweep_job j = {.xp = xp, .a = a};
  ek_team_run_static_if(parallel_for(xp), (xp->nblocks + XPBD_RANGE - 1) / XPBD_RANGE, blocks_chunk,
                        &j);
}

// x_v += w_v * (sum of v's corr entries, in entry order), chunk i's
// vertices.
static void gather_chunk(void *ctx, size_t i) {
  const sweep_job *j = ctx;
  const ek_xpbd *xp = j->xp;
  const real *corr = xp->corr, *w = xp->w;
  const size_t L = (size_t)xp->lanes, v0 = i * GATHER_VERTS;
  const size_t v1 = v0 + GATHER_VERTS < xp->nverts ? v0 + GATHER_VERTS : xp->nverts;
  real *x = j->x;
  for (size_t v = v0; v < v1; v++) {
    const size_t e0 = xp->vert_start[v], e1 = xp->vert_start[v + 1];
    if (e0 == e1 || w[v] == 0)
      continue;
    real s[3] = {0, 0, 0};
    for (size_t e = e0; e < e1; e++)
      for (int d = 0; d < 3; d++)
        s[d] += corr[xp->vert_entries[e] + (size_t)d * L];
    for (int d = 0; d < 3; d++)
      x[3 * v + d] += w[v] * s[d];
  }
}

// Chunk i of a Gauss-Seidel phase: tasks t0 + [i per, i per + per) of the
// phase (which share no vertex).
static void phase_chunk(void *ctx, size_t i) {
  const sweep_job *j = ctx;
  const ek_xpbd *xp = j->xp;
  const size_t t0 = j->t0 + i * j->per, t1 = t0 + j->per;
  for (size_t t = t0; t < t1 && t < j->t1; t++)
    KERNEL(xp->kt)(j->a, xp->task_block[t], xp->task_block[t + 1]);
}

// Until *done >= need: spins `spin` checks (ek_wait_spins: 2^20, ~1 ms,
// about libgomp's barrier spin; a chunk takes ~20 us), then sleeps on the
// condition variable that each finished chunk broadcasts to while anyone
// sleeps, so a thread waiting for a descheduled one frees its core.
// (Tried: 2^15 spins then sleep: on the loaded VM every handoff paid a
// wake-up, the 2-thread median 5x the barrier's; spins then sched_yield()
// for ever: 30-60x; docs/perf.md.)
// sleepers and done are sequentially consistent: either the waiter sees
// the new count or the finisher sees the sleeper, whose wait has begun by
// the time the finisher holds the mutex.
// A wait longer than XPBD_STALL_S (every one that sleeps after 2^20
// spins) is a stall (ek_team_note_stall).
static void wait_done(const ek_xpbd *xp, atomic_int *done, int need, int spin) {
  if (atomic_load_explicit(done, memory_order_acquire) >= need)
    return;
  const double t0 = omp_get_wtime();
  for (int spins = 0; spins < spin; spins++)
    if (atomic_load_explicit(done, memory_order_acquire) >= need)
      return;
  ek_xpbd *w = (ek_xpbd *)xp;
  pthread_mutex_lock(&w->flow_mutex);
  atomic_fetch_add(&w->flow_sleepers, 1);
  while (atomic_load(done) < need)
    pthread_cond_wait(&w->flow_cond, &w->flow_mutex);
  atomic_fetch_sub(&w->flow_sleepers, 1);
  pthread_mutex_unlock(&w->flow_mutex);
  if (omp_get_wtime() - t0 > XPBD_STALL_S)
    ek_team_note_stall();
}

static void mark_done(const ek_xpbd *xp, atomic_int *done, int value) {
  atomic_store(done, value);
  if (atomic_load(&xp->flow_sleepers) > 0) {
    ek_xpbd *w = (ek_xpbd *)xp;
    pthread_mutex_lock(&w->flow_mutex);
    pthread_cond_broadcast(&w->flow_cond);
    pthread_mutex_unlock(&w->flow_mutex);
  }
}

// Gauss-Seidel on tets without a barrier per phase (the phase barrier
// serialised the 13 phases of a 1e5-tet box: docs/perf.md): chunk c of the
// job is task t = task_order[c mod nt] of sweep it = it0 + c / nt, and
// starts once every neighbour u of t (a task sharing a vertex with it) has
// done its turns before it: sweep it for u < t (an earlier phase), sweep
// it - 1 for u > t. Every task then reads and writes its vertices in the
// order of the phased sweep, so the bits are the same. The team claims
// chunks in increasing c and each wait is for a smaller chunk (task_order
// puts a task after its neighbours of smaller index), so each wait is for a
// chunk that a running thread has claimed (never for one no thread has
// started), and the least unfinished chunk can always run: no wait is for
// ever, at any thread count (one thread runs them in order, waiting for
// none).
static void flow_chunk(void *ctx, size_t c) {
  const sweep_job *j = ctx;
  const ek_xpbd *xp = j->xp;
  const size_t t = (size_t)xp->task_order[c % j->nt];
  const int it = j->it0 + (int)(c / j->nt);
  for (size_t e = xp->task_dep_start[t]; e < xp->task_dep_start[t + 1]; e++) {
    const size_t u = (size_t)xp->task_dep[e];
    wait_done(xp, &xp->task_done[u], u < t ? it + 1 : it, j->spin);
  }
  KERNEL(xp->kt)(j->a, xp->task_block[t], xp->task_block[t + 1]);
  mark_done(xp, &xp->task_done[t], it + 1);
}

// The order the team claims a sweep's tasks in, for n threads: any order
// that puts each task after its neighbours of smaller index is correct (the
// waits of flow_chunk are then for claimed chunks); this one is a list
// schedule of n simulated threads, highest level first (Adam, Chandy and
// Dickson 1974), a task's cost its block count: a thread that comes free
// takes the ready task with the longest chain of later neighbours behind
// it. Task index order, the
// phased sweep's, left a thread waiting at the phase ends (the last phases
// hold 1 or 2 chunks; docs/perf.md, sixteenth round). On allocation
// failure the index order.
static void plan_order(ek_xpbd *xp, int n) {
  const size_t nt = xp->ntasks;
  double *prio = malloc(nt * sizeof(double)), *finish = malloc(nt * sizeof(double));
  double *free_at = malloc((size_t)n * sizeof(double));
  for (size_t t = 0; t < nt; t++)
    xp->task_order[t] = (int32_t)t;
  xp->order_threads = n;
  if (!prio || !finish || !free_at)
    goto done;
  for (size_t t = nt; t-- > 0;) {
    double tail = 0;
    for (size_t e = xp->task_dep_start[t]; e < xp->task_dep_start[t + 1]; e++) {
      const size_t u = (size_t)xp->task_dep[e];
      if (u > t && prio[u] > tail)
        tail = prio[u];
    }
    prio[t] = (double)(xp->task_block[t + 1] - xp->task_block[t]) + tail;
    finish[t] = -1; // not taken
  }
  for (int w = 0; w < n; w++)
    free_at[w] = 0;
  for (size_t k = 0; k < nt;) {
    int w = 0;
    for (int v = 1; v < n; v++)
      if (free_at[v] < free_at[w])
        w = v;
    const double now = free_at[w];
    size_t best = nt;
    double next = -1; // the first finish after now, if nothing is ready
    for (size_t t = 0; t < nt; t++) {
      if (finish[t] >= 0)
        continue;
      int ready = 1;
      for (size_t e = xp->task_dep_start[t]; e < xp->task_dep_start[t + 1] && ready; e++) {
        const size_t u = (size_t)xp->task_dep[e];
        if (u < t && !(finish[u] >= 0 && finish[u] <= now)) {
          ready = 0;
          if (finish[u] > now && (next < 0 || finish[u] < next))
            next = finish[u];
        }
      }
      if (ready && (best == nt || prio[t] > prio[best]))
        best = t;
    }
    if (best == nt) { // wait for the next task to finish
      free_at[w] = next;
      continue;
    }
    finish[best] = now + (double)(xp->task_block[best + 1] - xp->task_block[best]);
    free_at[w] = finish[best];
    xp->task_order[k++] = (int32_t)best;
  }
done:
  free(prio);
  free(finish);
  free(free_at);
}

// `iterations` sweeps.
static void sweeps(const ek_xpbd *xp, const real *xb, real *x, int iterations) {
  const int jacobi = xp->solver == EK_XPBD_JACOBI, par = parallel_for(xp);
  xpbd_args a = args_for(xp, jacobi ? XPBD_JACOBI : XPBD_GS, xb, x);
  if (jacobi)
    a.corr = xp->corr;
  sweep_job j = {.xp = xp, .a = &a, .x = x, .nt = xp->ntasks};
  if (!jacobi && xp->flow_ready && par && xp->ntasks > 0) {
    for (size_t t = 0; t < xp->ntasks; t++)
      atomic_store_explicit(&xp->task_done[t], 0, memory_order_relaxed);
    j.spin = ek_wait_spins(omp_get_max_threads());
    if (xp->order_threads != omp_get_max_threads())
      plan_order((ek_xpbd *)xp, omp_get_max_threads());
    // Whole sweeps per job, at most EK_TEAM_MAX_CHUNKS chunks.
    const size_t per_job = EK_TEAM_MAX_CHUNKS / xp->ntasks;
    for (int it = 0; it < iterations;) {
      const size_t k = (size_t)(iterations - it) < per_job ? (size_t)(iterations - it) : per_job;
      j.it0 = it;
      ek_team_run(k * xp->ntasks, flow_chunk, &j);
      it += (int)k;
    }
    return;
  }
  // Clusters: a task is one block, and a phase holds ~1-60 of them (1 198
  // blocks in 29 phases on the bench's box): a few chunks per worker balance
  // the ranges (32 tasks per chunk left one thread 32 and the other 14).
  const size_t split = 4 * (size_t)ek_team_threads();
  for (int it = 0; it < iterations; it++) {
    if (jacobi) {
      all_blocks(xp, &a);
      ek_team_run_static_if(par, (xp->nverts + GATHER_VERTS - 1) / GATHER_VERTS, gather_chunk, &j);
      continue;
    }
    // Gauss-Seidel: phases in order; a phase's tasks share no vertex.
    for (size_t p = 0; p < xp->nphases; p++) {
      j.t0 = xp->phase_task[p];
      j.t1 = xp->phase_task[p + 1];
      j.per = xp->elements == EK_XPBD_TETS || j.t1 - j.t0 <= split
                  ? 1
                  : (j.t1 - j.t0 + split - 1) / split;
      ek_team_run_static_if(par, (j.t1 - j.t0 + j.per - 1) / j.per, phase_chunk, &j);
    }
  }
}

int EK_P(xpbd_iterate)(ek_xpbd *xp, const real *x_base, real *x, int iterations) {
  int rc = check(xp, "ek_xpbd_iterate", x, 1);
  if (rc < 0)
    return rc;
  if (iterations < 0) {
    ek_set_error("ek_xpbd_iterate: iterations = %d: must be >= 0", iterations);
    return EK_EINVAL;
  }
  sweeps(xp, x_base, x, iterations);
  return EK_OK;
}

int EK_P(xpbd_residual)(const ek_xpbd *xp, const real *x_base, const real *x, double *residual,
                        double *cmax) {
  int rc = check(xp, "ek_xpbd_residual", x, 1);
  if (rc < 0)
    return rc;
  xpbd_args a = args_for(xp, XPBD_RESIDUAL, x_base, (real *)x);
  all_blocks(xp, &a);
  // Maxima do not depend on the order; a NaN anywhere is kept.
  const real *s = xp->sink;
  const size_t L = (size_t)xp->lanes;
  double r = 0, c = 0;
  for (size_t b = 0; b < xp->nblocks; b++)
    for (size_t l = 0; l < L; l++) {
      double rv = s[(b * 2) * L + l], cv = s[(b * 2 + 1) * L + l];
      if (!(rv <= r))
        r = rv;
      if (!(cv <= c))
        c = cv;
    }
  if (residual)
    *residual = r;
  if (cmax)
    *cmax = c;
  return EK_OK;
}

static double now(void) { return omp_get_wtime(); }

int EK_P(xpbd_profile)(ek_xpbd *xp, const real *x_base, const real *x, double seconds[3]) {
  int rc = check(xp, "ek_xpbd_profile", x, 1);
  if (rc < 0)
    return rc;
  if (!seconds) {
    ek_set_error("ek_xpbd_profile: NULL argument");
    return EK_EINVAL;
  }
  const size_t nx = 3 * xp->nverts, nl = xp->nblocks * (size_t)xp->lanes;
  real *copy = malloc((nx + 2 * nl) * sizeof(real));
  if (!copy) {
    ek_set_error("ek_xpbd_profile: out of memory");
    return EK_ENOMEM;
  }
  real *saved = copy + nx;
  memcpy(copy, x, nx * sizeof(real));
  memcpy(saved, xp->lambda_planes, nl * sizeof(real));
  memcpy(saved + nl, xp->lambda_h_planes, nl * sizeof(real));
  static const int ops[2] = {XPBD_F_ONLY, XPBD_EVAL};
  for (int k = 0; k < 2; k++) {
    xpbd_args a = args_for(xp, ops[k], x_base, copy);
    double t0 = now();
    all_blocks(xp, &a);
    seconds[k] = now() - t0;
  }
  double t0 = now();
  sweeps(xp, x_base, copy, 1);
  seconds[2] = now() - t0;
  memcpy(xp->lambda_planes, saved, nl * sizeof(real));
  memcpy(xp->lambda_h_planes, saved + nl, nl * sizeof(real));
  free(copy);
  return EK_OK;
}

#if defined(EK_REAL_F64)
// Precision-free entry points, built once (in the f64 instance).

const char *ek_xpbd_solver_name(ek_xpbd_solver s) {
  return s == EK_XPBD_GAUSS_SEIDEL ? "gauss_seidel" : s == EK_XPBD_JACOBI ? "jacobi" : "invalid";
}
const char *ek_xpbd_elements_name(ek_xpbd_elements e) {
  return e == EK_XPBD_TETS ? "tets" : e == EK_XPBD_CLUSTERS ? "clusters" : "invalid";
}

void ek_xpbd_destroy(ek_xpbd *xp) {
  if (!xp)
    return;
  free(xp->nmem);
  free(xp->moff);
  free(xp->idx);
  free(xp->cid);
  free(xp->con_slot);
  free(xp->bv64);
  ek_free(xp->bv);
  ek_free(xp->stiff);
  ek_free(xp->lambda_planes);
  ek_free(xp->lambda_h_planes);
  free(xp->w);
  free(xp->wd);
  ek_free(xp->corr);
  ek_free(xp->sink);
  free(xp->phase_task);
  free(xp->task_block);
  free(xp->task_dep_start);
  free(xp->task_dep);
  free(xp->task_order);
  free(xp->task_done);
  if (xp->flow_ready) {
    pthread_mutex_destroy(&xp->flow_mutex);
    pthread_cond_destroy(&xp->flow_cond);
  }
  free(xp->vert_start);
  free(xp->vert_entries);
  free(xp);
}

// Blocks of nblocks x L lanes whose member counts are set: the member
// planes and the per-lane arrays, zeroed (idx, cid -1).
static int alloc_blocks(ek_xpbd *xp, double **stiff64) {
  const size_t L = (size_t)xp->lanes;
  xp->moff = malloc((xp->nblocks + 1) * sizeof(size_t));
  if (!xp->moff)
    return EK_ENOMEM;
  size_t np = 0;
  for (size_t b = 0; b < xp->nblocks; b++) {
    xp->moff[b] = np;
    np += (size_t)xp->nmem[b];
  }
  xp->moff[xp->nblocks] = np;
  xp->nplanes = np;
  xp->idx = malloc(np * L * sizeof(int32_t));
  xp->bv64 = calloc(np * 3 * L, sizeof(double));
  xp->cid = malloc(xp->nblocks * L * sizeof(int32_t));
  xp->con_slot = malloc((xp->ncons ? xp->ncons : 1) * sizeof(int32_t));
  *stiff64 = calloc(xp->nblocks * L, sizeof(double));
  if (!xp->idx || !xp->bv64 || !xp->cid || !xp->con_slot || !*stiff64)
    return EK_ENOMEM;
  for (size_t i = 0; i < np * L; i++)
    xp->idx[i] = -1;
  for (size_t i = 0; i < xp->nblocks * L; i++)
    xp->cid[i] = -1;
  for (size_t j = 0; j < xp->ncons; j++)
    xp->con_slot[j] = -1;
  return EK_OK;
}

static int build_task_deps(ek_xpbd *xp);

// Tets: the element layer's coloured order, one block per L slots; phase =
// chunk colour, task = chunk (its tet colours in order).
static int build_tets(ek_xpbd *xp, double **stiff64) {
  const ek_tets *el = xp->el;
  const ek_tet_blocks *bl = &el->colored;
  const size_t L = (size_t)xp->lanes;
  xp->ncons = el->ntets;
  xp->nblocks = bl->nslots / L;
  xp->ncolors = el->ncolors;
  xp->max_members = 4;
  xp->nmem = malloc(xp->nblocks * sizeof(int32_t));
  if (!xp->nmem)
    return EK_ENOMEM;
  for (size_t b = 0; b < xp->nblocks; b++)
    xp->nmem[b] = 4;
  int rc = alloc_blocks(xp, stiff64);
  if (rc < 0)
    return rc;
  for (size_t s = 0; s < bl->nslots; s++) {
    const int32_t t = bl->slot_tet[s];
    if (t < 0)
      continue;
    const size_t b = s / L, l = s % L, m0 = xp->moff[b];
    xp->cid[s] = t;
    xp->con_slot[t] = (int32_t)s;
    (*stiff64)[s] = el->V0[t] * xp->stiff_scale;
    for (int k = 0; k < 4; k++)
      xp->idx[(m0 + (size_t)k) * L + l] = el->tets[4 * (size_t)t + (size_t)k];
    // F = Ds Dm^-1 = sum_k (x_k - x_0) (row k-1 of Dm^-1)^T.
    for (int k = 1; k < 4; k++)
      for (int d = 0; d < 3; d++)
        xp->bv64[((m0 + (size_t)k) * 3 + (size_t)d) * L + l] =
            el->Dm_inv[9 * (size_t)t + (size_t)(k - 1) * 3 + (size_t)d];
  }
  xp->nphases = (size_t)el->nphases;
  xp->ntasks = el->nchunks;
  xp->phase_task = malloc((xp->nphases + 1) * sizeof(size_t));
  xp->task_block = malloc((xp->ntasks + 1) * sizeof(size_t));
  if (!xp->phase_task || !xp->task_block)
    return EK_ENOMEM;
  for (size_t p = 0; p <= xp->nphases; p++)
    xp->phase_task[p] = el->phase_chunk[p];
  for (size_t k = 0; k <= xp->ntasks; k++)
    xp->task_block[k] = el->chunk_slot[k] / L;
  return build_task_deps(xp);
}

// The point-to-point schedule's data (flow_chunk): each task's neighbours
// through the tasks of each vertex.
static int build_task_deps(ek_xpbd *xp) {
  const size_t nt = xp->ntasks, nv = xp->nverts, L = (size_t)xp->lanes;
  size_t *vstart = calloc(nv + 1, sizeof(size_t));
  int32_t *stamp = malloc((nv > nt ? nv : nt) * sizeof(int32_t)), *vtask = NULL;
  size_t cap = 8 * nt + 8, nd = 0;
  xp->task_dep_start = malloc((nt + 1) * sizeof(size_t));
  xp->task_dep = malloc(cap * sizeof(int32_t));
  xp->task_order = malloc((nt ? nt : 1) * sizeof(int32_t));
  xp->task_done = malloc((nt ? nt : 1) * sizeof(atomic_int));
  int rc = EK_ENOMEM;
  if (!vstart || !stamp || !xp->task_dep_start || !xp->task_dep || !xp->task_order ||
      !xp->task_done)
    goto done;
  // Vertex -> tasks (CSR, each task once), in two passes.
  for (int pass = 0; pass < 2; pass++) {
    for (size_t v = 0; v < nv; v++)
      stamp[v] = -1;
    for (size_t t = 0; t < nt; t++)
      for (size_t s = xp->task_block[t] * 4 * L; s < xp->task_block[t + 1] * 4 * L; s++) {
        const int32_t v = xp->idx[s];
        if (v < 0 || stamp[v] == (int32_t)t)
          continue;
        stamp[v] = (int32_t)t;
        if (pass == 0)
          vstart[v + 1]++;
        else
          vtask[vstart[v]++] = (int32_t)t;
      }
    if (pass == 0) {
      for (size_t v = 0; v < nv; v++)
        vstart[v + 1] += vstart[v];
      vtask = malloc((vstart[nv] + 1) * sizeof(int32_t));
      if (!vtask)
        goto done;
    } else
      for (size_t v = nv; v > 0; v--) // undo the fill's advance
        vstart[v] = vstart[v - 1];
    vstart[0] = 0;
  }
  for (size_t t = 0; t < nt; t++)
    stamp[t] = -1;
  for (size_t t = 0; t < nt; t++) {
    xp->task_dep_start[t] = nd;
    stamp[t] = (int32_t)t;
    for (size_t s = xp->task_block[t] * 4 * L; s < xp->task_block[t + 1] * 4 * L; s++) {
      const int32_t v = xp->idx[s];
      if (v < 0)
        continue;
      for (size_t e = vstart[v]; e < vstart[v + 1]; e++) {
        const int32_t u = vtask[e];
        if (stamp[u] == (int32_t)t)
          continue;
        stamp[u] = (int32_t)t;
        if (nd == cap) {
          int32_t *grown = realloc(xp->task_dep, 2 * cap * sizeof(int32_t));
          if (!grown)
            goto done;
          xp->task_dep = grown;
          cap *= 2;
        }
        xp->task_dep[nd++] = u;
      }
    }
  }
  xp->task_dep_start[nt] = nd;
  for (size_t t = 0; t < nt; t++)
    atomic_init(&xp->task_done[t], 0);
  atomic_init(&xp->flow_sleepers, 0);
  if (pthread_mutex_init(&xp->flow_mutex, NULL) != 0)
    goto done;
  if (pthread_cond_init(&xp->flow_cond, NULL) != 0) {
    pthread_mutex_destroy(&xp->flow_mutex);
    goto done;
  }
  xp->flow_ready = 1;
  rc = EK_OK;
done:
  free(vstart);
  free(stamp);
  free(vtask);
  return rc;
}

static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

// One-rings: ring[rs[v] .. rs[v+1]) = v, then the vertices sharing a tet
// with v, ascending. Vertices in no tet get an empty ring. The incident
// tets come from the element layer's vertex incidence (tets.h).
static int build_rings(const ek_tets *el, size_t **rs_out, int32_t **ring_out) {
  const size_t nv = el->nverts;
  size_t maxdeg = 0, cap = 16 * nv + 16, n = 0;
  for (size_t v = 0; v < nv; v++)
    if ((size_t)(el->vert_start[v + 1] - el->vert_start[v]) > maxdeg)
      maxdeg = (size_t)(el->vert_start[v + 1] - el->vert_start[v]);
  size_t *rs = calloc(nv + 1, sizeof(size_t));
  int32_t *tmp = malloc((3 * maxdeg + 1) * sizeof(int32_t));
  int32_t *ring = malloc(cap * sizeof(int32_t));
  if (!rs || !tmp || !ring)
    goto fail;
  for (size_t v = 0; v < nv; v++) {
    rs[v] = n;
    size_t m = 0;
    for (int32_t e = el->vert_start[v]; e < el->vert_start[v + 1]; e++) {
      // Entry slot * 4 + corner of the Morton order; the slot's tet.
      const int32_t slot = el->vert_entries[e] / 4;
      const int32_t *t = el->tets + 4 * (size_t)el->morton.slot_tet[slot];
      for (int c = 0; c < 4; c++)
        if ((size_t)t[c] != v)
          tmp[m++] = t[c];
    }
    if (m == 0)
      continue;
    qsort(tmp, m, sizeof(int32_t), cmp_i32);
    if (n + m + 1 > cap) {
      cap = 2 * (n + m + 1);
      int32_t *r2 = realloc(ring, cap * sizeof(int32_t));
      if (!r2)
        goto fail;
      ring = r2;
    }
    ring[n++] = (int32_t)v;
    for (size_t i = 0; i < m; i++)
      if (i == 0 || tmp[i] != tmp[i - 1])
        ring[n++] = tmp[i];
  }
  rs[nv] = n;
  free(tmp);
  *rs_out = rs;
  *ring_out = ring;
  return EK_OK;
fail:
  free(rs);
  free(tmp);
  free(ring);
  return EK_ENOMEM;
}

// 3x3 inverse of a symmetric positive definite Q (adjugate / det).
static void inv3(const double Q[9], double det, double Qi[9]) {
  Qi[0] = (Q[4] * Q[8] - Q[5] * Q[7]) / det;
  Qi[1] = (Q[2] * Q[7] - Q[1] * Q[8]) / det;
  Qi[2] = (Q[1] * Q[5] - Q[2] * Q[4]) / det;
  Qi[3] = (Q[5] * Q[6] - Q[3] * Q[8]) / det;
  Qi[4] = (Q[0] * Q[8] - Q[2] * Q[6]) / det;
  Qi[5] = (Q[2] * Q[3] - Q[0] * Q[5]) / det;
  Qi[6] = (Q[3] * Q[7] - Q[4] * Q[6]) / det;
  Qi[7] = (Q[1] * Q[6] - Q[0] * Q[7]) / det;
  Qi[8] = (Q[0] * Q[4] - Q[1] * Q[3]) / det;
}

typedef struct {
  int32_t color, size, v;
} cluster_key;

static int cmp_cluster(const void *a, const void *b) {
  const cluster_key *x = a, *y = b;
  if (x->color != y->color)
    return (x->color > y->color) - (x->color < y->color);
  if (x->size != y->size)
    return (x->size < y->size) - (x->size > y->size); // larger first
  return (x->v > y->v) - (x->v < y->v);
}

// Clusters: one per vertex in a tet (its one-ring, seed 001's shape
// matching), coloured greedily (clusters sharing a vertex get different
// colours), each colour sorted by size and packed into blocks; phase =
// colour, task = block.
static int build_clusters(ek_xpbd *xp, const double *mass, double **stiff64) {
  static const char *fn = "ek_xpbd_create";
  const ek_tets *el = xp->el;
  const size_t nv = el->nverts, L = (size_t)xp->lanes;
  size_t *rs = NULL;
  int32_t *ring = NULL, *color = NULL;
  cluster_key *keys = NULL;
  double *vol = NULL, *bc = NULL;
  int rc = build_rings(el, &rs, &ring);
  if (rc < 0)
    return rc;
  rc = EK_ENOMEM;
  xp->ncons = nv;
  color = malloc(nv * sizeof(int32_t));
  vol = calloc(nv, sizeof(double));
  bc = malloc(3 * (rs[nv] ? rs[nv] : 1) * sizeof(double)); // b per ring entry
  keys = malloc(nv * sizeof(cluster_key));
  if (!color || !vol || !bc || !keys)
    goto done;
  // Volume shares: a quarter of each tet to each corner's cluster.
  for (size_t t = 0; t < el->ntets; t++)
    for (int c = 0; c < 4; c++)
      vol[el->tets[4 * t + (size_t)c]] += 0.25 * el->V0[t];
  // Shape matching per cluster (seed 001): Q = sum m rbar rbar^T, b_k =
  // m_k Q^-1 rbar_k, rbar relative to the rest centre of mass.
  const double *X = el->X;
  xp->max_members = 0;
  for (size_t v = 0; v < nv; v++) {
    const size_t r0 = rs[v], r1 = rs[v + 1];
    if (r0 == r1)
      continue;
    if (r1 - r0 > XPBD_MAX_MEMBERS) {
      ek_set_error("%s: the cluster of vertex %zu has %zu members, more than %d", fn, v, r1 - r0,
                   XPBD_MAX_MEMBERS);
      rc = EK_EINVAL;
      goto done;
    }
    if ((int)(r1 - r0) > xp->max_members)
      xp->max_members = (int)(r1 - r0);
    double msum = 0, cm[3] = {0, 0, 0};
    for (size_t e = r0; e < r1; e++) {
      const double m = mass[ring[e]];
      msum += m;
      for (int d = 0; d < 3; d++)
        cm[d] += m * X[3 * (size_t)ring[e] + (size_t)d];
    }
    double Q[9] = {0};
    if (msum > 0)
      for (size_t e = r0; e < r1; e++) {
        double rb[3], m = mass[ring[e]];
        for (int d = 0; d < 3; d++)
          rb[d] = X[3 * (size_t)ring[e] + (size_t)d] - cm[d] / msum;
        for (int i = 0; i < 3; i++)
          for (int j = 0; j < 3; j++)
            Q[3 * i + j] += m * rb[i] * rb[j];
      }
    const double det = Q[0] * (Q[4] * Q[8] - Q[5] * Q[7]) - Q[1] * (Q[3] * Q[8] - Q[5] * Q[6]) +
                       Q[2] * (Q[3] * Q[7] - Q[4] * Q[6]);
    const double tr = Q[0] + Q[4] + Q[8];
    // Singular (coplanar or massless members): det Q tiny against the
    // cube of its mean eigenvalue s = tr / 3. Q scales as mass x length^2:
    // where s^3 overflows or underflows (a body of 1e30 m or 1e-30 m), the
    // test and the inverse take Q / s (scale-free); elsewhere Q itself, as
    // always (the same bits).
    const double s = tr / 3, s3 = s * s * s;
    const int plain = isfinite(s3) && s3 > DBL_MIN * 1e12;
    double Qn[9], detn = 0;
    if (!plain && s > 0 && isfinite(s)) {
      for (int i = 0; i < 9; i++)
        Qn[i] = Q[i] / s;
      detn = Qn[0] * (Qn[4] * Qn[8] - Qn[5] * Qn[7]) - Qn[1] * (Qn[3] * Qn[8] - Qn[5] * Qn[6]) +
             Qn[2] * (Qn[3] * Qn[7] - Qn[4] * Qn[6]);
    }
    if (!(msum > 0) || !(plain ? det > 1e-12 * s3 : detn > 1e-12)) {
      ek_set_error("%s: the cluster of vertex %zu (%zu members, total mass %g) has a singular "
                   "Q = sum m rbar rbar^T (det Q / (tr Q / 3)^3 = %g, at least 1e-12 needed; "
                   "trace %g): its members are coplanar or massless",
                   fn, v, r1 - r0, msum, plain ? det / s3 : detn, tr);
      rc = EK_EINVAL;
      goto done;
    }
    double Qi[9];
    if (plain) {
      inv3(Q, det, Qi);
    } else {
      inv3(Qn, detn, Qi);
      for (int i = 0; i < 9; i++)
        Qi[i] /= s;
    }
    for (size_t e = r0; e < r1; e++) {
      double rb[3], m = mass[ring[e]];
      for (int d = 0; d < 3; d++)
        rb[d] = X[3 * (size_t)ring[e] + (size_t)d] - cm[d] / msum;
      for (int i = 0; i < 3; i++)
        bc[3 * e + (size_t)i] =
            m * (Qi[3 * i] * rb[0] + Qi[3 * i + 1] * rb[1] + Qi[3 * i + 2] * rb[2]);
    }
  }
  // Greedy colouring in vertex order (kernels/elements/layer.h): a
  // cluster's members are its ring, clusters sharing a member get
  // different colours; an empty ring gets colour -1 (no cluster).
  xp->ncolors = ek_layer_color(nv, nv, 0, 0, rs, ring, color);
  if (xp->ncolors < 0)
    goto done;
  size_t nk = 0;
  for (size_t v = 0; v < nv; v++)
    if (color[v] >= 0)
      keys[nk++] = (cluster_key){color[v], (int32_t)(rs[v + 1] - rs[v]), (int32_t)v};
  qsort(keys, nk, sizeof *keys, cmp_cluster);
  // Blocks: each colour's clusters, L at a time.
  size_t nb = 0;
  for (size_t i = 0; i < nk;) {
    size_t j = i;
    while (j < nk && j - i < L && keys[j].color == keys[i].color)
      j++;
    nb++;
    i = j;
  }
  xp->nblocks = nb;
  xp->nphases = (size_t)xp->ncolors;
  xp->ntasks = nb;
  xp->nmem = malloc((nb ? nb : 1) * sizeof(int32_t));
  xp->phase_task = calloc(xp->nphases + 1, sizeof(size_t));
  xp->task_block = malloc((nb + 1) * sizeof(size_t));
  int32_t *block_start = malloc((nb + 1) * sizeof(int32_t));
  if (!xp->nmem || !xp->phase_task || !xp->task_block || !block_start) {
    free(block_start);
    goto done;
  }
  nb = 0;
  for (size_t i = 0; i < nk;) {
    size_t j = i;
    while (j < nk && j - i < L && keys[j].color == keys[i].color)
      j++;
    block_start[nb] = (int32_t)i;
    xp->nmem[nb] = keys[i].size; // sorted by size: the first is the largest
    xp->phase_task[keys[i].color + 1] = nb + 1;
    nb++;
    i = j;
  }
  block_start[nb] = (int32_t)nk;
  for (size_t p = 1; p <= xp->nphases; p++)
    if (xp->phase_task[p] < xp->phase_task[p - 1])
      xp->phase_task[p] = xp->phase_task[p - 1];
  for (size_t b = 0; b <= nb; b++)
    xp->task_block[b] = b;
  if ((rc = alloc_blocks(xp, stiff64)) < 0) {
    free(block_start);
    goto done;
  }
  for (size_t b = 0; b < nb; b++)
    for (int32_t i = block_start[b]; i < block_start[b + 1]; i++) {
      const size_t l = (size_t)(i - block_start[b]), m0 = xp->moff[b];
      const int32_t v = keys[i].v;
      xp->cid[b * L + l] = v;
      xp->con_slot[v] = (int32_t)(b * L + l);
      (*stiff64)[b * L + l] = vol[v] * xp->stiff_scale;
      for (size_t e = rs[v]; e < rs[v + 1]; e++) {
        const size_t k = e - rs[v];
        xp->idx[(m0 + k) * L + l] = ring[e];
        if (k > 0)
          for (int d = 0; d < 3; d++)
            xp->bv64[((m0 + k) * 3 + (size_t)d) * L + l] = bc[3 * e + (size_t)d];
      }
    }
  free(block_start);
  rc = EK_OK;
done:
  free(rs);
  free(ring);
  free(color);
  free(keys);
  free(vol);
  free(bc);
  return rc;
}

// Vertex -> its correction entries (Jacobi), in block order: the
// incidence of the member planes (kernels/elements/layer.h), position
// p * L + l mapped to its correction offset p * 3L + l.
static int build_incidence(ek_xpbd *xp) {
  const size_t L = (size_t)xp->lanes, nv = xp->nverts;
  if (ek_layer_incidence(nv, xp->nplanes * L, xp->idx, &xp->vert_start, &xp->vert_entries))
    return EK_ENOMEM;
  for (size_t e = 0; e < xp->vert_start[nv]; e++)
    xp->vert_entries[e] = xp->vert_entries[e] / L * 3 * L + xp->vert_entries[e] % L;
  return EK_OK;
}

// Planes in the precision of the sweeps.
static void *planes_of(const double *src, size_t n, int precision) {
  void *p = ek_alloc((n ? n : 1) * (precision == 32 ? sizeof(float) : sizeof(double)));
  if (!p)
    return NULL;
  for (size_t i = 0; i < n; i++) {
    if (precision == 32)
      ((float *)p)[i] = (float)src[i];
    else
      ((double *)p)[i] = src[i];
  }
  return p;
}

ek_xpbd *ek_xpbd_create(const ek_tets *el, const ek_material *mat, double young, const double *mass,
                        const ek_xpbd_opts *opts) {
  static const char *fn = "ek_xpbd_create";
  ek_xpbd_opts o = {0};
  if (opts)
    o = *opts;
  if (!el || !mat) {
    ek_set_error("%s: NULL argument (elements %p, material %p)", fn, (const void *)el,
                 (const void *)mat);
    return NULL;
  }
  if (!ek_xpbd_supports(mat->model)) {
    ek_set_error("%s: model %s: XPBD has constraints for %s (seed 001's Hookean) and %s "
                 "(Macklin & Mueller 2021) only",
                 fn, ek_model_name(mat->model), ek_model_name(EK_XPBD_MODEL),
                 ek_model_name(EK_MODEL_STABLE_NEO_HOOKEAN));
    return NULL;
  }
  if (ek_material_check(mat) < 0)
    return NULL;
  if (mat->model == EK_MODEL_STABLE_NEO_HOOKEAN && !(mat->mu > 0 && mat->lambda > 0)) {
    ek_set_error("%s: stable neo-Hookean constraints need mu > 0 and lambda > 0 (compliances "
                 "1 / mu, 1 / lambda; rest shift 1 + 3 mu / (4 lambda)): mu %g, lambda %g",
                 fn, mat->mu, mat->lambda);
    return NULL;
  }
  if (!(young > 0) || !isfinite(young)) {
    ek_set_error("%s: Young's modulus %g: must be finite and > 0", fn, young);
    return NULL;
  }
  if ((unsigned)o.elements >= EK_XPBD_ELEMENTS_COUNT ||
      (unsigned)o.solver >= EK_XPBD_SOLVER_COUNT) {
    ek_set_error("%s: elements %d / solver %d: not a valid ek_xpbd_elements / ek_xpbd_solver", fn,
                 (int)o.elements, (int)o.solver);
    return NULL;
  }
  if (o.precision != 0 && o.precision != 32 && o.precision != 64) {
    ek_set_error("%s: precision %d: must be 32 or 64 (0 = 64)", fn, o.precision);
    return NULL;
  }
  if (o.elements == EK_XPBD_CLUSTERS) {
    if (!mass) {
      ek_set_error("%s: clusters need the vertex masses (shape matching weights)", fn);
      return NULL;
    }
    for (size_t v = 0; v < el->nverts; v++)
      if (!(mass[v] >= 0) || !isfinite(mass[v])) {
        ek_set_error("%s: mass[%zu] = %g: must be finite and >= 0", fn, v, mass[v]);
        return NULL;
      }
  }
  ek_isa isa;
  if (ek_isa_resolve(o.isa, &isa) < 0)
    return NULL;
  const ek_kernel_table *kt = ek_kernels_for(isa);
  if (!kt)
    return NULL;
  ek_xpbd *xp = calloc(1, sizeof *xp);
  if (!xp) {
    ek_set_error("%s: out of memory", fn);
    return NULL;
  }
  xp->el = el;
  xp->elements = o.elements;
  xp->solver = o.solver;
  xp->isa = isa;
  xp->kt = kt;
  xp->precision = o.precision ? o.precision : 64;
  xp->lanes = xp->precision == 32 ? EK_LANES_F32 : EK_LANES_F64;
  xp->model = mat->model;
  xp->mu = mat->mu;
  xp->lambda = mat->lambda;
  xp->young = young;
  // stiff planes: V E (StVK's k = V E h^2) or V (snh: k_D = V mu h^2,
  // k_H = V lambda h^2 in the kernel).
  xp->stiff_scale = mat->model == EK_MODEL_STABLE_NEO_HOOKEAN ? 1.0 : young;
  xp->nverts = el->nverts;
  double *stiff64 = NULL;
  int rc =
      o.elements == EK_XPBD_TETS ? build_tets(xp, &stiff64) : build_clusters(xp, mass, &stiff64);
  if (rc == EK_OK)
    rc = build_incidence(xp);
  const size_t nl = xp->nblocks * (size_t)xp->lanes;
  if (rc == EK_OK) {
    xp->bv = planes_of(xp->bv64, xp->nplanes * 3 * (size_t)xp->lanes, xp->precision);
    xp->stiff = planes_of(stiff64, nl, xp->precision);
    const size_t rb = xp->precision == 32 ? sizeof(float) : sizeof(double);
    xp->lambda_planes = ek_alloc((nl ? nl : 1) * rb);
    xp->lambda_h_planes = ek_alloc((nl ? nl : 1) * rb);
    xp->corr = ek_alloc((xp->nplanes * 3 * (size_t)xp->lanes + 1) * rb);
    xp->sink = ek_alloc((2 * nl + 1) * rb);
    xp->w = calloc(xp->nverts + 1, rb);
    xp->wd = calloc(xp->nverts + 1, rb);
    if (!xp->bv || !xp->stiff || !xp->lambda_planes || !xp->lambda_h_planes || !xp->corr ||
        !xp->sink || !xp->w || !xp->wd)
      rc = EK_ENOMEM;
    else {
      memset(xp->lambda_planes, 0, nl * rb);
      memset(xp->lambda_h_planes, 0, nl * rb);
    }
  }
  free(stiff64);
  if (rc < 0) {
    if (rc == EK_ENOMEM)
      ek_set_error("%s: out of memory for %zu constraints", fn, xp->ncons);
    ek_xpbd_destroy(xp);
    return NULL;
  }
  return xp;
}

size_t ek_xpbd_count(const ek_xpbd *xp) { return xp ? xp->ncons : 0; }
int ek_xpbd_ncolors(const ek_xpbd *xp) { return xp ? xp->ncolors : 0; }
int ek_xpbd_max_members(const ek_xpbd *xp) { return xp ? xp->max_members : 0; }

int ek_xpbd_members(const ek_xpbd *xp, size_t j, int32_t *members, double *b) {
  if (!xp || j >= xp->ncons) {
    ek_set_error("ek_xpbd_members: constraint %zu: out of range", j);
    return EK_EINVAL;
  }
  if (xp->con_slot[j] < 0)
    return 0; // a vertex in no tet has no cluster
  const size_t L = (size_t)xp->lanes, s = (size_t)xp->con_slot[j], bk = s / L, l = s % L;
  int K = 0;
  for (int k = 0; k < xp->nmem[bk]; k++) {
    const size_t p = xp->moff[bk] + (size_t)k;
    if (xp->idx[p * L + l] < 0)
      break;
    if (members)
      members[k] = xp->idx[p * L + l];
    if (b && k > 0)
      for (int d = 0; d < 3; d++)
        b[3 * (k - 1) + d] = xp->bv64[(p * 3 + (size_t)d) * L + l];
    K++;
  }
  return K;
}

int ek_xpbd_order(const ek_xpbd *xp, int32_t *order) {
  if (!xp || !order) {
    ek_set_error("ek_xpbd_order: NULL argument");
    return EK_EINVAL;
  }
  const size_t L = (size_t)xp->lanes;
  size_t n = 0;
  for (size_t t = 0; t < xp->ntasks; t++)
    for (size_t b = xp->task_block[t]; b < xp->task_block[t + 1]; b++)
      for (size_t l = 0; l < L; l++)
        if (xp->cid[b * L + l] >= 0)
          order[n++] = xp->cid[b * L + l];
  return (int)n;
}

int ek_xpbd_set_weights(ek_xpbd *xp, const double *w) {
  if (!xp || !w) {
    ek_set_error("ek_xpbd_set_weights: NULL argument");
    return EK_EINVAL;
  }
  for (size_t v = 0; v < xp->nverts; v++)
    if (!(w[v] >= 0) || !isfinite(w[v])) {
      ek_set_error("ek_xpbd_set_weights: w[%zu] = %g: must be finite and >= 0", v, w[v]);
      return EK_EINVAL;
    }
  const int jacobi = xp->solver == EK_XPBD_JACOBI;
  for (size_t v = 0; v < xp->nverts; v++) {
    // Jacobi's denominator counts each vertex once per constraint on it.
    const double wd = jacobi ? w[v] * (double)(xp->vert_start[v + 1] - xp->vert_start[v]) : w[v];
    if (xp->precision == 32) {
      ((float *)xp->w)[v] = (float)w[v];
      ((float *)xp->wd)[v] = (float)wd;
    } else {
      ((double *)xp->w)[v] = w[v];
      ((double *)xp->wd)[v] = wd;
    }
  }
  xp->weights_set = 1;
  return EK_OK;
}

int ek_xpbd_begin(ek_xpbd *xp, double h) {
  if (!xp) {
    ek_set_error("ek_xpbd_begin: NULL argument");
    return EK_EINVAL;
  }
  if (!(h > 0) || !isfinite(h)) {
    ek_set_error("ek_xpbd_begin: substep h = %g: must be finite and > 0", h);
    return EK_EINVAL;
  }
  xp->h = h;
  const size_t nl = xp->nblocks * (size_t)xp->lanes;
  memset(xp->lambda_planes, 0, nl * (xp->precision == 32 ? sizeof(float) : sizeof(double)));
  memset(xp->lambda_h_planes, 0, nl * (xp->precision == 32 ? sizeof(float) : sizeof(double)));
  return EK_OK;
}

static int lambda_of(const ek_xpbd *xp, const void *planes, double *lambda, const char *fn) {
  if (!xp || !lambda) {
    ek_set_error("%s: NULL argument", fn);
    return EK_EINVAL;
  }
  for (size_t j = 0; j < xp->ncons; j++) {
    const int32_t s = xp->con_slot[j];
    lambda[j] = s < 0                 ? 0.0
                : xp->precision == 32 ? ((const float *)planes)[s]
                                      : ((const double *)planes)[s];
  }
  return EK_OK;
}

int ek_xpbd_lambda(const ek_xpbd *xp, double *lambda) {
  return lambda_of(xp, xp ? xp->lambda_planes : NULL, lambda, "ek_xpbd_lambda");
}

int ek_xpbd_lambda_h(const ek_xpbd *xp, double *lambda) {
  return lambda_of(xp, xp ? xp->lambda_h_planes : NULL, lambda, "ek_xpbd_lambda_h");
}

int ek_xpbd_supports(ek_model model) {
  return model == EK_XPBD_MODEL || model == EK_MODEL_STABLE_NEO_HOOKEAN;
}

ek_model ek_xpbd_model(const ek_xpbd *xp) { return xp ? xp->model : EK_XPBD_MODEL; }
#endif
