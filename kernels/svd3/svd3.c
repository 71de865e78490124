// Driver of the SVD and polar kernels: option checks, dispatch once per
// batch, chunks of blocks on the helper team (team.h: the caller never
// waits for a thread that has not started). Built once per precision (EK_P
// names).
#include <ek/svd3.h>
#include <stdint.h>

#include "kernels.h"
#include "real.h"
#include "team.h"

// Default knobs, from the speed/accuracy sweep in README ("Accuracy"):
// McAdams' 4 approximate Jacobi sweeps alone miss the float budget on ~1% of
// random matrices (worst ~6e-3); two approximate sweeps followed by two
// exact one-sided sweeps meet it everywhere and cost fewer operations.
// (svd3_core.h flushes subnormals in the Jacobi sweeps from SVD3_FLUSH_SWEEPS
// = one more than these defaults: keep the two in step.)
#if defined(EK_REAL_F32)
typedef ek_svd3_block_f32_fn svd3_block_fn;
#define BLOCK_FN(t) ((t)->svd3_block_f32)
#define DEFAULT_SWEEPS 2
#define DEFAULT_REFINE 2
#define DEFAULT_EXACT_RSQRT 0 // the estimates of svd3_core.h are enough
#else
typedef ek_svd3_block_f64_fn svd3_block_fn;
#define BLOCK_FN(t) ((t)->svd3_block_f64)
#define DEFAULT_SWEEPS 3
#define DEFAULT_REFINE 2
#define DEFAULT_EXACT_RSQRT 0 // the same (exact anyway on AVX2: no double estimate)
#endif

// Blocks per team chunk (AoSoA), and matrices per AoS work item
// (32 blocks' worth): 32 blocks of 16 float matrices keep A, U, S, V of one
// chunk (~60 KB) in L2.
#define CHUNK_BLOCKS 32

ek_svd3_knobs EK_P(svd3_default_knobs)(void) {
  return (ek_svd3_knobs){
      .sweeps = DEFAULT_SWEEPS, .refine = DEFAULT_REFINE, .exact_rsqrt = DEFAULT_EXACT_RSQRT};
}

int EK_P(svd3_default_sweeps)(void) { return DEFAULT_SWEEPS; }

int EK_P(svd3_default_exact_rsqrt)(void) { return DEFAULT_EXACT_RSQRT; }

int EK_P(svd3_default_refine)(void) { return DEFAULT_REFINE; }

// The one check of the SVD options every entry point shares (ek_svd3_*,
// ek_polar3_*, the FVM force's svd_sweeps / svd_exact_rsqrt / svd_refine),
// then the knobs: the defaults with the non-zero options applied.
int EK_P(svd3_knobs_from)(const char *fn, int sweeps, int exact_rsqrt, int refine,
                          ek_svd3_knobs *k) {
  *k = EK_P(svd3_default_knobs)();
  if (sweeps < 0 || sweeps > EK_SVD3_MAX_SWEEPS) {
    ek_set_error("%s: sweeps = %d, must be 0 (default) or 1..%d", fn, sweeps, EK_SVD3_MAX_SWEEPS);
    return EK_EINVAL;
  }
  if (exact_rsqrt < -1 || exact_rsqrt > 1) {
    ek_set_error("%s: exact_rsqrt = %d, must be 0 (default), 1 (exact) or -1 (approximate)", fn,
                 exact_rsqrt);
    return EK_EINVAL;
  }
  if (refine < EK_SVD3_REFINE_NONE || refine > EK_SVD3_MAX_REFINE) {
    ek_set_error("%s: refine = %d, must be 0 (default), 1..%d or %d (none)", fn, refine,
                 EK_SVD3_MAX_REFINE, EK_SVD3_REFINE_NONE);
    return EK_EINVAL;
  }
  if (sweeps)
    k->sweeps = sweeps;
  if (refine)
    k->refine = refine == EK_SVD3_REFINE_NONE ? 0 : refine;
  if (exact_rsqrt)
    k->exact_rsqrt = exact_rsqrt > 0;
  return EK_OK;
}

