// Invariant: the cloth references (reference/cloth/) are right on their own
// terms, before any kernel is compared with them, all to EK_CLOTH_REF_TOL
// relative to the input's scale:
//   - ek_tri_rest_ref: at rest F = [t1 t2] has orthonormal columns and
//     F Dm = the rest edges (the frame of cloth.h); degenerate triangles
//     give -1;
//   - ek_polar32_ref: R Uc = F, R^T R = I, Uc symmetric, on every polar32
//     family; ek_polar_eig_ref (the seed's eqs. 15-20) agrees with it where
//     sigma2 is well away from 0;
//   - ek_kabsch_ref: recovers the rotation of noise-free sets; a reflected
//     set gives det R = +1;
//   - velocity gradients (seed 003 eqs. 28-36): a rigid motion gives
//     D = 0 and W = [omega]x for tets, L = [omega]x P for triangles; a
//     stretch rate v_i = r_i x_i gives D = diag(r), W = 0;
//   - the seed's numeric example (eqs. 5-13, face 0): its 2x2 xy-projected
//     F and, next to it, the 3x2 F and its stretches.
//
// Usage: test_cloth_ref [--seed N]
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "check_cloth.h"
#include "cli.h"
#include "cloth/cloth_ref.h"
#include "svd3/svd3_ref.h"

enum { N = 2000 };

static int failures;

static void report(const char *label, double err, double budget) {
  failures += ek_check_report(label, err, budget);
}

static double max_abs(const double *a, int n) {
  double m = 0;
  for (int i = 0; i < n; i++)
    m = fmax(m, fabs(a[i]));
  return m;
}

static void rest_frame(uint64_t seed) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "rest"));
  double worst = 0;
  for (int t = 0; t < N; t++) {
    double X[9], Dm_inv[4], area, F[6];
    for (int i = 0; i < 9; i++)
      X[i] = ek_rng_gauss(&rng);
    if (ek_tri_rest_ref(X, 1e-12, Dm_inv, &area) != 0)
      continue;
    ek_tri_F_ref(X, Dm_inv, F);
    // F^T F = I.
    for (int a = 0; a < 2; a++)
      for (int b = 0; b < 2; b++)
        worst =
            fmax(worst, fabs(F[a] * F[b] + F[2 + a] * F[2 + b] + F[4 + a] * F[4 + b] - (a == b)));
    // Twice the area from the cross product.
    double e1[3], e2[3];
    for (int i = 0; i < 3; i++)
      e1[i] = X[3 + i] - X[i], e2[i] = X[6 + i] - X[i];
    double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    double twoA = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    worst = fmax(worst, fabs(2 * area - twoA) / twoA);
  }
  report("rest frame: |F^T F - I| at rest, area", worst, EK_CLOTH_REF_TOL);
  // Degenerate: repeated corner, collinear corners, NaN.
  double rep[9] = {0, 0, 0, 1, 0, 0, 1, 0, 0}, col[9] = {0, 0, 0, 1, 1, 1, 2, 2, 2},
         bad[9] = {0, 0, 0, 1, 0, 0, 0, NAN, 0}, Dm_inv[4] = {7, 7, 7, 7};
  int rc = ek_tri_rest_ref(rep, 1e-12, Dm_inv, NULL) + ek_tri_rest_ref(col, 1e-12, Dm_inv, NULL) +
           ek_tri_rest_ref(bad, 1e-12, Dm_inv, NULL);
  int untouched = Dm_inv[0] == 7 && Dm_inv[3] == 7;
  printf("rest frame: degenerate triangles refused: rc sum %d (want -3), Dm_inv untouched %d: %s\n",
         rc, untouched, rc == -3 && untouched ? "PASS" : "FAIL");
  failures += !(rc == -3 && untouched);
}

