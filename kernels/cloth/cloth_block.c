// Cloth kernels on whole AoSoA blocks (contract in include/ek/cloth.h,
// layout in include/ek/batch.h): the triangle's 3x2 deformation gradient,
// the polar decomposition of a 3x2 F from the closed-form eigen-
// decomposition of C = F^T F (seed 003 eqs. 15-20), and the velocity
// gradients of triangles (L = Vs Ds^+) and tets (L = Vs Ds^-1).
//
// Only correctly rounded operations (add, mul, div, sqrt), no fused ones
// and the same order on every target: each ISA gives the same bits as the
// scalar build, which the tests use to catch lane mixing.
#include <float.h>
#include <math.h>
#include <string.h>

#include "simd/simd.h"
// simd.h first: kernels.h after it for the table type.
#include "elements/tri_polar_vec.h"
#include "kernels.h"

#if defined(EK_REAL_F32)
#define EPS FLT_EPSILON
#else
#define EPS DBL_EPSILON
#endif

// Offset of vector j's entry 0 in a batch of `planes`-plane blocks.
EK_INLINE size_t vec_offset(size_t j, int planes) {
  return (j / EK_VPB) * (size_t)planes * EK_LANES + (j % EK_VPB) * EK_W;
}

// Vector j of an AoSoA batch, or (aos) records j EK_W .. j EK_W + EK_W - 1
// of an AoS array, transposed in registers (simd.h, vload_records): the
// AoS entry points need no staging copy. The same lanes either way.
EK_INLINE void load_planes(const real *p, size_t j, int planes, vreal *out, int aos) {
  if (aos) {
    vload_records(p + (size_t)planes * EK_W * j, planes, out);
    return;
  }
  size_t o = vec_offset(j, planes);
  for (int i = 0; i < planes; i++)
    out[i] = vload(p + o + (size_t)i * EK_LANES);
}

EK_INLINE void store_planes(real *p, size_t j, int planes, const vreal *in, int aos) {
  if (aos) {
    vstore_records(p + (size_t)planes * EK_W * j, planes, in);
    return;
  }
  size_t o = vec_offset(j, planes);
  for (int i = 0; i < planes; i++)
    vstore(p + o + (size_t)i * EK_LANES, in[i]);
}

// nvec vectors of a kernel (AoSoA or AoS, as load_planes).
typedef void vectors_fn(size_t nvec, int aos, const real *a, const real *b, real *o0, real *o1,
                        real *o2);

// A block kernel's two layouts: count blocks (AoSoA), or count AoS records,
// the whole vectors in place and a last partial one through zero-padded
// copies (the AoSoA tail's padding, batch.h). planes: a, b, o0, o1, o2
// (inputs at most EK_RECORD_MAX planes). Inlined with its constant fn, so
// each layout gets its own straight-line loop.
EK_INLINE void run_layout(vectors_fn *fn, size_t count, int aos, const int planes[5], const real *a,
                          const real *b, real *o0, real *o1, real *o2) {
  if (!aos) {
    fn(count * EK_VPB, 0, a, b, o0, o1, o2);
    return;
  }
  size_t m = count / EK_W * EK_W, tail = count - m;
  fn(count / EK_W, 1, a, b, o0, o1, o2);
  if (!tail)
    return;
  real t[5][EK_RECORD_MAX * EK_W];
  const real *in[2] = {a, b};
  real *out[3] = {o0, o1, o2};
  for (int k = 0; k < 2; k++)
    if (in[k]) {
      memset(t[k], 0, sizeof t[k]);
      memcpy(t[k], in[k] + (size_t)planes[k] * m, tail * (size_t)planes[k] * sizeof(real));
    }
  fn(1, 1, a ? t[0] : NULL, b ? t[1] : NULL, o0 ? t[2] : NULL, o1 ? t[3] : NULL, o2 ? t[4] : NULL);
  for (int k = 0; k < 3; k++)
    if (out[k])
      memcpy(out[k] + (size_t)planes[2 + k] * m, t[2 + k],
             tail * (size_t)planes[2 + k] * sizeof(real));
}

