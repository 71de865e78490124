// Cloth force kernels on AoSoA triangle and hinge blocks, written once
// against the vector API and built per (ISA x precision). Contract in
// cloth_force_kernel.h, the models in include/ek/cloth_force.h.
//
// Membrane, per triangle (Teran et al. 2003 sec. 4 on a triangle):
//   F = [x1-x0, x2-x0] Dm^-1 (3x2), P = dPsi/dF, h = -A P Dm^-T,
//   corners 1, 2 = h's columns, corner 0 = -(h1 + h2).
// Bending, per hinge (Bergou et al. 2006 sec. 4): s = sum_i k_i x_i,
//   corner i = -k_b k_i s (the gradient of k_b / 2 |s|^2).
#include "../simd/simd.h"

#include "../elements/tri_polar.h"
#include "cloth_force_kernel.h"

#if defined(EK_REAL_F32)
typedef struct ek_cloth_force_args_f32 cloth_args;
#else
typedef struct ek_cloth_force_args_f64 cloth_args;
#endif

#define L EK_LANES

// ARAP's R for lanes whose F is near rank-deficient (sigma1 / sigma0 below
// ~1/64), where the closed form below loses digits: the Jacobi polar of
// kernels/elements/tri_polar.h in double, lane by lane.
static void arap_R_slow(const vreal F[6], vmask slow, vreal R[6]) {
  _Alignas(64) real Fl[6][EK_W], Rl[6][EK_W], m[EK_W];
  for (int k = 0; k < 6; k++) {
    vstore(Fl[k], F[k]);
    vstore(Rl[k], R[k]);
  }
  vstore(m, vsel(slow, vset(1), vzero()));
  for (int l = 0; l < EK_W; l++) {
    if (m[l] == 0)
      continue;
    double Fd[6];
    for (int k = 0; k < 6; k++)
      Fd[k] = (double)Fl[k][l];
    cloth_svd32 d;
    cloth_svd32_of(Fd, &d);
    for (int k = 0; k < 6; k++)
      Rl[k][l] = (real)d.R[k];
  }
  for (int k = 0; k < 6; k++)
    R[k] = vload(Rl[k]);
}

// P (3x2 row-major, P[2i + j]) of one vector of triangles.
static inline void membrane_P(const cloth_args *a, const vreal F[6], vreal P[6]) {
  const vreal f0[3] = {F[0], F[2], F[4]}, f1[3] = {F[1], F[3], F[5]};
  vreal C00 = vmul(f0[0], f0[0]), C01 = vmul(f0[0], f1[0]), C11 = vmul(f1[0], f1[0]);
  for (int i = 1; i < 3; i++) {
    C00 = vmla(f0[i], f0[i], C00);
    C01 = vmla(f0[i], f1[i], C01);
    C11 = vmla(f1[i], f1[i], C11);
  }
  if (a->model == EK_MEMBRANE_STVK) {
    // S = 2 mu E + lambda tr(E) I, E = (C - I)/2; P = F S.
    const vreal half = vset((real)0.5), mu2 = vset(2 * a->mu), lam = vset(a->lambda);
    vreal E00 = vmul(half, vsub(C00, vset(1))), E11 = vmul(half, vsub(C11, vset(1)));
    vreal E01 = vmul(half, C01), ltr = vmul(lam, vadd(E00, E11));
    vreal S00 = vmla(mu2, E00, ltr), S11 = vmla(mu2, E11, ltr), S01 = vmul(mu2, E01);
    for (int i = 0; i < 3; i++) {
      P[2 * i] = vmla(f0[i], S00, vmul(f1[i], S01));
      P[2 * i + 1] = vmla(f0[i], S01, vmul(f1[i], S11));
    }
    return;
  }
  // ARAP: P = 2 mu (F - R). (This closed form, not the polar of
  // kernels/elements/tri_polar_vec.h, because the force's bits are every
  // ARAP scene's: cloth_drop.) R = F Uc^-1 with Uc = sqrt(C) in closed form:
  // sqrt(C) = (C + s I) / t, s = sqrt(det C), t = sqrt(tr C + 2 s) (the
  // Cayley-Hamilton square root of a 2x2 SPD matrix), so
  // R = F adj(C + s I) / (s t). s = |f0 x f1| (no cancellation).
  vreal cx = vsub(vmul(f0[1], f1[2]), vmul(f0[2], f1[1]));
  vreal cy = vsub(vmul(f0[2], f1[0]), vmul(f0[0], f1[2]));
  vreal cz = vsub(vmul(f0[0], f1[1]), vmul(f0[1], f1[0]));
  vreal s = vsqrt(vmla(cx, cx, vmla(cy, cy, vmul(cz, cz))));
  vreal tr = vadd(C00, C11);
  vreal t = vsqrt(vmla(vset(2), s, tr));
  vmask slow = vmnot(vge(s, vmul(vset((real)(1.0 / 64)), tr)));
  vreal inv = vdiv(vset(1), vmul(vsel(slow, vset(1), s), vsel(slow, vset(1), t)));
  vreal a00 = vadd(C11, s), a11 = vadd(C00, s), a01 = vneg(C01);
  vreal R[6];
  for (int i = 0; i < 3; i++) {
    R[2 * i] = vmul(vmla(f0[i], a00, vmul(f1[i], a01)), inv);
    R[2 * i + 1] = vmul(vmla(f0[i], a01, vmul(f1[i], a11)), inv);
  }
  if (vany(slow))
    arap_R_slow(F, slow, R);
  const vreal mu2 = vset(2 * a->mu);
  for (int k = 0; k < 6; k++)
    P[k] = vmul(mu2, vsub(F[k], R[k]));
}

