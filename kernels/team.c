// The helper team of team.h.
//
// One job at a time. The claim word packs the job's epoch, its chunk count
// n and the next unclaimed chunk; a thread claims with one fetch-add and
// runs the chunk if the index it got is below n (so a helper that wakes
// during a later job claims from that job, which is as good). The caller
// publishes fn and ctx, zeroes the done count, then stores a new claim word
// (release); a helper reads fn and ctx only after a claim below n, and the
// job cannot end (done < n) before that chunk is done, so they cannot change
// under it. Helpers wait for a new epoch by spinning, then sleeping on a
// condition variable; the caller waits for the last claimed chunks the same
// way. sleepers / caller_sleeps and the words they guard are sequentially
// consistent: either the waker sees the sleeper, or the sleeper sees the
// change before it waits (it holds the mutex from its check to the wait).
// ek_team_run_ranges' jobs store no chunk count in the claim word (its new
// epoch only wakes the helpers): a worker takes chunks from the range words
// instead, each stored (release) after fn, ctx and base, and adds its count
// to done once it finds every range empty; ranges are empty when a job ends,
// so a helper still looking from an earlier job finds nothing, or this
// job's chunks.
#define _GNU_SOURCE
#include <omp.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <strings.h>

#include "team.h"

#define MAX_HELPERS 63
#define NEXT_BITS 20
#define N_BITS 20
#define NEXT_OF(w) ((size_t)((w) & ((UINT64_C(1) << NEXT_BITS) - 1)))
#define N_OF(w) ((size_t)(((w) >> NEXT_BITS) & ((UINT64_C(1) << N_BITS) - 1)))
#define EPOCH_OF(w) ((w) >> (NEXT_BITS + N_BITS))

static struct {
  pthread_mutex_t run; // held by the caller of the job in flight
  pthread_mutex_t m;   // for the sleeps below
  pthread_cond_t wake; // helpers between jobs
  pthread_cond_t idle; // the caller, for the last claimed chunks
  _Atomic uint64_t claim;
  atomic_size_t done;
  atomic_int sleepers, caller_sleeps;
  atomic_int want;        // helpers 1 .. want - 1 take part in the current job
  ek_team_fn *fn;         // ek_team_run's chunks: fn(ctx, base + i)
  ek_team_worker_fn *wfn; // ek_team_run_ranges': wfn(ctx, base + i, worker)
  atomic_int ranged;      // the job is ek_team_run_ranges'
  void *ctx;
  size_t base;     // first chunk of this job (a run of more than EK_TEAM_MAX_CHUNKS)
  size_t n;        // chunks of this job (ranges)
  int helpers;     // started (under run)
  atomic_int spin; // checks before a helper's wait for a job sleeps (ek_wait_spins)
  // A stalled job (stall_check, or ek_team_note_stall's flag from a wait
  // inside a chunk): jobs started before solo_until run on the caller alone
  // (solo_until under run).
  double solo_until;
  double last_stall; // when the last stall was seen (under run)
  atomic_int stalled;
  // ek_team_run_ranges: worker w's range of chunks, a line each: FRONT,
  // the next chunk its owner takes; BACK, one past the last (other workers
  // take from there); TAG, the job's epoch (low bits).
  struct {
    _Alignas(64) _Atomic uint64_t w;
  } range[MAX_HELPERS + 1];
} T = {.run = PTHREAD_MUTEX_INITIALIZER,
       .m = PTHREAD_MUTEX_INITIALIZER,
       .wake = PTHREAD_COND_INITIALIZER,
       .idle = PTHREAD_COND_INITIALIZER};

#define FRONT(w) ((size_t)((w) & ((UINT64_C(1) << 24) - 1)))
#define BACK(w) ((size_t)(((w) >> 24) & ((UINT64_C(1) << 20) - 1)))
#define BACK_ONE (UINT64_C(1) << 24)
#define TAG(epoch) (((uint64_t)(epoch)&TAG_MASK) << 44)
#define TAG_MASK ((UINT64_C(1) << 20) - 1)
#define TAG_OF(w) ((w) >> 44)

// Tells the caller, if it sleeps, that the job's chunks are done.
static void done_by(size_t count, size_t n) {
  size_t d = atomic_fetch_add_explicit(&T.done, count, memory_order_acq_rel) + count;
  if (d == n && atomic_load(&T.caller_sleeps)) {
    pthread_mutex_lock(&T.m);
    pthread_cond_broadcast(&T.idle);
    pthread_mutex_unlock(&T.m);
  }
}