// ---- Triangle deformation gradient ----------------------------------------
// F = [x1 - x0, x2 - x0] Dm^-1 (seed 003 eq. 2 in the rest triangle's own
// frame); x 9 planes, Dm_inv 4, F 6.
EK_INLINE void tri_F_vectors(size_t nvec, int aos, const real *x, const real *Dm_inv, real *F,
                             real *unused1, real *unused2) {
  (void)unused1, (void)unused2;
  for (size_t j = 0; j < nvec; j++) {
    vreal p[9], m[4], f[6];
    load_planes(x, j, 9, p, aos);
    load_planes(Dm_inv, j, 4, m, aos);
    for (int i = 0; i < 3; i++) {
      vreal e1 = vsub(p[3 + i], p[i]), e2 = vsub(p[6 + i], p[i]);
      f[2 * i] = vadd(vmul(e1, m[0]), vmul(e2, m[2]));
      f[2 * i + 1] = vadd(vmul(e1, m[1]), vmul(e2, m[3]));
    }
    store_planes(F, j, 6, f, aos);
  }
}

void EK_SYM(cloth_tri_F_block)(size_t count, int aos, const real *x, const real *Dm_inv, real *F,
                               real *unused1, real *unused2) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  run_layout(tri_F_vectors, count, aos, (const int[]){9, 4, 6, 0, 0}, x, Dm_inv, F, unused1,
             unused2);
  ek_fpmode_leave(mode);
}

// F 6 planes, R 6, Uc 4 (may be NULL).
EK_INLINE void polar32_vectors(size_t nvec, int aos, const real *F, const real *unused, real *R,
                               real *Uc, real *unused2) {
  (void)unused, (void)unused2;
  size_t j = 0;
  // AoS: two vectors per step, so the record transposes do not stand alone
  // between two polars (Zen 4, 1 thread, f32: 1.30x -> 1.23x the AoSoA
  // kernel on AVX2, 1.27x -> 1.21x on AVX-512; docs/perf.md, eleventh
  // round). Each vector's polar is the one-vector step's, so the same bits.
  if (aos)
    for (; j + 2 <= nvec; j += 2) {
      vreal f[2][6], r[2][6], u[2][4];
      load_planes(F, j, 6, f[0], aos);
      load_planes(F, j + 1, 6, f[1], aos);
      polar32_vec(f[0], r[0], u[0]);
      polar32_vec(f[1], r[1], u[1]);
      store_planes(R, j, 6, r[0], aos);
      store_planes(R, j + 1, 6, r[1], aos);
      if (Uc) {
        store_planes(Uc, j, 4, u[0], aos);
        store_planes(Uc, j + 1, 4, u[1], aos);
      }
    }
  for (; j < nvec; j++) {
    vreal f[6], r[6], u[4];
    load_planes(F, j, 6, f, aos);
    polar32_vec(f, r, u);
    store_planes(R, j, 6, r, aos);
    if (Uc)
      store_planes(Uc, j, 4, u, aos);
  }
}

// The AoS layout in a function of its own: its two-vector loop in the
// same function changed the AoSoA loop's register allocation, which then
// ran 4.5% slower (AVX2 f64, Zen 4: 19.35 against 18.5 ns per triangle).
static __attribute__((noinline)) void polar32_aos(size_t count, const real *F, real *R, real *Uc) {
  run_layout(polar32_vectors, count, 1, (const int[]){6, 0, 6, 4, 0}, F, NULL, R, Uc, NULL);
}

void EK_SYM(cloth_polar32_block)(size_t count, int aos, const real *F, const real *unused, real *R,
                                 real *Uc, real *unused2) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  if (aos)
    polar32_aos(count, F, R, Uc);
  else
    run_layout(polar32_vectors, count, 0, (const int[]){6, 0, 6, 4, 0}, F, unused, R, Uc, unused2);
  ek_fpmode_leave(mode);
}

