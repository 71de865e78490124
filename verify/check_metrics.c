// Error metrics of one 3x3 SVD or polar decomposition against the LAPACK
// reference, and the PASS / MARGINAL / FAIL verdict (BLIS testsuite style).
#include <math.h>
#include <stdio.h>

#include "check.h"

// Largest |.| of the 9 entries of M - I (or of M when minus_identity = 0).
static double max_abs9(const double M[9], int minus_identity) {
  double e = 0;
  for (int i = 0; i < 9; i++)
    e = fmax(e, fabs(M[i] - (minus_identity && i % 4 == 0 ? 1.0 : 0.0)));
  return e;
}

// |Q^T Q - I|_max: Q has orthonormal columns.
static double orth_error(const double Q[9]) {
  double G[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      G[3 * i + j] = Q[i] * Q[j] + Q[3 + i] * Q[3 + j] + Q[6 + i] * Q[6 + j];
  return max_abs9(G, 1);
}

static int any_nonfinite(const double *x, int n) {
  for (int i = 0; i < n; i++)
    if (!isfinite(x[i]))
      return 1;
  return 0;
}

// The scale errors are measured against: s1 of the input, or 1 for the
// zero matrix (absolute errors, where nothing else is meaningful).
static double scale_of(const double S_ref[3]) { return S_ref[0] > 0 ? S_ref[0] : 1.0; }

void ek_check_svd3(const double A[9], const double U[9], const double S[3], const double V[9],
                   const double S_ref[3], double sign_margin, ek_svd3_metrics *m) {
  double s1 = scale_of(S_ref);
  m->nonfinite = any_nonfinite(U, 9) || any_nonfinite(S, 3) || any_nonfinite(V, 9);
  // Reconstruction U diag(S) V^T, summed in double.
  double US[9], USV[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      US[3 * i + j] = U[3 * i + j] * S[j];
  ek_mul3_bt(US, V, USV);
  double r = 0;
  for (int i = 0; i < 9; i++)
    r = fmax(r, fabs(A[i] - USV[i]));
  m->recon = r / s1;
  m->orth = fmax(orth_error(U), orth_error(V));
  m->det = fmax(fabs(ek_det3(U) - 1), fabs(ek_det3(V) - 1));
  double ds = 0;
  for (int k = 0; k < 3; k++)
    ds = fmax(ds, fabs(S[k] - S_ref[k]));
  m->sigma = ds / s1;
  m->order = fmax(0.0, fmax(S[1] - S[0], fabs(S[2]) - S[1])) / s1;
  m->sign_wrong = fabs(S_ref[2]) > sign_margin * s1 && (S[2] < 0) != (S_ref[2] < 0);
  if (m->nonfinite) {
    // fmax drops NaN; make sure a non-finite output shows in every metric.
    m->recon = m->orth = m->det = m->sigma = m->order = INFINITY;
  }
}

double ek_svd3_metrics_worst(const ek_svd3_metrics *m) {
  if (m->nonfinite || m->sign_wrong)
    return INFINITY;
  return fmax(fmax(fmax(m->recon, m->orth), fmax(m->det, m->sigma)), m->order);
}

// rdiff: the polar factor is only as well determined as the gap allows; a
// perturbation dA moves R by up to 2 |dA| / (s2 + s3) with signed s3
// (Higham, "Functions of Matrices", SIAM 2008, Thm. 8.9; Li 1995), so
// |R - R_ref| (s2 + s3) / (2 s1) is held to the same budget as |dA| / s1.
// Where s2 + s3 <= 0 (R not unique) it is not measured.
void ek_check_polar3(const double A[9], const double R[9], const double Ssym[9],
                     const double S_ref[3], const double R_ref[9], ek_polar3_metrics *m) {
  double s1 = scale_of(S_ref);
  m->nonfinite = any_nonfinite(R, 9) || (Ssym && any_nonfinite(Ssym, 9));
  m->orth = orth_error(R);
  m->det = fabs(ek_det3(R) - 1);
  m->recon = m->sym = 0;
  if (Ssym) {
    double RS[9];
    ek_mul3(R, Ssym, RS);
    for (int i = 0; i < 9; i++)
      m->recon = fmax(m->recon, fabs(A[i] - RS[i]));
    m->recon /= s1;
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++)
        m->sym = fmax(m->sym, fabs(Ssym[3 * i + j] - Ssym[3 * j + i]));
    m->sym /= s1;
  }
  double gap = S_ref[1] + S_ref[2];
  m->rdiff = 0;
  if (gap > 0) {
    double d = 0;
    for (int i = 0; i < 9; i++)
      d = fmax(d, fabs(R[i] - R_ref[i]));
    m->rdiff = d * gap / (2 * s1);
  }
  if (m->nonfinite)
    m->recon = m->orth = m->det = m->sym = m->rdiff = INFINITY;
}

double ek_polar3_metrics_worst(const ek_polar3_metrics *m) {
  if (m->nonfinite)
    return INFINITY;
  return fmax(fmax(fmax(m->recon, m->orth), fmax(m->det, m->sym)), m->rdiff);
}

ek_verdict ek_check_verdict(double err, double budget) {
  if (!(err <= budget)) // also NaN
    return EK_FAIL;
  return err > 0.5 * budget ? EK_MARGINAL : EK_PASS;
}

const char *ek_verdict_name(ek_verdict v) {
  return v == EK_PASS ? "PASS" : v == EK_MARGINAL ? "MARGINAL" : "FAIL";
}

int ek_check_report(const char *label, double err, double budget) {
  ek_verdict v = ek_check_verdict(err, budget);
  printf("%-58s err=%-11.4g budget=%-8.3g ratio=%-9.3g %s\n", label, err, budget, err / budget,
         ek_verdict_name(v));
  return v == EK_FAIL;
}
