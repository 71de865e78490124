// The ek-bench family API: how a benchmark family (bench/bench_<family>.c)
// declares its rows to the ek-bench program (bench/ek_bench.c).
//
// A family is one function `int bench_<family>(ek_bench *b)`. Adding one:
//   1. write bench/bench_<family>.c and add it to EK_BENCH_FAMILY_SOURCES
//      (bench/CMakeLists.txt),
//   2. add its prototype and one line `{"<family>", bench_<family>}` to the
//      family table in bench/ek_bench.c.
//
// ek-bench calls every family twice: first in a listing pass (to count the
// rows for the progress line, or to print them under --list), then in the
// timing pass. A family must declare the same rows in both passes; in the
// listing pass ek_bench_run only records the name, so a family should skip
// expensive setup (big allocations, input generation) when
// ek_bench_listing(b) is true. ek_bench_wants(b, name) tells whether the
// --filter and --threads options select a row, so a family can also skip
// the setup of rows nobody asked for.
//
// Row names are '/'-separated, most general first, with knobs as key:value
// and the thread count last, e.g. "svd3/aosoa/avx2/f32/sweeps:4/threads:2".
// The harness derives the 2-thread / 1-thread ratio by looking up the same
// name with "threads:1", so keep "/threads:N" as the last component.
//
// Usage in a family (sketch):
//   for each isa in ek_bench_isas(b, isas) and each threads in
//   ek_bench_thread_counts(b, counts):
//     snprintf(name, sizeof name, "svd3/aosoa/%s/f32/threads:%d", ...);
//     if (!ek_bench_wants(b, name)) continue;
//     if (!ek_bench_listing(b)) { ...set up ctx, check the kernel's rc... }
//     ek_bench_row row = {.name = name, .family = "svd3", .isa = isa, ...};
//     ek_bench_run(b, &row);
#ifndef EK_BENCH_BENCH_H
#define EK_BENCH_BENCH_H

#include <ek/core.h>
#include <stddef.h>

#include "check.h" // ek_rng
#include "timer.h"

