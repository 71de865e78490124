// Scalar double oracles for the cloth kernels (cloth_ref.h).
#include "cloth_ref.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

extern void dgesvd_(const char *jobu, const char *jobvt, const int *m, const int *n, double *a,
                    const int *lda, double *s, double *u, const int *ldu, double *vt,
                    const int *ldvt, double *work, const int *lwork, int *info);
extern void dsyev_(const char *jobz, const char *uplo, const int *n, double *a, const int *lda,
                   double *w, double *work, const int *lwork, int *info);
extern void dgesv_(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv, double *b,
                   const int *ldb, int *info);

static double dot3(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void fill_nan(double *a, int n) {
  for (int i = 0; i < n; i++)
    a[i] = NAN;
}

// ---- Rest frame by Gram-Schmidt -------------------------------------------
int ek_tri_rest_ref(const double X[9], double rel, double Dm_inv[4], double *area) {
  for (int i = 0; i < 9; i++)
    if (!isfinite(X[i]))
      return -1;
  double E1[3], E2[3], E3[3];
  for (int i = 0; i < 3; i++)
    E1[i] = X[3 + i] - X[i], E2[i] = X[6 + i] - X[i], E3[i] = X[6 + i] - X[3 + i];
  double l1 = sqrt(dot3(E1, E1));
  double lmax2 = fmax(dot3(E1, E1), fmax(dot3(E2, E2), dot3(E3, E3)));
  if (!(l1 > 0))
    return -1;
  double t1[3], r[3];
  for (int i = 0; i < 3; i++)
    t1[i] = E1[i] / l1;
  double m01 = dot3(E2, t1);
  for (int i = 0; i < 3; i++)
    r[i] = E2[i] - m01 * t1[i];
  double m11 = sqrt(dot3(r, r)); // E2.t2 with t2 = r / |r|
  double twoA = l1 * m11;
  if (!(twoA > rel * lmax2))
    return -1;
  // Dm = [[l1, m01], [0, m11]]: inverse = adj / det.
  double det = l1 * m11;
  Dm_inv[0] = m11 / det;
  Dm_inv[1] = -m01 / det;
  Dm_inv[2] = 0;
  Dm_inv[3] = l1 / det;
  if (area)
    *area = 0.5 * twoA;
  return 0;
}

void ek_tri_F_ref(const double x[9], const double Dm_inv[4], double F[6]) {
  for (int i = 0; i < 3; i++) {
    double e1 = x[3 + i] - x[i], e2 = x[6 + i] - x[i];
    F[2 * i] = e1 * Dm_inv[0] + e2 * Dm_inv[2];
    F[2 * i + 1] = e1 * Dm_inv[1] + e2 * Dm_inv[3];
  }
}

// ---- Polar decomposition of a 3x2 F by dgesvd -----------------------------
int ek_polar32_ref(const double F[6], double R[6], double Uc[4], double sigma[2]) {
  for (int i = 0; i < 6; i++)
    if (!isfinite(F[i])) {
      fill_nan(R, 6), fill_nan(Uc, 4), fill_nan(sigma, 2);
      return -1;
    }
  // Column-major 3x2 copy, scaled by the largest entry (so 1e+-300 and
  // subnormal F keep their precision inside dgesvd).
  double a[6], S[2], U[9], VT[4], work[64], scale = 0;
  for (int i = 0; i < 6; i++)
    scale = fmax(scale, fabs(F[i]));
  if (scale == 0)
    scale = 1;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 2; j++)
      a[i + 3 * j] = F[2 * i + j] / scale;
  int m = 3, n = 2, lwork = 64, info = 0;
  dgesvd_("A", "A", &m, &n, a, &m, S, U, &m, VT, &n, work, &lwork, &info);
  if (info != 0) {
    fprintf(stderr, "ek_polar32_ref: dgesvd info = %d\n", info);
    fill_nan(R, 6), fill_nan(Uc, 4), fill_nan(sigma, 2);
    return -1;
  }
  // U[i + 3 k] = U_ik, VT[k + 2 j] = (V^T)_kj = V_jk.
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 2; j++)
      R[2 * i + j] = U[i] * VT[2 * j] + U[i + 3] * VT[1 + 2 * j];
  for (int i = 0; i < 2; i++)
    for (int j = 0; j < 2; j++)
      Uc[2 * i + j] = (VT[2 * i] * S[0] * VT[2 * j] + VT[1 + 2 * i] * S[1] * VT[1 + 2 * j]) * scale;
  sigma[0] = S[0] * scale, sigma[1] = S[1] * scale;
  return 0;
}

