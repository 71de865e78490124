// Benchmark results: rows (one per timed variant), the run's metadata, and
// the two writers (HDF5, and JSON in Google Benchmark's schema).
//
// HDF5 layout (written to "<path>.tmp.<pid>", then linked into place, so a
// file under the final name is always whole):
//   /                       attributes: run metadata (strings and numbers),
//                           load_avg (float64[3])
//   /benchmarks             attribute "count"; one group per row, nested by
//                           the '/'-separated row name, e.g.
//   /benchmarks/svd3/aosoa/avx2/f32/sweeps:4/threads:2
//       datasets  samples_ns, samples_cpu_ns (float64[nsamples]): per-item
//                 wall time and calling-thread CPU time of each sample
//       attributes name, family, isa, precision, knobs, baseline, flags
//                 (strings), knob.<key> (one string per knob), threads,
//                 items, iters, nsamples, passes (integers), overhead_ns,
//                 the statistics (median_ns, min_ns ...), declared and
//                 achieved rates, fractions and ratios, other_pass_median_ns
//                 (float64; NaN where not applicable)
//   /caches                 one attribute per cache level ("L1d" ...)
// JSON: Google Benchmark's schema (the key list is in results.c), so its
// tools/compare.py, or bench/compare.py, can compare two runs. Per row:
// "aggregate" entries mean, median, stddev, cv and min (as Google Benchmark
// writes them with repetitions and a "min" custom statistic; iterations =
// calls x items, so real_time is ns per item); one "iteration" entry per
// sample only when asked (samples = 1). ek's numbers are counters (numbers)
// and its descriptive fields the "label" string, as Google Benchmark writes
// user counters and labels; ek's run metadata is custom context (strings).
// A value that does not apply is left out, never null. Numbers are written
// with 17 significant digits (bit-exact on reading back).
#ifndef EK_BENCH_RESULTS_H
#define EK_BENCH_RESULTS_H

#include <stddef.h>

#include "timer.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EK_RESULTS_NAME_MAX 192
// The buffers of the machine facts ek_results_collect_metadata reads (a
// metadata text itself has any length).
#define EK_RESULTS_TEXT_MAX 512

typedef enum { EK_META_TEXT, EK_META_NUMBER, EK_META_BOOL } ek_meta_kind;

typedef struct {
  char key[64];
  ek_meta_kind kind;
  char *text;    // EK_META_TEXT: owned by the results set, whole; else NULL
  double number; // EK_META_NUMBER; EK_META_BOOL: 0 or 1
} ek_meta;

typedef struct {
  char type[16]; // "Data", "Instruction", "Unified"
  int level;
  long long size; // bytes
  int num_sharing;
} ek_cache_info;

// Row flags (ek_result_row.flags): what the robustness tests found.
enum {
  // Median more than EK_RESULTS_NOISY_SPREAD above the minimum: the samples
  // disagree (another load on the machine?).
  EK_ROW_NOISY = 1u << 0,
  // Time far off the same row at 1 thread (more than EK_RESULTS_TWIN_SLOWER
  // times slower, or more than EK_RESULTS_TWIN_FASTER x threads faster), also
  // after a second pass: a disturbed run, or a real effect to check.
  EK_ROW_TWIN = 1u << 1,
  // The FMA probe at this row's threads stayed disturbed: %peak is against
  // threads x the 1-thread peak (an estimate), not a measurement.
  EK_ROW_PEAK_ESTIMATED = 1u << 2,
  // The triad at this row's threads stayed disturbed: no %bw.
  EK_ROW_TRIAD_DISTURBED = 1u << 3,
};
#define EK_RESULTS_NOISY_SPREAD 0.10
#define EK_RESULTS_TWIN_SLOWER 2.0
#define EK_RESULTS_TWIN_FASTER 1.5

// 1 if the statistics show a noisy row: (median - min) / min above
// EK_RESULTS_NOISY_SPREAD. A median far from the minimum is robust to what
// the MAD misses: a few samples all slowed by the same amount.
int ek_results_stats_noisy(const ek_stats *s);
// The twin test of a row at T threads against the same row at 1 thread,
// `cores` the cores T threads can use: EK_TWIN_SLOW if the row is more than
// EK_RESULTS_TWIN_SLOWER times slower than its twin (more threads never
// make a row that much slower unless something disturbed it), EK_TWIN_FAST
// if it is more than EK_RESULTS_TWIN_FASTER x cores times faster (the twin
// was the disturbed one), EK_TWIN_OK otherwise or when a median is not
// positive and finite.
typedef enum { EK_TWIN_OK, EK_TWIN_SLOW, EK_TWIN_FAST } ek_twin_verdict;
ek_twin_verdict ek_results_twin_test(double median_ns, double twin_median_ns, int cores);
// The flags as comma-separated words ("noisy,twin,peak~,triad?"), "" if none.
const char *ek_results_flags_text(unsigned flags, char *buf, size_t cap);

