// Machine limits: FMA peak through the fma_probe kernel, stream triad
// (McCalpin, STREAM benchmark, "Triad" kernel and its byte-counting rule).
#include "machine.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "kernels.h" // ek_kernels_for: the fma_probe entries of each ISA
#include "results.h" // ek_results_program: the name messages start with
#include "timer.h"

void ek_machine_init(ek_machine *m) {
  memset(m, 0, sizeof *m);
  for (int i = 0; i < EK_ISA_COUNT; i++)
    for (int p = 0; p < 2; p++)
      for (int t = 0; t <= EK_MACHINE_MAX_THREADS; t++)
        m->peak_gflops[i][p][t] = m->peak_measured[i][p][t] = NAN;
  for (int t = 0; t <= EK_MACHINE_MAX_THREADS; t++)
    m->triad_gbs[t] = m->triad_measured[t] = NAN;
}

// ---- FMA peak ----------------------------------------------------------

typedef struct {
  ek_fma_probe_fn *probe;
  long rounds;
  int threads;
  double sink; // sum of the probe results, so no call is dead code
} peak_ctx;

static void peak_call(void *p) {
  peak_ctx *c = p;
  double sink = 0;
#pragma omp parallel num_threads(c->threads) reduction(+ : sink)
  {
    double flops;
    sink += c->probe(c->rounds, &flops);
  }
  c->sink += sink;
  ek_do_not_optimize(&c->sink);
}

double ek_machine_measure_peak(ek_isa isa, int f64, int threads, double min_time) {
  const ek_kernel_table *k = ek_kernels_for(isa);
  if (!k || threads < 1) {
    fprintf(stderr, "%s: cannot measure peak of ISA '%s' at %d threads\n", ek_results_program(),
            ek_isa_name(isa), threads);
    return NAN;
  }
  // 2^16 rounds: a call of a fraction of a millisecond, long next to the
  // cost of opening the parallel region.
  peak_ctx c = {
      .probe = f64 ? k->fma_probe_f64 : k->fma_probe_f32, .rounds = 1L << 16, .threads = threads};
  double flops_per_probe = 0;
  c.sink += c.probe(c.rounds, &flops_per_probe);
  ek_timer_opts o = ek_timer_defaults();
  o.min_time = min_time;
  o.warmup_time = 0.02;
  ek_timing t;
  if (ek_time(peak_call, &c, 1, &o, &t) != 0)
    return NAN;
  double gflops = flops_per_probe * threads / t.stats.min;
  ek_timing_free(&t);
  return gflops;
}

// ---- stream triad ------------------------------------------------------

typedef struct {
  double *a, *b, *c;
  long n;
  double s;
  int threads;
} triad_ctx;

static void triad_call(void *p) {
  triad_ctx *t = p;
  double *restrict a = t->a;
  const double *restrict b = t->b, *restrict c = t->c;
  double s = t->s;
  long n = t->n;
#pragma omp parallel for schedule(static) num_threads(t->threads)
  for (long i = 0; i < n; i++)
    a[i] = b[i] + s * c[i];
  ek_do_not_optimize(a);
}

double ek_machine_measure_triad(int threads, double array_bytes, double min_time) {
  long n = (long)(array_bytes / sizeof(double));
  size_t bytes = ((size_t)n * sizeof(double) + 63) / 64 * 64;
  triad_ctx t = {.n = n, .s = 3.0, .threads = threads};
  t.a = aligned_alloc(64, bytes);
  t.b = aligned_alloc(64, bytes);
  t.c = aligned_alloc(64, bytes);
  double gbs = NAN;
  if (!t.a || !t.b || !t.c || threads < 1) {
    fprintf(stderr, "%s: cannot allocate 3 x %.0f MiB for the triad\n", ek_results_program(),
            array_bytes / (1 << 20));
  } else {
    // First touch with the triad's own schedule: each thread's pages are
    // placed near it (matters on NUMA machines).
#pragma omp parallel for schedule(static) num_threads(threads)
    for (long i = 0; i < n; i++) {
      t.a[i] = 0;
      t.b[i] = 1;
      t.c[i] = 2;
    }
    ek_timer_opts o = ek_timer_defaults();
    o.min_time = min_time;
    o.warmup_time = 0;
    ek_timing tm;
    if (ek_time(triad_call, &t, (size_t)n, &o, &tm) == 0) {
      // STREAM counts 3 x 8 bytes per element for triad.
      gbs = 24.0 / tm.stats.min;
      ek_timing_free(&tm);
    }
  }
  free(t.a);
  free(t.b);
  free(t.c);
  return gbs;
}

