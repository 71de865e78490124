// Invariant: the benchmark timer's statistics equal their definitions
// (median, MAD, mean, sample standard deviation, CV) on known arrays of odd
// and even length with ties, and on seeded random arrays (median splits
// the data in halves, order does not matter, input is not modified); the
// calibrated timing overhead is finite and >= 0; a call that sleeps 2 ms
// measures >= 2 ms (the clock and the per-item division are right); the
// iteration count grows until a sample lasts the minimum sample time; and
// the sampling stops only after min_time and min_samples are reached.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "cli.h"
#include "timer.h"

static int failures;

// Relative error against the budget: PASS, MARGINAL above half, FAIL above.
static void check_close(const char *what, double got, double expected, const double *input,
                        size_t n) {
  double err = fabs(got - expected) / (expected != 0 ? fabs(expected) : 1);
  double ratio = err / EK_TIMER_STATS_RTOL;
  const char *verdict = ek_verdict_name(ek_check_verdict(err, EK_TIMER_STATS_RTOL));
  printf("%-8s %-40s rel.err %.3g  err/budget %.3g\n", verdict, what, err, ratio);
  if (!(ratio <= 1)) {
    failures++;
    printf("  input:");
    for (size_t i = 0; i < n; i++)
      printf(" %.17g", input[i]);
    printf("\n  expected %.17g, got %.17g\n", expected, got);
  }
}

static void check_true(const char *what, int ok, const char *detail) {
  printf("%-8s %s (%s)\n", ok ? "PASS" : "FAIL", what, detail);
  if (!ok)
    failures++;
}

static void known_arrays(void) {
  const double odd[] = {3, 1, 2};
  const double even[] = {4, 1, 3, 2};
  const double ties[] = {1, 1, 1, 5};
  const double ties_odd[] = {7, 7, 1, 7, 2};
  const double outlier[] = {1, 2, 3, 4, 100};
  const double one[] = {42};
  check_close("median odd {3,1,2} = 2", ek_median(odd, 3), 2, odd, 3);
  check_close("median even {4,1,3,2} = 2.5", ek_median(even, 4), 2.5, even, 4);
  check_close("median ties {1,1,1,5} = 1", ek_median(ties, 4), 1, ties, 4);
  check_close("median ties {7,7,1,7,2} = 7", ek_median(ties_odd, 5), 7, ties_odd, 5);
  check_close("median single {42} = 42", ek_median(one, 1), 42, one, 1);
  // MAD: median of |x - median|.
  check_close("MAD {1,2,3,4,100} = 1", ek_mad(outlier, 5), 1, outlier, 5);
  check_close("MAD {4,1,3,2} = 1", ek_mad(even, 4), 1, even, 4);
  check_close("MAD ties {1,1,1,5} = 0 (abs.)", ek_mad(ties, 4) + 1, 1, ties, 4);
  check_close("MAD {7,7,1,7,2} = 0 (abs.)", ek_mad(ties_odd, 5) + 1, 1, ties_odd, 5);
  // {2,4,4,4,5,5,7,9}: mean 5, squared deviations sum 32, sample
  // variance 32/7.
  const double sd[] = {2, 4, 4, 4, 5, 5, 7, 9};
  check_close("mean = 5", ek_mean(sd, 8), 5, sd, 8);
  check_close("stddev = sqrt(32/7)", ek_stddev(sd, 8), sqrt(32.0 / 7), sd, 8);
  check_close("CV = sqrt(32/7)/5", ek_cv(sd, 8), sqrt(32.0 / 7) / 5, sd, 8);
  check_close("stddev of one value = 0 (abs.)", ek_stddev(one, 1) + 1, 1, one, 1);
  ek_stats st = ek_stats_of(outlier, 5);
  check_close("stats_of: median", st.median, 3, outlier, 5);
  check_close("stats_of: min", st.min, 1, outlier, 5);
  check_close("stats_of: max", st.max, 100, outlier, 5);
  check_close("stats_of: mad", st.mad, 1, outlier, 5);
  check_close("stats_of: mean", st.mean, 22, outlier, 5);
  check_true("stats_of: n", st.n == 5, "n == 5");
  check_true("median of empty array is NaN", isnan(ek_median(odd, 0)), "n = 0");
}

static unsigned long long lcg_state;
static double uniform(void) {
  // Knuth's MMIX LCG; top 53 bits as a double in [0, 1).
  lcg_state = lcg_state * 6364136223846793005ULL + 1442695040888963407ULL;
  return (double)(lcg_state >> 11) * 0x1p-53;
}

