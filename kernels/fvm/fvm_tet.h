// Per-tet steps shared by the FVM block kernels (fvm_block.c: the force;
// hessian_block.c: the gradient, the Hessian product and its diagonal
// blocks), on AoSoA tet blocks (kernels/elements/tets.h; block b of the
// packed planes: idx[(b*4 + c)*L + l], dm_inv[(b*9 + k)*L + l],
// v0[b*L + l]). Include after simd/simd.h.
#ifndef EK_FVM_TET_H
#define EK_FVM_TET_H

#include <stdint.h>

// The corners' coordinates: vload_points where the target has it (same
// values as vgather_points: loads and a transpose instead of gathers).
#if defined(EK_HAVE_VLOAD_POINTS)
#define tet_points vload_points
#else
#define tet_points vgather_points
#endif

// The block's Dm^-1 planes at lane offset o.
EK_INLINE void tet_dm_inv(const real *dmi_block, int o, vreal Dmi[9]) {
  for (int k = 0; k < 9; k++)
    Dmi[k] = vload(dmi_block + k * EK_LANES + o);
}

// D = Ds Dm^-1 from Ds = [x1-x0, x2-x0, x3-x0] (row i, column c: Ds[3 i +
// c]) and the block's Dm^-1 planes at offset o; lanes in is_pad get `pad`
// on the diagonal and zero elsewhere.
EK_INLINE void tet_ds_dm_inv(const vreal Ds[9], vmask is_pad, const real *dmi_block, int o,
                             real pad, vreal D[9]) {
  vreal Dmi[9];
  tet_dm_inv(dmi_block, o, Dmi);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      vreal s = vmul(Ds[i * 3 + 0], Dmi[0 * 3 + j]);
      s = vfma(Ds[i * 3 + 1], Dmi[1 * 3 + j], s);
      s = vfma(Ds[i * 3 + 2], Dmi[2 * 3 + j], s);
      D[i * 3 + j] = vsel(is_pad, vset(i == j ? pad : 0), s);
    }
}

// Gather the 4 corners of the EK_W lanes at offset o of block b from the
// points x (vgather_points, straight into registers) and form
// D = [x1-x0, x2-x0, x3-x0] Dm^-1 (Teran et al. 2003 sec. 4): F for
// positions, dF for a displacement. Padding lanes (index -1) get `pad`
// (the identity for F, zero for dF) so every model stays finite there.
EK_INLINE void tet_gradient(const real *x, const int32_t *idx_block, const real *dmi_block, int o,
                            real pad, vreal D[9]) {
  const int32_t *idx = idx_block + o;
  vreal x0[3], xc[3], Ds[9];
  vmask is_pad = tet_points(x, idx, x0);
  for (int c = 0; c < 3; c++) {
    tet_points(x, idx + (c + 1) * EK_LANES, xc);
    for (int i = 0; i < 3; i++)
      Ds[i * 3 + c] = vsub(xc[i], x0[i]);
  }
  tet_ds_dm_inv(Ds, is_pad, dmi_block, o, pad, D);
}

// tet_gradient with the 4 corners' loads in one loop that is not unrolled
// (one copy of tet_points' code instead of two; the same values): the FVM
// force's (fvm_vec.h; the Hessian passes keep tet_gradient).
EK_INLINE void tet_gradient_rolled(const real *x, const int32_t *idx_block, const real *dmi_block,
                                   int o, real pad, vreal D[9]) {
  const int32_t *idx = idx_block + o;
  vreal p[4][3], Ds[9];
  vmask m[4];
#pragma GCC unroll 1
  for (int c = 0; c < 4; c++)
    m[c] = tet_points(x, idx + c * EK_LANES, p[c]);
  for (int c = 0; c < 3; c++)
    for (int i = 0; i < 3; i++)
      Ds[i * 3 + c] = vsub(p[c + 1][i], p[0][i]);
  tet_ds_dm_inv(Ds, m[0], dmi_block, o, pad, D);
}

// H = s P Dm^-T: H[i][c] = s sum_k P[i][k] Dm^-1[c][k], with s = -V0 for
// the force (H's columns are the forces on corners 1..3, Teran et al.
// 2003 sec. 4) and s = V0 for the energy's gradient or its differential;
// corner 0 gets -(h1 + h2 + h3). tet_corner_row: component i of the four
// corners' values, h[c] of corner c, from P and the Dm^-1 planes.
EK_INLINE void tet_corner_row(const vreal P[9], const vreal Dmi[9], vreal s, int i, vreal h[4]) {
  for (int c = 0; c < 3; c++) {
    vreal t = vmul(P[i * 3 + 0], Dmi[c * 3 + 0]);
    t = vfma(P[i * 3 + 1], Dmi[c * 3 + 1], t);
    t = vfma(P[i * 3 + 2], Dmi[c * 3 + 2], t);
    h[c + 1] = vmul(s, t);
  }
  h[0] = vneg(vadd(vadd(h[1], h[2]), h[3]));
}

