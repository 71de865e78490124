// A team of OpenMP threads in which no thread waits for one that has not
// started: the driver (thread 0) runs phases of fixed chunks, each chunk
// claimed from an atomic counter by whichever thread gets it first, and
// waits only for chunks already claimed (by a thread that is running
// them). A worker descheduled by another process (a shared machine) costs
// the phase nothing: the driver runs its chunks. A fork/join per phase
// instead (omp parallel for) waits at every join for every thread, one
// scheduler slice each when a core is busy (sim/README.md, fifteenth
// round). A chunk's result must not depend on which thread runs it, so the
// bits do not depend on the thread count.
//
// Use, one team per caller (not reentrant):
//   claim_team_begin(t);
//   #pragma omp parallel
//   if (omp_get_thread_num() == 0) { ... claim_team_run(t, ...) ...;
//                                    claim_team_end(t); }
//   else claim_team_serve(t);
#ifndef EK_SIM_CLAIM_TEAM_H
#define EK_SIM_CLAIM_TEAM_H

#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

typedef void claim_chunk_fn(void *ctx, size_t chunk);

typedef struct {
  // The phase: generation (16 bits), chunk count (24), next chunk (24).
  _Atomic uint64_t state;
  atomic_size_t done; // the phase's chunks finished
  atomic_int quit;
  atomic_int sleepers; // threads waiting on cond
  claim_chunk_fn *fn;  // the phase's, written by the driver before state
  void *ctx;
  uint64_t gen0; // the generation at claim_team_begin
  int spin;      // checks before a wait sleeps
  // Backing off (driver only): phases still to run on the driver alone
  // after a stall, the next back-off, the stall-free phases since.
  long solo, backoff, calm;
  pthread_mutex_t mutex;
  pthread_cond_t cond;
} claim_team;

// Chunk counts of a phase below this (2^24).
#define CLAIM_TEAM_MAX_CHUNKS ((size_t)1 << 24)

int claim_team_init(claim_team *t); // 0, or -1 (pthread)
void claim_team_destroy(claim_team *t);
void claim_team_begin(claim_team *t); // before the region
// Driver: chunks [0, n) of fn; shared 0: the driver runs them all itself
// (small work, no wake-up). Returns when every chunk has finished. A
// phase whose end waited for a claimed chunk much longer than the
// driver's own chunks took (its thread was descheduled mid-chunk: the
// machine is busy) makes the next phases run on the driver alone, 64 at
// first, twice as many after each such stall (up to 2^16), back to 64
// after 256 shared phases without one.
void claim_team_run(claim_team *t, claim_chunk_fn *fn, void *ctx, size_t n, int shared);
void claim_team_end(claim_team *t);   // driver: releases the workers
void claim_team_serve(claim_team *t); // workers: until claim_team_end

#endif
