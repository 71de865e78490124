// Invariant: the verdicts of ek-verify --extremes (check_stability.h) tell
// a restored state from a broken one on hand-made states of a box mesh:
// finite rejects NaN, infinity and a point past the blow-up distance and
// accepts one just inside; the volume verdict accepts |V/V0 - 1| <= 1% and
// rejects 1.5%, a mirrored body (V = -V0) and NaN; every tet of a mirrored
// or flattened body counts as inverted; the shape error is at rounding
// level for a rigid motion, and above its tolerance for a mirrored body
// (Kabsch gives a rotation, never a reflection), a 3% stretch and NaN,
// below it for noise of 1e-3; the rest displacement is held against the
// per-precision bounds (a 1e-11 drift passes both, 1e-7 passes f32 only).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ek/ek.h>

#include "check.h"
#include "check_box.h"
#include "check_stability.h"
#include "cli.h"
#include "test_tolerances.h"

// A rigid motion leaves the shape error at rounding: a few eps of the
// body's coordinates.
#define RIGID_SHAPE_TOL 1e-12

static int failures;

static void check(const char *what, int ok, double value) {
  printf("%-4s %-64s (%.6g)\n", ok ? "PASS" : "FAIL", what, value);
  if (!ok)
    failures++;
}

int main(int argc, char **argv) {
  unsigned long long seed = ek_cli_test_args(argc, argv, 7, NULL);
  printf("test_stability_verdicts: seed %llu\n", seed);
  const double L = 0.2;
  ek_check_box m;
  if (ek_check_box_create(&m, 3, 3, 3, L, L, L) != 0) {
    printf("FAIL ek_check_box_create: %s\n", ek_last_error());
    return 1;
  }
  size_t nv = m.nverts, nt = m.ntets;
  const double *X = m.X;
  const int32_t *T = m.T;
  double size = sqrt(3.0) * L, centre[3] = {L / 2, L / 2, L / 2};
  double *x = malloc(3 * nv * sizeof(double));
  double *w = malloc(nv * sizeof(double));
  if (!x || !w)
    return 1;
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  for (size_t i = 0; i < nv; i++)
    w[i] = 0.5 + ek_rng_uniform(&rng);

  // ---- finite ----
  memcpy(x, X, 3 * nv * sizeof(double));
  check("finite: the rest state", ek_stab_finite(3 * nv, x, centre, size), 1);
  x[3 * (nv / 2) + 1] = NAN;
  check("finite: one NaN coordinate is not", !ek_stab_finite(3 * nv, x, centre, size), 0);
  x[3 * (nv / 2) + 1] = INFINITY;
  check("finite: one infinite coordinate is not", !ek_stab_finite(3 * nv, x, centre, size), 0);
  x[3 * (nv / 2) + 1] = centre[1] + 1.001 * EK_STAB_BLOWUP_FACTOR * size;
  check("finite: a point past the blow-up distance is not",
        !ek_stab_finite(3 * nv, x, centre, size), x[3 * (nv / 2) + 1]);
  x[3 * (nv / 2) + 1] = centre[1] - 0.999 * EK_STAB_BLOWUP_FACTOR * size;
  check("finite: a point just inside it is", ek_stab_finite(3 * nv, x, centre, size),
        x[3 * (nv / 2) + 1]);

  // ---- volume and inverted tets ----
  double V0 = ek_stab_volume(nt, T, X);
  check("volume: the box's tets sum to L^3", fabs(V0 / (L * L * L) - 1) < 1e-12, V0);
  for (int pass = 0; pass < 2; pass++) {
    double s = pass == 0 ? 1.003 : 1.005; // V/V0 = 1.009, 1.0151
    for (size_t i = 0; i < 3 * nv; i++)
      x[i] = centre[i % 3] + s * (X[i] - centre[i % 3]);
    double V = ek_stab_volume(nt, T, x);
    check(pass == 0 ? "volume: 0.9% larger is recovered" : "volume: 1.5% larger is not",
          ek_stab_volume_recovered(V, V0, EK_SIM_VOLUME_TOL) == (pass == 0), V / V0);
  }
  for (size_t i = 0; i < nv; i++) { // mirror z about the centre
    memcpy(x + 3 * i, X + 3 * i, 3 * sizeof(double));
    x[3 * i + 2] = L - X[3 * i + 2];
  }
  double Vm = ek_stab_volume(nt, T, x);
  check("volume: a mirrored body (V = -V0) is not recovered",
        !ek_stab_volume_recovered(Vm, V0, EK_SIM_VOLUME_TOL), Vm / V0);
  check("inverted: every tet of a mirrored body", ek_stab_inverted(nt, T, x) == nt,
        (double)ek_stab_inverted(nt, T, x));
  check("volume: NaN is not recovered", !ek_stab_volume_recovered(NAN, V0, EK_SIM_VOLUME_TOL), 0);
  check("inverted: none at rest", ek_stab_inverted(nt, T, X) == 0,
        (double)ek_stab_inverted(nt, T, X));
  for (size_t i = 0; i < nv; i++) { // flattened onto z = L/2
    memcpy(x + 3 * i, X + 3 * i, 3 * sizeof(double));
    x[3 * i + 2] = L / 2;
  }
  check("inverted: every tet of a flat body (J = 0)", ek_stab_inverted(nt, T, x) == nt,
        (double)ek_stab_inverted(nt, T, x));

  // ---- shape error ----
  double R[9];
  ek_rng_rotation(&rng, R);
  double shift[3] = {0.3, -1.2, 5.0};
  for (size_t i = 0; i < nv; i++)
    for (int k = 0; k < 3; k++)
      x[3 * i + k] = shift[k] + R[3 * k] * X[3 * i] + R[3 * k + 1] * X[3 * i + 1] +
                     R[3 * k + 2] * X[3 * i + 2];
  double e = ek_stab_shape_error(nv, X, x, w, size);
  check("shape: a rigid motion is restored (rounding)", e <= RIGID_SHAPE_TOL, e);
  for (size_t i = 0; i < nv; i++) {
    memcpy(x + 3 * i, X + 3 * i, 3 * sizeof(double));
    x[3 * i + 2] = L - X[3 * i + 2];
  }
  e = ek_stab_shape_error(nv, X, x, w, size);
  check("shape: a mirrored body is not restored", e > EK_STAB_SHAPE_TOL, e);
  for (size_t i = 0; i < 3 * nv; i++)
    x[i] = centre[i % 3] + 1.03 * (X[i] - centre[i % 3]);
  e = ek_stab_shape_error(nv, X, x, w, size);
  check("shape: a 3% stretch is not restored", e > EK_STAB_SHAPE_TOL, e);
  for (size_t i = 0; i < 3 * nv; i++)
    x[i] = X[i] + 1e-3 * size * (2 * ek_rng_uniform(&rng) - 1) / sqrt(3.0);
  e = ek_stab_shape_error(nv, X, x, w, size);
  check("shape: noise of 1e-3 of the size is restored", e <= EK_STAB_SHAPE_TOL, e);
  x[5] = NAN;
  e = ek_stab_shape_error(nv, X, x, w, size);
  check("shape: NaN gives NaN", isnan(e), e);

  // ---- rest displacement ----
  for (int pass = 0; pass < 3; pass++) {
    double d = pass == 0 ? 1e-11 : 1e-7;
    memcpy(x, X, 3 * nv * sizeof(double));
    x[3 * (nv - 1)] += d * size;
    double disp = ek_stab_max_displacement(nv, X, x, size);
    if (pass == 2) {
      x[1] = NAN;
      disp = ek_stab_max_displacement(nv, X, x, size);
      check("rest: NaN is not at rest", !(disp <= ek_stab_rest_tol(32)), disp);
      continue;
    }
    check(pass == 0 ? "rest: 1e-11 drift is at rest in f64" : "rest: 1e-7 drift is not, in f64",
          (disp <= ek_stab_rest_tol(64)) == (pass == 0), disp);
    check(pass == 0 ? "rest: 1e-11 drift is at rest in f32" : "rest: 1e-7 drift is, in f32",
          disp <= ek_stab_rest_tol(32), disp);
    check("rest: the displacement is measured", fabs(disp / d - 1) < 1e-3, disp / d);
  }

  free(x);
  free(w);
  ek_check_box_destroy(&m);
  printf("test_stability_verdicts: %d failures\n", failures);
  return failures ? 1 : 0;
}