// tet_corner_values: all of them, written to hb[(c*3 + i)*L + o].
EK_INLINE void tet_corner_values(const vreal P[9], const real *dmi_block, vreal s, int o,
                                 real *hb) {
  vreal Dmi[9];
  tet_dm_inv(dmi_block, o, Dmi);
  for (int i = 0; i < 3; i++) {
    vreal h[4];
    tet_corner_row(P, Dmi, s, i, h);
    for (int c = 0; c < 4; c++)
      vstore(hb + (c * 3 + i) * EK_LANES + o, h[c]);
  }
}

// Add one block's corner values hb[(c*ncomp + i)*L + l] into out (nverts x
// ncomp), lane by lane (the block's tets share no vertex, so the order
// inside a block is free; lane order keeps it fixed anyway).
static inline void tet_scatter_block(const int32_t *idx_block, const real *hb, int ncomp,
                                     real *out) {
  for (int l = 0; l < EK_LANES; l++) {
    if (idx_block[l] < 0)
      continue;
    for (int c = 0; c < 4; c++) {
      real *o = out + (size_t)idx_block[c * EK_LANES + l] * (size_t)ncomp;
      for (int i = 0; i < ncomp; i++)
        o[i] += hb[(c * ncomp + i) * EK_LANES + l];
    }
  }
}

// The force's rows of 4 (the thread buffers' padded rows, scatter.c) where
// the target has them (vstore_rows4, vadd_row4: kernels/simd/avx512.h):
// tet_corner_values' values, the same operations, stored as rows of 4
// (lane l's row of corner c at rows + 16 o + vrow4_at(l, c); 16 L reals
// per block, 64-byte aligned) right where they are made, so the scatter
// adds rows from memory with no transpose of its own.
#if defined(EK_HAVE_VROWS4)
EK_INLINE void tet_corner_rows4(const vreal P[9], const real *dmi_block, vreal s, int o,
                                real *rows) {
  vreal Dmi[9], h[12], r[4];
  tet_dm_inv(dmi_block, o, Dmi);
  for (int i = 0; i < 3; i++) {
    tet_corner_row(P, Dmi, s, i, r);
    for (int c = 0; c < 4; c++)
      h[c * 3 + i] = r[c];
  }
  vstore_rows4(rows + o * 16, h);
}

// tet_scatter_block's adds (lane order, corners inner, o's NaN first) of a
// block's rows of 4 (tet_corner_rows4 of each of its vectors) into out
// (nverts x 4, a thread buffer), a vector at a time (vadd_rows4).
static inline void tet_scatter_rows4(const int32_t *idx_block, const real *rows, real *out) {
  for (int o = 0; o < EK_LANES; o += EK_W)
    vadd_rows4(out, idx_block + o, EK_LANES, rows + o * 16);
}

#else
// tet_scatter_block's adds into rows of 4 (3 components and a pad the sums
// leave alone but for adding 0: out is a thread buffer of nverts x 4,
// scatter.c) from the corner planes, through vscatter_add_rows4 where the
// target has it (AVX2: the rows made from the planes in registers; rows
// stored where the corner values are made, as AVX-512 does, were slower
// there, docs/perf.md).
static inline void tet_scatter_block_rows4(const int32_t *idx_block, const real *hb, real *out) {
#if defined(EK_HAVE_VSCATTER_ADD_ROWS4)
  for (int o = 0; o < EK_LANES; o += EK_W) {
    vreal h[12];
    for (int k = 0; k < 12; k++)
      h[k] = vload(hb + k * EK_LANES + o);
    vscatter_add_rows4(out, idx_block + o, EK_LANES, h);
  }
#else
  for (int l = 0; l < EK_LANES; l++) {
    if (idx_block[l] < 0)
      continue;
    for (int c = 0; c < 4; c++) {
      real *o = out + (size_t)idx_block[c * EK_LANES + l] * 4;
      for (int i = 0; i < 3; i++)
        o[i] += hb[(c * 3 + i) * EK_LANES + l];
    }
  }
#endif
}
#endif
#endif