// ek_team_run_ranges' work: worker id's own range from the front, then the
// others' from their backs; the done count once, at the end (a chunk of a
// later job cannot be among them: the job ends only after this count).
// epoch: the job this worker was called for. Its own range may hold a
// later job's chunks (a helper still here when that job started: it is one
// of that job's workers, or its range would not have been set), the others'
// only this job's: a worker of an earlier, wider job takes nothing from a
// later one, whose staging has no buffers for it.
static void chunk(size_t i, int id) {
  if (T.wfn)
    T.wfn(T.ctx, i, id);
  else
    T.fn(T.ctx, i);
}

static size_t work_ranges(int id, uint64_t epoch) {
  const int nr = atomic_load_explicit(&T.want, memory_order_relaxed);
  size_t count = 0;
  for (;;) {
    uint64_t w = atomic_fetch_add_explicit(&T.range[id].w, 1, memory_order_acq_rel);
    if (FRONT(w) >= BACK(w))
      break;
    chunk(T.base + FRONT(w), id);
    count++;
  }
  for (int k = 1; k < nr; k++) {
    const int r = (id + k) % nr;
    uint64_t w = atomic_load_explicit(&T.range[r].w, memory_order_acquire);
    while (FRONT(w) < BACK(w) && TAG_OF(w) == (epoch & TAG_MASK))
      if (atomic_compare_exchange_weak_explicit(&T.range[r].w, &w, w - BACK_ONE,
                                                memory_order_acq_rel, memory_order_acquire)) {
        chunk(T.base + BACK(w) - 1, id);
        count++;
        w = atomic_load_explicit(&T.range[r].w, memory_order_acquire);
      }
  }
  if (count)
    done_by(count, T.n);
  return count;
}

// Claims and runs chunks of the current job until none is left; id: the
// worker index (0: the caller, else the helper's). Returns how many it ran.
static size_t work(int id, uint64_t epoch) {
  if (atomic_load_explicit(&T.ranged, memory_order_relaxed))
    return work_ranges(id, epoch);
  for (size_t count = 0;; count++) {
    uint64_t w = atomic_fetch_add_explicit(&T.claim, 1, memory_order_acq_rel);
    if (NEXT_OF(w) >= N_OF(w))
      return count;
    T.fn(T.ctx, T.base + NEXT_OF(w));
    done_by(1, N_OF(w));
  }
}

typedef struct {
  int id, bound;
  cpu_set_t set;
} helper_start;

static void *helper(void *arg) {
  helper_start h = *(helper_start *)arg;
  free(arg);
  const int id = h.id;
  // A chunk may call a kernel that opens an OpenMP region (below its
  // threshold: run on this thread), and libgomp binds a thread to the first
  // place at its first region: open one first, then move to our place.
  volatile int in_region = 0;
#pragma omp parallel num_threads(1)
  in_region = omp_get_num_threads();
  (void)in_region;
  if (h.bound)
    pthread_setaffinity_np(pthread_self(), sizeof h.set, &h.set);
  uint64_t seen = 0;
  for (;;) {
    uint64_t w = atomic_load_explicit(&T.claim, memory_order_acquire);
    const int spin = atomic_load_explicit(&T.spin, memory_order_relaxed);
    for (int spins = 0; EPOCH_OF(w) == seen && spins < spin; spins++)
      w = atomic_load_explicit(&T.claim, memory_order_acquire);
    if (EPOCH_OF(w) == seen) {
      pthread_mutex_lock(&T.m);
      atomic_fetch_add(&T.sleepers, 1);
      while (EPOCH_OF(w = atomic_load(&T.claim)) == seen)
        pthread_cond_wait(&T.wake, &T.m);
      atomic_fetch_sub(&T.sleepers, 1);
      pthread_mutex_unlock(&T.m);
    }
    seen = EPOCH_OF(w);
    if (id < atomic_load_explicit(&T.want, memory_order_relaxed))
      work(id, seen);
  }
  return NULL;
}

// Helper id's cores: those of the OpenMP place thread id of a team would
// get under OMP_PROC_BIND=close (ek-sim's and ek-bench's default: one thread
// per core); 0 where threads are not bound.
static int place_of(int id, cpu_set_t *set) {
  const int np = omp_get_num_places(), here = omp_get_place_num();
  if (omp_get_proc_bind() == omp_proc_bind_false || np < 2 || here < 0)
    return 0;
  const int p = (here + id) % np, nids = omp_get_place_num_procs(p);
  int *ids = malloc((size_t)(nids > 0 ? nids : 1) * sizeof *ids);
  if (!ids)
    return 0;
  omp_get_place_proc_ids(p, ids);
  CPU_ZERO(set);
  for (int i = 0; i < nids; i++)
    if (ids[i] >= 0 && ids[i] < CPU_SETSIZE)
      CPU_SET(ids[i], set);
  free(ids);
  return 1;
}

