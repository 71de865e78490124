// Membrane energy and (projected) Hessian product of a triangle mesh on
// AoSoA triangle blocks, written once against the vector API and built per
// (ISA x precision): the vector forms of the scalar double paths of
// cloth_force.c (ek_cloth_energy_f64, ek_cloth_hessian_apply_f64), checked
// against the double reference (reference/cloth_force/) in
// tests/test_cloth_force.c and ek-verify. Models and contract in
// include/ek/cloth_force.h, arguments in cloth_force_kernel.h.
//
// Per triangle (Teran et al. 2003 sec. 4 on a triangle; seed 003 eq. 2 in
// 3D): F = [x1-x0, x2-x0] Dm^-1 (3x2), and
//   energy:  A Psi(F);
//   Hessian: dF = [dx1-dx0, dx2-dx0] Dm^-1, g = A dP(F; dF) Dm^-T,
//            corners 1, 2 = g's columns, corner 0 = -(g1 + g2).
// StVK: Psi = mu E:E + lambda/2 tr(E)^2, dP = dF S + F dS; projected, S's
// negative eigenvalues are set to 0 in dF S. ARAP: Psi = mu sum (sigma_i -
// 1)^2 and dP = 2 mu (dF - dR) in the SVD frame of F (the 3x2 form of
// Smith et al. 2019's eigen-analysis; cloth_force.c states it), projected
// by clamping its twist and out-of-plane eigenvalues at 0. The SVD is the
// vectorised polar of kernels/elements/tri_polar_vec.h (the one ek_polar32
// runs).
//
// Padding lanes (area 0) read point 0 (F = 0): their results are set to 0
// (ARAP's 1 / sigma is infinite there).
#include <math.h>

#include "../simd/simd.h"

#include "../elements/tri_polar_vec.h"
#include "cloth_force_kernel.h"

#if defined(EK_REAL_F32)
typedef struct ek_cloth_force_args_f32 cloth_args;
#else
typedef struct ek_cloth_force_args_f64 cloth_args;
#endif

#define L EK_LANES

// F (or dF) = [p1-p0, p2-p0] Dm^-1 (3x2 row-major) from three gathered
// corners.
static inline void tri_F(const vreal p0[3], const vreal p1[3], const vreal p2[3], const vreal D[4],
                         vreal F[6]) {
  for (int i = 0; i < 3; i++) {
    vreal e1 = vsub(p1[i], p0[i]), e2 = vsub(p2[i], p0[i]);
    F[2 * i] = vadd(vmul(e1, D[0]), vmul(e2, D[2]));
    F[2 * i + 1] = vadd(vmul(e1, D[1]), vmul(e2, D[3]));
  }
}

// C = F^T F (its three entries).
static inline void tri_C(const vreal F[6], vreal *C00, vreal *C01, vreal *C11) {
  *C00 = vadd(vadd(vmul(F[0], F[0]), vmul(F[2], F[2])), vmul(F[4], F[4]));
  *C01 = vadd(vadd(vmul(F[0], F[1]), vmul(F[2], F[3])), vmul(F[4], F[5]));
  *C11 = vadd(vadd(vmul(F[1], F[1]), vmul(F[3], F[3])), vmul(F[5], F[5]));
}

// ---- Energy density -----------------------------------------------------
static inline vreal membrane_psi(const cloth_args *a, const vreal F[6]) {
  const vreal half = vset((real)0.5), one = vset(1), mu = vset(a->mu);
  if (a->model == EK_MEMBRANE_STVK) {
    vreal C00, C01, C11;
    tri_C(F, &C00, &C01, &C11);
    vreal E00 = vmul(half, vsub(C00, one)), E11 = vmul(half, vsub(C11, one));
    vreal E01 = vmul(half, C01), tr = vadd(E00, E11);
    // The double path's order: mu (E00^2 + E11^2 + 2 E01^2) + ((lambda /
    // 2) tr) tr (2 E01 E01 = 2 (E01 E01) exactly).
    vreal EE = vadd(vadd(vmul(E00, E00), vmul(E11, E11)), vmul(vset(2), vmul(E01, E01)));
    return vadd(vmul(mu, EE), vmul(vmul(vmul(half, vset(a->lambda)), tr), tr));
  }
  // ARAP: |F - R|^2 = sum (sigma_i - 1)^2.
  tri_svd_vec d;
  tri_svd32_vec(F, &d);
  vreal s0 = vsub(vmul(d.sigma1, d.s), one), s1 = vsub(vmul(d.sigma2, d.s), one);
  return vmul(mu, vadd(vmul(s0, s0), vmul(s1, s1)));
}