void EK_SYM(cloth_membrane_block)(const cloth_args *a, size_t b0, size_t b1) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  for (size_t b = b0; b < b1; b++) {
    const int32_t *idx = a->tri_idx + b * 3 * L;
    const real *dm = a->dm_inv + b * 4 * L, *area = a->area + b * L;
    real *out = a->tri_corner + b * 9 * L;
    for (int o = 0; o < L; o += EK_W) {
      vreal p0[3], p1[3], p2[3];
      vgather_points(a->x, idx + o, p0);
      vgather_points(a->x, idx + L + o, p1);
      vgather_points(a->x, idx + 2 * L + o, p2);
      const vreal D00 = vload(dm + o), D01 = vload(dm + L + o), D10 = vload(dm + 2 * L + o),
                  D11 = vload(dm + 3 * L + o);
      // F = Ds Dm^-1, Ds = [x1 - x0, x2 - x0] (seed 003 eq. 2, in 3D).
      vreal F[6];
      for (int i = 0; i < 3; i++) {
        vreal e1 = vsub(p1[i], p0[i]), e2 = vsub(p2[i], p0[i]);
        F[2 * i] = vmla(e1, D00, vmul(e2, D10));
        F[2 * i + 1] = vmla(e1, D01, vmul(e2, D11));
      }
      vreal P[6];
      membrane_P(a, F, P);
      // h = -A P Dm^-T: h1 = -A (P0 D00 + P1 D01), h2 = -A (P0 D10 + P1 D11).
      const vreal nA = vneg(vload(area + o));
      for (int i = 0; i < 3; i++) {
        vreal h1 = vmul(nA, vmla(P[2 * i], D00, vmul(P[2 * i + 1], D01)));
        vreal h2 = vmul(nA, vmla(P[2 * i], D10, vmul(P[2 * i + 1], D11)));
        vstore(out + (3 + i) * L + o, h1);
        vstore(out + (6 + i) * L + o, h2);
        vstore(out + i * L + o, vneg(vadd(h1, h2)));
      }
    }
  }
  ek_fpmode_leave(mode);
}

void EK_SYM(cloth_bending_block)(const cloth_args *a, size_t b0, size_t b1) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  for (size_t b = b0; b < b1; b++) {
    const int32_t *idx = a->hinge_idx + b * 4 * L;
    const real *k = a->hinge_k + b * 4 * L;
    real *out = a->hinge_corner + b * 12 * L;
    for (int o = 0; o < L; o += EK_W) {
      vreal s[3] = {vzero(), vzero(), vzero()}, kc[4];
      for (int c = 0; c < 4; c++) {
        vreal p[3];
        vgather_points(a->x, idx + c * L + o, p);
        kc[c] = vload(k + c * L + o);
        for (int i = 0; i < 3; i++)
          s[i] = vmla(kc[c], p[i], s[i]);
      }
      const vreal nkb = vset(-a->bending);
      for (int i = 0; i < 3; i++) {
        vreal ns = vmul(nkb, s[i]);
        for (int c = 0; c < 4; c++)
          vstore(out + (c * 3 + i) * L + o, vmul(kc[c], ns));
      }
    }
  }
  ek_fpmode_leave(mode);
}

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(cloth_force_block_fill)(ek_kernel_table *t);
void EK_SYM(cloth_force_block_fill)(ek_kernel_table *t) {
  t->EK_FIELD(cloth_membrane_block) = EK_SYM(cloth_membrane_block);
  t->EK_FIELD(cloth_bending_block) = EK_SYM(cloth_bending_block);
}
