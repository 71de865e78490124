// Reference FVM force, double, AoS (Teran et al. 2003 sec. 4, seed 004).
#include "fvm_ref.h"

#include <math.h>
#include <string.h>

#include "material/model_ref.h"

// Edge matrix [p1-p0, p2-p0, p3-p0] as columns, row-major.
static void edge_matrix(const double *p, const int32_t t[4], double D[9]) {
  for (int c = 0; c < 3; c++)
    for (int r = 0; r < 3; r++)
      D[r * 3 + c] = p[t[c + 1] * 3 + r] - p[t[0] * 3 + r];
}

double ek_fvm_tet_F_ref(const double *X, const double *x, const int32_t tet[4], double F[9],
                        double Dm_inv[9]) {
  double Dm[9], Ds[9];
  edge_matrix(X, tet, Dm);
  edge_matrix(x, tet, Ds);
  double det = m3_inverse(Dm, Dm_inv);
  // F = Ds Dm^-1.
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      double s = 0;
      for (int k = 0; k < 3; k++)
        s += Ds[i * 3 + k] * Dm_inv[k * 3 + j];
      F[i * 3 + j] = s;
    }
  return fabs(det) / 6;
}

void ek_fvm_forces_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                       const ek_material_ref *m, const double *R, const double *x, double *f,
                       double *fscale) {
  memset(f, 0, nverts * 3 * sizeof(double));
  if (fscale)
    memset(fscale, 0, nverts * 3 * sizeof(double));
  for (size_t e = 0; e < ntets; e++) {
    const int32_t *t = tets + e * 4;
    double F[9], Dm_inv[9], P[9];
    double V0 = ek_fvm_tet_F_ref(X, x, t, F, Dm_inv);
    ek_pk1_ref(m, F, R ? R + e * 9 : NULL, P);
    // H = -V0 P Dm^-T; column c of H is the force on vertex c + 1, and
    // vertex 0 gets -(h1 + h2 + h3) (Teran et al. 2003 sec. 4).
    double H[9];
    for (int i = 0; i < 3; i++)
      for (int c = 0; c < 3; c++) {
        double s = 0;
        for (int k = 0; k < 3; k++)
          s += P[i * 3 + k] * Dm_inv[c * 3 + k];
        H[i * 3 + c] = -V0 * s;
      }
    for (int i = 0; i < 3; i++) {
      double h0 = 0;
      for (int c = 0; c < 3; c++) {
        f[t[c + 1] * 3 + i] += H[i * 3 + c];
        h0 -= H[i * 3 + c];
        if (fscale)
          fscale[t[c + 1] * 3 + i] += fabs(H[i * 3 + c]);
      }
      f[t[0] * 3 + i] += h0;
      if (fscale)
        fscale[t[0] * 3 + i] += fabs(H[i * 3 + 0]) + fabs(H[i * 3 + 1]) + fabs(H[i * 3 + 2]);
    }
  }
}

double ek_fvm_energy_ref(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                         const ek_material_ref *m, const double *R, const double *x) {
  (void)nverts;
  double E = 0;
  for (size_t e = 0; e < ntets; e++) {
    double F[9], Dm_inv[9];
    double V0 = ek_fvm_tet_F_ref(X, x, tets + e * 4, F, Dm_inv);
    E += V0 * ek_psi_ref(m, F, R ? R + e * 9 : NULL);
  }
  return E;
}