// L, D = (L + L^T)/2, W = (L - L^T)/2 (seed 003 eqs. 29-31); any may be
// NULL.
EK_INLINE void store_LDW(size_t j, const vreal l[9], real *L, real *D, real *W, int aos) {
  if (L)
    store_planes(L, j, 9, l, aos);
  vreal half = vset((real)0.5), d[9], w[9];
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) {
      d[3 * r + c] = vmul(vadd(l[3 * r + c], l[3 * c + r]), half);
      w[3 * r + c] = vmul(vsub(l[3 * r + c], l[3 * c + r]), half);
    }
  if (D)
    store_planes(D, j, 9, d, aos);
  if (W)
    store_planes(W, j, 9, w, aos);
}

// ---- Triangle velocity gradient L = Fdot F^+ = Vs Ds^+ ---------------------
// With N = e1 x e2 (Ds = [e1 e2]), the rows of Ds^+ are the dual basis of
// the edges in the plane: d1 = (e2 x N) / |N|^2, d2 = (N x e1) / |N|^2
// (d_i . e_j = delta_ij, d_i . N = 0), so L = g1 d1^T + g2 d2^T (Vs =
// [g1 g2]). Rank 1 (sigma2 <= 3 eps sigma1, i.e. |N| <= 3 eps lambda1):
// Ds^+ = v1 (Ds v1)^T / |Ds v1|^2 (v1 the top eigenvector of Ds^T Ds), so
// L = (Vs v1)(Ds v1)^T / |Ds v1|^2; Ds = 0 gives L = 0. Edges and
// velocities are scaled by the largest edge entry first (L is unchanged).
EK_INLINE void tri_velgrad_vectors(size_t nvec, int aos, const real *x, const real *v, real *L,
                                   real *D, real *W) {
  vreal zero = vzero(), one = vset(1);
  for (size_t j = 0; j < nvec; j++) {
    vreal p[9], q[9], e[6];
    load_planes(x, j, 9, p, aos);
    load_planes(v, j, 9, q, aos);
    for (int i = 0; i < 3; i++)
      e[i] = vsub(p[3 + i], p[i]), e[3 + i] = vsub(p[6 + i], p[i]);
    vmask finite;
    vreal s = max_abs(e, 6, &finite);
    vmask rank0 = veq(s, zero);
    vreal sd = vsel(rank0, one, s);
    vreal e1[3], e2[3], g1[3], g2[3];
    for (int i = 0; i < 3; i++) {
      e1[i] = vdiv(e[i], sd), e2[i] = vdiv(e[3 + i], sd);
      g1[i] = vdiv(vsub(q[3 + i], q[i]), sd), g2[i] = vdiv(vsub(q[6 + i], q[i]), sd);
    }
    vreal N[3], d1[3], d2[3];
    cross3(e1, e2, N);
    vreal n2 = dot3(N, N);
    cross3(e2, N, d1);
    cross3(N, e1, d2);
    // The rank test: |N|^2 <= (3 eps lambda1)^2.
    vreal a = dot3(e1, e1), b = dot3(e1, e2), c = dot3(e2, e2);
    vreal h = vsqrt(vadd(vmul(vmul(vsub(a, c), vset((real)0.5)), vmul(vsub(a, c), vset((real)0.5))),
                         vmul(b, b)));
    vreal lambda1 = vadd(vmul(vadd(a, c), vset((real)0.5)), h);
    vreal cut = vmul(vset((real)(3 * EPS)), lambda1);
    vmask rank2 = vgt(n2, vmul(cut, cut));
    vreal ninv = vdiv(one, vsel(rank2, n2, one));
    vreal v1[2];
    sym2_top_eigvec(a, b, c, v1);
    vreal dv[3], gv[3];
    for (int i = 0; i < 3; i++) {
      dv[i] = vadd(vmul(e1[i], v1[0]), vmul(e2[i], v1[1]));
      gv[i] = vadd(vmul(g1[i], v1[0]), vmul(g2[i], v1[1]));
    }
    vreal dinv = vdiv(one, vsel(rank0, one, dot3(dv, dv)));
    vreal l[9];
    for (int r = 0; r < 3; r++)
      for (int col = 0; col < 3; col++) {
        vreal full = vmul(vadd(vmul(g1[r], d1[col]), vmul(g2[r], d2[col])), ninv);
        vreal one_rank = vmul(vmul(gv[r], dv[col]), dinv);
        l[3 * r + col] = vsel(rank2, full, vsel(rank0, zero, one_rank));
      }
    store_LDW(j, l, L, D, W, aos);
  }
}

