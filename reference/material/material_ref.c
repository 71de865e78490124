// The material reference: switches by model, applies the clamp (Irving et
// al. 2004, sec. 5) and the PSD projection (explicit 9x9 Hessian, LAPACK
// dsyev, negative eigenvalues set to zero, reassembled). The kernels use
// the analytic U, V-frame eigensystem instead (Teran et al. 2005), so the
// two are different algorithms and the reference can catch kernel errors.
#include "material_ref.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "../svd3/svd3_ref.h"
#include "model_ref.h"

// LAPACK symmetric eigensolver (Fortran symbol).
extern void dsyev_(const char *jobz, const char *uplo, const int *n, double *a, const int *lda,
                   double *w, double *work, const int *lwork, int *info);

// Same numbering as ek_model in include/ek/material.h.
enum { LINEAR, STVK, COROT_LINEAR, FIXED_COROT, ARAP, PSI_R, NH, SNH, MODEL_COUNT };

typedef struct {
  double (*psi)(const ek_lame_ref *, const double *, const double *);
  void (*P)(const ek_lame_ref *, const double *, const double *, double *);
  void (*dP)(const ek_lame_ref *, const double *, const double *, const double *, double *);
  int clampable; // evaluated through singular values: the clamp applies
} model_entry;

static const model_entry models[MODEL_COUNT] = {
    [LINEAR] = {linear_psi_ref, linear_P_ref, linear_dP_ref, 0},
    [STVK] = {stvk_psi_ref, stvk_P_ref, stvk_dP_ref, 0},
    [COROT_LINEAR] = {corot_linear_psi_ref, corot_linear_P_ref, corot_linear_dP_ref, 0},
    [FIXED_COROT] = {fixed_corot_psi_ref, fixed_corot_P_ref, fixed_corot_dP_ref, 1},
    [ARAP] = {arap_psi_ref, arap_P_ref, arap_dP_ref, 1},
    [PSI_R] = {psi_r_psi_ref, psi_r_P_ref, psi_r_dP_ref, 0},
    [NH] = {nh_psi_ref, nh_P_ref, nh_dP_ref, 1},
    [SNH] = {snh_psi_ref, snh_P_ref, snh_dP_ref, 1},
};

static const model_entry *entry_of(const ek_material_ref *m) {
  if (m->model < 0 || m->model >= MODEL_COUNT) {
    fprintf(stderr, "material_ref: model %d is not an ek_model\n", m->model);
    return NULL;
  }
  return &models[m->model];
}

int ek_material_ref_model_count(void) { return MODEL_COUNT; }
int ek_material_ref_clampable(int m) {
  return m >= 0 && m < MODEL_COUNT ? models[m].clampable : -1;
}

void ek_polar_rotation_ref(const double F[9], double R[9]) { ek_polar3_ref(F, R, NULL); }

// dR of the polar rotation, F = R S (S symmetric): R^T dF - dF^T R = W S + S W
// with W = R^T dR skew; for W = [w]_x this is [(tr(S) I - S) w]_x, so
// w = (tr(S) I - S)^-1 axial(R^T dF - dF^T R) (derived here: dF = dR S + R dS with
// dS symmetric, and the identity for skew W and symmetric S). Singular where two signed singular
// values sum to zero, as R itself.
void ek_polar_rotation_diff_ref(const double F[9], const double dF[9], double dR[9]) {
  double R[9], S[9], RtdF[9];
  ek_polar3_ref(F, R, S);
  m3_mul_tn(R, dF, RtdF);
  double b[3] = {RtdF[7] - RtdF[5], RtdF[2] - RtdF[6], RtdF[3] - RtdF[1]};
  double M[9], Mc[9], trS = m3_trace(S);
  for (int k = 0; k < 9; k++)
    M[k] = (k % 4 == 0 ? trS : 0) - S[k];
  m3_cof(M, Mc); // M^-1 = cof(M)^T / det M (M symmetric, so cof(M)^T = cof(M))
  double detM = m3_det(M), w[3];
  for (int i = 0; i < 3; i++)
    w[i] = (Mc[3 * i] * b[0] + Mc[3 * i + 1] * b[1] + Mc[3 * i + 2] * b[2]) / detM;
  double W[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0};
  m3_mul(R, W, dR);
}