#ifdef __cplusplus
extern "C" {
#endif

// The run: options, filter, machine limits, collected results (opaque).
typedef struct ek_bench ek_bench;

// Upper bound of the thread counts one run times (default run: 1 and 2).
#define EK_BENCH_MAX_THREAD_COUNTS 8
// Longest row name, including the terminating NUL.
#define EK_BENCH_NAME_MAX 192

typedef struct {
  // Unique row name (see the naming rule above), at most EK_BENCH_NAME_MAX-1.
  const char *name;
  // Family name, e.g. "svd3".
  const char *family;
  // Target the row runs. EK_ISA_AUTO marks code that is not an ek kernel
  // (e.g. LAPACK); its %peak is then taken against the best ISA available.
  ek_isa isa;
  // Label stored as the row's ISA field instead of ek_isa_name(isa), e.g.
  // "lapack" or "none" for ISA-independent code; NULL = ek_isa_name(isa).
  const char *isa_label;
  // "f32" or "f64" (selects the peak the row is compared with).
  const char *precision;
  // Threads for this row: the harness calls omp_set_num_threads(threads)
  // before timing, so fn should run through OpenMP (as the ek API does).
  int threads;
  // Variant knobs as "key=value" pairs separated by ';' (e.g.
  // "sweeps=4;rsqrt=exact;api=aosoa"); NULL or "" for none.
  const char *knobs;
  // Items processed by one call of fn (matrices, elements, ...).
  size_t items;
  // Declared work per item, for GFLOP/s and GB/s; 0 = not meaningful.
  double flops_per_item;
  double bytes_per_item;
  // Name of the row this one is compared with in the speed-up column (e.g.
  // the LAPACK row of the same precision and threads), or NULL. It may be
  // declared before or after this row.
  const char *baseline;
  // The timed work: one call processes the whole batch of `items` items.
  ek_bench_fn *fn;
  void *ctx;
  // Where fn leaves its call's return code (0: success), or NULL: a
  // nonzero one while timed fails the row, which is then not recorded.
  const int *rc;
  // A check of what the timed calls left (a sim row's blow-up), called
  // once after the timing and before the row is recorded, or NULL. It
  // returns nonzero when it failed the row (saying why with
  // ek_bench_fail): the row is then not recorded.
  int (*after)(void *ctx);
} ek_bench_row;

// 1 under a listing pass (counting rows, or --list): do no expensive setup.
int ek_bench_listing(const ek_bench *b);
// 1 if the --filter regex matches `name` (and the run is not stopping).
int ek_bench_wants(const ek_bench *b, const char *name);
// 1 if the run has a --filter: rows too slow for the default suite (the
// bracket's solver rows) run only when a filter names them.
int ek_bench_filtered(const ek_bench *b);
// Time one row (or, in a listing pass, just count/print it) and record the
// result. 0 on success (also when filtered out), < 0 on error.
int ek_bench_run(ek_bench *b, const ek_bench_row *row);

// Thread counts to time, in increasing order (default {1, 2}; --threads N
// gives {N}). Writes at most EK_BENCH_MAX_THREAD_COUNTS and returns how many.
int ek_bench_thread_counts(const ek_bench *b, int *counts);
// ISAs built into ek and runnable on this CPU, scalar first. Targets the CPU
// lacks are skipped, with a note printed once per run
// ("skipped avx512: not supported by this CPU"). Writes at most EK_ISA_COUNT.
int ek_bench_isas(ek_bench *b, ek_isa *isas);
// Seed for the family's random inputs (--seed, printed and recorded).
unsigned long long ek_bench_seed(const ek_bench *b);
// Median ns per item of a row already timed in this run (e.g. to compare
// two rows in a note); NAN if the row was not timed (filtered out, failed,
// or in the listing pass).
double ek_bench_median_ns(const ek_bench *b, const char *name);
// Print a note (stderr) and record it with the run's metadata.
void ek_bench_note(ek_bench *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
// Report a failure (kernel returned an error, setup failed): printed, and
// ek-bench exits non-zero at the end. Rows already timed are still written
// (as a partial run, the first failure in its partial_reason); a row whose
// function reports one while ek_bench_run times it is not recorded, and the
// message is prefixed with the row's name.
// Notes and failures are not thread-safe: call them outside OpenMP regions.
void ek_bench_fail(ek_bench *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

// A row's big arrays in one block, one after another in the order given,
// each `offset` bytes (< 64) into a 64-byte line and rounded up to whole
// lines; arrays[k] gets the k-th. Returns the block (free it with ek_free),
// or NULL when out of memory. Why: allocated one by one, they land in
// whatever earlier rows freed (a library PETSc loads sets glibc's
// M_MMAP_MAX to 0 and M_TRIM_THRESHOLD to -1, so big blocks come from the
// heap and are never given back), and their relative placement changes
// with the rows selected. Zen 4 runs the warm polar on 2^20 matrices ~8%
// slower (AoS) with A 2^28 + 448 bytes past R (one such run's placement:
// the same bits 12-27 of the linear address, presumably the L1D way
// predictor's tag, Lipp et al. 2020, "Take A Way") and its AoSoA kernel
// ~40% slower with A 2^28 bytes past R (docs/perf.md, warm polar,
// thirteenth round). One after the other is what a program allocating
// its arrays in turn gets from a fresh heap or from mmap.
void *ek_bench_arrays(int narrays, const size_t *bytes, size_t offset, void **arrays);

// A family entry point; returns 0, or < 0 after ek_bench_fail.
typedef int ek_bench_family_fn(ek_bench *b);

// Seeded Gaussian numbers for inputs (the check library's xoshiro256**
// words + Box-Muller): the same seed gives the same inputs on every run and
// thread count.
typedef struct {
  ek_rng words;
  int has_spare;
  double spare;
} ek_bench_rng;
void ek_bench_rng_init(ek_bench_rng *rng, unsigned long long seed);
double ek_bench_rng_gauss(ek_bench_rng *rng);

#ifdef __cplusplus
}
#endif
#endif