// A forked child has only its calling thread: no helpers, fresh locks.
static void after_fork(void) {
  pthread_mutex_init(&T.run, NULL);
  pthread_mutex_init(&T.m, NULL);
  pthread_cond_init(&T.wake, NULL);
  pthread_cond_init(&T.idle, NULL);
  atomic_store(&T.sleepers, 0);
  atomic_store(&T.caller_sleeps, 0);
  T.helpers = 0;
}

// Starts helpers up to `count` (under run); returns how many there are.
static int start_helpers(int count) {
  if (count > MAX_HELPERS)
    count = MAX_HELPERS;
  if (T.helpers == 0)
    pthread_atfork(NULL, NULL, after_fork);
  while (T.helpers < count) {
    pthread_attr_t attr;
    pthread_t th;
    if (pthread_attr_init(&attr) != 0)
      break;
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    helper_start *h = malloc(sizeof *h);
    if (!h) {
      pthread_attr_destroy(&attr);
      break;
    }
    h->id = T.helpers + 1;
    h->bound = place_of(h->id, &h->set);
    int rc = pthread_create(&th, &attr, helper, h);
    pthread_attr_destroy(&attr);
    if (rc != 0) {
      free(h);
      break;
    }
    T.helpers++;
  }
  return T.helpers;
}

static void serial(size_t n, ek_team_fn *fn, ek_team_worker_fn *wfn, void *ctx) {
  for (size_t i = 0; i < n; i++)
    if (wfn)
      wfn(ctx, i, 0);
    else
      fn(ctx, i);
}

int ek_wait_spins(int threads) {
  static atomic_int passive = -1; // OMP_WAIT_POLICY=passive, once read
  int p = atomic_load_explicit(&passive, memory_order_relaxed);
  if (p < 0) {
    const char *policy = getenv("OMP_WAIT_POLICY");
    p = policy && strcasecmp(policy, "passive") == 0;
    atomic_store_explicit(&passive, p, memory_order_relaxed);
  }
  return p || threads > omp_get_num_procs() ? 1 << 8 : 1 << 20;
}

int ek_team_threads(void) {
  const int threads = omp_get_max_threads();
  return omp_in_parallel() || threads < 2 ? 1 : threads > MAX_HELPERS ? MAX_HELPERS + 1 : threads;
}

// A late helper: one that claimed a chunk and was then descheduled (another
// process wanted its core) holds the caller, waiting for that chunk, for a
// scheduler slice: milliseconds, where a chunk takes microseconds. A wait
// longer than STALL_CHUNKS of the caller's own chunks and STALL_MIN_S is
// taken for that, and the jobs that start in the next STALL_SOLO_S run on
// the caller alone (the same chunks: the same bits), then the helpers
// join again. The matrix-free cantilever_implicit's CG at 2 threads beside
// two processes busy 2 ms / idle 3 ms: step medians 588-619 ms without,
// 509-535 with (1 thread 479-487); a window of 4-64x the stall did less
// (docs/perf.md, eighteenth round). The relative bound keeps a long chunk's
// ordinary wait (a part of a large mesh's product) from counting. Under run.
//
// Only a stall within STALL_REPEAT_S of the one before opens the window: a
// busy core stalls the helpers again and again, while a VM's host also
// takes a core away now and then for 0.1-2.5 ms, and a window after each
// of those sent 50 ms of 2-thread work to one thread for a stall that was
// over (quiet Zen 4 VM: 6-20% of a 2-thread SVD batch's time at the
// 1-thread speed, 0.4-5% with this rule; beside run/sleep load the
// windows still open: docs/perf.md, nineteenth round).
#define STALL_CHUNKS 8
#define STALL_MIN_S 100e-6
#define STALL_SOLO_S 0.05
#define STALL_REPEAT_S 0.1
// wait_from 0: no wait, only the flag.
static void stall_check(double chunk_s, double wait_from) {
  const double end = omp_get_wtime(), waited = wait_from > 0 ? end - wait_from : 0;
  const int flagged = atomic_exchange_explicit(&T.stalled, 0, memory_order_relaxed);
  if (flagged || (waited > STALL_CHUNKS * chunk_s && waited > STALL_MIN_S)) {
    if (T.last_stall > 0 && end - T.last_stall < STALL_REPEAT_S)
      T.solo_until = end + STALL_SOLO_S;
    T.last_stall = end;
  }
}