void EK_SYM(cloth_tri_velgrad_block)(size_t count, int aos, const real *x, const real *v, real *L,
                                     real *D, real *W) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  run_layout(tri_velgrad_vectors, count, aos, (const int[]){9, 9, 9, 9, 9}, x, v, L, D, W);
  ek_fpmode_leave(mode);
}

// ---- Tet velocity gradient L = Fdot F^-1 = Vs Ds^-1 (seed 003 eq. 28) ------
// The rows of Ds^-1 are the dual basis of the edges: (e2 x e3, e3 x e1,
// e1 x e2) / det Ds, so L = sum_k g_k d_k^T. Edges and velocities are
// scaled by the largest edge entry first (L is unchanged; det Ds is then at
// most 6 and never overflows). det Ds = 0: NaN. x and v 12 planes, AoSoA
// only (aos must be 0: 12 planes are more than a record transpose takes;
// its driver gathers the corners from the mesh into blocks anyway).
void EK_SYM(cloth_tet_velgrad_block)(size_t nblocks, int aos, const real *x, const real *v, real *L,
                                     real *D, real *W) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  (void)aos;
  size_t nvec = nblocks * EK_VPB;
  vreal one = vset(1);
  for (size_t j = 0; j < nvec; j++) {
    vreal p[12], q[12], e[9];
    load_planes(x, j, 12, p, 0);
    load_planes(v, j, 12, q, 0);
    for (int k = 0; k < 3; k++)
      for (int i = 0; i < 3; i++)
        e[3 * k + i] = vsub(p[3 * (k + 1) + i], p[i]);
    vmask finite;
    vreal s = max_abs(e, 9, &finite);
    vreal sd = vsel(veq(s, vzero()), one, s);
    vreal ed[3][3], g[3][3], d[3][3];
    for (int k = 0; k < 3; k++)
      for (int i = 0; i < 3; i++) {
        ed[k][i] = vdiv(e[3 * k + i], sd);
        g[k][i] = vdiv(vsub(q[3 * (k + 1) + i], q[i]), sd);
      }
    cross3(ed[1], ed[2], d[0]);
    cross3(ed[2], ed[0], d[1]);
    cross3(ed[0], ed[1], d[2]);
    vreal det = dot3(ed[0], d[0]);
    vmask ok = vmnot(veq(det, vzero()));
    vreal dinv = vsel(ok, vdiv(one, det), vset((real)NAN));
    vreal l[9];
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++)
        l[3 * r + c] =
            vmul(vadd(vadd(vmul(g[0][r], d[0][c]), vmul(g[1][r], d[1][c])), vmul(g[2][r], d[2][c])),
                 dinv);
    store_LDW(j, l, L, D, W, 0);
  }
  ek_fpmode_leave(mode);
}

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(cloth_block_fill)(ek_kernel_table *t);
void EK_SYM(cloth_block_fill)(ek_kernel_table *t) {
  t->EK_FIELD(cloth_tri_F_block) = EK_SYM(cloth_tri_F_block);
  t->EK_FIELD(cloth_polar32_block) = EK_SYM(cloth_polar32_block);
  t->EK_FIELD(cloth_tri_velgrad_block) = EK_SYM(cloth_tri_velgrad_block);
  t->EK_FIELD(cloth_tet_velgrad_block) = EK_SYM(cloth_tet_velgrad_block);
}