static void polar(uint64_t seed) {
  double *F = ek_check_malloc(6 * N * sizeof(double));
  for (int f = 0; f < ek_polar32_nfamilies; f++) {
    const ek_polar32_family *fam = &ek_polar32_families[f];
    if (fam->flags & EK_FAMILY_NONFINITE || !(fam->flags & EK_FAMILY_F64))
      continue;
    if (strstr(fam->name, "subnormal")) { // outputs ~1e-310 resolve only ~5e-14 of themselves
      printf("SKIP polar32_ref %s: outputs in the subnormal range resolve 5e-324 / 1e-310 = 5e-14 "
             "of their size, too coarse for %g (test_cloth compares the kernels with the "
             "reference there)\n",
             fam->name, EK_CLOTH_REF_TOL);
      continue;
    }
    ek_rng rng;
    ek_rng_seed(&rng, ek_check_stream_seed(seed, fam->name));
    fam->generate(&rng, N, F);
    double worst = 0, worst_eig = 0;
    for (int k = 0; k < N; k++) {
      double R[6], Uc[4], s[2], m[6] = {0};
      ek_polar32_ref(F + 6 * k, R, Uc, s);
      ek_polar32_metrics met;
      ek_check_polar32(F + 6 * k, R, Uc, R, Uc, s, &met);
      worst = fmax(worst, ek_polar32_metrics_worst(&met));
      // The seed's eigen route agrees where sigma2 / sigma1 > 1e-4, its R
      // weighted by (sigma2 / sigma1)^2 and Uc by sigma2 / sigma1 (C
      // squares the condition number: lambda2 carries ~eps lambda1).
      // Where C = F^T F is representable: sigma1^2 neither overflows nor
      // underflows (the 1e+-300 families are the seed route's failure).
      if (s[1] > 1e-4 * s[0] && s[0] < 1e150 && s[0] > 1e-150) {
        double R2[6], Uc2[4], s2[2], scale = s[0];
        ek_polar_eig_ref(3, F + 6 * k, R2, Uc2, s2);
        for (int i = 0; i < 6; i++)
          m[i] = fabs(R2[i] - R[i]) * (s[1] / s[0]) * (s[1] / s[0]);
        for (int i = 0; i < 4; i++)
          m[i] = fmax(m[i], fabs(Uc2[i] - Uc[i]) / scale * (s[1] / s[0]));
        worst_eig = fmax(worst_eig, max_abs(m, 6));
      }
    }
    char label[96];
    snprintf(label, sizeof label, "polar32_ref %-13s R Uc = F, R^T R = I", fam->name);
    report(label, worst, EK_CLOTH_REF_TOL);
    snprintf(label, sizeof label, "polar_eig_ref %-13s vs dgesvd, weighted", fam->name);
    report(label, worst_eig, EK_CLOTH_REF_TOL);
  }
  free(F);
}

static void kabsch(uint64_t seed) {
  const char *fams[] = {"exact", "reflected"};
  for (int f = 0; f < 2; f++) {
    ek_kabsch_set s;
    ek_kabsch_set_init(&s, fams[f], seed, 500, 64);
    double worst = 0, worst_det = 0;
    for (size_t k = 0; k < s.nsets; k++) {
      double R[9], sv[3];
      size_t k0 = s.offsets[k];
      ek_kabsch_ref(s.offsets[k + 1] - k0, s.P + 3 * k0, s.Q + 3 * k0, NULL,
                    ek_kabsch_spread_eps(64), R, sv);
      worst_det = fmax(worst_det, fabs(ek_det3(R) - 1));
      if (f == 0)
        for (int i = 0; i < 9; i++)
          worst = fmax(worst, fabs(R[i] - s.R_true[9 * k + i]) * (sv[1] + sv[2]) / sv[0]);
    }
    char label[96];
    snprintf(label, sizeof label, "kabsch_ref %-9s |det R - 1|", fams[f]);
    report(label, worst_det, EK_CLOTH_REF_TOL);
    if (f == 0)
      report("kabsch_ref exact     R = the rotation the set was made with", worst,
             EK_CLOTH_REF_TOL);
    ek_kabsch_set_free(&s);
  }
}

// [omega]x
static void spin(const double w[3], double S[9]) {
  double s[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0};
  memcpy(S, s, sizeof s);
}