// The clamp (Irving et al. 2004, sec. 5): F_hat = U diag(max(sigma, c)) V^T.
// Returns 1 if some singular value was clamped (F_hat != F), else 0 and
// F_hat = F exactly. The SVD reference's convention is rotation-variant, so
// an inverted F has sigma_3 < 0 and is clamped to c.
static int clamped_F(const ek_material_ref *m, const model_entry *e, const double F[9],
                     double Fhat[9]) {
  memcpy(Fhat, F, 9 * sizeof(double));
  if (!e->clampable || !(m->clamp > 0))
    return 0;
  double U[9], S[3], V[9];
  if (ek_svd3_ref(F, U, S, V) != 0)
    return 0; // non-finite F: evaluated as is, NaN propagates
  if (S[0] >= m->clamp && S[1] >= m->clamp && S[2] >= m->clamp)
    return 0;
  for (int i = 0; i < 3; i++)
    S[i] = fmax(S[i], m->clamp);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      Fhat[3 * i + j] = U[3 * i] * S[0] * V[3 * j] + U[3 * i + 1] * S[1] * V[3 * j + 1] +
                        U[3 * i + 2] * S[2] * V[3 * j + 2];
  return 1;
}

static ek_lame_ref lame_of(const ek_material_ref *m) { return (ek_lame_ref){m->mu, m->lambda}; }

double ek_psi_ref(const ek_material_ref *m, const double F[9], const double R[9]) {
  const model_entry *e = entry_of(m);
  if (!e)
    return NAN;
  ek_lame_ref p = lame_of(m);
  double Fhat[9];
  if (!clamped_F(m, e, F, Fhat))
    return e->psi(&p, F, R);
  // Extended to first order past the clamp: psi(F_hat) + P(F_hat):(F - F_hat).
  double P[9], D[9];
  e->P(&p, Fhat, R, P);
  for (int k = 0; k < 9; k++)
    D[k] = F[k] - Fhat[k];
  return e->psi(&p, Fhat, R) + m3_ddot(P, D);
}

void ek_pk1_ref(const ek_material_ref *m, const double F[9], const double R[9], double P[9]) {
  const model_entry *e = entry_of(m);
  if (!e) {
    for (int k = 0; k < 9; k++)
      P[k] = NAN;
    return;
  }
  ek_lame_ref p = lame_of(m);
  double Fhat[9];
  clamped_F(m, e, F, Fhat);
  e->P(&p, Fhat, R, P);
}

void ek_hessian_ref(const ek_material_ref *m, const double F[9], const double R[9], double H[81],
                    int project) {
  const model_entry *e = entry_of(m);
  if (!e) {
    for (int k = 0; k < 81; k++)
      H[k] = NAN;
    return;
  }
  ek_lame_ref p = lame_of(m);
  double Fhat[9];
  clamped_F(m, e, F, Fhat);
  // Column b = dP(F; e_b).
  for (int b = 0; b < 9; b++) {
    double dF[9] = {0}, dP[9];
    dF[b] = 1;
    e->dP(&p, Fhat, R, dF, dP);
    for (int a = 0; a < 9; a++)
      H[9 * a + b] = dP[a];
  }
  if (!project)
    return;
  int finite = 1;
  for (int k = 0; k < 81; k++)
    finite &= isfinite(H[k]) != 0;
  if (!finite)
    return; // NaN in, NaN out: nothing to project
  // Symmetrise (H is symmetric up to rounding), eigendecompose, clamp (or
  // mirror) the negative eigenvalues, rebuild.
  double A[81], w[9], work[9 * 34];
  for (int a = 0; a < 9; a++)
    for (int b = 0; b < 9; b++)
      A[9 * a + b] = 0.5 * (H[9 * a + b] + H[9 * b + a]);
  int n = 9, lwork = 9 * 34, info = 0;
  dsyev_("V", "U", &n, A, &n, w, work, &lwork, &info);
  if (info != 0) {
    fprintf(stderr, "material_ref: dsyev failed (info %d)\n", info);
    for (int k = 0; k < 81; k++)
      H[k] = NAN;
    return;
  }
  // Column-major: eigenvector k is A[9 k .. 9 k + 8].
  for (int a = 0; a < 9; a++)
    for (int b = 0; b < 9; b++) {
      double s = 0;
      for (int k = 0; k < 9; k++)
        s += (project == 2 ? fabs(w[k]) : fmax(w[k], 0.0)) * A[9 * k + a] * A[9 * k + b];
      H[9 * a + b] = s;
    }
}

void ek_pk1_diff_ref(const ek_material_ref *m, const double F[9], const double R[9],
                     const double dF[9], double dP[9], int project) {
  double H[81];
  ek_hessian_ref(m, F, R, H, project);
  for (int a = 0; a < 9; a++) {
    double s = 0;
    for (int b = 0; b < 9; b++)
      s += H[9 * a + b] * dF[b];
    dP[a] = s;
  }
}
