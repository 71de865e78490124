// Invariant: the LAPACK reference ek_svd3_ref returns ek's rotation-variant
// SVD of A: U diag(S) V^T = A, U and V rotations (det +1), S0 >= S1 >= |S2|,
// S2 < 0 exactly when det A < 0, all to EK_SVD3_REF_TOL relative to s1, on
// random and every extremes family; a non-finite A gives rc -1 and NaN only.
// ek_polar3_ref gives a rotation R and symmetric Ssym with R Ssym = A.
// The scalar replica of the kernel's algorithm (ek_svd3_mcadams_ref) with
// the library's default knobs meets the kernel budgets against LAPACK.
//
// Usage: test_svd3_ref [--seed N]
#include <ek/svd3.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels/kernels.h" // ek_svd3_knobs: the library's default knobs
#include "check.h"
#include "cli.h"
#include "svd3/svd3_ref.h"

// The driver's defaults (kernels/svd3/svd3.c), so the replica runs the very
// knobs the kernels run.
ek_svd3_knobs ek_svd3_default_knobs_f32(void);
ek_svd3_knobs ek_svd3_default_knobs_f64(void);

enum { N_RANDOM = 20000, N_FAMILY = 1000 };

static int failures;

static void print_case(const double A[9], const double U[9], const double S[3], const double V[9],
                       const double S_ref[3]) {
  ek_print3("A", A);
  ek_print3("U", U);
  ek_print3("V", V);
  printf("  S          % .17g % .17g % .17g\n", S[0], S[1], S[2]);
  if (S_ref)
    printf("  S expected % .17g % .17g % .17g\n", S_ref[0], S_ref[1], S_ref[2]);
}

// LAPACK convention and accuracy on one set; returns the worst error.
static double check_lapack_set(const ek_svd3_set *s, const char *label) {
  double worst = 0;
  int shown = 0;
  for (size_t i = 0; i < s->n; i++) {
    const double *A = s->A + 9 * i;
    double U[9], S[3], V[9];
    int rc = ek_svd3_ref(A, U, S, V);
    if (!ek_check_finite9(A)) {
      int nan_out = 1;
      for (int k = 0; k < 9; k++)
        nan_out &= isnan(U[k]) && isnan(V[k]) && (k >= 3 || isnan(S[k]));
      if (rc != -1 || !nan_out) {
        printf("FAIL %s #%zu: non-finite input gave rc %d, outputs not all NaN\n", label, i, rc);
        print_case(A, U, S, V, NULL);
        failures++;
      }
      continue;
    }
    ek_svd3_metrics m;
    ek_check_svd3(A, U, S, V, S, EK_SVD3_REF_TOL, &m);
    // The sign rule against det A itself, where det A is clearly non-zero
    // (|det A| = s0 s1 |s2| > tol s0^3).
    double det = ek_det3(A), s1 = S[0] > 0 ? S[0] : 1;
    int sign_wrong = fabs(det) > EK_SVD3_REF_TOL * s1 * s1 * s1 && (S[2] < 0) != (det < 0);
    double w = rc != 0 || sign_wrong ? INFINITY : ek_svd3_metrics_worst(&m);
    if (w > EK_SVD3_REF_TOL && shown++ < 3) {
      printf("FAIL %s #%zu: rc %d recon %.3g orth %.3g det %.3g order %.3g sign_wrong %d "
             "(det A = %.6g)\n",
             label, i, rc, m.recon, m.orth, m.det, m.order, sign_wrong, det);
      print_case(A, U, S, V, NULL);
    }
    worst = fmax(worst, w);
  }
  return worst;
}

static double check_polar_set(const ek_svd3_set *s) {
  double worst = 0;
  for (size_t i = 0; i < s->n; i++) {
    if (s->bad[i])
      continue;
    const double *A = s->A + 9 * i;
    double R[9], P[9];
    ek_polar3_ref(A, R, P);
    ek_polar3_metrics m;
    ek_check_polar3(A, R, P, s->S_ref + 3 * i, s->R_ref + 9 * i, &m);
    worst = fmax(worst, ek_polar3_metrics_worst(&m));
  }
  return worst;
}

