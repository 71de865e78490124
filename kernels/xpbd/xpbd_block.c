// XPBD block kernel: the Hookean constraint of seed 001 (include/ek/xpbd.h)
// on AoSoA constraint blocks (layout in xpbd_kernel.h), written once against
// the vector API and built per (ISA x precision). Per constraint:
//   F = sum_{k>=1} (x_k - x_0) b_k^T         (Teran 2003 / seed 001)
//   W = mu e:e + lambda/2 tr(e)^2, P = F S    (StVK, kernels/material/families.h)
//   C = sqrt(2 W / E), g_k = P b_k / E, g_0 = -sum g_k, grad_k C = g_k / C
//   dlambda = -(C k + lambda) / (k sum_k wd_k |g_k|^2 / C^2 + 1), k = V E h^2
// (Macklin et al. 2016 eq. 18 multiplied through by k = 1 / alpha~, so a
// padding lane, k = 0, gives dlambda = -lambda = 0 with no infinity), and
// the correction x_k += w_k g_k dlambda / C. The loop is instantiated per
// operation and for tets (4 members, a compile-time constant) apart from
// clusters (nmem[b] members). The stable neo-Hookean pair (snh_blocks
// below) is the same loop with two constraints per element.
#include "../simd/simd.h"

#include "../material/families.h"
#include "xpbd_kernel.h"

#if defined(EK_REAL_F32)
typedef struct ek_xpbd_args_f32 xpbd_args;
#else
typedef struct ek_xpbd_args_f64 xpbd_args;
#endif

#define L EK_LANES

// Gauss-Seidel: add w_v * hb (member k, lane l) into x; lanes with s == 0
// (skipped or padding) are left alone, so a constraint at rest writes
// nothing.
static void scatter_block(const xpbd_args *a, const int32_t *idx, int K, const real *hb,
                          const real *s) {
  for (int l = 0; l < L; l++) {
    if (s[l] == 0)
      continue;
    for (int k = 0; k < K; k++) {
      const int32_t v = idx[k * L + l];
      if (v < 0)
        continue;
      const real wv = a->w[v];
      real *xv = a->x + 3 * (size_t)v;
      for (int d = 0; d < 3; d++)
        xv[d] += wv * hb[(k * 3 + d) * L + l];
    }
  }
}

// Member positions: x, or xb + x (displacements from a base); loads and a
// transpose where the target has them (vload_points: vgather_points'
// values).
#if defined(EK_HAVE_VLOAD_POINTS)
#define xpbd_points vload_points
#else
#define xpbd_points vgather_points
#endif
// raw (or NULL): x alone, for the in-register update below.
EK_INLINE vmask gather_member(const xpbd_args *a, const int32_t *idx, vreal p[3], vreal *raw) {
  const vmask pad = xpbd_points(a->x, idx, p);
  if (raw)
    for (int i = 0; i < 3; i++)
      raw[i] = p[i];
  if (a->xb) {
    vreal q[3];
    xpbd_points(a->xb, idx, q);
    for (int i = 0; i < 3; i++)
      p[i] = vadd(q[i], p[i]);
  }
  return pad;
}

// F of one vector of constraints (seed 001: F = sum_{k>=1} (x_k - x_0)
// b_k^T, differences first: no cancellation of large coordinates) from
// the member indices idx and rest vectors bv at the vector's lanes; with
// reg, the members' x as loaded into xo (the in-register update). Returns
// the padding lanes' mask.
EK_INLINE vmask members_F(const xpbd_args *a, const int32_t *idx, const real *bv, int K, int reg,
                          vreal x0[3], vreal F[9], vreal xo[4][3]) {
  const vmask pad = gather_member(a, idx, x0, reg ? xo[0] : NULL);
  for (int i = 0; i < 9; i++)
    F[i] = vzero();
  for (int k = 1; k < K; k++) {
    vreal xk[3], bk[3];
    gather_member(a, idx + k * L, xk, reg ? xo[k] : NULL);
    for (int j = 0; j < 3; j++)
      bk[j] = vload(bv + (k * 3 + j) * L);
    for (int i = 0; i < 3; i++) {
      const vreal d = vsub(xk[i], x0[i]);
      for (int j = 0; j < 3; j++)
        F[3 * i + j] = vfma(d, bk[j], F[3 * i + j]);
    }
  }
  return pad;
}

