// claim_team.h: phases of fixed chunks claimed from an atomic counter.
#include "claim_team.h"

#include <omp.h>
#include <stdlib.h>
#include <strings.h>
#include <time.h>

#define GEN(v) ((v) >> 48)
#define COUNT(v) (((v) >> 24) & 0xffffff)
#define NEXT(v) ((v)&0xffffff)
#define BACKOFF_MIN 64
#define BACKOFF_MAX 65536
#define CALM_PHASES 256

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int claim_team_init(claim_team *t) {
  atomic_init(&t->state, 0);
  atomic_init(&t->done, 0);
  atomic_init(&t->quit, 0);
  atomic_init(&t->sleepers, 0);
  t->fn = NULL;
  t->ctx = NULL;
  t->gen0 = 0;
  t->spin = 0;
  t->solo = 0;
  t->backoff = BACKOFF_MIN;
  t->calm = 0;
  if (pthread_mutex_init(&t->mutex, NULL))
    return -1;
  if (pthread_cond_init(&t->cond, NULL)) {
    pthread_mutex_destroy(&t->mutex);
    return -1;
  }
  return 0;
}

void claim_team_destroy(claim_team *t) {
  pthread_cond_destroy(&t->cond);
  pthread_mutex_destroy(&t->mutex);
}

void claim_team_begin(claim_team *t) {
  // Spin 2^16 checks (~65 us: longer than the driver's serial work
  // between passes, far shorter than a scheduler slice), then sleep; 2^8
  // with OMP_WAIT_POLICY=passive or more threads than processors. 2^20
  // (~1 ms, libgomp's and the XPBD sweep's spin) kept the worker spinning
  // through the driver's solo phases: with other processes busy, 2-thread
  // steps took twice the 1-thread time (cantilever_implicit, load 6-7 on
  // 2 cores: 2.0-2.3 s against 0.96-1.03 s; 2^8-2^16: 0.75-1.15 s).
  const char *policy = getenv("OMP_WAIT_POLICY");
  const int passive = policy && strcasecmp(policy, "passive") == 0;
  t->spin = passive || omp_get_max_threads() > omp_get_num_procs() ? 1 << 8 : 1 << 16;
  t->gen0 = GEN(atomic_load(&t->state));
  atomic_store(&t->quit, 0);
}

static void wake(claim_team *t) {
  if (atomic_load(&t->sleepers) > 0) {
    pthread_mutex_lock(&t->mutex);
    pthread_cond_broadcast(&t->cond);
    pthread_mutex_unlock(&t->mutex);
  }
}

// Claims and runs chunks of phase g until none is left (or the phase has
// changed); returns the longest chunk's time where timed. fn and ctx are
// read after a successful claim: the driver rewrites them only once every
// chunk of the phase has finished, this one included (its done count
// comes after).
static double claim_chunks(claim_team *t, uint64_t g, int timed) {
  uint64_t v = atomic_load(&t->state);
  double longest = 0;
  while (GEN(v) == g && NEXT(v) < COUNT(v)) {
    if (!atomic_compare_exchange_weak(&t->state, &v, v + 1))
      continue; // v reloaded
    const double t0 = timed ? now() : 0;
    t->fn(t->ctx, (size_t)NEXT(v));
    if (timed && now() - t0 > longest)
      longest = now() - t0;
    atomic_fetch_add(&t->done, 1);
    wake(t);
    v = atomic_load(&t->state);
  }
  return longest;
}

// sleepers and the awaited values are sequentially consistent: either the
// waiter sees the new value or the writer sees the sleeper, whose wait has
// begun by the time the writer holds the mutex (as xpbd.c's wait_done).
static void wait_done(claim_team *t, size_t n) {
  for (int s = 0; s < t->spin; s++)
    if (atomic_load_explicit(&t->done, memory_order_acquire) >= n)
      return;
  pthread_mutex_lock(&t->mutex);
  atomic_fetch_add(&t->sleepers, 1);
  while (atomic_load(&t->done) < n)
    pthread_cond_wait(&t->cond, &t->mutex);
  atomic_fetch_sub(&t->sleepers, 1);
  pthread_mutex_unlock(&t->mutex);
}

void claim_team_run(claim_team *t, claim_chunk_fn *fn, void *ctx, size_t n, int shared) {
  if (shared && n >= 2 && t->solo > 0)
    t->solo--;
  else if (shared && n >= 2 && n < CLAIM_TEAM_MAX_CHUNKS) {
    t->fn = fn;
    t->ctx = ctx;
    atomic_store(&t->done, 0);
    const uint64_t g = (GEN(atomic_load(&t->state)) + 1) & 0xffff;
    atomic_store(&t->state, g << 48 | (uint64_t)n << 24);
    wake(t);
    const double longest = claim_chunks(t, g, 1), t0 = now();
    wait_done(t, n);
    // A stall: the wait outlasted twice the driver's longest chunk by 0.5
    // ms (a scheduler slice is milliseconds; chunks differ by less).
    if (now() - t0 > 2 * longest + 5e-4) {
      t->solo = t->backoff;
      t->backoff = t->backoff < BACKOFF_MAX ? 2 * t->backoff : BACKOFF_MAX;
      t->calm = 0;
    } else if (++t->calm >= CALM_PHASES)
      t->backoff = BACKOFF_MIN;
    return;
  }
  for (size_t c = 0; c < n; c++)
    fn(ctx, c);
}

void claim_team_end(claim_team *t) {
  atomic_store(&t->quit, 1);
  wake(t);
}

void claim_team_serve(claim_team *t) {
  uint64_t seen = t->gen0;
  for (;;) {
    uint64_t v = atomic_load(&t->state);
    for (int s = 0; GEN(v) == seen && !atomic_load(&t->quit); s++) {
      if (s == t->spin) {
        pthread_mutex_lock(&t->mutex);
        atomic_fetch_add(&t->sleepers, 1);
        while (GEN(atomic_load(&t->state)) == seen && !atomic_load(&t->quit))
          pthread_cond_wait(&t->cond, &t->mutex);
        atomic_fetch_sub(&t->sleepers, 1);
        pthread_mutex_unlock(&t->mutex);
      }
      v = atomic_load(&t->state);
    }
    if (GEN(v) == seen)
      return; // quit, and no new phase
    seen = GEN(v);
    claim_chunks(t, seen, 0);
  }
}