static void random_arrays(unsigned long long seed) {
  lcg_state = seed;
  int ok_split = 1, ok_perm = 1, ok_const = 1;
  char detail[256] = "all lengths 1..64";
  for (size_t n = 1; n <= 64; n++) {
    double x[64], y[64], copy[64];
    for (size_t i = 0; i < n; i++)
      // Few distinct values, so ties are common.
      x[i] = floor(uniform() * 8) / 4;
    memcpy(copy, x, n * sizeof *x);
    double m = ek_median(x, n);
    ok_const &= memcmp(copy, x, n * sizeof *x) == 0;
    // Median definition: at most half of the values lie strictly below,
    // at most half strictly above.
    size_t below = 0, above = 0;
    for (size_t i = 0; i < n; i++) {
      below += x[i] < m;
      above += x[i] > m;
    }
    if (2 * below > n || 2 * above > n) {
      ok_split = 0;
      snprintf(detail, sizeof detail, "n=%zu median %.17g: %zu below, %zu above", n, m, below,
               above);
    }
    // Reversed order gives the same median and MAD.
    for (size_t i = 0; i < n; i++)
      y[i] = x[n - 1 - i];
    if (ek_median(y, n) != m || ek_mad(y, n) != ek_mad(x, n)) {
      ok_perm = 0;
      snprintf(detail, sizeof detail, "n=%zu: reversed array changes median or MAD", n);
    }
  }
  check_true("random arrays: median splits the data in halves", ok_split, detail);
  check_true("random arrays: order does not matter", ok_perm, detail);
  check_true("random arrays: input not modified", ok_const, "memcmp before/after");
}

static void sleep_2ms(void *ctx) {
  (void)ctx;
  struct timespec ts = {0, 2000000};
  while (nanosleep(&ts, &ts) != 0) {
  }
}

static volatile double tiny_sink;
static void tiny_work(void *ctx) {
  (void)ctx;
  double s = 0;
  for (int i = 0; i < 100; i++)
    s += i * 0.5;
  tiny_sink = s;
}

static void timing(void) {
  double ov = ek_timer_overhead_ns();
  char detail[256];
  snprintf(detail, sizeof detail, "overhead %.1f ns", ov);
  check_true("timer overhead is finite and >= 0", isfinite(ov) && ov >= 0, detail);

  ek_timer_opts o = ek_timer_defaults();
  o.min_time = 0.03;
  o.min_samples = 5;
  o.warmup_time = 0;
  ek_timing t;
  int rc = ek_time(sleep_2ms, NULL, 1, &o, &t);
  snprintf(detail, sizeof detail, "rc %d, min sample %.0f ns per call, median %.0f, %d samples", rc,
           rc ? NAN : t.stats.min, rc ? NAN : t.stats.median, rc ? 0 : t.nsamples);
  // nanosleep sleeps at least as long as asked: every sample >= 2 ms.
  check_true("2 ms sleep measures >= 2 ms per call", rc == 0 && t.stats.min >= 2e6, detail);
  if (rc == 0) {
    snprintf(detail, sizeof detail, "%d samples (>= %d), %.4f s total (>= %.4f s)", t.nsamples,
             o.min_samples, t.total_s, o.min_time);
    check_true("sampling reaches min_samples and min_time",
               t.nsamples >= o.min_samples && t.total_s >= o.min_time, detail);
    ek_timing_free(&t);
  }
  // Items: per-item time of 4 items per call is a quarter of the call.
  rc = ek_time(sleep_2ms, NULL, 4, &o, &t);
  snprintf(detail, sizeof detail, "rc %d, min %.0f ns per item", rc, rc ? NAN : t.stats.min);
  check_true("2 ms sleep over 4 items measures >= 0.5 ms per item", rc == 0 && t.stats.min >= 5e5,
             detail);
  if (rc == 0)
    ek_timing_free(&t);

  // A call of well under a microsecond: iters must grow until a sample
  // lasts min_sample_time. Samples after the growth step repeat the same
  // work, so their median is at least half the target (slack for a
  // frequency step or an interrupt during the growth sample).
  o.min_sample_time = 2e-3;
  rc = ek_time(tiny_work, NULL, 1, &o, &t);
  if (rc == 0) {
    double sample_ns = t.stats.median * (double)t.iters;
    snprintf(detail, sizeof detail, "iters %ld, growth sample %.0f ns, target %.0f ns", t.iters,
             t.growth_ns, o.min_sample_time * 1e9);
    check_true("iteration growth reaches the minimum sample time",
               t.iters > 1 && t.growth_ns >= o.min_sample_time * 1e9, detail);
    snprintf(detail, sizeof detail, "median sample %.0f ns, half the target %.0f ns", sample_ns,
             0.5 * o.min_sample_time * 1e9);
    check_true("later samples repeat the grown work", sample_ns >= 0.5 * o.min_sample_time * 1e9,
               detail);
    ek_timing_free(&t);
  } else {
    check_true("iteration growth reaches the minimum sample time", 0, "ek_time failed");
  }

  rc = ek_time(tiny_work, NULL, 0, &o, &t);
  snprintf(detail, sizeof detail, "rc %d", rc);
  check_true("items = 0 is rejected", rc < 0, detail);
}

int main(int argc, char **argv) {
  unsigned long long seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_timer: seed %llu, budget EK_TIMER_STATS_RTOL = %g\n", seed, EK_TIMER_STATS_RTOL);
  known_arrays();
  random_arrays(seed);
  timing();
  printf("test_timer: %s (%d failure%s)\n", failures ? "FAILED" : "passed", failures,
         failures == 1 ? "" : "s");
  return failures ? 1 : 0;
}
