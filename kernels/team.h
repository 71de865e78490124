// Internal: a team of helper threads that run fixed chunks claimed from a
// counter, for the passes that must stay fast when a core is busy: the
// explicit loop's FVM force and integration, the cloth force, the cloth
// XPBD sweep, the implicit loop's matrix-free CG, and (sixteenth round) the
// public batch drivers: the SVD and polar batches (svd3.c, AoSoA and AoS),
// the warm polar batches (polar.c), material_eval (material.c, AoSoA and
// AoS), the staged AoS<->AoSoA chunks (batch/aosoa.c) and the FVM force's
// per-tet F (fvm.c). A user's process then has one pool, not libgomp's and
// this one spinning against each other.
//
// Why not an OpenMP region: a region's end is a barrier, so the thread that
// called it waits for every team thread to arrive, and a thread that the
// machine has descheduled (another process holds its core) arrives when it
// is given the core again, milliseconds later. Here the caller waits only
// for the chunks a helper has claimed and is running: a helper that has not
// woken yet, or whose core is busy, claims nothing, and the caller runs the
// chunks itself. A chunk does the same work whoever runs it, so the results
// have the same bits at any thread count and any timing.
#ifndef EK_TEAM_H
#define EK_TEAM_H

#include <stddef.h>

// Work of chunk i of a job.
typedef void ek_team_fn(void *ctx, size_t i);

// Runs fn(ctx, i) once for every i in [0, n), in claim order (increasing i)
// on the calling thread and on up to omp_get_max_threads() - 1 helper
// threads, and returns once every chunk is done (what the chunks wrote is
// then visible to the caller). Runs everything on the calling thread when
// n <= 1, at 1 thread, inside an OpenMP parallel region, or while another
// thread's job runs. More than EK_TEAM_MAX_CHUNKS chunks (the claim word's
// count) run as several jobs, one after the other.
#define EK_TEAM_MAX_CHUNKS ((size_t)1 << 19)
void ek_team_run(size_t n, ek_team_fn *fn, void *ctx);

// Work of chunk i on worker `worker`: 0 for the calling thread, 1 ..
// ek_team_threads() - 1 for the helpers; a worker runs one chunk at a time,
// so per-worker scratch (staging buffers) needs no lock.
typedef void ek_team_worker_fn(void *ctx, size_t i, int worker);

// The workers an ek_team_run* called now from this thread may use: 1 inside
// an OpenMP parallel region, else omp_get_max_threads() (at most 64).
int ek_team_threads(void);

// ek_team_run, passing each chunk its worker (0 for every chunk where it
// runs on the calling thread alone), and with the chunks split as OpenMP's
// static schedule splits a loop: worker w runs the w-th of
// ek_team_threads() contiguous ranges from its front, then takes chunks
// from the backs of the others' ranges (those of a helper that has not
// started, or whose core is busy). While both cores are free a chunk runs
// on the same core call after call, so a batch that fits the L2s stays in
// them (one claim word shared by all moved the chunks between the cores);
// each claim is on the worker's own line.
void ek_team_run_ranges(size_t n, ek_team_worker_fn *fn, void *ctx);

// ek_team_run with ek_team_run_ranges' split (a chunk on the same core call
// after call while both cores are free), for passes whose chunks need no
// order among themselves and no per-worker scratch.
void ek_team_run_static(size_t n, ek_team_fn *fn, void *ctx);

// Checks a wait spins before it sleeps, for `threads` threads: 2^20 (~1 ms,
// about libgomp's own spin), 2^8 with more threads than processors (a
// spinning thread may hold the core of the one it waits for) or
// OMP_WAIT_POLICY=passive (read once, as libgomp does), where libgomp
// sleeps almost at once too. The team's waits and xpbd.c's sweeps_flow.
int ek_wait_spins(int threads);

// For a chunk whose wait for another chunk outlasted a scheduler slice (the
// thread it waited for was off its core: xpbd.c's flow): counted as a
// stall, as the caller's own wait for a late helper is (team.c,
// stall_check); a stall within 0.1 s of the one before makes the jobs that
// start in the next 50 ms run on the calling thread alone. Any thread may
// call it during a job; called between jobs, it counts at the end of the
// next job handed to the helpers. tests/test_team.c checks that the jobs
// started inside the window ran on the caller alone, and kernels' bits
// with the window open.
void ek_team_note_stall(void);

// ek_team_run where parallel, else the chunks in order on this thread.
static inline void ek_team_run_if(int parallel, size_t n, ek_team_fn *fn, void *ctx) {
  if (parallel)
    ek_team_run(n, fn, ctx);
  else
    for (size_t i = 0; i < n; i++)
      fn(ctx, i);
}

// ek_team_run_ranges where parallel, else the chunks in order on this
// thread (worker 0).
static inline void ek_team_run_ranges_if(int parallel, size_t n, ek_team_worker_fn *fn, void *ctx) {
  if (parallel)
    ek_team_run_ranges(n, fn, ctx);
  else
    for (size_t i = 0; i < n; i++)
      fn(ctx, i, 0);
}

// ek_team_run_static where parallel, else the chunks in order on this thread.
static inline void ek_team_run_static_if(int parallel, size_t n, ek_team_fn *fn, void *ctx) {
  if (parallel)
    ek_team_run_static(n, fn, ctx);
  else
    for (size_t i = 0; i < n; i++)
      fn(ctx, i);
}

#endif