static void velocity_gradients(uint64_t seed) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "velgrad"));
  double rigid_tet = 0, rigid_tri = 0, stretch_tet = 0, stretch_tri = 0;
  for (int e = 0; e < N; e++) {
    double x[12], v[12], w[3], c[3], r[3], L[9], D[9], W[9], S[9];
    for (int i = 0; i < 12; i++)
      x[i] = ek_rng_gauss(&rng);
    for (int i = 0; i < 3; i++)
      w[i] = ek_rng_gauss(&rng), c[i] = ek_rng_gauss(&rng), r[i] = ek_rng_gauss(&rng);
    spin(w, S);
    // Rigid: v = omega x x + c.
    for (int k = 0; k < 4; k++)
      for (int i = 0; i < 3; i++)
        v[3 * k + i] =
            S[3 * i] * x[3 * k] + S[3 * i + 1] * x[3 * k + 1] + S[3 * i + 2] * x[3 * k + 2] + c[i];
    // Relative to the rate times the tet's condition |Ds| |Ds^-1|.
    double Ds[9], Us[9], Ss[3], Vs[9];
    for (int k = 0; k < 3; k++)
      for (int i = 0; i < 3; i++)
        Ds[3 * i + k] = x[3 * (k + 1) + i] - x[i];
    ek_svd3_ref(Ds, Us, Ss, Vs);
    double cond = Ss[0] / fabs(Ss[2]);
    double scale = max_abs(w, 3) * cond;
    ek_tet_velgrad_ref(x, v, L);
    ek_LDW_ref(L, D, W);
    for (int i = 0; i < 9; i++)
      rigid_tet = fmax(rigid_tet, fmax(fabs(D[i]), fabs(W[i] - S[i])) / scale);
    // Triangle (the first 3 corners): L = [omega]x P, P = I - n n^T.
    ek_tri_velgrad_ref(x, v, 3 * 2.2e-16, L);
    double e1[3], e2[3], n[3];
    for (int i = 0; i < 3; i++)
      e1[i] = x[3 + i] - x[i], e2[i] = x[6 + i] - x[i];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1], n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int i = 0; i < 3; i++)
      n[i] /= nn;
    // The pseudo-inverse's error grows as the triangle's condition
    // (1 / sin of its angle at x0): weighted by sin, slivers skipped.
    double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    double l2 = sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
    if (nn > 1e-2 * l1 * l2)
      for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
          double SP =
              S[3 * i + j] - (S[3 * i] * n[0] + S[3 * i + 1] * n[1] + S[3 * i + 2] * n[2]) * n[j];
          rigid_tri = fmax(rigid_tri, fabs(L[3 * i + j] - SP) / scale * nn / (l1 * l2));
        }
    // Stretch rate: v_i = r_i x_i.
    for (int k = 0; k < 4; k++)
      for (int i = 0; i < 3; i++)
        v[3 * k + i] = r[i] * x[3 * k + i];
    ek_tet_velgrad_ref(x, v, L);
    ek_LDW_ref(L, D, W);
    double rs = max_abs(r, 3) * cond;
    for (int i = 0; i < 9; i++)
      stretch_tet =
          fmax(stretch_tet, fmax(fabs(D[i] - (i % 4 == 0 ? r[i / 4] : 0)), fabs(W[i])) / rs);
    // In-plane stretch of a triangle in the xy plane: D = diag(r1, r2, 0).
    double xt[9], vt[9];
    for (int k = 0; k < 3; k++) {
      xt[3 * k] = x[3 * k], xt[3 * k + 1] = x[3 * k + 1], xt[3 * k + 2] = 0;
      for (int i = 0; i < 3; i++)
        vt[3 * k + i] = r[i] * xt[3 * k + i];
    }
    ek_tri_velgrad_ref(xt, vt, 3 * 2.2e-16, L);
    ek_LDW_ref(L, D, W);
    double a1 = xt[3] - xt[0], a2 = xt[4] - xt[1], b1 = xt[6] - xt[0], b2 = xt[7] - xt[1];
    double sin_ = fabs(a1 * b2 - a2 * b1) / (sqrt(a1 * a1 + a2 * a2) * sqrt(b1 * b1 + b2 * b2));
    if (sin_ > 1e-2)
      for (int i = 0; i < 9; i++)
        stretch_tri = fmax(stretch_tri, fmax(fabs(D[i] - (i == 0   ? r[0]
                                                          : i == 4 ? r[1]
                                                                   : 0)),
                                             fabs(W[i])) /
                                            (rs / cond) * sin_);
  }
  report("tet L rigid: D = 0, W = [omega]x", rigid_tet, EK_CLOTH_REF_TOL);
  report("tri L rigid: L = [omega]x (I - n n^T)", rigid_tri, EK_CLOTH_REF_TOL);
  report("tet L stretch rate: D = diag(r), W = 0", stretch_tet, EK_CLOTH_REF_TOL);
  report("tri L in-plane stretch rate: D = diag(r1, r2, 0)", stretch_tri, EK_CLOTH_REF_TOL);
}