// The replica against LAPACK with the given knobs; returns the worst error.
static double check_replica_set(const ek_svd3_set *s, ek_svd3_knobs k, double budget,
                                const char *label) {
  double worst = 0;
  int shown = 0;
  for (size_t i = 0; i < s->n; i++) {
    const double *A = s->A + 9 * i;
    double U[9], S[3], V[9];
    int rc = ek_svd3_mcadams_ref(A, k.sweeps, k.refine, U, S, V);
    if (s->bad[i]) {
      if (rc != -1 || !isnan(S[0]) || !isnan(U[0]) || !isnan(V[8])) {
        printf("FAIL %s #%zu: replica on non-finite input: rc %d, outputs not NaN\n", label, i, rc);
        failures++;
      }
      continue;
    }
    ek_svd3_metrics m;
    ek_check_svd3(A, U, S, V, s->S_ref + 3 * i, budget, &m);
    double w = rc != 0 ? INFINITY : ek_svd3_metrics_worst(&m);
    if (w > budget && shown++ < 2) {
      printf("FAIL %s #%zu: replica recon %.3g orth %.3g det %.3g sigma %.3g sign_wrong %d\n",
             label, i, m.recon, m.orth, m.det, m.sigma, m.sign_wrong);
      print_case(A, U, S, V, s->S_ref + 3 * i);
    }
    worst = fmax(worst, w);
  }
  return worst;
}

// Exact answers: diagonal and permutation inputs, including the sign rule.
static void check_known(void) {
  static const struct {
    double A[9], S[3];
  } cases[] = {
      {{3, 0, 0, 0, -2, 0, 0, 0, 1}, {3, 2, -1}},
      {{1, 0, 0, 0, 2, 0, 0, 0, 3}, {3, 2, 1}},
      {{0, 0, 0, 0, 0, 0, 0, 0, 0}, {0, 0, 0}},
      {{0, 5, 0, 0, 0, 4, 3, 0, 0}, {5, 4, 3}},     // cyclic permutation, det +
      {{0, 5, 0, 4, 0, 0, 0, 0, 3}, {5, 4, -3}},    // transposition, det -
      {{-1, 0, 0, 0, -1, 0, 0, 0, -1}, {1, 1, -1}}, // -I
      {{2, 0, 0, 0, 2, 0, 0, 0, 0}, {2, 2, 0}},
  };
  double worst = 0;
  for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
    double U[9], S[3], V[9];
    ek_svd3_ref(cases[c].A, U, S, V);
    ek_svd3_metrics m;
    ek_check_svd3(cases[c].A, U, S, V, cases[c].S, EK_SVD3_REF_TOL, &m);
    double w = ek_svd3_metrics_worst(&m);
    if (w > EK_SVD3_REF_TOL) {
      printf("FAIL known case %zu:\n", c);
      print_case(cases[c].A, U, S, V, cases[c].S);
    }
    worst = fmax(worst, w);
  }
  failures +=
      ek_check_report("lapack known answers (diag, permutations, -I, 0)", worst, EK_SVD3_REF_TOL);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_svd3_ref: seed %llu\n", (unsigned long long)seed);
  check_known();
  ek_svd3_knobs k64 = ek_svd3_default_knobs_f64(), k32 = ek_svd3_default_knobs_f32();
  printf("replica knobs: f64 default sweeps %d refine %d; f32 default sweeps %d refine %d\n",
         k64.sweeps, k64.refine, k32.sweeps, k32.refine);
  for (int f = -1; f < ek_check_nfamilies; f++) {
    const ek_check_family *fam = &ek_check_families[f < 0 ? 0 : f];
    const char *name = f < 0 ? "random" : fam->name;
    ek_svd3_set s;
    ek_svd3_set_init(&s, fam, name, seed, f < 0 ? N_RANDOM : N_FAMILY, 64);
    char label[96];
    snprintf(label, sizeof label, "lapack %s", name);
    failures += ek_check_report(label, check_lapack_set(&s, label), EK_SVD3_REF_TOL);
    snprintf(label, sizeof label, "lapack polar %s", name);
    failures += ek_check_report(label, check_polar_set(&s), EK_SVD3_REF_TOL);
    snprintf(label, sizeof label, "replica f64-knobs %s", name);
    failures +=
        ek_check_report(label, check_replica_set(&s, k64, EK_SVD3_TOL_F64, label), EK_SVD3_TOL_F64);
    snprintf(label, sizeof label, "replica f32-knobs %s", name);
    failures +=
        ek_check_report(label, check_replica_set(&s, k32, EK_SVD3_TOL_F32, label), EK_SVD3_TOL_F32);
    ek_svd3_set_free(&s);
  }
  printf("test_svd3_ref: %s (%d failing checks)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
