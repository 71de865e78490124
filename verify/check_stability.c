// ek_check's stability verdicts (check_stability.h).
#include "check_stability.h"

#include <ek/cloth.h>
#include <math.h>
#include <stdlib.h>

int ek_stab_finite(size_t n, const double *x, const double center[3], double size) {
  double limit = EK_STAB_BLOWUP_FACTOR * size;
  for (size_t i = 0; i < n; i++)
    if (!isfinite(x[i]) || !(fabs(x[i] - center[i % 3]) <= limit))
      return 0;
  return 1;
}

static double tet_signed_volume(const int32_t *t, const double *x) {
  const double *a = x + 3 * t[0];
  double D[9]; // columns x1 - x0, x2 - x0, x3 - x0
  for (int c = 0; c < 3; c++)
    for (int k = 0; k < 3; k++)
      D[3 * k + c] = x[3 * t[c + 1] + k] - a[k];
  return (D[0] * (D[4] * D[8] - D[5] * D[7]) - D[1] * (D[3] * D[8] - D[5] * D[6]) +
          D[2] * (D[3] * D[7] - D[4] * D[6])) /
         6.0;
}

double ek_stab_volume(size_t nt, const int32_t *tets, const double *x) {
  double V = 0;
  for (size_t e = 0; e < nt; e++)
    V += tet_signed_volume(tets + 4 * e, x);
  return V;
}

size_t ek_stab_inverted(size_t nt, const int32_t *tets, const double *x) {
  size_t n = 0;
  for (size_t e = 0; e < nt; e++)
    n += !(tet_signed_volume(tets + 4 * e, x) > 0);
  return n;
}

int ek_stab_volume_recovered(double V, double V0, double tol) {
  return isfinite(V) && isfinite(V0) && V0 > 0 && fabs(V / V0 - 1.0) <= tol;
}

double ek_stab_shape_error(size_t nv, const double *X, const double *x, const double *w,
                           double size) {
  for (size_t i = 0; i < 3 * nv; i++)
    if (!isfinite(x[i]))
      return NAN;
  size_t offsets[2] = {0, nv};
  double R[9];
  if (nv == 0 || ek_kabsch_f64(1, offsets, X, x, w, R) != 0)
    return NAN;
  double Xbar[3] = {0, 0, 0}, xbar[3] = {0, 0, 0}, wsum = 0;
  for (size_t i = 0; i < nv; i++) {
    double wi = w ? w[i] : 1.0;
    wsum += wi;
    for (int k = 0; k < 3; k++) {
      Xbar[k] += wi * X[3 * i + k];
      xbar[k] += wi * x[3 * i + k];
    }
  }
  for (int k = 0; k < 3; k++) {
    Xbar[k] /= wsum;
    xbar[k] /= wsum;
  }
  double worst = 0;
  for (size_t i = 0; i < nv; i++) {
    double d[3], e2 = 0;
    for (int k = 0; k < 3; k++)
      d[k] = X[3 * i + k] - Xbar[k];
    for (int k = 0; k < 3; k++) {
      double r =
          R[3 * k] * d[0] + R[3 * k + 1] * d[1] + R[3 * k + 2] * d[2] + xbar[k] - x[3 * i + k];
      e2 += r * r;
    }
    worst = fmax(worst, sqrt(e2));
  }
  return worst / size;
}

double ek_stab_max_displacement(size_t nv, const double *X, const double *x, double size) {
  double worst = 0;
  for (size_t i = 0; i < nv; i++) {
    double e2 = 0;
    for (int k = 0; k < 3; k++)
      e2 += (x[3 * i + k] - X[3 * i + k]) * (x[3 * i + k] - X[3 * i + k]);
    if (isnan(e2))
      return NAN;
    worst = fmax(worst, sqrt(e2));
  }
  return worst / size;
}

double ek_stab_rest_tol(int precision) {
  return precision == 32 ? EK_STAB_REST_TOL_F32 : EK_STAB_REST_TOL_F64;
}