// XPBD_F_ONLY (xpbd_kernel.h): the sum of F's entries to sink, so that no
// part of F is dead code.
EK_INLINE void sink_F(real *sink, const vreal F[9]) {
  vreal t = F[0];
  for (int i = 1; i < 9; i++)
    t = vadd(t, F[i]);
  vstore(sink, t);
}

// Gauss-Seidel on tets where the target stores points from registers
// (vstore_points: AVX-512, AVX2): the members' x as loaded (a block's lanes
// share no vertex, so nothing else wrote them since), x + w (g s) per lane
// and member (scatter_block's operations: hb = g s, then x += w hb),
// stored for the lanes with s != 0; the stable neo-Hookean pair's x + w g
// for the lanes that are not padding (its s is 1 there).
#if defined(EK_HAVE_VSTORE_POINTS)
#define XPBD_REG_SCATTER 1
#define xpbd_store_points vstore_points
#else
#define XPBD_REG_SCATTER 0
EK_INLINE void xpbd_store_points(real *x, const int32_t *idx, vmask keep, const vreal p[3]) {
  (void)x, (void)idx, (void)keep, (void)p; // not called: XPBD_REG_SCATTER is 0
}
#endif

EK_INLINE void xpbd_blocks(int tets, int op, const xpbd_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[XPBD_MAX_MEMBERS * 3 * L];
  _Alignas(64) real sl[L];
  const vreal inv_young = vset(a->inv_young), h2 = vset(a->h2), c_min = vset(a->c_min);
  const vreal zero = vzero(), one = vset(1), two = vset(2), half_lam = vset((real)0.5 * a->lam),
              mu = vset(a->mu);
  for (size_t b = b0; b < b1; b++) {
    const int K = tets ? 4 : a->nmem[b];
    const size_t m0 = tets ? 4 * b : a->moff[b];
    const int32_t *idx = a->idx + m0 * L;
    const real *bv = a->bv + m0 * 3 * L;
    real *corr = a->corr ? a->corr + m0 * 3 * L : hb;
    for (int o = 0; o < L; o += EK_W) {
      const int reg = XPBD_REG_SCATTER && tets && op == XPBD_GS;
      vreal x0[3], F[9], xo[4][3], wk[4];
      const vmask pad = members_F(a, idx + o, bv + o, K, reg, x0, F, xo);
      if (op == XPBD_F_ONLY) {
        sink_F(a->sink + b * L + o, F);
        continue;
      }
      // W and P = F S (S = 2 mu e + lambda tr(e) I, e the Green strain).
      vreal E[9], S[9], P[9];
      stvk_green(F, E);
      stvk_second_pk(a->mu, a->lam, E, S);
      vm3_mul(F, S, P);
      const vreal tr = vadd(E[0], vadd(E[4], E[8]));
      const vreal W = vmla(mu, vm3_ddot(E, E), vmul(half_lam, vmul(tr, tr)));
      const vreal C = vsqrt(vmax(vmul(two, vmul(W, inv_young)), zero));
      const vmask active = vmand(vgt(C, c_min), vmnot(pad));
      const vreal lam_j = vload(a->lambda + b * L + o);
      const vreal kh2 = vmul(vload(a->stiff + b * L + o), h2);
      if (op == XPBD_RESIDUAL) {
        // |C + alpha~ lambda| = |C + lambda / k|; k > 0 on active lanes.
        const vreal r = vabs(vadd(C, vdiv(lam_j, vsel(active, kh2, one))));
        vstore(a->sink + (b * 2) * L + o, vsel(active, r, zero));
        vstore(a->sink + (b * 2 + 1) * L + o, vsel(active, C, zero));
        continue;
      }
      // g_k = P b_k / E (k >= 1), g_0 = -sum: written to corr (Jacobi) or
      // hb (Gauss-Seidel) and scaled in place below.
      vreal g0[3] = {zero, zero, zero}, dsum = zero;
      for (int k = 1; k < K; k++) {
        vreal bk[3];
        for (int j = 0; j < 3; j++)
          bk[j] = vload(bv + (k * 3 + j) * L + o);
        vreal n2 = zero;
        for (int i = 0; i < 3; i++) {
          vreal g = vmul(P[3 * i], bk[0]);
          g = vfma(P[3 * i + 1], bk[1], g);
          g = vfma(P[3 * i + 2], bk[2], g);
          g = vmul(g, inv_young);
          g0[i] = vsub(g0[i], g);
          n2 = vfma(g, g, n2);
          vstore(corr + (k * 3 + i) * L + o, g);
        }
        wk[k & 3] = vgather(a->wd, idx + k * L + o); // read for tets only (k < 4)
        dsum = vfma(wk[k & 3], n2, dsum);
      }
      vreal n2 = zero;
      for (int i = 0; i < 3; i++) {
        n2 = vfma(g0[i], g0[i], n2);
        vstore(corr + i * L + o, g0[i]);
      }
      wk[0] = vgather(a->wd, idx + o);
      dsum = vfma(wk[0], n2, dsum);
      const vreal inv_c = vdiv(one, vsel(active, C, one));
      const vreal num = vneg(vfma(C, kh2, lam_j));
      const vreal den = vfma(vmul(kh2, dsum), vmul(inv_c, inv_c), one);
      const vreal dl = vsel(active, vdiv(num, den), zero);
      if (op == XPBD_EVAL) {
        vstore(a->sink + b * L + o, dl);
        continue;
      }
      // The correction before its w_k: grad_k C dlambda = g_k dlambda / C.
      vstore(a->lambda + b * L + o, vadd(lam_j, dl));
      const vreal s = vmul(dl, inv_c);
      if (reg) { // wd is w for Gauss-Seidel
        const vmask keep = vmnot(veq(s, zero));
        for (int k = 0; k < 4; k++) {
          vreal xn[3];
          for (int i = 0; i < 3; i++)
            xn[i] = vadd(xo[k][i], vmul(wk[k], vmul(vload(corr + (k * 3 + i) * L + o), s)));
          xpbd_store_points(a->x, idx + k * L + o, keep, xn);
        }
        continue;
      }
      vstore(sl + o, s);
      for (int k = 0; k < K; k++)
        for (int i = 0; i < 3; i++) {
          real *c = corr + (k * 3 + i) * L + o;
          vstore(c, vmul(vload(c), s));
        }
    }
    if (op == XPBD_GS && !(XPBD_REG_SCATTER && tets))
      scatter_block(a, idx, K, hb, sl);
  }
}