static int resolve(const char *fn, const ek_svd3_opts *o, int polar, ek_svd3_knobs *k,
                   svd3_block_fn **block) {
  static const ek_svd3_opts zero_opts;
  if (!o)
    o = &zero_opts;
  int rc = EK_P(svd3_knobs_from)(fn, o->sweeps, o->exact_rsqrt, o->refine, k);
  if (rc < 0)
    return rc;
  k->polar = polar;
  const ek_kernel_table *t = ek_kernels_resolve(o->isa);
  if (!t)
    return EK_EISA;
  *block = BLOCK_FN(t);
  k->chains = t->svd3_chains;
  return EK_OK;
}

// The row's chains (svd3_block.c) on a batch whose arrays fit the caches,
// 2 beyond: measured on Zen 5, 4 chains took 9.0-9.3 ns per matrix against
// 10.2 on a 4096-matrix batch (0.5 MB) but 31-39 ns against 22-27 on 2^20
// matrices (120 MB, AoSoA and AoS alike; docs/perf.md). The bound lies
// between the two measured sizes; 4 MiB (a few L2s, well inside L3) is a
// choice, not a measurement. Same bits either way. (The drivers keep the
// row's chains past it where they stream the outputs: run_blocks, run_aos.)
#define WIDE_MAX_BYTES ((size_t)4 << 20)
static int chains_for(const ek_svd3_knobs *k, size_t matrices) {
  return matrices * 30 * sizeof(real) <= WIDE_MAX_BYTES ? k->chains : 2;
}

// Streaming stores of the outputs (k->nt; AoS, and AoSoA in run_blocks) on
// a batch whose arrays pass this many bytes: nothing of a batch that size
// is still in the caches when the call returns (32 MiB: Zen 5's L3 per
// CCD; a choice, not a measurement), so its outputs would only have been
// read from memory before being overwritten (write-allocate: 84 B more per
// f32 matrix on top of its 120) and evicted again. Each output array is
// streamed only where its vectors start on 64 bytes (AoS: after the head,
// ek_aos_head; a chunk and a vector are whole lines). With all of them streamed, the
// kernel keeps its row's chains (4 on Zen 5): the 4-chain loop's spills
// no longer queue behind stores that miss. Zen 5, AVX-512 f32 default,
// 2^20 matrices, 1 thread, process CPU time on a busy machine, 30 rounds
// interleaved, min / median ns per matrix: plain stores 2 chains 11.36 /
// 11.62, 4 chains 14.16 / 14.40; streamed 2 chains 11.43 / 11.68, 4
// chains 10.38 / 10.55 (docs/perf.md). Same bits.
#define NT_MIN_BYTES ((size_t)32 << 20)
static int aligned64(const void *p) { return (uintptr_t)p % 64 == 0; }
static int nt_for(size_t n, const real *U, const real *S, const real *V) {
  if (n * 30 * sizeof(real) <= NT_MIN_BYTES)
    return 0;
  return (U && aligned64(U) ? EK_SVD3_NT_U : 0) | (V && aligned64(V) ? EK_SVD3_NT_V : 0) |
         (S && aligned64(S) ? EK_SVD3_NT_S : 0);
}

// AoSoA path: chains_for's 2 chains on a batch beyond the caches, unless
// the row takes more (svd3_chains: AVX2 on Zen 4, AVX-512 on Zen 5) and
// all outputs can be streamed (past NT_MIN_BYTES, U, S, V / R, Ssym on 64
// bytes: every vector of a block plane is then aligned). Then they are
// streamed, in line order (svd3_put_lines), and the row's chains kept, as
// in run_aos: the 4-chain loop no longer waits for stores that miss. Zen 4
// (2 cores, shared), 2^20 f32 / 2^18 f64 matrices, AVX2, 1 thread, process
// CPU time, medians of 4 rounds' least calls, ns per matrix, plain 2
// chains -> streamed 4 chains: SVD f32 24.6 -> 22.4, f64 79.9 -> 68.5,
// polar f32 26.1 -> 23.3, f64 83.2 -> 71.4 (4096-matrix calls: 20.7 and
// 66.3). Streaming at 2 chains paid nothing (AVX2 f32 26.5 against 26.1;
// AVX-512 f32 17.9 against 17.4, polar 18.9 against 17.6 in a quiet
// spell), so the rows that keep 2 chains keep their plain stores
// (docs/perf.md, "Memory-bound paths", tenth round). Same bits.
typedef struct {
  svd3_block_fn *block;
  size_t n; // blocks (AoSoA) or matrices (AoS)
  const real *A;
  real *U, *S, *V;
  const ek_svd3_knobs *k;
} batch_job;

