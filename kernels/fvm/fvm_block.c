// FVM force kernel on AoSoA tet blocks (Teran et al. 2003 sec. 4, seed 004),
// written once against the vector API and built per (ISA x precision).
// Per tet: Ds = [x1-x0, x2-x0, x3-x0], F = Ds Dm^-1, P = P(F) (the
// material's inline stress, kernels/material/material_core.h),
// H = -V0 P Dm^-T, h1..h3 to vertices 1..3 and -(h1+h2+h3) to vertex 0.
// The argument contract is in fvm_kernel.h; the scatter strategies (which
// call this with f or corner set) live in the driver, fvm.c.
#include "../simd/simd.h"

#include "../material/material_core.h"
#include "../svd3/svd3_core.h"
#include "fvm_kernel.h"

#if defined(EK_REAL_F32)
typedef struct ek_fvm_args_f32 fvm_args;
#else
typedef struct ek_fvm_args_f64 fvm_args;
#endif

#define L EK_LANES

// Step 1: gather. Positions of the 4 corners of every lane of block b into
// xb[(c*3 + i)*L + l] (the vector API has no gather, and a block-wide
// scalar gather into a cache-resident buffer lets the arithmetic below use
// aligned plane loads). Padding lanes read vertex 0 and are masked later.
static void gather_block(const fvm_args *a, size_t b, real *xb, real *pad) {
  const int32_t *idx = a->idx + b * 4 * L;
  for (int c = 0; c < 4; c++)
    for (int l = 0; l < L; l++) {
      int32_t v = idx[c * L + l];
      const real *p = a->x + (size_t)(v < 0 ? 0 : v) * 3;
      xb[(c * 3 + 0) * L + l] = p[0];
      xb[(c * 3 + 1) * L + l] = p[1];
      xb[(c * 3 + 2) * L + l] = p[2];
    }
  for (int l = 0; l < L; l++)
    pad[l] = idx[l] < 0 ? (real)1 : (real)0;
}

// Rotations of corotated linear, caller tet order -> lanes (identity in
// padding lanes).
static void gather_R(const fvm_args *a, size_t b, real *Rb) {
  for (int l = 0; l < L; l++) {
    int32_t t = a->slot_tet[b * L + l];
    for (int k = 0; k < 9; k++)
      Rb[k * L + l] = t >= 0 ? (real)a->R[(size_t)t * 9 + k] : (real)(k % 4 == 0);
  }
}

// Step 2: F = Ds Dm^-1 for EK_W lanes at offset o of the block; padding
// lanes get F = I so every model stays finite there.
static void deformation_gradient(const real *xb, const real *dm_inv, const real *pad, int o,
                                 vreal F[9]) {
  vreal Ds[9];
  for (int i = 0; i < 3; i++) {
    vreal x0 = vload(xb + (0 * 3 + i) * L + o);
    for (int c = 0; c < 3; c++)
      Ds[i * 3 + c] = vsub(vload(xb + ((c + 1) * 3 + i) * L + o), x0);
  }
  vreal Dmi[9];
  for (int k = 0; k < 9; k++)
    Dmi[k] = vload(dm_inv + k * L + o);
  vmask is_pad = vgt(vload(pad + o), vzero());
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      vreal s = vmul(Ds[i * 3 + 0], Dmi[0 * 3 + j]);
      s = vfma(Ds[i * 3 + 1], Dmi[1 * 3 + j], s);
      s = vfma(Ds[i * 3 + 2], Dmi[2 * 3 + j], s);
      F[i * 3 + j] = vsel(is_pad, vset((real)(i == j)), s);
    }
}

