// The ek benchmark timer (our own; no Google Benchmark).
//
// Method: CLOCK_MONOTONIC; the cost of one timing call pair is calibrated
// and subtracted from every sample; warm-up calls first; a sample times an
// inner loop of `iters` calls, with iters grown until a sample takes at
// least min_sample_time (so clock resolution is negligible); samples are
// taken until their total reaches min_time and there are at least
// min_samples. Statistics over the per-item times of the samples: median,
// min, max, MAD, mean, standard deviation, coefficient of variation.
#ifndef EK_BENCH_TIMER_H
#define EK_BENCH_TIMER_H

#include <signal.h>
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

// Budget of tests/test_timer.c: the statistics of a short array agree with
// their closed forms to within rounding, relative to the expected value
// (the median and MAD of exactly representable data are exact).
#define EK_TIMER_STATS_RTOL 1e-14

// Compiler barriers, so timed results are not optimised away:
// ek_do_not_optimize(p) makes the compiler assume *p is read and written;
// ek_clobber() makes it assume all memory is read and written.
static inline void ek_do_not_optimize(void *p) { __asm__ volatile("" : : "g"(p) : "memory"); }
static inline void ek_clobber(void) { __asm__ volatile("" : : : "memory"); }

// The timed work: one call processes a whole batch of items.
typedef void ek_bench_fn(void *ctx);

typedef struct {
  double min_time;        // total sample time to reach, seconds (default 0.5)
  int min_samples;        // at least this many samples (default 5)
  int max_samples;        // stop at this many samples (default 1000)
  double min_sample_time; // a sample lasts at least this, seconds (default 1e-3)
  double warmup_time;     // warm-up before sampling, seconds (default 0.05;
                          // at least one call is always made)
  // Read between calls of the warm-up and the growth, and between samples:
  // once nonzero (a signal handler's flag), the timing stops unfinished
  // (EK_TIME_STOPPED). NULL (the default): never.
  const volatile sig_atomic_t *stop;
} ek_timer_opts;

// ek_time's return when opts->stop was set: nothing is filled in.
#define EK_TIME_STOPPED 1

// Defaults as listed above.
ek_timer_opts ek_timer_defaults(void);

typedef struct {
  size_t n;
  double median, min, max;
  double mad;    // median absolute deviation from the median (unscaled)
  double mean;   // arithmetic mean
  double stddev; // sample standard deviation (n - 1 denominator)
  double cv;     // stddev / mean
} ek_stats;

typedef struct {
  double overhead_ns; // calibrated cost of one timing call pair (subtracted)
  long iters;         // calls per sample
  double growth_ns;   // duration of the growth sample that reached
                      // min_sample_time with `iters` calls (>= it)
  size_t items;       // items per call
  int nsamples;
  double *sample_ns;     // per-item wall time of each sample, ns (malloc'd)
  double *sample_cpu_ns; // per-item CPU time of the calling thread, ns
  ek_stats stats;        // over sample_ns
  double total_s;        // wall time of all samples, s
} ek_timing;

// Monotonic wall clock and calling-thread CPU clock, nanoseconds.
double ek_now_ns(void);
double ek_thread_cpu_ns(void);

// Median over many back-to-back clock reads of the cost of one read pair,
// ns; finite and >= 0. Computed once per process and cached.
double ek_timer_overhead_ns(void);

// Time fn(ctx) (one call = `items` items). opts may be NULL (defaults).
// Fills *out (free with ek_timing_free). 0 on success, EK_TIME_STOPPED (see
// ek_timer_opts.stop), < 0 on bad arguments or allocation failure (message
// on stderr).
int ek_time(ek_bench_fn *fn, void *ctx, size_t items, const ek_timer_opts *opts, ek_timing *out);
void ek_timing_free(ek_timing *t);

// Statistics on arrays; x is not modified. n == 0 gives NaN.
double ek_median(const double *x, size_t n);
double ek_mad(const double *x, size_t n);
double ek_mean(const double *x, size_t n);
double ek_stddev(const double *x, size_t n); // n - 1 denominator; 0 if n == 1
double ek_cv(const double *x, size_t n);     // stddev / mean
ek_stats ek_stats_of(const double *x, size_t n);

#ifdef __cplusplus
}
#endif
#endif