// ---- The seed's route: eigen-decomposition of C by dsyev ------------------
int ek_polar_eig_ref(int rows, const double *F, double *R, double Uc[4], double sigma[2]) {
  double C[4] = {0, 0, 0, 0}, w[2], work[64];
  for (int i = 0; i < 2; i++)
    for (int j = 0; j < 2; j++)
      for (int k = 0; k < rows; k++)
        C[i + 2 * j] += F[2 * k + i] * F[2 * k + j];
  int n = 2, lwork = 64, info = 0;
  dsyev_("V", "U", &n, C, &n, w, work, &lwork, &info);
  if (info != 0) {
    fprintf(stderr, "ek_polar_eig_ref: dsyev info = %d\n", info);
    return -1;
  }
  // Ascending eigenvalues; eigenvector k is column k of C.
  double s[2], inv[4] = {0, 0, 0, 0};
  for (int k = 0; k < 2; k++)
    s[k] = sqrt(fmax(w[k], 0));
  sigma[0] = s[1], sigma[1] = s[0];
  for (int i = 0; i < 2; i++)
    for (int j = 0; j < 2; j++) {
      Uc[2 * i + j] = 0;
      for (int k = 0; k < 2; k++) {
        Uc[2 * i + j] += s[k] * C[i + 2 * k] * C[j + 2 * k];
        inv[2 * i + j] += C[i + 2 * k] * C[j + 2 * k] / s[k];
      }
    }
  for (int i = 0; i < rows; i++)
    for (int j = 0; j < 2; j++)
      R[2 * i + j] = s[0] > 0 ? F[2 * i] * inv[j] + F[2 * i + 1] * inv[2 + j] : NAN;
  return 0;
}

// ---- Kabsch by dgesvd -----------------------------------------------------
static void centroids(size_t n, const double *P, const double *Q, const double *w, double pbar[3],
                      double qbar[3]) {
  double sw = 0;
  for (int i = 0; i < 3; i++)
    pbar[i] = qbar[i] = 0;
  for (size_t k = 0; k < n; k++) {
    double wk = w ? w[k] : 1;
    sw += wk;
    for (int i = 0; i < 3; i++)
      pbar[i] += wk * P[3 * k + i], qbar[i] += wk * Q[3 * k + i];
  }
  for (int i = 0; i < 3; i++)
    if (sw > 0)
      pbar[i] /= sw, qbar[i] /= sw;
}

static double det3(const double *A) {
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
         A[2] * (A[3] * A[7] - A[4] * A[6]);
}

int ek_kabsch_ref(size_t n, const double *P, const double *Q, const double *w, double spread_eps,
                  double R[9], double s[3]) {
  double pbar[3], qbar[3], H[9] = {0};
  centroids(n, P, Q, w, pbar, qbar);
  for (size_t k = 0; k < n; k++) {
    double wk = w ? w[k] : 1;
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++)
        H[3 * i + j] += wk * (P[3 * k + i] - pbar[i]) * (Q[3 * k + j] - qbar[j]);
  }
  double hmax = 0, sp = 0, sq = 0, cp = 0, cq = 0;
  for (int i = 0; i < 9; i++)
    hmax = fmax(hmax, fabs(H[i]));
  for (int i = 0; i < 3; i++)
    cp = fmax(cp, fabs(pbar[i])), cq = fmax(cq, fabs(qbar[i]));
  for (size_t k = 0; k < n; k++)
    for (int i = 0; i < 3; i++)
      sp = fmax(sp, fabs(P[3 * k + i] - pbar[i])), sq = fmax(sq, fabs(Q[3 * k + i] - qbar[i]));
  if (!(hmax > 0) || !(sp > spread_eps * cp) || !(sq > spread_eps * cq)) {
    for (int i = 0; i < 9; i++)
      R[i] = i % 4 == 0;
    if (s)
      s[0] = s[1] = s[2] = 0;
    return 0;
  }
  double a[9], S[3], U[9], VT[9], work[128];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      a[i + 3 * j] = H[3 * i + j] / hmax;
  int three = 3, lwork = 128, info = 0;
  dgesvd_("A", "A", &three, &three, a, &three, S, U, &three, VT, &three, work, &lwork, &info);
  if (info != 0) {
    fprintf(stderr, "ek_kabsch_ref: dgesvd info = %d\n", info);
    fill_nan(R, 9);
    return -1;
  }
  // Row-major U and V: Ur[3 i + k] = U_ik, Vr[3 i + k] = V_ik.
  double Ur[9], Vr[9], VUt[9];
  for (int i = 0; i < 3; i++)
    for (int k = 0; k < 3; k++)
      Ur[3 * i + k] = U[i + 3 * k], Vr[3 * i + k] = VT[k + 3 * i];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      VUt[3 * i + j] =
          Vr[3 * i] * Ur[3 * j] + Vr[3 * i + 1] * Ur[3 * j + 1] + Vr[3 * i + 2] * Ur[3 * j + 2];
  double d = det3(VUt) < 0 ? -1 : 1; // seed 003 eq. 21's d = det(V U^T)
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      R[3 * i + j] =
          Vr[3 * i] * Ur[3 * j] + Vr[3 * i + 1] * Ur[3 * j + 1] + d * Vr[3 * i + 2] * Ur[3 * j + 2];
  if (s)
    s[0] = S[0] * hmax, s[1] = S[1] * hmax, s[2] = d * S[2] * hmax;
  return 0;
}