void EK_SYM(cloth_membrane_energy_block)(const cloth_args *a, size_t b0, size_t b1) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  for (size_t b = b0; b < b1; b++) {
    const int32_t *idx = a->tri_idx + b * 3 * L;
    const real *dm = a->dm_inv + b * 4 * L, *area = a->area + b * L;
    for (int o = 0; o < L; o += EK_W) {
      vreal p0[3], p1[3], p2[3];
      vmask pad = vgather_points(a->x, idx + o, p0);
      vgather_points(a->x, idx + L + o, p1);
      vgather_points(a->x, idx + 2 * L + o, p2);
      const vreal D[4] = {vload(dm + o), vload(dm + L + o), vload(dm + 2 * L + o),
                          vload(dm + 3 * L + o)};
      vreal F[6];
      tri_F(p0, p1, p2, D, F);
      vreal e = vmul(vload(area + o), membrane_psi(a, F));
      vstore(a->tri_energy + b * L + o, vsel(pad, vzero(), e));
    }
  }
  ek_fpmode_leave(mode);
}

// ---- Hessian product ----------------------------------------------------
// The projection's fast-lane test (membrane_dP): m in (PD_MIN, PD_MAX) so
// that m^2 neither underflows nor overflows, and m^2 (1 - PD_MARGIN) >=
// r^2, a margin far above the few-ulp rounding of the test and of hypot.
#if defined(EK_REAL_F32)
#define PD_MIN 1e-18f
#define PD_MAX 1e18f
#define PD_MARGIN 1e-5f
#define HYPOT hypotf
#else
#define PD_MIN 1e-150
#define PD_MAX 1e150
#define PD_MARGIN 1e-12
#define HYPOT hypot
#endif

// S's negative eigenvalues to 0, lane by lane where !pd, in the double
// path's operations (cloth_force.c membrane_dP): l0,1 = m +- r with r =
// hypot((S00 - S11) / 2, S01); l1 < 0 < l0: S+ = l0 / (l0 - l1) (S - l1 I),
// the projector onto l0's eigenvector scaled by l0; l0 <= 0: S+ = 0.
static void stvk_project_lanes(vmask pd, vreal *S00, vreal *S11, vreal *S01) {
  _Alignas(64) real a[EK_W], c[EK_W], b[EK_W], keep[EK_W];
  vstore(a, *S00), vstore(c, *S11), vstore(b, *S01);
  vstore(keep, vsel(pd, vset(1), vzero()));
  for (int l = 0; l < EK_W; l++) {
    if (keep[l] != 0)
      continue;
    real m = (real)0.5 * (a[l] + c[l]), r = HYPOT((real)0.5 * (a[l] - c[l]), b[l]);
    real l0 = m + r, l1 = m - r;
    if (l1 < 0) {
      if (l0 <= 0) {
        a[l] = c[l] = b[l] = 0;
      } else {
        real w = l0 / (l0 - l1);
        a[l] = w * (a[l] - l1), c[l] = w * (c[l] - l1), b[l] = w * b[l];
      }
    }
  }
  *S00 = vload(a), *S11 = vload(c), *S01 = vload(b);
}

