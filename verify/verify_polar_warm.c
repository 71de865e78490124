// ek-verify family "polar_warm": the warm-started polar (include/ek/polar.h)
// against the SVD polar (LAPACK dgesvd, ek_polar3_ref), max_ij |R - R_svd|
// (no scale: a rotation's entries are in [-1, 1]).
// Rows per ISA x precision, default iterations:
//   random     A = R* S, s_i in [0.5, 2], guess within 10 degrees: budgeted
//   near       s_i in [0.9, 1.1], guess within 1 degree: budgeted
//   cantilever, twist   the scenes' F (fixed corotated) every 5 steps over
//              the first 400 (quick: 100), R chained from sample to sample
//              as the loop keeps it, best ISA: budgeted (max; the p99 is
//              the second metric)
//   far 90..180 deg, inverted (the smallest stretch negated), inverted
//              near-flat, inverted with the largest negated (the SVD polar
//              180 degrees from the guess): the extremes; trade rows
//              (printed, not judged against the budget), with the count of
//              matrices beyond it; the output must still be a rotation
//              (orthogonality and det as metrics; a NaN is a failure).
#include <ek/polar.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "check_polar_warm.h"
#include "scene_find.h"
#include "svd3/svd3_ref.h"
#include "verify.h"

static double orth_det(const double r[9]) {
  double Rt[9] = {r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]}, RtR[9];
  ek_mul3(Rt, r, RtR);
  double d = fabs(ek_det3(r) - 1);
  for (int i = 0; i < 9; i++)
    d = fmax(d, fabs(RtR[i] - (i % 4 == 0)));
  return d;
}

static void set_row(ek_verify_ctx *ctx, ek_isa isa, int bits, const char *inputs, size_t n,
                    const double *A, const double *G, int trade) {
  ek_verify_row row = {.kernel = "polar_warm", .count = n, .trade = trade};
  snprintf(row.variant, sizeof row.variant, "%s f%d iterations=default", ek_isa_name(isa), bits);
  snprintf(row.inputs, sizeof row.inputs, "%s", inputs);
  if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
    return;
  double *R = ek_check_malloc(n * 9 * sizeof(double));
  memcpy(R, G, n * 9 * sizeof(double));
  int rc = ek_check_run_polar_warm(bits, 1, n, A, R, isa, 0);
  double budget = bits == 32 ? EK_POLAR_WARM_TOL_F32 : EK_POLAR_WARM_TOL_F64;
  double rdiff = 0, orth = 0;
  long beyond = 0;
  for (size_t e = 0; e < n && rc == 0; e++) {
    double d = ek_check_polar_error(bits, A + e * 9, R + e * 9), o = orth_det(R + e * 9);
    if (!(o == o) || !(d == d))
      row.nonfinite++;
    else {
      rdiff = fmax(rdiff, d), orth = fmax(orth, o);
      beyond += d > budget;
    }
  }
  row.nmetrics = 3;
  row.metric[0] = "rdiff", row.value[0] = rdiff;
  row.metric[1] = "orth_det", row.value[1] = orth;
  row.metric[2] = "beyond_budget", row.value[2] = (double)beyond;
  row.worst = rc ? INFINITY : trade ? orth : fmax(rdiff, orth);
  row.budget = budget;
  ek_verify_emit(ctx, &row);
  free(R);
}

int verify_polar_warm(ek_verify_ctx *ctx) {
  ek_verify_note_skipped_isas(ctx, "polar_warm");
  size_t n = ek_verify_n_random(ctx);
  double *A = ek_check_malloc(n * 9 * sizeof(double)), *G = ek_check_malloc(n * 9 * sizeof(double));
  const struct {
    const char *name;
    double s_min, s_max, deg_min, deg_max;
    int trade;
  } sets[] = {{"random", 0.5, 2, 0, 10, 0},
              {"near", 0.9, 1.1, 0, 1, 0},
              {"far_90_180deg", 0.5, 2, 90, 180, 1},
              {"inverted", -0.5, 2, 0, 10, 1},
              {"inverted_near_flat", -0.9, 1.1, 0, 10, 1},
              {"inverted_largest_negated", 0.5, -2, 0, 10, 1}};
  ek_isa best = EK_ISA_SCALAR;
  for (ek_isa isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available(isa))
      continue;
    best = isa;
    for (int bits = 32; bits <= 64; bits += 32)
      for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++) {
        ek_rng rng;
        ek_rng_seed(&rng, ek_check_stream_seed(ek_verify_seed(ctx), sets[k].name));
        ek_check_warm_cases(&rng, n, sets[k].s_min, sets[k].s_max, sets[k].deg_min, sets[k].deg_max,
                            A, G);
        set_row(ctx, isa, bits, sets[k].name, n, A, G, sets[k].trade);
      }
  }
  free(A), free(G);
  static const char *const scenes[] = {"cantilever", "twist"};
  long steps = ek_verify_quick(ctx) ? 100 : 400;
  for (int s = 0; s < 2; s++)
    for (int bits = 32; bits <= 64; bits += 32) {
      ek_verify_row row = {.kernel = "polar_warm"};
      snprintf(row.variant, sizeof row.variant, "%s f%d iterations=default", ek_isa_name(best),
               bits);
      snprintf(row.inputs, sizeof row.inputs, "%s_%ld_steps", scenes[s], steps);
      if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
        continue;
      char path[1200], err[1024];
      ek_check_warm_run w = {0};
      int rc = ek_shipped_scene(scenes[s], path, sizeof path, err, sizeof err);
      if (rc == 0)
        rc = ek_check_polar_warm_sim(path, steps, 5, bits, best, 0, &w, err, sizeof err);
      if (rc != 0)
        ek_verify_note(ctx, "polar_warm %s: %s", scenes[s], err);
      row.count = w.tets * w.samples;
      row.nmetrics = 3;
      row.metric[0] = "rdiff_max", row.value[0] = w.max;
      row.metric[1] = "rdiff_p99", row.value[1] = w.p99;
      row.metric[2] = "max_step_deg", row.value[2] = w.max_angle_deg;
      row.worst = rc ? INFINITY : w.max;
      row.budget = bits == 32 ? EK_POLAR_WARM_TOL_F32 : EK_POLAR_WARM_TOL_F64;
      ek_verify_emit(ctx, &row);
    }
  return 0;
}