static void blocks_chunk(void *ctx, size_t c, int worker) {
  (void)worker;
  const batch_job *j = ctx;
  size_t b0 = c * CHUNK_BLOCKS, nb = j->n - b0 < CHUNK_BLOCKS ? j->n - b0 : CHUNK_BLOCKS;
  j->block(nb, j->A + b0 * 9 * EK_LANES, j->U + b0 * 9 * EK_LANES,
           j->S ? j->S + b0 * 3 * EK_LANES : NULL, j->V ? j->V + b0 * 9 * EK_LANES : NULL, j->k);
}

static void run_blocks(svd3_block_fn *block, size_t nblocks, const real *A, real *U, real *S,
                       real *V, const ek_svd3_knobs *kin) {
  size_t nchunks = (nblocks + CHUNK_BLOCKS - 1) / CHUNK_BLOCKS;
  ek_svd3_knobs kb = *kin;
  kb.chains = chains_for(kin, nblocks * EK_LANES);
  const int all = EK_SVD3_NT_U | (V ? EK_SVD3_NT_V : 0) | (S ? EK_SVD3_NT_S : 0);
  if (kb.chains < kin->chains && nt_for(nblocks * EK_LANES, U, S, V) == all)
    kb.nt = all, kb.chains = kin->chains;
  batch_job j = {block, nblocks, A, U, S, V, &kb};
  ek_team_run_ranges(nchunks, blocks_chunk, &j);
}

// AoS path: the kernel reads and writes the AoS arrays itself, transposing
// in registers (svd3_block.c, k->aos), so nothing is staged or copied.
// Chunks of whole blocks (a multiple of EK_W): every vector of a chunk is
// full except at the very end of the batch and in the head (ek_aos_head).
static void aos_chunk(void *ctx, size_t c, int worker) {
  (void)worker;
  const batch_job *j = ctx;
  const size_t chunk = (size_t)CHUNK_BLOCKS * EK_LANES;
  size_t i0 = c * chunk, m = j->n - i0 < chunk ? j->n - i0 : chunk;
  j->block(m, j->A + 9 * i0, j->U ? j->U + 9 * i0 : NULL, j->S ? j->S + 3 * i0 : NULL,
           j->V ? j->V + 9 * i0 : NULL, j->k);
}

static int run_aos(svd3_block_fn *block, size_t n, const real *A, real *U, real *S, real *V,
                   const ek_svd3_knobs *k) {
  ek_svd3_knobs ka = *k;
  ka.aos = 1;
  ka.chains = chains_for(k, n);
  // The first output's lines decide the head (ek_aos_head; the others,
  // allocated alike, usually share them).
  const void *first = U ? (const void *)U : V ? (const void *)V : (const void *)A;
  const size_t head = ek_aos_head(first, 9 * sizeof(real), n);
  if (head)
    block(head, A, U, S && !k->polar ? S : NULL, V, &ka);
  A += 9 * head, n -= head;
  U = U ? U + 9 * head : NULL, V = V ? V + 9 * head : NULL, S = S ? S + 3 * head : NULL;
  // S is not written in polar mode (nor streamed).
  const real *Sw = k->polar ? NULL : S;
  ka.nt = nt_for(n, U, Sw, V);
  const int all = (U ? EK_SVD3_NT_U : 0) | (V ? EK_SVD3_NT_V : 0) | (Sw ? EK_SVD3_NT_S : 0);
  if (ka.nt && ka.nt == all)
    ka.chains = k->chains;
  const size_t chunk = (size_t)CHUNK_BLOCKS * EK_LANES;
  size_t nchunks = (n + chunk - 1) / chunk;
  batch_job j = {block, n, A, U, S && !k->polar ? S : NULL, V, &ka};
  ek_team_run_ranges(nchunks, aos_chunk, &j);
  return EK_OK;
}