// ---- checks ------------------------------------------------------------

int ek_machine_effective_threads(int threads) {
  int cores = omp_get_num_places();
  if (cores < 1)
    cores = (int)sysconf(_SC_NPROCESSORS_ONLN);
  if (cores < 1)
    cores = 1;
  return threads < cores ? threads : cores;
}

int ek_machine_peak_plausible(double peak_1, double peak_t, int cores) {
  if (cores < 2 || !isfinite(peak_1) || !isfinite(peak_t))
    return 1;
  double scaling = peak_t / peak_1;
  return scaling >= EK_MACHINE_PEAK_MIN_SCALING * cores &&
         scaling <= EK_MACHINE_PEAK_MAX_SCALING * cores;
}

int ek_machine_triad_plausible(double triad_1, double triad_t, int cores) {
  if (cores < 2 || !isfinite(triad_1) || !isfinite(triad_t))
    return 1;
  return triad_t >= triad_1;
}

// Measure every probe at `threads`, or only those whose check failed
// (recheck), keeping the best reading of each.
static void measure_at(ek_machine *m, int threads, const unsigned char (*redo)[2], int redo_triad,
                       double min_time) {
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available((ek_isa)isa))
      continue;
    for (int p = 0; p < 2; p++) {
      if (redo && !redo[isa][p])
        continue;
      double v = ek_machine_measure_peak((ek_isa)isa, p, threads, min_time);
      double *best = &m->peak_measured[isa][p][threads];
      if (isfinite(v) && !(v <= *best))
        *best = v;
    }
  }
  if (!redo || redo_triad) {
    double v = ek_machine_measure_triad(threads, m->triad_array_bytes, min_time);
    double *best = &m->triad_measured[threads];
    if (isfinite(v) && !(v <= *best))
      *best = v;
  }
}

int ek_machine_measure(ek_machine *m, const int *threads, int nthreads, double min_time) {
  // 64 MiB per array, 3 arrays: 6x the 32 MiB L3 of the reference machine.
  m->triad_array_bytes = 64.0 * 1024 * 1024;
  int rc = 0;
  // 1 thread first: the reference every other count is checked against.
  int list[EK_MACHINE_MAX_THREADS + 1], n = 0;
  list[n++] = 1;
  for (int i = 0; i < nthreads; i++) {
    int t = threads[i];
    if (t < 1 || t > EK_MACHINE_MAX_THREADS) {
      fprintf(stderr, "%s: thread count %d outside 1..%d\n", ek_results_program(), t,
              EK_MACHINE_MAX_THREADS);
      rc = -1;
      continue;
    }
    int seen = 0;
    for (int k = 0; k < n; k++)
      seen |= list[k] == t;
    if (!seen)
      list[n++] = t;
  }
  for (int k = 0; k < n; k++) {
    measure_at(m, list[k], NULL, 1, min_time);
    m->attempts[list[k]] = 1;
    m->cores[list[k]] = ek_machine_effective_threads(list[k]);
  }
  for (int k = 1; k < n; k++) {
    int t = list[k];
    for (;;) {
      unsigned char redo[EK_ISA_COUNT][2] = {{0}};
      int bad = 0;
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
        for (int p = 0; p < 2; p++)
          if (!ek_machine_peak_plausible(m->peak_measured[isa][p][1], m->peak_measured[isa][p][t],
                                         m->cores[t]))
            bad = redo[isa][p] = 1;
      int redo_triad =
          !ek_machine_triad_plausible(m->triad_measured[1], m->triad_measured[t], m->cores[t]);
      if ((!bad && !redo_triad) || m->attempts[t] >= EK_MACHINE_PROBE_ATTEMPTS)
        break;
      // A pause, so a burst of other work can pass, then both ends of
      // each failed check again.
      struct timespec pause = {0, 200 * 1000 * 1000};
      nanosleep(&pause, NULL);
      measure_at(m, 1, redo, redo_triad, min_time);
      measure_at(m, t, redo, redo_triad, min_time);
      m->attempts[t]++;
    }
  }
  ek_machine_settle(m);
  return rc;
}

