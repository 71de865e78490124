// Machine limits: FMA peak through the fma_probe kernel, stream triad
// (McCalpin, STREAM benchmark, "Triad" kernel and its byte-counting rule).
#include "machine.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#include "kernels.h" // ek_kernels_for: the fma_probe entries of each ISA
#include "timer.h"

void ek_machine_init(ek_machine *m) {
  for (int i = 0; i < EK_ISA_COUNT; i++)
    for (int p = 0; p < 2; p++)
      for (int t = 0; t <= EK_MACHINE_MAX_THREADS; t++)
        m->peak_gflops[i][p][t] = NAN;
  for (int t = 0; t <= EK_MACHINE_MAX_THREADS; t++)
    m->triad_gbs[t] = NAN;
  m->triad_array_bytes = 0;
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
    fprintf(stderr, "ek machine: cannot measure peak of ISA '%s' at %d threads\n", ek_isa_name(isa),
            threads);
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
    fprintf(stderr, "ek machine: cannot allocate 3 x %.0f MiB for the triad\n",
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

int ek_machine_measure(ek_machine *m, const int *threads, int nthreads, double min_time) {
  // 64 MiB per array, 3 arrays: 6x the 32 MiB L3 of the reference machine.
  m->triad_array_bytes = 64.0 * 1024 * 1024;
  int rc = 0;
  for (int i = 0; i < nthreads; i++) {
    int t = threads[i];
    if (t < 1 || t > EK_MACHINE_MAX_THREADS) {
      fprintf(stderr, "ek machine: thread count %d outside 1..%d\n", t, EK_MACHINE_MAX_THREADS);
      rc = -1;
      continue;
    }
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      for (int p = 0; p < 2; p++)
        m->peak_gflops[isa][p][t] = ek_machine_measure_peak((ek_isa)isa, p, t, min_time);
    }
    m->triad_gbs[t] = ek_machine_measure_triad(t, m->triad_array_bytes, min_time);
  }
  return rc;
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