// Step 4: H = -V0 P Dm^-T: H[i][c] = -V0 sum_k P[i][k] Dm^-1[c][k]; then the
// four corner forces, corner 0 = -(h1 + h2 + h3), into hb[(c*3+i)*L + o].
static void corner_forces(const vreal P[9], const real *dm_inv, const real *v0, int o, real *hb) {
  vreal Dmi[9];
  for (int k = 0; k < 9; k++)
    Dmi[k] = vload(dm_inv + k * L + o);
  vreal nv0 = vneg(vload(v0 + o));
  for (int i = 0; i < 3; i++) {
    vreal h[3];
    for (int c = 0; c < 3; c++) {
      vreal s = vmul(P[i * 3 + 0], Dmi[c * 3 + 0]);
      s = vfma(P[i * 3 + 1], Dmi[c * 3 + 1], s);
      s = vfma(P[i * 3 + 2], Dmi[c * 3 + 2], s);
      h[c] = vmul(nv0, s);
      vstore(hb + ((c + 1) * 3 + i) * L + o, h[c]);
    }
    vstore(hb + (0 * 3 + i) * L + o, vneg(vadd(vadd(h[0], h[1]), h[2])));
  }
}

// Step 5: scatter one block's corner forces into f, lane by lane (the
// block's tets share no vertex, so the order inside a block is free; lane
// order keeps it fixed anyway).
static void scatter_block(const fvm_args *a, size_t b, const real *hb) {
  const int32_t *idx = a->idx + b * 4 * L;
  real *f = a->f;
  for (int l = 0; l < L; l++) {
    if (idx[l] < 0)
      continue;
    for (int c = 0; c < 4; c++) {
      real *fv = f + (size_t)idx[c * L + l] * 3;
      fv[0] += hb[(c * 3 + 0) * L + l];
      fv[1] += hb[(c * 3 + 1) * L + l];
      fv[2] += hb[(c * 3 + 2) * L + l];
    }
  }
}

void EK_SYM(fvm_block)(const fvm_args *a, size_t b0, size_t b1) {
  _Alignas(64) real xb[12 * L];
  _Alignas(64) real pad[L];
  _Alignas(64) real Rb[9 * L];
  _Alignas(64) real hb[12 * L];
  ek_material_lanes mp =
      material_lanes_make((int)a->mat->model, a->mat->mu, a->mat->lambda, a->mat->clamp, a->svd);
  int need_R = a->mat->model == EK_MODEL_COROTATED_LINEAR;
  for (size_t b = b0; b < b1; b++) {
    const real *dm_inv = a->dm_inv + b * 9 * L;
    const real *v0 = a->v0 + b * L;
    if (!a->P_in) {
      gather_block(a, b, xb, pad);
      if (need_R)
        gather_R(a, b, Rb);
    }
    for (int o = 0; o < L; o += EK_W) {
      vreal P[9];
      if (a->P_in) {
        for (int k = 0; k < 9; k++)
          P[k] = vload(a->P_in + (b * 9 + k) * L + o);
      } else {
        vreal F[9], R[9];
        deformation_gradient(xb, dm_inv, pad, o, F);
        // Step 3: the stress, inline (no memory round trip for F or P).
        if (need_R)
          for (int k = 0; k < 9; k++)
            R[k] = vload(Rb + k * L + o);
        else
          for (int k = 0; k < 9; k++)
            R[k] = F[k]; // never read: only corotated linear reads R
        material_pk1(&mp, F, R, P);
      }
      corner_forces(P, dm_inv, v0, o, a->corner ? a->corner + b * 12 * L : hb);
    }
    if (!a->corner)
      scatter_block(a, b, hb);
  }
}

// Phase-split pass 1: F only, into F[(b*9 + k)*L + l].
void EK_SYM(fvm_F_block)(const fvm_args *a, size_t b0, size_t b1, real *Fout) {
  _Alignas(64) real xb[12 * L];
  _Alignas(64) real pad[L];
  for (size_t b = b0; b < b1; b++) {
    gather_block(a, b, xb, pad);
    for (int o = 0; o < L; o += EK_W) {
      vreal F[9];
      deformation_gradient(xb, a->dm_inv + b * 9 * L, pad, o, F);
      for (int k = 0; k < 9; k++)
        vstore(Fout + (b * 9 + k) * L + o, F[k]);
    }
  }
}