double ek_kabsch_objective_ref(size_t n, const double *P, const double *Q, const double *w,
                               const double R[9], double *size) {
  double pbar[3], qbar[3], e = 0, sz = 0;
  centroids(n, P, Q, w, pbar, qbar);
  for (size_t k = 0; k < n; k++) {
    double wk = w ? w[k] : 1, p[3], q[3];
    for (int i = 0; i < 3; i++)
      p[i] = P[3 * k + i] - pbar[i], q[i] = Q[3 * k + i] - qbar[i];
    for (int i = 0; i < 3; i++) {
      double r = R[3 * i] * p[0] + R[3 * i + 1] * p[1] + R[3 * i + 2] * p[2] - q[i];
      e += wk * r * r;
    }
    sz += wk * (dot3(p, p) + dot3(q, q));
  }
  if (size)
    *size = sz;
  return e;
}

// ---- Velocity gradients ---------------------------------------------------
int ek_tet_velgrad_ref(const double x[12], const double v[12], double L[9]) {
  // Ds^T L^T = Vs^T, column-major: A[i + 3 j] = (Ds^T)_ij = edge i's
  // coordinate j, B likewise with the velocity edges; X = L^T.
  double A[9], B[9];
  int ipiv[3], three = 3, info = 0;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      A[i + 3 * j] = x[3 * (i + 1) + j] - x[j];
      B[i + 3 * j] = v[3 * (i + 1) + j] - v[j];
    }
  dgesv_(&three, &three, A, &three, ipiv, B, &three, &info);
  if (info != 0) {
    fill_nan(L, 9);
    return -1;
  }
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      L[3 * j + i] = B[i + 3 * j];
  return 0;
}

int ek_tri_velgrad_ref(const double x[9], const double v[9], double rcond, double L[9]) {
  double a[6], S[2], U[9], VT[4], work[64];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 2; j++)
      a[i + 3 * j] = x[3 * (j + 1) + i] - x[i];
  int m = 3, n = 2, lwork = 64, info = 0;
  dgesvd_("A", "A", &m, &n, a, &m, S, U, &m, VT, &n, work, &lwork, &info);
  if (info != 0) {
    fill_nan(L, 9);
    return -1;
  }
  // Ds^+ = V diag(1/S) U^T (2x3), singular values <= rcond S[0] dropped.
  double pinv[6] = {0};
  for (int k = 0; k < 2; k++) {
    if (!(S[k] > rcond * S[0]) || S[k] == 0)
      continue;
    for (int i = 0; i < 2; i++)
      for (int j = 0; j < 3; j++)
        pinv[3 * i + j] += VT[k + 2 * i] * U[j + 3 * k] / S[k];
  }
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      double g1 = v[3 + i] - v[i], g2 = v[6 + i] - v[i];
      L[3 * i + j] = g1 * pinv[j] + g2 * pinv[3 + j];
    }
  return 0;
}

void ek_LDW_ref(const double L[9], double D[9], double W[9]) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      if (D)
        D[3 * i + j] = 0.5 * (L[3 * i + j] + L[3 * j + i]);
      if (W)
        W[3 * i + j] = 0.5 * (L[3 * i + j] - L[3 * j + i]);
    }
}
