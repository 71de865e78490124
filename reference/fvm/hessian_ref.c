// Reference Hessian product of the FVM energy, double, AoS: the
// differential of the force of fvm_ref.c with the material reference's
// (optionally projected) 9x9 Hessian. No cache, no frames, no reordering.
#include <math.h>
#include <string.h>

#include "fvm_ref.h"

void ek_fvm_hessian_apply_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                              const ek_material_ref *m, const double *R, const double *x,
                              const double *p, int project, double *y, double *yscale) {
  memset(y, 0, nverts * 3 * sizeof(double));
  if (yscale)
    memset(yscale, 0, nverts * 3 * sizeof(double));
  for (size_t e = 0; e < ntets; e++) {
    const int32_t *t = tets + e * 4;
    double F[9], Dm_inv[9], dDs[9], dF[9], dP[9];
    double V0 = ek_fvm_tet_F_ref(X, x, t, F, Dm_inv);
    for (int c = 0; c < 3; c++)
      for (int r = 0; r < 3; r++)
        dDs[r * 3 + c] = p[t[c + 1] * 3 + r] - p[t[0] * 3 + r];
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++)
        dF[i * 3 + j] = dDs[i * 3 + 0] * Dm_inv[0 * 3 + j] + dDs[i * 3 + 1] * Dm_inv[1 * 3 + j] +
                        dDs[i * 3 + 2] * Dm_inv[2 * 3 + j];
    ek_pk1_diff_ref(m, F, R ? R + e * 9 : NULL, dF, dP, project);
    // G = V0 dP Dm^-T: column c to vertex c + 1, minus their sum to vertex 0.
    for (int i = 0; i < 3; i++) {
      double g0 = 0;
      for (int c = 0; c < 3; c++) {
        double g = V0 * (dP[i * 3 + 0] * Dm_inv[c * 3 + 0] + dP[i * 3 + 1] * Dm_inv[c * 3 + 1] +
                         dP[i * 3 + 2] * Dm_inv[c * 3 + 2]);
        y[t[c + 1] * 3 + i] += g;
        g0 -= g;
        if (yscale) {
          yscale[t[c + 1] * 3 + i] += fabs(g);
          yscale[t[0] * 3 + i] += fabs(g);
        }
      }
      y[t[0] * 3 + i] += g0;
    }
  }
}

// Reference assembled Hessian, dense (3 nverts)^2, double: per tet the
// 12x12 element Hessian column by column (column (c, k): the element's
// product with the unit move of corner c along k, the loop above for one
// tet), added plainly into K. yscale-like: Kscale (may be NULL) gets the
// sum of the contributions' absolute values per entry.
void ek_fvm_hessian_assemble_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                                 const ek_material_ref *m, const double *R, const double *x,
                                 int project, double *K, double *Kscale) {
  const size_t n = 3 * nverts;
  memset(K, 0, n * n * sizeof(double));
  if (Kscale)
    memset(Kscale, 0, n * n * sizeof(double));
  for (size_t e = 0; e < ntets; e++) {
    const int32_t *t = tets + e * 4;
    double F[9], Dm_inv[9];
    double V0 = ek_fvm_tet_F_ref(X, x, t, F, Dm_inv);
    for (int c = 0; c < 4; c++)
      for (int k = 0; k < 3; k++) {
        // dDs of the unit move: column c - 1 (corner c >= 1) is e_k, or
        // every column is -e_k (corner 0).
        double dDs[9] = {0}, dF[9], dP[9];
        for (int j = 0; j < 3; j++)
          if (c == 0 || j == c - 1)
            dDs[k * 3 + j] = c == 0 ? -1 : 1;
        for (int i = 0; i < 3; i++)
          for (int j = 0; j < 3; j++)
            dF[i * 3 + j] = dDs[i * 3 + 0] * Dm_inv[0 * 3 + j] +
                            dDs[i * 3 + 1] * Dm_inv[1 * 3 + j] + dDs[i * 3 + 2] * Dm_inv[2 * 3 + j];
        ek_pk1_diff_ref(m, F, R ? R + e * 9 : NULL, dF, dP, project);
        const size_t colj = (size_t)t[c] * 3 + (size_t)k;
        for (int i = 0; i < 3; i++) {
          double g0 = 0;
          for (int d = 0; d < 3; d++) {
            double g = V0 * (dP[i * 3 + 0] * Dm_inv[d * 3 + 0] + dP[i * 3 + 1] * Dm_inv[d * 3 + 1] +
                             dP[i * 3 + 2] * Dm_inv[d * 3 + 2]);
            K[((size_t)t[d + 1] * 3 + (size_t)i) * n + colj] += g;
            g0 -= g;
            if (Kscale)
              Kscale[((size_t)t[d + 1] * 3 + (size_t)i) * n + colj] += fabs(g);
          }
          K[((size_t)t[0] * 3 + (size_t)i) * n + colj] += g0;
          if (Kscale)
            Kscale[((size_t)t[0] * 3 + (size_t)i) * n + colj] += fabs(g0);
        }
      }
  }
}
