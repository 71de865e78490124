// Plain double replica of the warm-started polar iteration; the steps and
// their sources are those of kernels/polar/polar_warm_core.h (same banners).
#include "polar_warm_ref.h"

#include <math.h>

// Step 1: the guess's quaternion, Shepperd 1978 (largest of c_0..c_3).
static void quat_from(const double R[9], double q[4]) {
  double tr = R[0] + R[4] + R[8];
  double c[4] = {1 + tr, 1 + 2 * R[0] - tr, 1 + 2 * R[4] - tr, 1 + 2 * R[8] - tr};
  double rows[4][4] = {
      {c[0], R[7] - R[5], R[2] - R[6], R[3] - R[1]},
      {R[7] - R[5], c[1], R[1] + R[3], R[2] + R[6]},
      {R[2] - R[6], R[1] + R[3], c[2], R[5] + R[7]},
      {R[3] - R[1], R[2] + R[6], R[5] + R[7], c[3]},
  };
  int k = 0;
  for (int i = 1; i < 4; i++)
    if (c[i] > c[k])
      k = i;
  for (int i = 0; i < 4; i++)
    q[i] = rows[k][i];
}

// |q|^2 R(q / |q|).
static void quat_matrix(const double q[4], double R[9]) {
  double w = q[0], x = q[1], y = q[2], z = q[3];
  R[0] = w * w + x * x - y * y - z * z;
  R[4] = w * w - x * x + y * y - z * z;
  R[8] = w * w - x * x - y * y + z * z;
  R[1] = 2 * (x * y - w * z), R[3] = 2 * (x * y + w * z);
  R[2] = 2 * (x * z + w * y), R[6] = 2 * (x * z - w * y);
  R[5] = 2 * (y * z - w * x), R[7] = 2 * (y * z + w * x);
}

// Step 2: one step from M = A R^T: Newton theta = H^-1 g where H = tr(M) I -
// sym(M) is positive definite, else Mueller's g / (|tr M| + eps); then
// q <- (1, theta / 2) (x) q.
static void step(const double M[9], double q[4]) {
  double g[3] = {M[7] - M[5], M[2] - M[6], M[3] - M[1]};
  double t = M[0] + M[4] + M[8];
  double H[3][3] = {{M[4] + M[8], -0.5 * (M[1] + M[3]), -0.5 * (M[2] + M[6])},
                    {0, M[0] + M[8], -0.5 * (M[5] + M[7])},
                    {0, 0, M[0] + M[4]}};
  H[1][0] = H[0][1], H[2][0] = H[0][2], H[2][1] = H[1][2];
  double adj[3][3];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      adj[i][j] = H[i1][j1] * H[i2][j2] - H[i1][j2] * H[i2][j1];
    }
  double det = H[0][0] * adj[0][0] + H[0][1] * adj[1][0] + H[0][2] * adj[2][0];
  double minor2 = H[0][0] * H[1][1] - H[0][1] * H[1][0];
  double v[3];
  if (H[0][0] > 0 && minor2 > 0 && det > 0) {
    for (int i = 0; i < 3; i++)
      v[i] = 0.5 * (adj[i][0] * g[0] + adj[i][1] * g[1] + adj[i][2] * g[2]) / det;
  } else {
    for (int i = 0; i < 3; i++)
      v[i] = 0.5 * g[i] / (fabs(t) + 1e-300);
  }
  double w = q[0], u[3] = {q[1], q[2], q[3]};
  q[0] = w - (v[0] * u[0] + v[1] * u[1] + v[2] * u[2]);
  q[1] = u[0] + w * v[0] + (v[1] * u[2] - v[2] * u[1]);
  q[2] = u[1] + w * v[1] + (v[2] * u[0] - v[0] * u[2]);
  q[3] = u[2] + w * v[2] + (v[0] * u[1] - v[1] * u[0]);
}

static void ART(const double A[9], const double R[9], double M[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      M[i * 3 + j] =
          A[i * 3] * R[j * 3] + A[i * 3 + 1] * R[j * 3 + 1] + A[i * 3 + 2] * R[j * 3 + 2];
}

int ek_polar_warm_ref(const double A_in[9], double R[9], int iters) {
  int finite = iters >= 1;
  for (int i = 0; i < 9; i++)
    finite = finite && isfinite(A_in[i]) && isfinite(R[i]);
  if (!finite) {
    for (int i = 0; i < 9; i++)
      R[i] = NAN;
    return -1;
  }
  // Step 0: scale A by 1 / max |a_ij|.
  double amax = 0, A[9], q[4], M[9];
  for (int i = 0; i < 9; i++)
    amax = fmax(amax, fabs(A_in[i]));
  for (int i = 0; i < 9; i++)
    A[i] = A_in[i] / (amax > 0 ? amax : 1);
  quat_from(R, q);
  ART(A, R, M);
  step(M, q);
  for (int it = 1; it < iters; it++) {
    double Rq[9], n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++)
      q[i] /= n; // the kernel's scale bound (an estimate there; the steps ignore the scale)
    quat_matrix(q, Rq);
    ART(A, Rq, M);
    step(M, q);
  }
  double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  quat_matrix(q, R);
  for (int i = 0; i < 9; i++)
    R[i] /= n2;
  return 0;
}