// The stable neo-Hookean pair (include/ek/xpbd.h; Macklin & Mueller 2021)
// per element, from the same F:
//   C_D = sqrt(I_C - log(1 + I_C)), dC_D/dF = I_C / ((1 + I_C) C_D) F,
//   C_H = J - a,                    dC_H/dF = cof F,
// k_D = V mu h^2, k_H = V lambda h^2 (1 / alpha~), gD_k = dC_D/dF b_k,
// gH_k = cof F b_k, A_XY = sum_k wd_k gX_k . gY_k (member 0's g = -sum),
// and the coupled 2x2 solve (each row multiplied by its k, as above):
//   [k_D A_DD + 1, k_D A_DH; k_H A_DH, k_H A_HH + 1] dl = -[k_D C_D +
//   lambda_D; k_H C_H + lambda_H]
// by Cramer's rule (the determinant is k_D k_H det(G W G^T + alpha~) > 0,
// and 1 on a padding lane, whose k are 0), then x_k += w_k (dl_D dC_D/dF +
// dl_H cof F) b_k. C_D <= c_min (F ~ 0: a body crushed to a point) drops
// C_D's gradient (0/0); C_H has none to drop.
EK_INLINE void snh_blocks(int tets, int op, const xpbd_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[XPBD_MAX_MEMBERS * 3 * L];
  _Alignas(64) real sl[L];
  const vreal h2 = vset(a->h2), c_min = vset(a->c_min), shift = vset(a->rest_shift);
  const vreal zero = vzero(), one = vset(1), mu = vset(a->mu), lam = vset(a->lam);
  for (size_t b = b0; b < b1; b++) {
    const int K = tets ? 4 : a->nmem[b];
    const size_t m0 = tets ? 4 * b : a->moff[b];
    const int32_t *idx = a->idx + m0 * L;
    const real *bv = a->bv + m0 * 3 * L;
    real *corr = a->corr ? a->corr + m0 * 3 * L : hb;
    for (int o = 0; o < L; o += EK_W) {
      const int reg = XPBD_REG_SCATTER && tets && op == XPBD_GS;
      vreal x0[3], F[9], xo[4][3], wk[4];
      const vmask pad = members_F(a, idx + o, bv + o, K, reg, x0, F, xo);
      if (op == XPBD_F_ONLY) {
        sink_F(a->sink + b * L + o, F);
        continue;
      }
      vreal cof[9];
      vm3_cof(F, cof);
      const vreal CH = vsub(vm3_det_cof(F, cof), shift);
      const vreal Ic = vm3_ddot(F, F), Ic1 = vadd(Ic, one);
      const vreal CD = vsqrt(vmax(vsub(Ic, vlog(Ic1)), zero));
      const vmask live = vmand(vgt(CD, c_min), vmnot(pad));
      const vreal sD = vsel(live, vdiv(Ic, vmul(Ic1, vsel(live, CD, one))), zero);
      const vreal lD = vload(a->lambda + b * L + o), lH = vload(a->lambda_h + b * L + o);
      const vreal V = vload(a->stiff + b * L + o);
      const vreal kD = vmul(vmul(V, mu), h2), kH = vmul(vmul(V, lam), h2);
      if (op == XPBD_RESIDUAL) {
        const vmask act = vmnot(pad);
        const vreal rD = vabs(vadd(CD, vdiv(lD, vsel(act, kD, one))));
        const vreal rH = vabs(vadd(CH, vdiv(lH, vsel(act, kH, one))));
        vstore(a->sink + (b * 2) * L + o, vsel(act, vmax(rD, rH), zero));
        vstore(a->sink + (b * 2 + 1) * L + o, vsel(act, vabs(CH), zero));
        continue;
      }
      vreal PD[9];
      for (int i = 0; i < 9; i++)
        PD[i] = vmul(sD, F[i]);
      vreal gD0[3] = {zero, zero, zero}, gH0[3] = {zero, zero, zero};
      vreal add = zero, ahh = zero, adh = zero;
      for (int k = 1; k < K; k++) {
        vreal bk[3];
        for (int j = 0; j < 3; j++)
          bk[j] = vload(bv + (k * 3 + j) * L + o);
        vreal dd = zero, hh = zero, dh = zero;
        for (int i = 0; i < 3; i++) {
          vreal gd = vmul(PD[3 * i], bk[0]);
          gd = vfma(PD[3 * i + 1], bk[1], gd);
          gd = vfma(PD[3 * i + 2], bk[2], gd);
          vreal gh = vmul(cof[3 * i], bk[0]);
          gh = vfma(cof[3 * i + 1], bk[1], gh);
          gh = vfma(cof[3 * i + 2], bk[2], gh);
          gD0[i] = vsub(gD0[i], gd);
          gH0[i] = vsub(gH0[i], gh);
          dd = vfma(gd, gd, dd);
          hh = vfma(gh, gh, hh);
          dh = vfma(gd, gh, dh);
        }
        wk[k & 3] = vgather(a->wd, idx + k * L + o); // read for tets only (k < 4)
        add = vfma(wk[k & 3], dd, add);
        ahh = vfma(wk[k & 3], hh, ahh);
        adh = vfma(wk[k & 3], dh, adh);
      }
      {
        vreal dd = zero, hh = zero, dh = zero;
        for (int i = 0; i < 3; i++) {
          dd = vfma(gD0[i], gD0[i], dd);
          hh = vfma(gH0[i], gH0[i], hh);
          dh = vfma(gD0[i], gH0[i], dh);
        }
        wk[0] = vgather(a->wd, idx + o);
        add = vfma(wk[0], dd, add);
        ahh = vfma(wk[0], hh, ahh);
        adh = vfma(wk[0], dh, adh);
      }
      const vreal m11 = vfma(kD, add, one), m12 = vmul(kD, adh);
      const vreal m21 = vmul(kH, adh), m22 = vfma(kH, ahh, one);
      const vreal r1 = vneg(vfma(kD, CD, lD)), r2 = vneg(vfma(kH, CH, lH));
      const vreal det = vsub(vmul(m11, m22), vmul(m12, m21));
      const vmask act = vmnot(pad);
      const vreal dlD = vsel(act, vdiv(vsub(vmul(r1, m22), vmul(m12, r2)), det), zero);
      const vreal dlH = vsel(act, vdiv(vsub(vmul(m11, r2), vmul(m21, r1)), det), zero);
      if (op == XPBD_EVAL) {
        vstore(a->sink + b * L + o, vadd(dlD, dlH));
        continue;
      }
      vstore(a->lambda + b * L + o, vadd(lD, dlD));
      vstore(a->lambda_h + b * L + o, vadd(lH, dlH));
      // The correction before its w_k: (dl_D dC_D/dF + dl_H cof F) b_k;
      // in registers as xpbd_blocks' (x + w g, stored for the lanes that
      // scatter_block writes: the non-padding ones).
      vreal Pc[9], g0[3] = {zero, zero, zero};
      for (int i = 0; i < 9; i++)
        Pc[i] = vfma(dlH, cof[i], vmul(dlD, PD[i]));
      for (int k = 1; k < K; k++) {
        vreal bk[3], xn[3];
        for (int j = 0; j < 3; j++)
          bk[j] = vload(bv + (k * 3 + j) * L + o);
        for (int i = 0; i < 3; i++) {
          vreal g = vmul(Pc[3 * i], bk[0]);
          g = vfma(Pc[3 * i + 1], bk[1], g);
          g = vfma(Pc[3 * i + 2], bk[2], g);
          g0[i] = vsub(g0[i], g);
          if (reg)
            xn[i] = vadd(xo[k & 3][i], vmul(wk[k & 3], g));
          else
            vstore(corr + (k * 3 + i) * L + o, g);
        }
        if (reg)
          xpbd_store_points(a->x, idx + k * L + o, act, xn);
      }
      if (reg) {
        vreal xn[3];
        for (int i = 0; i < 3; i++)
          xn[i] = vadd(xo[0][i], vmul(wk[0], g0[i]));
        xpbd_store_points(a->x, idx + o, act, xn);
        continue;
      }
      for (int i = 0; i < 3; i++)
        vstore(corr + i * L + o, g0[i]);
      vstore(sl + o, vsel(act, one, zero));
    }
    if (op == XPBD_GS && !(XPBD_REG_SCATTER && tets))
      scatter_block(a, idx, K, hb, sl);
  }
}

#define XPBD_CASE(OP)                                                                              \
  case OP:                                                                                         \
    if (a->snh) {                                                                                  \
      if (a->tets)                                                                                 \
        snh_blocks(1, OP, a, b0, b1);                                                              \
      else                                                                                         \
        snh_blocks(0, OP, a, b0, b1);                                                              \
    } else if (a->tets)                                                                            \
      xpbd_blocks(1, OP, a, b0, b1);                                                               \
    else                                                                                           \
      xpbd_blocks(0, OP, a, b0, b1);                                                               \
    break;

void EK_SYM(xpbd_block)(const xpbd_args *a, size_t b0, size_t b1) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  switch (a->op) {
    XPBD_CASE(XPBD_GS)
    XPBD_CASE(XPBD_JACOBI)
    XPBD_CASE(XPBD_RESIDUAL)
    XPBD_CASE(XPBD_F_ONLY)
    XPBD_CASE(XPBD_EVAL)
  default:
    break;
  }
  ek_fpmode_leave(mode);
}

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(xpbd_block_fill)(ek_kernel_table *t);
void EK_SYM(xpbd_block_fill)(ek_kernel_table *t) { t->EK_FIELD(xpbd_block) = EK_SYM(xpbd_block); }