void ek_team_note_stall(void) { atomic_store_explicit(&T.stalled, 1, memory_order_relaxed); }

// One job of n <= EK_TEAM_MAX_CHUNKS chunks, base + [0, n), under run.
static void job(size_t base, size_t n, int threads, int spin) {
  T.base = base;
  T.n = n;
  atomic_store_explicit(&T.want, threads, memory_order_relaxed);
  atomic_store_explicit(&T.done, 0, memory_order_relaxed);
  // Ranges as OpenMP's static schedule splits a loop (release: a worker
  // that takes a chunk from one sees this job's fn, ctx and base).
  const uint64_t epoch = EPOCH_OF(atomic_load_explicit(&T.claim, memory_order_relaxed)) + 1;
  const int ranged = atomic_load_explicit(&T.ranged, memory_order_relaxed);
  if (ranged)
    for (int r = 0; r < threads; r++)
      atomic_store_explicit(&T.range[r].w,
                            TAG(epoch) | (uint64_t)(n * (size_t)(r + 1) / (size_t)threads) << 24 |
                                n * (size_t)r / (size_t)threads,
                            memory_order_release);
  // The claim word: a new epoch wakes the helpers; no chunk to claim there
  // for ranges.
  atomic_store(&T.claim, epoch << (NEXT_BITS + N_BITS) | (uint64_t)(ranged ? 0 : n) << NEXT_BITS);
  if (atomic_load(&T.sleepers) > 0) {
    pthread_mutex_lock(&T.m);
    pthread_cond_broadcast(&T.wake);
    pthread_mutex_unlock(&T.m);
  }
  const double start = omp_get_wtime();
  const size_t mine = work(0, epoch);
  // Only chunks a helper claimed are left: wait for them.
  if (atomic_load_explicit(&T.done, memory_order_acquire) == n) {
    if (atomic_load_explicit(&T.stalled, memory_order_relaxed))
      stall_check(0, 0);
    return;
  }
  const double wait_from = omp_get_wtime();
  int spins = 0;
  while (spins < spin && atomic_load_explicit(&T.done, memory_order_acquire) != n)
    spins++;
  if (spins == spin) {
    pthread_mutex_lock(&T.m);
    atomic_store(&T.caller_sleeps, 1);
    while (atomic_load(&T.done) != n)
      pthread_cond_wait(&T.idle, &T.m);
    atomic_store(&T.caller_sleeps, 0);
    pthread_mutex_unlock(&T.m);
  }
  stall_check((wait_from - start) / (double)(mine ? mine : 1), wait_from);
}

static void run(size_t n, ek_team_fn *fn, ek_team_worker_fn *wfn, int ranged, void *ctx) {
  const int threads = ek_team_threads();
  if (n <= 1 || threads < 2 || pthread_mutex_trylock(&T.run) != 0) {
    serial(n, fn, wfn, ctx);
    return;
  }
  if (T.solo_until > 0 && omp_get_wtime() < T.solo_until) { // a helper was late (stall_check)
    pthread_mutex_unlock(&T.run);
    serial(n, fn, wfn, ctx);
    return;
  }
  T.solo_until = 0;
  const int helpers = start_helpers(threads - 1);
  if (helpers == 0) {
    pthread_mutex_unlock(&T.run);
    serial(n, fn, wfn, ctx);
    return;
  }
  const int spin = ek_wait_spins(omp_get_max_threads());
  atomic_store_explicit(&T.spin, spin, memory_order_relaxed);
  T.fn = fn;
  T.wfn = wfn;
  T.ctx = ctx;
  atomic_store_explicit(&T.ranged, ranged, memory_order_relaxed);
  // The claim word holds at most EK_TEAM_MAX_CHUNKS: more run as several jobs.
  for (size_t base = 0; base < n; base += EK_TEAM_MAX_CHUNKS)
    job(base, n - base < EK_TEAM_MAX_CHUNKS ? n - base : EK_TEAM_MAX_CHUNKS, threads, spin);
  pthread_mutex_unlock(&T.run);
}

void ek_team_run(size_t n, ek_team_fn *fn, void *ctx) { run(n, fn, NULL, 0, ctx); }

void ek_team_run_ranges(size_t n, ek_team_worker_fn *fn, void *ctx) { run(n, NULL, fn, 1, ctx); }

void ek_team_run_static(size_t n, ek_team_fn *fn, void *ctx) { run(n, fn, NULL, 1, ctx); }
