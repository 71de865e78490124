// Internal to reference/: the per-model entry points (one file per model,
// HOBAK's psi / PK1 / hessian split) and small 3x3 helpers (also used by
// the fvm and xpbd references). All
// matrices row-major 3x3. The clamp and the projection live in
// material_ref.c, once for every model.
#ifndef EK_MODEL_REF_H
#define EK_MODEL_REF_H

#include <math.h>
#include <string.h>

typedef struct {
  double mu, lambda;
} ek_lame_ref;

// psi, P, and dP = (d^2 psi/dF^2) : dF (unprojected), for each model. R is the
// given rotation of corotated linear, ignored by the others.
#define EK_DECLARE_MODEL_REF(name)                                                                 \
  double name##_psi_ref(const ek_lame_ref *p, const double F[9], const double R[9]);               \
  void name##_P_ref(const ek_lame_ref *p, const double F[9], const double R[9], double P[9]);      \
  void name##_dP_ref(const ek_lame_ref *p, const double F[9], const double R[9],                   \
                     const double dF[9], double dP[9]);
EK_DECLARE_MODEL_REF(linear)
EK_DECLARE_MODEL_REF(stvk)
EK_DECLARE_MODEL_REF(corot_linear)
EK_DECLARE_MODEL_REF(fixed_corot)
EK_DECLARE_MODEL_REF(arap)
EK_DECLARE_MODEL_REF(psi_r)
EK_DECLARE_MODEL_REF(nh)
EK_DECLARE_MODEL_REF(snh)

// Shared by the models: polar rotation R(F) = U V^T (from ek_svd3_ref) and
// its differential dR(F; dF), in material_ref.c.
void ek_polar_rotation_ref(const double F[9], double R[9]);
void ek_polar_rotation_diff_ref(const double F[9], const double dF[9], double dR[9]);

static inline double m3_det(const double A[9]) {
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
         A[2] * (A[3] * A[7] - A[4] * A[6]);
}
// cof(A) = det(A) A^-T, a quadratic polynomial in A (so defined for all A).
static inline void m3_cof(const double A[9], double C[9]) {
  C[0] = A[4] * A[8] - A[5] * A[7];
  C[1] = A[5] * A[6] - A[3] * A[8];
  C[2] = A[3] * A[7] - A[4] * A[6];
  C[3] = A[2] * A[7] - A[1] * A[8];
  C[4] = A[0] * A[8] - A[2] * A[6];
  C[5] = A[1] * A[6] - A[0] * A[7];
  C[6] = A[1] * A[5] - A[2] * A[4];
  C[7] = A[2] * A[3] - A[0] * A[5];
  C[8] = A[0] * A[4] - A[1] * A[3];
}
// A^-1 = cof(A)^T / det A; returns det A.
static inline double m3_inverse(const double A[9], double Ai[9]) {
  double C[9];
  m3_cof(A, C);
  double det = A[0] * C[0] + A[1] * C[1] + A[2] * C[2];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      Ai[3 * i + j] = C[3 * j + i] / det;
  return det;
}
// d cof(A; dA): cof is quadratic, cof(A + dA) = cof A + D + cof dA with D
// bilinear, so D = cof(A + dA) - cof(A) - cof(dA) exactly (up to rounding,
// fine for an oracle compared at 1e-10).
static inline void m3_cof_diff(const double A[9], const double dA[9], double D[9]) {
  // Expanded bilinear form rather than the difference, to avoid cancellation.
  D[0] = A[4] * dA[8] + dA[4] * A[8] - A[5] * dA[7] - dA[5] * A[7];
  D[1] = A[5] * dA[6] + dA[5] * A[6] - A[3] * dA[8] - dA[3] * A[8];
  D[2] = A[3] * dA[7] + dA[3] * A[7] - A[4] * dA[6] - dA[4] * A[6];
  D[3] = A[2] * dA[7] + dA[2] * A[7] - A[1] * dA[8] - dA[1] * A[8];
  D[4] = A[0] * dA[8] + dA[0] * A[8] - A[2] * dA[6] - dA[2] * A[6];
  D[5] = A[1] * dA[6] + dA[1] * A[6] - A[0] * dA[7] - dA[0] * A[7];
  D[6] = A[1] * dA[5] + dA[1] * A[5] - A[2] * dA[4] - dA[2] * A[4];
  D[7] = A[2] * dA[3] + dA[2] * A[3] - A[0] * dA[5] - dA[0] * A[5];
  D[8] = A[0] * dA[4] + dA[0] * A[4] - A[1] * dA[3] - dA[1] * A[3];
}
static inline void m3_mul(const double A[9], const double B[9], double C[9]) {
  double T[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      T[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
  memcpy(C, T, sizeof T);
}
// C = A^T B
static inline void m3_mul_tn(const double A[9], const double B[9], double C[9]) {
  double T[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      T[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
  memcpy(C, T, sizeof T);
}
// C = A B^T
static inline void m3_mul_nt(const double A[9], const double B[9], double C[9]) {
  double T[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      T[3 * i + j] =
          A[3 * i] * B[3 * j] + A[3 * i + 1] * B[3 * j + 1] + A[3 * i + 2] * B[3 * j + 2];
  memcpy(C, T, sizeof T);
}
static inline double m3_ddot(const double A[9], const double B[9]) {
  double s = 0;
  for (int i = 0; i < 9; i++)
    s += A[i] * B[i];
  return s;
}
static inline double m3_trace(const double A[9]) { return A[0] + A[4] + A[8]; }

#endif