// dP of one vector of triangles for dF, projected when a->project.
static inline void membrane_dP(const cloth_args *a, const vreal F[6], const vreal dF[6],
                               vreal dP[6]) {
  const vreal half = vset((real)0.5), one = vset(1), zero = vzero(), mu2 = vset(2 * a->mu);
  if (a->model == EK_MEMBRANE_STVK) {
    const vreal lam = vset(a->lambda);
    vreal C00, C01, C11;
    tri_C(F, &C00, &C01, &C11);
    vreal E00 = vmul(half, vsub(C00, one)), E11 = vmul(half, vsub(C11, one)), E01 = vmul(half, C01);
    vreal ltr = vmul(lam, vadd(E00, E11));
    vreal S00 = vadd(vmul(mu2, E00), ltr), S11 = vadd(vmul(mu2, E11), ltr), S01 = vmul(mu2, E01);
    if (a->project) {
      // S's negative eigenvalues to 0 (2x2 symmetric): lanes where S is
      // clearly positive definite keep it (l1 = m - r > 0 with a margin far
      // above the rounding of r, so the double path's l1 is >= 0 too); the
      // others take the double path's closed form lane by lane, with its
      // hypot (stvk_project_lanes), so the f64 product keeps its bits.
      vreal m = vmul(half, vadd(S00, S11)), dh = vmul(half, vsub(S00, S11));
      vreal r2 = vadd(vmul(dh, dh), vmul(S01, S01));
      vmask pd = vmand(vmand(vgt(m, vset(PD_MIN)), vlt(m, vset(PD_MAX))),
                       vge(vmul(vmul(m, m), vset(1 - PD_MARGIN)), r2));
      if (!vall(pd))
        stvk_project_lanes(pd, &S00, &S11, &S01);
    }
    // dE = sym(F^T dF), dS = 2 mu dE + lambda tr(dE) I.
    vreal G00 = vadd(vadd(vmul(F[0], dF[0]), vmul(F[2], dF[2])), vmul(F[4], dF[4]));
    vreal G01 = vadd(vadd(vmul(F[0], dF[1]), vmul(F[2], dF[3])), vmul(F[4], dF[5]));
    vreal G10 = vadd(vadd(vmul(F[1], dF[0]), vmul(F[3], dF[2])), vmul(F[5], dF[4]));
    vreal G11 = vadd(vadd(vmul(F[1], dF[1]), vmul(F[3], dF[3])), vmul(F[5], dF[5]));
    vreal dE01 = vmul(half, vadd(G01, G10)), dltr = vmul(lam, vadd(G00, G11));
    vreal dS00 = vadd(vmul(mu2, G00), dltr), dS11 = vadd(vmul(mu2, G11), dltr);
    vreal dS01 = vmul(mu2, dE01);
    for (int i = 0; i < 3; i++) {
      const vreal f0 = F[2 * i], f1 = F[2 * i + 1], d0 = dF[2 * i], d1 = dF[2 * i + 1];
      // Summed left to right, as the double path.
      dP[2 * i] = vadd(vadd(vadd(vmul(d0, S00), vmul(d1, S01)), vmul(f0, dS00)), vmul(f1, dS01));
      dP[2 * i + 1] =
          vadd(vadd(vadd(vmul(d0, S01), vmul(d1, S11)), vmul(f0, dS01)), vmul(f1, dS11));
    }
    return;
  }
  // ARAP: dP = 2 mu (dF - dR) = 2 mu [U (sym M + gt skew M) V^T +
  // n sum_b g_b w_b v_b^T], M = U^T dF V, w = n^T dF V, gt = 1 - 2 /
  // (sigma0 + sigma1), g_b = 1 - 1 / sigma_b (cloth_force.c).
  tri_svd_vec d;
  tri_svd32_vec(F, &d);
  vreal n[3];
  cross3(d.u1, d.u2, n);
  const vreal U[3][2] = {{d.u1[0], d.u2[0]}, {d.u1[1], d.u2[1]}, {d.u1[2], d.u2[2]}};
  const vreal V[2][2] = {{d.v1[0], d.v2[0]}, {d.v1[1], d.v2[1]}};
  vreal G[3][2]; // dF V
  for (int i = 0; i < 3; i++)
    for (int b = 0; b < 2; b++)
      G[i][b] = vadd(vmul(dF[2 * i], V[0][b]), vmul(dF[2 * i + 1], V[1][b]));
  vreal M[2][2], w[2];
  for (int b = 0; b < 2; b++) {
    for (int c = 0; c < 2; c++)
      M[c][b] = vadd(vadd(vmul(U[0][c], G[0][b]), vmul(U[1][c], G[1][b])), vmul(U[2][c], G[2][b]));
    w[b] = vadd(vadd(vmul(n[0], G[0][b]), vmul(n[1], G[1][b])), vmul(n[2], G[2][b]));
  }
  vreal sg0 = vmul(d.sigma1, d.s), sg1 = vmul(d.sigma2, d.s);
  vreal gt = vsub(one, vdiv(vset(2), vadd(sg0, sg1)));
  vreal g0 = vsub(one, vdiv(one, sg0)), g1 = vsub(one, vdiv(one, sg1));
  if (a->project) {
    gt = vmax(gt, zero);
    g0 = vmax(g0, zero);
    g1 = vmax(g1, zero);
  }
  vreal sym = vmul(half, vadd(M[0][1], M[1][0])), k = vmul(half, vsub(M[1][0], M[0][1]));
  const vreal N[2][2] = {{M[0][0], vsub(sym, vmul(gt, k))}, {vadd(sym, vmul(gt, k)), M[1][1]}};
  vreal gw0 = vmul(g0, w[0]), gw1 = vmul(g1, w[1]);
  for (int j = 0; j < 2; j++) {
    // H = N V^T (column j), and the out-of-plane term n (g w) . V row j.
    vreal H0 = vadd(vmul(N[0][0], V[j][0]), vmul(N[0][1], V[j][1]));
    vreal H1 = vadd(vmul(N[1][0], V[j][0]), vmul(N[1][1], V[j][1]));
    vreal out = vadd(vmul(gw0, V[j][0]), vmul(gw1, V[j][1]));
    for (int i = 0; i < 3; i++)
      dP[2 * i + j] = vmul(mu2, vadd(vadd(vmul(U[i][0], H0), vmul(U[i][1], H1)), vmul(n[i], out)));
  }
}

