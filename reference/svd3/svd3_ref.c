// The 3x3 SVD oracle: LAPACK dgesvd (one-sided Householder bidiagonalisation
// and implicit QR, a different algorithm from the kernel's Jacobi, so it can
// catch the kernel's algorithmic errors), converted to ek's rotation-variant
// convention.
#include "svd3_ref.h"

#include <math.h>
#include <stdio.h>

// LAPACK's Fortran entry point (column-major; returns V^T, not V).
extern void dgesvd_(const char *jobu, const char *jobvt, const int *m, const int *n, double *a,
                    const int *lda, double *s, double *u, const int *ldu, double *vt,
                    const int *ldvt, double *work, const int *lwork, int *info);

static double det3(const double M[9]) {
  return M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) +
         M[2] * (M[3] * M[7] - M[4] * M[6]);
}

static void fill_nan(double *x, int n) {
  for (int i = 0; i < n; i++)
    x[i] = NAN;
}

int ek_svd3_ref(const double A[9], double U[9], double S[3], double V[9]) {
  for (int i = 0; i < 9; i++)
    if (!isfinite(A[i])) {
      fill_nan(U, 9), fill_nan(S, 3), fill_nan(V, 9);
      return -1;
    }
  // Row-major A -> column-major a: a[i + 3j] = A_ij.
  double a[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      a[i + 3 * j] = A[3 * i + j];
  const int three = 3, lwork = 64;
  double u[9], vt[9], work[64];
  int info = 0;
  dgesvd_("A", "A", &three, &three, a, &three, S, u, &three, vt, &three, work, &lwork, &info);
  if (info != 0) {
    fprintf(stderr, "ek_svd3_ref: dgesvd info = %d\n", info);
    fill_nan(U, 9), fill_nan(S, 3), fill_nan(V, 9);
    return -1;
  }
  // u is column-major: U_rc = u[r + 3c]. vt is column-major V^T:
  // (V^T)_cr = vt[c + 3r] = V_rc, so V row-major has vt's memory layout.
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) {
      U[3 * r + c] = u[r + 3 * c];
      V[3 * r + c] = vt[c + 3 * r];
    }
  // dgesvd gives S0 >= S1 >= S2 >= 0 and orthogonal U, V of either
  // determinant. A reflection is moved into the smallest singular value:
  // negating the last column of U (or V) and S2 leaves U diag(S) V^T
  // unchanged and makes that factor a rotation. Then det A = S0 S1 S2, so
  // S2 < 0 exactly when det A < 0.
  if (det3(U) < 0) {
    for (int r = 0; r < 3; r++)
      U[3 * r + 2] = -U[3 * r + 2];
    S[2] = -S[2];
  }
  if (det3(V) < 0) {
    for (int r = 0; r < 3; r++)
      V[3 * r + 2] = -V[3 * r + 2];
    S[2] = -S[2];
  }
  return 0;
}

int ek_polar3_ref(const double A[9], double R[9], double Ssym[9]) {
  double U[9], S[3], V[9];
  int rc = ek_svd3_ref(A, U, S, V);
  if (rc != 0) {
    fill_nan(R, 9);
    if (Ssym)
      fill_nan(Ssym, 9);
    return rc;
  }
  // R = U V^T; Ssym = V diag(S) V^T, so R Ssym = U diag(S) V^T = A.
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      double r = 0, s = 0;
      for (int k = 0; k < 3; k++) {
        r += U[3 * i + k] * V[3 * j + k];
        s += V[3 * i + k] * S[k] * V[3 * j + k];
      }
      R[3 * i + j] = r;
      if (Ssym)
        Ssym[3 * i + j] = s;
    }
  return 0;
}
