// The speed/accuracy map (`ek-bench --suite tradeoff`): one point per knob
// setting of a family, its cost and its error against the double reference.
// Families add points; the suite marks the Pareto front per family and
// writes them all to one HDF5 group and one JSON file (bench/tradeoff.c).
#ifndef EK_BENCH_TRADEOFF_H
#define EK_BENCH_TRADEOFF_H

#include <stddef.h>

#include "results.h" // the run metadata the writers record

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ek_tradeoff ek_tradeoff;

typedef struct {
  // The map the point belongs to: "svd3", "polar3", "pk1/fixed_corotated",
  // "loop/cantilever" ... (the front is marked within one family).
  const char *family;
  // The setting as "key=value" pairs separated by ';', e.g.
  // "precision=f32;sweeps=2;refine=2;rsqrt=approx;isa=avx512".
  const char *setting;
  int is_default;   // the library's (or the scene's) default setting
  int is_reference; // the setting the others' errors are measured from
  // Cost: median and minimum over the samples, in time_unit
  // ("ns/matrix", "ns/element", "s/simulated s").
  double time_median, time_min;
  const char *time_unit;
  int threads;
  // Error distribution over count samples (matrices, elements, vertices),
  // in the unit error_metric names; budget NaN when there is none.
  const char *error_metric;
  long count;
  double err_p50, err_p99, err_p9999, err_max;
  double budget;
  long over_budget;
  // Loops only (NaN otherwise): relative energy drift over the run.
  double energy_drift;
} ek_tradeoff_point;

// Copies the point (and its strings). 0, or < 0 with a message on stderr.
int ek_tradeoff_add(ek_tradeoff *t, const ek_tradeoff_point *p);

// Error distribution of n values (reordered in place): fills count, the
// percentiles, max and over_budget of p (budget read from p->budget).
void ek_tradeoff_distribution(double *err, long n, ek_tradeoff_point *p);

// The loop maps (bench/tradeoff_loops.c): explicit / implicit / XPBD
// settings on the scenes, deviation from the most accurate setting after
// the simulated time. 0, or < 0 on error.
int ek_tradeoff_loops(ek_tradeoff *t);

// ---- The suite side (bench/tradeoff.c; added with the kernel part) -------
// What `ek-bench --suite tradeoff` was asked for; the families read it.
#define EK_TRADEOFF_MAX_THREAD_COUNTS 8
typedef struct {
  unsigned long long seed; // of every input set (--seed)
  long n;                  // matrices / elements per error distribution (--n)
  int quick;               // --quick: small sets, short timings (tests)
  double min_time;         // seconds of samples per timed point
  int thread_counts[EK_TRADEOFF_MAX_THREAD_COUNTS];
  int nthread_counts;
  unsigned isa_mask; // bit i set: ISA i may be mapped
} ek_tradeoff_opts;

ek_tradeoff *ek_tradeoff_create(const ek_tradeoff_opts *opts);
void ek_tradeoff_free(ek_tradeoff *t);
const ek_tradeoff_opts *ek_tradeoff_options(const ek_tradeoff *t);

// Progress on stderr, "[k/N] text" as the default suite prints it: a family
// announces how many steps it will take (ek_tradeoff_expect), then reports
// each one as it starts (ek_tradeoff_progress).
void ek_tradeoff_expect(ek_tradeoff *t, int steps);
void ek_tradeoff_progress(ek_tradeoff *t, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

size_t ek_tradeoff_count(const ek_tradeoff *t);

// Pareto front of n points (both coordinates lower is better): front[i] = 1
// when no other point dominates it, i.e. no point j has time[j] <= time[i]
// and err[j] <= err[i] with one of the two strictly lower. Of points equal
// in both (duplicates), only the first in the given order is on the front
// (a deterministic pick: they cost the same). A point with a NaN time or
// error is never on the front and hides no other point; +inf and 0 compare
// as numbers (an error of 0, a loop's reference, beats every error > 0).
void ek_tradeoff_pareto(size_t n, const double *time, const double *err, unsigned char *front);
// The fronts of every family, among the points of the same thread count:
// on err_p99 and on err_max. Called by the writers; 1 if point i is on it.
int ek_tradeoff_on_front(ek_tradeoff *t, size_t i, int on_max);

// Write the points and the run metadata (results.h: cpu, ISAs, threads,
// revision ...). HDF5: /tradeoff/<family>/points, one compound row per
// point; JSON: {"suite", "metadata", "points": [...]}. Written to a temp
// name and renamed; without force an existing file is an error. 0 or < 0
// (message on stderr naming the file).
int ek_tradeoff_write_h5(ek_tradeoff *t, const ek_results *meta, const char *path, int force);
int ek_tradeoff_write_json(ek_tradeoff *t, const ek_results *meta, const char *path, int force);

// The kernel families (bench/tradeoff_kernels.c): svd3, polar3 and
// pk1/<model>; and the hook of the warm-started polar decomposition.
int ek_tradeoff_kernels(ek_tradeoff *t);
int ek_tradeoff_polar_warm(ek_tradeoff *t);

#ifdef __cplusplus
}
#endif
#endif
