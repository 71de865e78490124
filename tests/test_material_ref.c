// Invariants of the double material reference (reference/material/), per
// model, with and without the clamp:
//  - P equals central differences of psi, and dP equals central differences
//    of P (best step h in 1e-3..1e-6), within EK_MATERIAL_FD_TOL;
//  - the Hessian is symmetric: dP(A):B = dP(B):A;
//  - the projected Hessian is PSD, its eigenvalues are max(eig H, 0) and
//    H - H_proj is negative semi-definite (so it is exactly the eigen-clamp,
//    also for inverted F, i.e. reflected Sigma), and it equals H where H is
//    already PSD;
//  - rest: P(I) = 0, P(Q) = 0 for rotations (rotation-invariant models;
//    corotated linear with R = Q); rotation invariance P(QF) = Q P(F);
//  - at F = I, dP is linear elasticity with the model's (mu', lambda')
//    (include/ek/material.h);
//  - neo-Hookean without clamp: psi = +inf and P NaN for J <= 0; with the
//    clamp everything is finite, and a clamp below every singular value
//    changes nothing.
// Identities that hold exactly are held to EK_PK1_TOL_F64 in the norms of
// include/ek/material.h.
#include <ek/material.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "cli.h"
#include "material/material_ref.h"
#include "test_tolerances.h"

extern void dsyev_(const char *jobz, const char *uplo, const int *n, double *a, const int *lda,
                   double *w, double *work, const int *lwork, int *info);

// Random inputs from the shared check library (verify/check.h).
static ek_rng rng;
static double urange(double a, double b) { return a + (b - a) * ek_rng_uniform(&rng); }
static void mul(const double A[9], const double B[9], double C[9]) { ek_mul3(A, B, C); }
static void rotation(double Q[9]) { ek_rng_rotation(&rng, Q); }
static void from_sigma(const double s[3], double F[9]) { ek_rng_with_sigma(&rng, s, F); }
// Input kinds: 0 near identity, 1 large deformation, 2 inverted (one
// negative singular value, pairs kept away from sigma_i + sigma_j = 0).
enum { NEAR_ID, LARGE, INVERTED, KINDS };
static const char *const kind_names[KINDS] = {"near-identity", "large", "inverted"};
static void make_F(int kind, double F[9]) {
  if (kind == NEAR_ID) {
    for (int k = 0; k < 9; k++)
      F[k] = (k % 4 == 0) + urange(-0.2, 0.2);
    return;
  }
  double s[3];
  if (kind == LARGE)
    s[0] = urange(0.4, 2.5), s[1] = urange(0.4, 2.5), s[2] = urange(0.4, 2.5);
  else
    s[0] = urange(0.8, 2), s[1] = urange(0.8, 2), s[2] = -urange(0.1, 0.5);
  from_sigma(s, F);
}

static double amax(const double *a, int n) {
  double m = 0;
  for (int i = 0; i < n; i++)
    m = fmax(m, fabs(a[i]));
  return m;
}
static double scale_of(const double F[9]) { return fmax(1, amax(F, 9)); }

// ---- result table ----
static int failures;
typedef struct {
  const char *name;
  double worst, budget;
  long samples;
} check;
static void report(const char *model, check *c) {
  double r = c->worst / c->budget;
  const char *st = ek_verdict_name(ek_check_verdict(c->worst, c->budget));
  if (!(r <= 1))
    failures++;
  printf("  %-12s %-34s err %.3e  budget %.1e  err/budget %.3f  (%ld samples)  %s\n", model,
         c->name, c->worst, c->budget, r, c->samples, st);
}
static void note(check *c, double err, const char *model, const double F[9], const char *what) {
  c->samples++;
  if (!(err <= c->worst))
    c->worst = err; // NaN propagates as the worst
  if (!(err <= c->budget)) {
    printf("    FAIL %s %s: %s err %.3e at F =", model, c->name, what, err);
    for (int k = 0; k < 9; k++)
      printf(" %.17g", F[k]);
    printf("\n");
  }
}

// Eigenvalues (ascending) and vectors (column-major in A) of symmetric H.
static void eig9(const double H[81], double w[9], double A[81]) {
  memcpy(A, H, 81 * sizeof(double));
  int n = 9, lwork = 9 * 34, info;
  double work[9 * 34];
  dsyev_("V", "U", &n, A, &n, w, work, &lwork, &info);
  if (info)
    for (int k = 0; k < 9; k++)
      w[k] = NAN;
}