int EK_P(svd3)(size_t n, const real *A, real *U, real *S, real *V, const ek_svd3_opts *opts) {
  ek_svd3_knobs k;
  svd3_block_fn *block;
  int rc = resolve("ek_svd3", opts, 0, &k, &block);
  if (rc)
    return rc;
  if (n && (!A || !S)) {
    ek_set_error("ek_svd3: A and S must not be NULL (n = %zu)", n);
    return EK_EINVAL;
  }
  if ((rc =
           ek_batch_check("ek_svd3", n, 9 * sizeof(real), _Alignof(real), 4,
                          (const void *[]){A, U, S, V}, (const char *const[]){"A", "U", "S", "V"})))
    return rc;
  return n ? run_aos(block, n, A, U, S, V, &k) : EK_OK;
}

int EK_P(svd3_aosoa)(size_t nblocks, const real *A, real *U, real *S, real *V,
                     const ek_svd3_opts *opts) {
  ek_svd3_knobs k;
  svd3_block_fn *block;
  int rc = resolve("ek_svd3_aosoa", opts, 0, &k, &block);
  if (rc)
    return rc;
  if (nblocks && (!A || !U || !S || !V)) {
    ek_set_error("ek_svd3_aosoa: A, U, S, V must not be NULL (nblocks = %zu)", nblocks);
    return EK_EINVAL;
  }
  if ((rc =
           ek_batch_check("ek_svd3_aosoa", nblocks, 9 * EK_LANES * sizeof(real), _Alignof(real), 4,
                          (const void *[]){A, U, S, V}, (const char *const[]){"A", "U", "S", "V"})))
    return rc;
  run_blocks(block, nblocks, A, U, S, V, &k);
  return EK_OK;
}

int EK_P(polar3)(size_t n, const real *A, real *R, real *Ssym, const ek_svd3_opts *opts) {
  ek_svd3_knobs k;
  svd3_block_fn *block;
  int rc = resolve("ek_polar3", opts, 1, &k, &block);
  if (rc)
    return rc;
  if (n && (!A || !R)) {
    ek_set_error("ek_polar3: A and R must not be NULL (n = %zu)", n);
    return EK_EINVAL;
  }
  if ((rc = ek_batch_check("ek_polar3", n, 9 * sizeof(real), _Alignof(real), 3,
                           (const void *[]){A, R, Ssym}, (const char *const[]){"A", "R", "Ssym"})))
    return rc;
  return n ? run_aos(block, n, A, R, NULL, Ssym, &k) : EK_OK;
}

int EK_P(polar3_aosoa)(size_t nblocks, const real *A, real *R, real *Ssym,
                       const ek_svd3_opts *opts) {
  ek_svd3_knobs k;
  svd3_block_fn *block;
  int rc = resolve("ek_polar3_aosoa", opts, 1, &k, &block);
  if (rc)
    return rc;
  if (nblocks && (!A || !R)) {
    ek_set_error("ek_polar3_aosoa: A and R must not be NULL (nblocks = %zu)", nblocks);
    return EK_EINVAL;
  }
  if ((rc = ek_batch_check("ek_polar3_aosoa", nblocks, 9 * EK_LANES * sizeof(real), _Alignof(real),
                           3, (const void *[]){A, R, Ssym},
                           (const char *const[]){"A", "R", "Ssym"})))
    return rc;
  run_blocks(block, nblocks, A, R, NULL, Ssym, &k);
  return EK_OK;
}
