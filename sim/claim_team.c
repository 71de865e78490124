// claim_team.h: phases of fixed chunks claimed from an atomic counter.
#include "claim_team.h"

#include <omp.h>
#include <stdlib.h>
#include <strings.h>

#define GEN(v) ((v) >> 48)
#define COUNT(v) (((v) >> 24) & 0xffffff)
#define NEXT(v) ((v)&0xffffff)

int claim_team_init(claim_team *t) {
  atomic_init(&t->state, 0);
  atomic_init(&t->done, 0);
  atomic_init(&t->quit, 0);
  atomic_init(&t->sleepers, 0);
  t->fn = NULL;
  t->ctx = NULL;
  t->gen0 = 0;
  t->spin = 0;
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
  // As the XPBD sweep's waits (kernels/xpbd/xpbd.c, wait_done): spin ~1 ms
  // (2^20 checks, about libgomp's barrier), then sleep; almost at once
  // with OMP_WAIT_POLICY=passive or more threads than processors.
  const char *policy = getenv("OMP_WAIT_POLICY");
  const int passive = policy && strcasecmp(policy, "passive") == 0;
  t->spin = passive || omp_get_max_threads() > omp_get_num_procs() ? 1 << 8 : 1 << 20;
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
// changed). fn and ctx are read after a successful claim: the driver
// rewrites them only once every chunk of the phase has finished, this one
// included (its done count comes after).
static void claim_chunks(claim_team *t, uint64_t g) {
  uint64_t v = atomic_load(&t->state);
  while (GEN(v) == g && NEXT(v) < COUNT(v)) {
    if (!atomic_compare_exchange_weak(&t->state, &v, v + 1))
      continue; // v reloaded
    t->fn(t->ctx, (size_t)NEXT(v));
    atomic_fetch_add(&t->done, 1);
    wake(t);
    v = atomic_load(&t->state);
  }
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
  if (!shared || n < 2 || n >= CLAIM_TEAM_MAX_CHUNKS) {
    for (size_t c = 0; c < n; c++)
      fn(ctx, c);
    return;
  }
  t->fn = fn;
  t->ctx = ctx;
  atomic_store(&t->done, 0);
  const uint64_t g = (GEN(atomic_load(&t->state)) + 1) & 0xffff;
  atomic_store(&t->state, g << 48 | (uint64_t)n << 24);
  wake(t);
  claim_chunks(t, g);
  wait_done(t, n);
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
    claim_chunks(t, seen);
  }
}