// ---- Seed 003's numeric example (eqs. 5-13, face 0) -----------------------
// Eqs. 5-8 list two configurations of face 0, "VertT" and "VertR"; eqs.
// 10-11 the edge vectors u1 = v1 - v2, u2 = v1 - v3 of each to 4 decimals;
// eq. 13 maps them to a 2x2 F by dropping z: F = [VecR]_xy [VecT]_xy^-1.
static void seed_example(void) {
  const double T[9] = {0.771842, -0.0144887, 6.39045,     0.780121, -0.0186188,
                       6.37318,  0.737177,   -0.00912791, 6.39292};
  const double Rv[9] = {0.759919, -0.015194, 6.38401,     0.767822, -0.0212492,
                        6.3669,   0.726977,  -0.00749985, 6.38692};
  const double VecT[6] = {-0.0079, 0.0061, 0.0171, 0.0329, -0.0077, -0.0029};
  const double VecR[6] = {-0.0083, 0.0041, 0.0173, 0.0347, -0.0054, -0.0025};
  // The differences of eqs. 5-6 (VertT) round to eq. 11 (VecR) and those of
  // eqs. 7-8 to eq. 10 (VecT): the seed's labels are swapped between the
  // slides. Checked to the 4 decimals the seed prints.
  double uT[6], uR[6], swap_err = 0;
  for (int i = 0; i < 3; i++) {
    uT[i] = T[i] - T[3 + i], uT[3 + i] = T[i] - T[6 + i];
    uR[i] = Rv[i] - Rv[3 + i], uR[3 + i] = Rv[i] - Rv[6 + i];
  }
  for (int i = 0; i < 6; i++)
    swap_err = fmax(swap_err, fmax(fabs(uT[i] - VecR[i]), fabs(uR[i] - VecT[i])));
  printf("seed eqs. 5-11: VertT's edges = VecR and VertR's = VecT (labels swapped): "
         "max |diff| %.2g <= 0.5e-4 (4 decimals): %s\n",
         swap_err, swap_err <= 0.5e-4 + 1e-12 ? "PASS" : "FAIL");
  failures += !(swap_err <= 0.5e-4 + 1e-12);
  // Eq. 13: F2 = A B^-1 from the printed vectors (x, y only), and from the
  // full-precision vertices; the printed ones are rounded to 0.5e-4, so
  // |dF2|_F <= (|dA|_F + |F2|_F |dB|_F) |B^-1|_F with |dA|_F, |dB|_F <= 1e-4.
  double F2[4], F2v[4];
  for (int pass = 0; pass < 2; pass++) {
    const double *a = pass ? uT : VecR, *b = pass ? uR : VecT;
    double A[4] = {a[0], a[3], a[1], a[4]}, B[4] = {b[0], b[3], b[1], b[4]};
    double det = B[0] * B[3] - B[1] * B[2];
    double Bi[4] = {B[3] / det, -B[1] / det, -B[2] / det, B[0] / det};
    double *out = pass ? F2v : F2;
    for (int i = 0; i < 2; i++)
      for (int j = 0; j < 2; j++)
        out[2 * i + j] = A[2 * i] * Bi[j] + A[2 * i + 1] * Bi[2 + j];
  }
  double nF = 0, d2 = 0, B[4] = {VecT[0], VecT[3], VecT[1], VecT[4]};
  double nBi = sqrt(B[0] * B[0] + B[1] * B[1] + B[2] * B[2] + B[3] * B[3]) /
               fabs(B[0] * B[3] - B[1] * B[2]); // |B^-1|_F = |B|_F / |det B| for 2x2
  for (int i = 0; i < 4; i++)
    nF += F2[i] * F2[i];
  double bound = (1e-4 + sqrt(nF) * 1e-4) * nBi;
  for (int i = 0; i < 4; i++)
    d2 += (F2[i] - F2v[i]) * (F2[i] - F2v[i]);
  printf("seed eq. 13: 2x2 F (printed vectors) = [[%.4f, %.4f], [%.4f, %.4f]]\n", F2[0], F2[1],
         F2[2], F2[3]);
  printf("seed eq. 13: 2x2 F (vertices)        = [[%.4f, %.4f], [%.4f, %.4f]]; |diff|_F %.3g <= "
         "rounding bound %.3g: %s\n",
         F2v[0], F2v[1], F2v[2], F2v[3], sqrt(d2), bound, sqrt(d2) <= bound ? "PASS" : "FAIL");
  failures += !(sqrt(d2) <= bound);
  // Next to it the 3x2 F: rest = VertR (whose edges are VecT), deformed =
  // VertT, in the rest triangle's own frame (ek_tri_rest_ref).
  double Dm_inv[4], area, F[6], R[6], Uc[4], s[2], s2[2], R2[6], Uc2[4];
  if (ek_tri_rest_ref(Rv, 1e-12, Dm_inv, &area) != 0) {
    printf("FAIL seed example: rest triangle refused\n");
    failures++;
    return;
  }
  ek_tri_F_ref(T, Dm_inv, F);
  ek_polar32_ref(F, R, Uc, s);
  ek_polar_eig_ref(2, F2v, R2, Uc2, s2);
  printf("seed example, 3x2 F = [[%.4f, %.4f], [%.4f, %.4f], [%.4f, %.4f]], stretches %.4f %.4f, "
         "J = area ratio %.4f\n",
         F[0], F[1], F[2], F[3], F[4], F[5], s[0], s[1], s[0] * s[1]);
  printf("seed example, 2x2 xy F stretches %.4f %.4f, J %.4f (det F2 = %.4f)\n", s2[0], s2[1],
         s2[0] * s2[1], F2v[0] * F2v[3] - F2v[1] * F2v[2]);
  // What the projection loses: each edge's length ratio |e| / |E| lies in
  // [sigma2, sigma1] of the 3x2 F (exactly: F maps the rest edges to the
  // deformed ones); the xy projection keeps only part of each edge.
  double worst_edge = 0;
  for (int k = 0; k < 2; k++) {
    double E = 0, e = 0, Exy = 0, exy = 0;
    for (int i = 0; i < 3; i++) {
      double dE = Rv[3 * (k + 1) + i] - Rv[i], de = T[3 * (k + 1) + i] - T[i];
      E += dE * dE, e += de * de;
      if (i < 2)
        Exy += dE * dE, exy += de * de;
    }
    double ratio = sqrt(e / E);
    double over = fmax(0, fmax(ratio - s[0], s[1] - ratio)) / s[0];
    worst_edge = fmax(worst_edge, over);
    printf("  edge %d: 3D length ratio %.4f (xy keeps %.0f%% of the rest edge's length, xy ratio "
           "%.4f)\n",
           k + 1, ratio, 100 * sqrt(Exy / E), sqrt(exy / Exy));
  }
  report("seed example: 3D edge ratios within the 3x2 stretches", worst_edge, EK_CLOTH_REF_TOL);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_cloth_ref: seed %llu\n", (unsigned long long)seed);
  rest_frame(seed);
  polar(seed);
  kabsch(seed);
  velocity_gradients(seed);
  seed_example();
  printf("%s (%d failing)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
