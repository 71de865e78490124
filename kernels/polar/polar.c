// Driver of the warm-started polar kernel (include/ek/polar.h): option
// checks, dispatch once per batch, chunks of blocks on the helper team
// (team.h). Built once per precision (EK_P names).
#include <ek/polar.h>

#include "kernels.h"
#include "real.h"
#include "team.h"

// Default iterations, from the error sweep in README ("Warm-started
// polar"): from a guess within 10 degrees, two Newton steps leave < 1e-6
// (f32 rounding) and three leave ~1e-15 (f64).
#if defined(EK_REAL_F32)
typedef ek_polar_warm_block_f32_fn polar_warm_block_fn;
#define BLOCK_FN(t) ((t)->polar_warm_block_f32)
#define AOS_FN(t) ((t)->polar_warm_aos_f32)
#define DEFAULT_ITERATIONS 2
#else
typedef ek_polar_warm_block_f64_fn polar_warm_block_fn;
#define BLOCK_FN(t) ((t)->polar_warm_block_f64)
#define AOS_FN(t) ((t)->polar_warm_aos_f64)
#define DEFAULT_ITERATIONS 3
#endif

// Blocks per work item and per AoS staging chunk (as the SVD driver).
#define CHUNK_BLOCKS 32

int EK_P(polar_warm_default_iterations)(void) { return DEFAULT_ITERATIONS; }

int EK_P(polar_warm_iterations_from)(const char *fn, int iterations, int *out) {
  if (iterations < 0 || iterations > EK_POLAR_WARM_MAX_ITERATIONS) {
    ek_set_error("%s: polar iterations = %d, must be 0 (default) or 1..%d", fn, iterations,
                 EK_POLAR_WARM_MAX_ITERATIONS);
    return EK_EINVAL;
  }
  *out = iterations ? iterations : DEFAULT_ITERATIONS;
  return EK_OK;
}

// The table's AoSoA block kernel, or its AoS kernel (aos = 1).
static int resolve(const char *fn, const ek_polar_warm_opts *o, int aos, int *iters,
                   polar_warm_block_fn **block) {
  static const ek_polar_warm_opts zero_opts;
  if (!o)
    o = &zero_opts;
  int rc = EK_P(polar_warm_iterations_from)(fn, o->iterations, iters);
  if (rc < 0)
    return rc;
  const ek_kernel_table *t = ek_kernels_resolve(o->isa);
  if (!t)
    return EK_EISA;
  *block = aos ? AOS_FN(t) : BLOCK_FN(t);
  return EK_OK;
}

typedef struct {
  polar_warm_block_fn *block;
  size_t n; // blocks (AoSoA) or matrices (AoS)
  const real *A;
  real *R;
  int iters;
} warm_job;

static void blocks_chunk(void *ctx, size_t c, int worker) {
  (void)worker;
  const warm_job *j = ctx;
  size_t b0 = c * CHUNK_BLOCKS, nb = j->n - b0 < CHUNK_BLOCKS ? j->n - b0 : CHUNK_BLOCKS;
  j->block(nb, j->A + b0 * 9 * EK_LANES, j->R + b0 * 9 * EK_LANES, j->iters);
}

static void aos_chunk(void *ctx, size_t c, int worker) {
  (void)worker;
  const warm_job *j = ctx;
  const size_t chunk = (size_t)CHUNK_BLOCKS * EK_LANES;
  size_t i0 = c * chunk, m = j->n - i0 < chunk ? j->n - i0 : chunk;
  j->block(m, j->A + 9 * i0, j->R + 9 * i0, j->iters);
}

int EK_P(polar3_warm_aosoa)(size_t nblocks, const real *A, real *R,
                            const ek_polar_warm_opts *opts) {
  static const char *fn = "ek_polar3_warm_aosoa";
  int iters;
  polar_warm_block_fn *block;
  int rc = resolve(fn, opts, 0, &iters, &block);
  if (rc)
    return rc;
  if (nblocks && (!A || !R)) {
    ek_set_error("%s: A and R must not be NULL (nblocks = %zu)", fn, nblocks);
    return EK_EINVAL;
  }
  if ((rc = ek_batch_check(fn, nblocks, 9 * EK_LANES * sizeof(real), _Alignof(real), 2,
                           (const void *[]){A, R}, (const char *const[]){"A", "R"})))
    return rc;
  warm_job j = {block, nblocks, A, R, iters};
  ek_team_run_ranges((nblocks + CHUNK_BLOCKS - 1) / CHUNK_BLOCKS, blocks_chunk, &j);
  return EK_OK;
}

// AoS: the kernel reads and writes the AoS arrays itself, transposing in
// registers (polar_warm_block.c, polar_warm_aos), as the SVD's AoS path
// does: packing A and R into staging blocks and unpacking R cost more than
// the kernel (13.6 ns against 4.0 per f32 matrix on a cache-resident batch,
// Xeon, 1 thread: issue 27). Chunks of CHUNK_BLOCKS blocks' worth of
// matrices per work item; the same bits per matrix as the AoSoA path.
int EK_P(polar3_warm)(size_t n, const real *A, real *R, const ek_polar_warm_opts *opts) {
  static const char *fn = "ek_polar3_warm";
  int iters;
  polar_warm_block_fn *aos;
  int rc = resolve(fn, opts, 1, &iters, &aos);
  if (rc)
    return rc;
  if (n && (!A || !R)) {
    ek_set_error("%s: A and R must not be NULL (n = %zu)", fn, n);
    return EK_EINVAL;
  }
  if ((rc = ek_batch_check(fn, n, 9 * sizeof(real), _Alignof(real), 2, (const void *[]){A, R},
                           (const char *const[]){"A", "R"})))
    return rc;
  // The output's lines decide the head (ek_aos_head); A, allocated alike,
  // usually shares them.
  const size_t head = ek_aos_head(R, 9 * sizeof(real), n);
  if (head)
    aos(head, A, R, iters);
  A += 9 * head, R += 9 * head, n -= head;
  const size_t chunk = (size_t)CHUNK_BLOCKS * EK_LANES;
  warm_job j = {aos, n, A, R, iters};
  ek_team_run_ranges((n + chunk - 1) / chunk, aos_chunk, &j);
  return EK_OK;
}