typedef struct {
  char name[EK_RESULTS_NAME_MAX];
  char family[32];
  char isa[16];
  char precision[8];
  int threads;
  char knobs[256]; // "key=value;key=value"
  size_t items;    // per call
  long iters;      // calls per sample
  double overhead_ns;
  int nsamples;
  double *sample_ns;     // per item, owned by the results set
  double *sample_cpu_ns; // per item, owned; may be NULL (then = sample_ns)
  ek_stats stats;
  double flops_per_item, bytes_per_item; // declared, 0 = n/a
  // Derived (ek_results_derive) or set by the harness; NaN = n/a.
  double items_per_second, gflops, gbytes_per_second;
  double peak_gflops, triad_gbs;     // machine limits used for the fractions
  double peak_fraction, bw_fraction; // achieved / limit
  char baseline[EK_RESULTS_NAME_MAX];
  double speedup_vs_baseline;  // baseline median / this median
  double speedup_threads;      // same row at threads:1 median / this median
  unsigned flags;              // EK_ROW_*
  int passes;                  // 1, or 2 when a second pass was timed
  double other_pass_median_ns; // the median of the pass not kept; NaN if one pass
} ek_result_row;

typedef struct {
  ek_result_row *rows;
  size_t nrows, rows_cap;
  ek_meta *meta;
  size_t nmeta, meta_cap;
  ek_cache_info caches[16];
  int ncaches;
  double load_avg[3]; // 1, 5, 15 minutes (getloadavg)
  int nload_avg;
} ek_results;

void ek_results_init(ek_results *r);
void ek_results_free(ek_results *r);

// Set (or replace) a metadata entry. 0 on success, < 0 on bad key/memory.
int ek_results_meta_text(ek_results *r, const char *key, const char *value);
int ek_results_meta_number(ek_results *r, const char *key, double value);
int ek_results_meta_bool(ek_results *r, const char *key, int value);
const ek_meta *ek_results_meta_find(const ek_results *r, const char *key);

// Everything recorded with every run: date, host_name, executable, num_cpus,
// mhz_per_cpu, cpu_scaling_enabled, library_build_type, library_version,
// caches, load_avg, cpu_model,
// compiler, c_flags, kernel_flags, build_type, isas_built, isas_available,
// git_revision, omp_proc_bind, omp_places, hdf5_version.
void ek_results_collect_metadata(ek_results *r, const char *executable);

// 1 if name can be a row name: 1..EK_RESULTS_NAME_MAX-1 printable ASCII
// characters without spaces, '/'-separated components, none empty, "." or
// "..", no leading or trailing '/'.
int ek_results_valid_name(const char *name);
// Append a row: fields zeroed, rates and ratios NaN. The samples are copied.
// Returns the row (valid until the next add), NULL on bad input or memory.
ek_result_row *ek_results_add(ek_results *r, const char *name, const ek_timing *timing);
const ek_result_row *ek_results_find(const ek_results *r, const char *name);

// Rates from the median, speed-up vs each row's baseline, and the
// threads:N / threads:1 ratio. Fractions need peak_gflops / triad_gbs set.
void ek_results_derive(ek_results *r);

// 1 if a file exists at path.
int ek_results_file_exists(const char *path);
// Write the set. Without force an existing file is an error and is left
// untouched; with force it is replaced atomically. 0 on success, < 0 on
// error (message on stderr naming the path); no partial file is left.
int ek_results_write_h5(const ek_results *r, const char *path, int force);
// samples = 1 adds one "iteration" entry per sample (large: a default suite
// has ~1e5 samples); 0 writes the aggregates only.
int ek_results_write_json(const ek_results *r, const char *path, int force, int samples);

// For other writers of a run (the tradeoff suite, bench/tradeoff.c). Every
// file goes to "<path>.tmp.<pid>" and is put in place only when whole;
// without force an existing path is left untouched and is an error.
// Errors on stderr, prefixed with who. 0 or -1.
// An HDF5 file: meta's attributes, then body(file, ctx) (file: its hid_t;
// body returns 0 or < 0).
int ek_results_write_h5_with(const char *who, const char *path, int force, const ek_results *meta,
                             int (*body)(long long file, const void *ctx), const void *ctx);
// A text file: text and a newline; frees text.
int ek_results_write_text(const char *who, const char *path, char *text, int force);
// The name the harness's messages (results files, machine probes) start
// with: the running program's (ek-bench sets it), "ek results" until set.
void ek_results_set_program(const char *name);
const char *ek_results_program(void);

#ifdef __cplusplus
}
#endif
#endif