void ek_machine_settle(ek_machine *m) {
  for (int t = 1; t <= EK_MACHINE_MAX_THREADS; t++) {
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
      for (int p = 0; p < 2; p++) {
        m->peak_gflops[isa][p][t] = m->peak_measured[isa][p][t];
        m->peak_disturbed[isa][p][t] = 0;
      }
    m->triad_gbs[t] = m->triad_measured[t];
    m->triad_disturbed[t] = 0;
  }
  for (int t = 2; t <= EK_MACHINE_MAX_THREADS; t++) {
    int cores = m->cores[t];
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
      for (int p = 0; p < 2; p++) {
        double one = m->peak_measured[isa][p][1], many = m->peak_measured[isa][p][t];
        if (ek_machine_peak_plausible(one, many, cores))
          continue;
        if (many / one < EK_MACHINE_PEAK_MIN_SCALING * cores) {
          // The T-thread probe read low: each core's units are independent,
          // so cores x the 1-thread peak is the limit to compare with.
          m->peak_disturbed[isa][p][t] = 1;
          m->peak_gflops[isa][p][t] = cores * one;
        } else {
          // The 1-thread probe read low.
          m->peak_disturbed[isa][p][1] = 1;
          m->peak_gflops[isa][p][1] = many / cores;
        }
      }
    if (!ek_machine_triad_plausible(m->triad_measured[1], m->triad_measured[t], cores)) {
      m->triad_disturbed[t] = 1;
      m->triad_gbs[t] = NAN;
    }
  }
}

const char *ek_machine_warnings(const ek_machine *m, const int *threads, int nthreads, char *buf,
                                size_t cap) {
  if (cap == 0)
    return buf;
  buf[0] = 0;
  for (int i = 0; i < nthreads; i++) {
    int t = threads[i];
    if (t < 1 || t > EK_MACHINE_MAX_THREADS)
      continue;
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
      for (int p = 0; p < 2; p++) {
        if (!m->peak_disturbed[isa][p][t])
          continue;
        size_t used = strlen(buf);
        const char *isa_name = ek_isa_name((ek_isa)isa), *prec = p ? "f64" : "f32";
        if (t > 1)
          snprintf(buf + used, cap - used,
                   "WARNING: FMA probe %s %s at %d threads read %.1f GFLOP/s, %.2fx the 1-thread "
                   "%.1f (expected >= %.2fx; best of %d attempts): disturbed; rows at %d threads "
                   "use the estimate %.1f (flag peak~)\n",
                   isa_name, prec, t, m->peak_measured[isa][p][t],
                   m->peak_measured[isa][p][t] / m->peak_measured[isa][p][1],
                   m->peak_measured[isa][p][1], EK_MACHINE_PEAK_MIN_SCALING * m->cores[t],
                   m->attempts[t], t, m->peak_gflops[isa][p][t]);
        else
          snprintf(buf + used, cap - used,
                   "WARNING: FMA probe %s %s at 1 thread read %.1f GFLOP/s, far below the "
                   "per-thread rate at more threads: disturbed; rows at 1 thread use the "
                   "estimate %.1f (flag peak~)\n",
                   isa_name, prec, m->peak_measured[isa][p][1], m->peak_gflops[isa][p][1]);
      }
    if (m->triad_disturbed[t]) {
      size_t used = strlen(buf);
      snprintf(buf + used, cap - used,
               "WARNING: triad at %d threads disturbed: read %.1f GB/s, below %.1f at 1 thread "
               "(best of %d attempts); rows have no %%bw (flag triad?)\n",
               t, m->triad_measured[t], m->triad_measured[1], m->attempts[t]);
    }
  }
  return buf;
}

int ek_machine_peak_estimated(const ek_machine *m, ek_isa isa, int f64, int threads) {
  if (threads < 1 || threads > EK_MACHINE_MAX_THREADS)
    return 0;
  if (isa == EK_ISA_AUTO) {
    for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
      if (m->peak_disturbed[i][f64 != 0][threads])
        return 1;
    return 0;
  }
  return (unsigned)isa < EK_ISA_COUNT && m->peak_disturbed[isa][f64 != 0][threads];
}

int ek_machine_triad_disturbed(const ek_machine *m, int threads) {
  return threads >= 1 && threads <= EK_MACHINE_MAX_THREADS && m->triad_disturbed[threads];
}

double ek_machine_peak(const ek_machine *m, ek_isa isa, int f64, int threads) {
  if (threads < 1 || threads > EK_MACHINE_MAX_THREADS)
    return NAN;
  if (isa == EK_ISA_AUTO) {
    double best = NAN;
    for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++) {
      double v = m->peak_gflops[i][f64 != 0][threads];
      if (isfinite(v) && !(v <= best))
        best = v;
    }
    return best;
  }
  if ((unsigned)isa >= EK_ISA_COUNT)
    return NAN;
  return m->peak_gflops[isa][f64 != 0][threads];
}

double ek_machine_triad(const ek_machine *m, int threads) {
  if (threads < 1 || threads > EK_MACHINE_MAX_THREADS)
    return NAN;
  return m->triad_gbs[threads];
}