static int rotation_invariant(int model) {
  return model != EK_MODEL_LINEAR && model != EK_MODEL_COROTATED_LINEAR;
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  ek_rng_seed(&rng, seed);
  printf("test_material_ref --seed %llu\n", (unsigned long long)seed);
  const double mu = 1.3, lambda = 2.1, clamp_on = 0.3;
  const int trials = 12;
  const double steps[4] = {1e-3, 1e-4, 1e-5, 1e-6};

  for (int model = 0; model < EK_MODEL_COUNT; model++) {
    const char *name = ek_model_name((ek_model)model);
    check fdP = {"P vs central diff of psi", 0, EK_MATERIAL_FD_TOL, 0};
    check fddP = {"dP vs central diff of P", 0, EK_MATERIAL_FD_TOL, 0};
    check sym = {"symmetry dP(A):B = dP(B):A", 0, EK_PK1_TOL_F64, 0};
    check psd = {"projected H: PSD, eig-clamp", 0, EK_PK1_TOL_F64, 0};
    check same = {"projected H = H where H PSD", 0, EK_PK1_TOL_F64, 0};
    check rest = {"P(I) = 0, P(Q) = 0", 0, EK_PK1_TOL_F64, 0};
    check rot = {"P(QF) = Q P(F)", 0, EK_PK1_TOL_F64, 0};
    check lin = {"dP(I) = linear elasticity", 0, EK_PK1_TOL_F64, 0};
    check dom = {"domain: NaN/inf only J<=0 (NH)", 0, 0.5, 0};
    check clampc = {"clamp below all sigma: no change", 0, EK_PK1_TOL_F64, 0};
    const double pscale0 = mu + fabs(lambda);

    for (int with_clamp = 0; with_clamp < 2; with_clamp++) {
      ek_material_ref m = {model, mu, lambda, with_clamp ? clamp_on : 0};
      for (int kind = 0; kind < KINDS; kind++)
        for (int t = 0; t < trials; t++) {
          double F[9], R[9], P[9], H[81];
          make_F(kind, F);
          rotation(R);
          const double s = scale_of(F), pscale = pscale0 * s * s * s;
          int in_domain = !(model == EK_MODEL_NEO_HOOKEAN && !with_clamp && kind == INVERTED);
          // The clamp is active for an inverted F: psi is extended to first
          // order there, so P is its gradient only where nothing is clamped.
          int clamp_active =
              with_clamp && kind == INVERTED &&
              (model == EK_MODEL_FIXED_COROTATED || model == EK_MODEL_ARAP ||
               model == EK_MODEL_NEO_HOOKEAN || model == EK_MODEL_STABLE_NEO_HOOKEAN);
          ek_pk1_ref(&m, F, R, P);
          ek_hessian_ref(&m, F, R, H, 0);
          if (!in_domain) {
            double psi = ek_psi_ref(&m, F, R);
            int ok = psi == INFINITY && isnan(P[0]) && isnan(H[0]);
            note(&dom, ok ? 0 : 1, name, F, kind_names[kind]);
            continue;
          }
          int finite =
              isfinite(ek_psi_ref(&m, F, R)) && isfinite(amax(P, 9)) && isfinite(amax(H, 81));
          note(&dom, finite ? 0 : 1, name, F, kind_names[kind]);
          const double hscale = fmax(amax(H, 81), pscale0 * s * s);
          if (!clamp_active) {
            // P vs central differences of psi.
            double best = INFINITY;
            for (int h = 0; h < 4; h++) {
              double fd[9];
              for (int k = 0; k < 9; k++) {
                double Fp[9], Fm[9];
                memcpy(Fp, F, sizeof Fp), memcpy(Fm, F, sizeof Fm);
                Fp[k] += steps[h], Fm[k] -= steps[h];
                fd[k] = (ek_psi_ref(&m, Fp, R) - ek_psi_ref(&m, Fm, R)) / (2 * steps[h]);
              }
              double e = 0;
              for (int k = 0; k < 9; k++)
                e = fmax(e, fabs(fd[k] - P[k]));
              best = fmin(best, e / fmax(amax(P, 9), pscale));
            }
            note(&fdP, best, name, F, kind_names[kind]);
            // dP vs central differences of P along a random dF.
            double dF[9], dP[9];
            for (int k = 0; k < 9; k++)
              dF[k] = urange(-1, 1);
            ek_pk1_diff_ref(&m, F, R, dF, dP, 0);
            best = INFINITY;
            for (int h = 0; h < 4; h++) {
              double Fp[9], Fm[9], Pp[9], Pm[9], e = 0;
              for (int k = 0; k < 9; k++)
                Fp[k] = F[k] + steps[h] * dF[k], Fm[k] = F[k] - steps[h] * dF[k];
              ek_pk1_ref(&m, Fp, R, Pp);
              ek_pk1_ref(&m, Fm, R, Pm);
              for (int k = 0; k < 9; k++)
                e = fmax(e, fabs((Pp[k] - Pm[k]) / (2 * steps[h]) - dP[k]));
              best = fmin(best, e / fmax(amax(dP, 9), pscale0 * s * s * amax(dF, 9)));
            }
            note(&fddP, best, name, F, kind_names[kind]);
          }
          // Symmetry of dP.
          double A[9], B[9], dPA[9], dPB[9];
          for (int k = 0; k < 9; k++)
            A[k] = urange(-1, 1), B[k] = urange(-1, 1);
          ek_pk1_diff_ref(&m, F, R, A, dPA, 0);
          ek_pk1_diff_ref(&m, F, R, B, dPB, 0);
          double ab = 0, ba = 0;
          for (int k = 0; k < 9; k++)
            ab += dPA[k] * B[k], ba += dPB[k] * A[k];
          note(&sym, fabs(ab - ba) / (9 * hscale), name, F, kind_names[kind]);
          // Projection: eigenvalues of H_proj = max(eig H, 0); H - H_proj NSD.
          double Hp[81], D[81], w[9], wp[9], wd[9], V[81];
          ek_hessian_ref(&m, F, R, Hp, 1);
          for (int k = 0; k < 81; k++)
            D[k] = H[k] - Hp[k];
          for (int a = 0; a < 9; a++) // symmetrise H for dsyev (reads upper)
            for (int b = 0; b < a; b++)
              D[9 * a + b] = D[9 * b + a];
          eig9(H, w, V);
          eig9(Hp, wp, V);
          eig9(D, wd, V);
          double e = 0;
          for (int k = 0; k < 9; k++)
            e = fmax(e, fabs(wp[k] - fmax(w[k], 0)));
          e = fmax(e, fmax(wd[8], 0)); // H - H_proj has no positive eigenvalue
          note(&psd, e / hscale, name, F, kind_names[kind]);
          if (w[0] > EK_PK1_TOL_F64 * hscale) {
            double d = 0;
            for (int k = 0; k < 81; k++)
              d = fmax(d, fabs(D[k]));
            note(&same, d / hscale, name, F, kind_names[kind]);
          }
          // Rotation invariance P(QF) = Q P(F) (corotated linear: R -> QR).
          if (rotation_invariant(model) || model == EK_MODEL_COROTATED_LINEAR) {
            double Q[9], QF[9], QR[9], PQ[9], QP[9];
            rotation(Q);
            mul(Q, F, QF);
            mul(Q, R, QR);
            ek_pk1_ref(&m, QF, QR, PQ);
            mul(Q, P, QP);
            double d = 0;
            for (int k = 0; k < 9; k++)
              d = fmax(d, fabs(PQ[k] - QP[k]));
            note(&rot, d / fmax(amax(P, 9), pscale), name, F, kind_names[kind]);
          }
          // A clamp below every singular value changes nothing (non-inverted F).
          if (with_clamp && kind != INVERTED) {
            ek_material_ref m0 = m;
            m0.clamp = 0;
            double Pc[9], P0[9];
            ek_material_ref mc = m;
            mc.clamp = 0.05; // below the smallest singular value generated
            ek_pk1_ref(&mc, F, R, Pc);
            ek_pk1_ref(&m0, F, R, P0);
            double d = 0;
            for (int k = 0; k < 9; k++)
              d = fmax(d, fabs(Pc[k] - P0[k]));
            note(&clampc, d / fmax(amax(P0, 9), pscale), name, F, kind_names[kind]);
          }
        }
      // Rest: P(I) = 0 and P(Q) = 0.
      double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, P[9];
      ek_pk1_ref(&m, I, I, P);
      note(&rest, amax(P, 9) / pscale0, name, I, "F = I");
      for (int t = 0; t < trials; t++) {
        double Q[9];
        rotation(Q);
        if (!rotation_invariant(model) && model != EK_MODEL_COROTATED_LINEAR)
          continue;
        ek_pk1_ref(&m, Q, Q, P); // corotated linear reads R = Q
        note(&rest, amax(P, 9) / pscale0, name, Q, "F = Q");
      }
      // dP at I is linear elasticity with the model's (mu', lambda').
      double mu_l = mu, lambda_l = lambda;
      if (model == EK_MODEL_ARAP || model == EK_MODEL_PSI_R)
        lambda_l = 0;
      if (model == EK_MODEL_STABLE_NEO_HOOKEAN)
        mu_l = 0.75 * mu, lambda_l = lambda - 0.625 * mu;
      for (int t = 0; t < trials; t++) {
        double dF[9], dP[9], e = 0;
        for (int k = 0; k < 9; k++)
          dF[k] = urange(-1, 1);
        ek_pk1_diff_ref(&m, I, I, dF, dP, 0);
        double tr = dF[0] + dF[4] + dF[8];
        for (int i = 0; i < 3; i++)
          for (int j = 0; j < 3; j++)
            e = fmax(e, fabs(dP[3 * i + j] - (mu_l * (dF[3 * i + j] + dF[3 * j + i]) +
                                              (i == j ? lambda_l * tr : 0))));
        note(&lin, e / (pscale0 * amax(dF, 9)), name, I, "F = I");
      }
    }
    printf("%s\n", name);
    check *all[] = {&fdP, &fddP, &sym, &psd, &same, &rest, &rot, &lin, &dom, &clampc};
    for (size_t c = 0; c < sizeof all / sizeof *all; c++)
      if (all[c]->samples)
        report(name, all[c]);
  }
  printf("%s: %d check(s) failed\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
