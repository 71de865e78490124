// The speed/accuracy map (`ek-bench --suite tradeoff`): one point per knob
// setting of a family, its cost and its error against the double reference.
// Families add points; the suite marks the Pareto front per family and
// writes them all to one HDF5 group and one JSON file (bench/tradeoff.c).
#ifndef EK_BENCH_TRADEOFF_H
#define EK_BENCH_TRADEOFF_H

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

#ifdef __cplusplus
}
#endif
#endif
