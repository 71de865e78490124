// The ek benchmark timer; the method is described in timer.h.
#include "timer.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

double ek_now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

double ek_thread_cpu_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

ek_timer_opts ek_timer_defaults(void) {
  ek_timer_opts o = {.min_time = 0.5,
                     .min_samples = 5,
                     .max_samples = 1000,
                     .min_sample_time = 1e-3,
                     .warmup_time = 0.05};
  return o;
}

// ---- statistics --------------------------------------------------------

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

// Median of a sorted array: the middle value, or the mean of the two
// middle values for even n.
static double median_sorted(const double *s, size_t n) {
  if (n % 2)
    return s[n / 2];
  return 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

double ek_median(const double *x, size_t n) {
  if (n == 0)
    return NAN;
  double *s = malloc(n * sizeof *s);
  if (!s)
    return NAN;
  memcpy(s, x, n * sizeof *s);
  qsort(s, n, sizeof *s, cmp_double);
  double m = median_sorted(s, n);
  free(s);
  return m;
}

double ek_mad(const double *x, size_t n) {
  if (n == 0)
    return NAN;
  double m = ek_median(x, n);
  double *d = malloc(n * sizeof *d);
  if (!d)
    return NAN;
  for (size_t i = 0; i < n; i++)
    d[i] = fabs(x[i] - m);
  double mad = ek_median(d, n);
  free(d);
  return mad;
}

double ek_mean(const double *x, size_t n) {
  if (n == 0)
    return NAN;
  double s = 0;
  for (size_t i = 0; i < n; i++)
    s += x[i];
  return s / (double)n;
}

double ek_stddev(const double *x, size_t n) {
  if (n == 0)
    return NAN;
  if (n == 1)
    return 0;
  // Two passes (mean, then squared deviations): no cancellation.
  double m = ek_mean(x, n), s = 0;
  for (size_t i = 0; i < n; i++)
    s += (x[i] - m) * (x[i] - m);
  return sqrt(s / (double)(n - 1));
}

double ek_cv(const double *x, size_t n) { return ek_stddev(x, n) / ek_mean(x, n); }

ek_stats ek_stats_of(const double *x, size_t n) {
  ek_stats st = {.n = n};
  st.median = ek_median(x, n);
  st.mad = ek_mad(x, n);
  st.mean = ek_mean(x, n);
  st.stddev = ek_stddev(x, n);
  st.cv = st.stddev / st.mean;
  st.min = n ? x[0] : NAN;
  st.max = n ? x[0] : NAN;
  for (size_t i = 1; i < n; i++) {
    st.min = x[i] < st.min ? x[i] : st.min;
    st.max = x[i] > st.max ? x[i] : st.max;
  }
  return st;
}

// ---- timing ------------------------------------------------------------

static double overhead_cache = -1;

double ek_timer_overhead_ns(void) {
  if (overhead_cache >= 0)
    return overhead_cache;
  // A sample is bracketed by one pair of clock reads; its cost (the time
  // from one read to the next with nothing in between) is in every sample.
  enum { N = 1001 };
  static double d[N];
  for (int i = 0; i < N; i++) {
    double t0 = ek_now_ns();
    double t1 = ek_now_ns();
    d[i] = t1 - t0;
  }
  double m = ek_median(d, N);
  overhead_cache = isfinite(m) && m > 0 ? m : 0;
  return overhead_cache;
}

// Wall time of `iters` calls, ns, minus the calibrated overhead (never
// below zero).
static double run_calls(ek_bench_fn *fn, void *ctx, long iters, double overhead, double *cpu_ns) {
  double c0 = ek_thread_cpu_ns();
  double t0 = ek_now_ns();
  for (long i = 0; i < iters; i++) {
    fn(ctx);
    ek_clobber();
  }
  double t1 = ek_now_ns();
  double c1 = ek_thread_cpu_ns();
  if (cpu_ns)
    *cpu_ns = c1 - c0;
  double t = t1 - t0 - overhead;
  return t > 0 ? t : 0;
}

int ek_time(ek_bench_fn *fn, void *ctx, size_t items, const ek_timer_opts *opts, ek_timing *out) {
  ek_timer_opts o = opts ? *opts : ek_timer_defaults();
  memset(out, 0, sizeof *out);
  if (!fn || items == 0 || !(o.min_time >= 0) || o.min_samples < 1 ||
      o.max_samples < o.min_samples || !(o.min_sample_time > 0) || !(o.warmup_time >= 0)) {
    fprintf(stderr,
            "ek_time: invalid arguments (fn %p, items %zu, min_time %g, "
            "min_samples %d, max_samples %d, min_sample_time %g)\n",
            (void *)fn, items, o.min_time, o.min_samples, o.max_samples, o.min_sample_time);
    return -1;
  }
  double overhead = ek_timer_overhead_ns();
  out->overhead_ns = overhead;
  out->items = items;

  // Warm-up: caches, page faults, frequency ramp; at least one call.
  double start = ek_now_ns();
  do {
    if (o.stop && *o.stop)
      return EK_TIME_STOPPED;
    fn(ctx);
    ek_clobber();
  } while (ek_now_ns() - start < o.warmup_time * 1e9);

  // Grow iters until one sample lasts min_sample_time. Each step aims at
  // 1.4x the target from the last measurement, growing at least 2x and at
  // most 100x per step (a first call in the noise must not overshoot).
  double target_ns = o.min_sample_time * 1e9;
  long iters = 1;
  for (;;) {
    if (o.stop && *o.stop)
      return EK_TIME_STOPPED;
    double t = run_calls(fn, ctx, iters, overhead, NULL);
    if (t >= target_ns) {
      out->growth_ns = t;
      break;
    }
    double grow = t > 0 ? 1.4 * target_ns / t : 100;
    grow = grow < 2 ? 2 : grow > 100 ? 100 : grow;
    iters = (long)ceil((double)iters * grow);
  }
  out->iters = iters;

  out->sample_ns = malloc((size_t)o.max_samples * sizeof(double));
  out->sample_cpu_ns = malloc((size_t)o.max_samples * sizeof(double));
  if (!out->sample_ns || !out->sample_cpu_ns) {
    fprintf(stderr, "ek_time: out of memory for %d samples\n", o.max_samples);
    ek_timing_free(out);
    return -3;
  }
  double per_call_items = (double)iters * (double)items;
  double total = 0;
  int n = 0;
  while (n < o.max_samples && (n < o.min_samples || total < o.min_time * 1e9)) {
    if (o.stop && *o.stop) {
      ek_timing_free(out);
      return EK_TIME_STOPPED;
    }
    double cpu;
    double t = run_calls(fn, ctx, iters, overhead, &cpu);
    out->sample_ns[n] = t / per_call_items;
    out->sample_cpu_ns[n] = cpu / per_call_items;
    total += t;
    n++;
  }
  out->nsamples = n;
  out->total_s = total * 1e-9;
  out->stats = ek_stats_of(out->sample_ns, (size_t)n);
  return 0;
}

void ek_timing_free(ek_timing *t) {
  free(t->sample_ns);
  free(t->sample_cpu_ns);
  t->sample_ns = t->sample_cpu_ns = NULL;
  t->nsamples = 0;
}
