// Internal: the scatter strategies of ek_scatter (include/ek/fvm.h), shared
// by every kernel that sums per-tet corner values into vertices: the FVM
// force (fvm.c) and the Hessian passes (hessian.c). A job names a range
// function over AoSoA blocks of the strategy's slot order; the strategy
// decides which thread adds what where. Built once per
// precision (real.h).
//
// Determinism: COLORED, THREAD_BUFFERS and GATHER sum every vertex's
// contributions in an order fixed by the mesh alone (phase, chunk and slot
// order; part order with EK_FVM_PARTS fixed parts; slot order), so the
// result has the same bits for any thread count. ATOMIC does not.
#ifndef EK_FVM_SCATTER_H
#define EK_FVM_SCATTER_H

#include <ek/fvm.h>

#include "../elements/tets.h"
#include "../real.h"

// Blocks [b0, b1) of the job's slot order: either add each tet's corner
// values straight into out (nverts x ncomp, caller vertex order; the
// strategy guarantees no other thread touches those vertices), or, when
// corner != NULL, write them to corner[(b * 4 * ncomp + c * ncomp + i) * L
// + l] (corner c, component i, lane l) and leave out alone.
typedef void scatter_range_fn(const void *ctx, size_t b0, size_t b1, real *out, real *corner);

typedef struct {
  const ek_tets *el;
  ek_scatter strategy; // resolved: not AUTO
  int ncomp;           // values per vertex: 3 (a force) or 6 (a symmetric 3x3 block)
  int parallel;        // 0: run on the calling thread alone
  scatter_range_fn *range;
  const void *ctx;
  // Floats per vertex in THREAD_BUFFERS' buffers (what the range function
  // adds into there): ncomp (0 says so too), or 4 for ncomp 3, rows padded
  // so that a target can add a row with one 16-byte load and store
  // (fvm_tet.h, tet_scatter_block_rows4; fvm.c chooses). The other
  // strategies add into out, rows of ncomp.
  int buf_stride;
} scatter_job;

// out (nverts x ncomp) = the sum of the job's corner values; overwritten.
// Every strategy runs on the helper team (kernels/team.h: the caller never
// waits for a thread that has not started). EK_OK or EK_ENOMEM (scratch
// buffers).
int EK_P(scatter_run)(const scatter_job *job, real *out);

// The slot order a strategy runs over: the coloured one for COLORED, the
// Morton one for the others.
static inline const ek_tet_blocks *scatter_blocks(const ek_tets *el, ek_scatter s) {
  return s == EK_SCATTER_COLORED ? &el->colored : &el->morton;
}

// Scratch reused across calls from one calling thread (kernels are called
// every step; allocating and faulting in tens of MB each time would cost
// more than the kernel). Grows, never shrinks. Slots 0 and 1 belong to
// scatter_run; callers use slots from SCATTER_SCRATCH_FREE on.
#define SCATTER_SCRATCH_FREE 2
#define SCATTER_SCRATCH_SLOTS 5
real *EK_P(scratch_get)(int which, size_t bytes);

// Contiguous share [*lo, *hi) of [b0, b1) for thread t of nt.
static inline void scatter_share(size_t b0, size_t b1, int t, int nt, size_t *lo, size_t *hi) {
  size_t n = b1 - b0;
  *lo = b0 + n * (size_t)t / (size_t)nt;
  *hi = b0 + n * (size_t)(t + 1) / (size_t)nt;
}

#endif