void EK_SYM(cloth_membrane_hessian_block)(const cloth_args *a, size_t b0, size_t b1) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  for (size_t b = b0; b < b1; b++) {
    const int32_t *idx = a->tri_idx + b * 3 * L;
    const real *dm = a->dm_inv + b * 4 * L, *area = a->area + b * L;
    real *out = a->tri_corner + b * 9 * L;
    for (int o = 0; o < L; o += EK_W) {
      vreal p[3][3], q[3][3];
      vmask pad = vgather_points(a->x, idx + o, p[0]);
      for (int c = 1; c < 3; c++)
        vgather_points(a->x, idx + c * L + o, p[c]);
      for (int c = 0; c < 3; c++)
        vgather_points(a->dx, idx + c * L + o, q[c]);
      const vreal D[4] = {vload(dm + o), vload(dm + L + o), vload(dm + 2 * L + o),
                          vload(dm + 3 * L + o)};
      vreal F[6], dF[6], dP[6];
      tri_F(p[0], p[1], p[2], D, F);
      tri_F(q[0], q[1], q[2], D, dF);
      membrane_dP(a, F, dF, dP);
      // g = A dP Dm^-T: g1 = A (dP0 D00 + dP1 D01), g2 = A (dP0 D10 + dP1 D11).
      const vreal A = vload(area + o), zero = vzero();
      for (int i = 0; i < 3; i++) {
        vreal g1 = vmul(A, vadd(vmul(dP[2 * i], D[0]), vmul(dP[2 * i + 1], D[1])));
        vreal g2 = vmul(A, vadd(vmul(dP[2 * i], D[2]), vmul(dP[2 * i + 1], D[3])));
        g1 = vsel(pad, zero, g1), g2 = vsel(pad, zero, g2);
        vstore(out + (3 + i) * L + o, g1);
        vstore(out + (6 + i) * L + o, g2);
        vstore(out + i * L + o, vneg(vadd(g1, g2)));
      }
    }
  }
  ek_fpmode_leave(mode);
}

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(cloth_membrane_block_fill)(ek_kernel_table *t);
void EK_SYM(cloth_membrane_block_fill)(ek_kernel_table *t) {
  t->EK_FIELD(cloth_membrane_energy_block) = EK_SYM(cloth_membrane_energy_block);
  t->EK_FIELD(cloth_membrane_hessian_block) = EK_SYM(cloth_membrane_hessian_block);
}
