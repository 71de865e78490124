// The FVM force kernel of one model (Teran et al. 2003 sec. 4, seed 004),
// instantiated by model_kernels.h in the model's file: per tet, Ds =
// [x1-x0, x2-x0, x3-x0], F = Ds Dm^-1, P = P(F) (material_core.h),
// H = -V0 P Dm^-T, h1..h3 to vertices 1..3 and -(h1+h2+h3) to vertex 0.
// The block loop is instantiated per SVD or warm-polar variant with the
// variant a compile-time constant; the models that take an SVD run two
// vectors' Jacobi chains side by side (svd3_pair), or four where the row's
// svd3_chains says so (svd3_quad_est), as the SVD kernel does.
// The argument contract is in fvm_kernel.h; the scatter strategies (which
// call this with f or corner set) live in the driver, fvm.c.
#ifndef EK_FVM_MODEL_H
#define EK_FVM_MODEL_H

#include "../material/material_core.h"
#include "../polar/polar_warm_core.h"
#include "fvm_vec.h"

// The SVD models' corner forces right after each vector's P (fvm_blocks).
#if defined(EK_TARGET_AVX512)
#define FVM_FUSED_CORNERS 1
#else
#define FVM_FUSED_CORNERS 0
#endif

// Blocks [b0, b1), group by group: gather, F of every vector, P (through the SVD for
// `sigma`, two vectors at a time; or through `warm` iterations of the warm
// polar when warm > 0), corner forces, scatter.
// nc: vectors in flight through the SVD (2, or 4 for the wide variant,
// fvm_blocks_sigma), a compile-time constant at each call.
EK_INLINE void fvm_blocks(int sigma, int exact, int warm, int nc, const fvm_args *a, size_t b0,
                          size_t b1) {
  _Alignas(64) real Rb[GROUP_BLOCKS_MAX][9 * L];
  _Alignas(64) real hb[GROUP_BLOCKS_MAX][16 * L]; // corner_forces' rows of 4 or planes
  const ek_material_lanes mp =
      material_lanes_make(a->mat->mu, a->mat->lambda, a->mat->clamp, a->svd);
  const int gb = nc == 4 ? GROUP_BLOCKS_WIDE : GROUP_BLOCKS;
  for (size_t b = b0; b < b1; b += (size_t)gb) {
    const int nb = b1 - b < (size_t)gb ? (int)(b1 - b) : gb;
    if (a->prefetch)
      for (size_t bn = b + (size_t)gb; bn < b + 2 * (size_t)gb && bn < b1; bn++)
        prefetch_vertices(a, bn);
    for (size_t bn = b + 2 * (size_t)gb; bn < b + 3 * (size_t)gb && bn < b1; bn++)
      prefetch_planes(a, bn);
    if (MODEL_READS_R && !a->R_direct)
      for (int g = 0; g < nb; g++)
        gather_R(a, b + (size_t)g, Rb[g]);
    if (warm && !a->R_direct)
      for (int g = 0; g < nb; g++)
        gather_R_warm(a, b + (size_t)g, Rb[g]);
    for (int v0 = 0; v0 < nb * EK_VPB; v0 += nc) {
      // Fewer than nc only in the last group of a range on AVX-512 (one vector per block).
      const int nv = nb * EK_VPB - v0 < nc ? nb * EK_VPB - v0 : nc;
      vreal F[4][9], P[4][9];
      for (int j = 0; j < nv; j++) {
        const int g = (v0 + j) / EK_VPB, o = (v0 + j) % EK_VPB * EK_W;
        deformation_gradient(a, b + (size_t)g, o, F[j]);
      }
      if (warm) {
        // Step 3c: R by the warm polar from the state's rotation (stored
        // back), then P from F and R.
        for (int j = 0; j < nv; j++) {
          const int g = (v0 + j) / EK_VPB, o = (v0 + j) % EK_VPB * EK_W;
          real *Rsrc = (a->R_direct ? a->R_warm + (b + (size_t)g) * 9 * L : Rb[g]) + o;
          vreal R[9];
          for (int k = 0; k < 9; k++)
            R[k] = vload(Rsrc + k * L);
          polar_warm_core(F[j], R, warm);
          for (int k = 0; k < 9; k++)
            vstore(Rsrc + k * L, R[k]);
          material_pk1_rotation(&mp, F[j], R, P[j]);
        }
      } else if (sigma) {
        // Step 3a: the SVD of the nv vectors side by side, then P from it.
        vreal U[4][9], S[4][3], V[4][9];
        if (nc == 4)
          EK_SYM(svd3_quad_est)(nv, (const vreal(*)[9])F, U, S, V, mp.svd.sweeps, mp.svd.refine);
        else
          svd3_pair(nv, (const vreal(*)[9])F, U, S, V, mp.svd.sweeps, mp.svd.refine, exact);
        // AVX-512: P and the corner forces of one vector after the other
        // (P stays in registers; the same operations per vector; fixed
        // corotated f32 ~1% faster on Zen 5, equal or slower with AVX2:
        // docs/perf.md).
        for (int j = 0; j < nv; j++) {
          material_pk1_svd(&mp, U[j], S[j], V[j], P[j]);
          if (FVM_FUSED_CORNERS) {
            const int g = (v0 + j) / EK_VPB, o = (v0 + j) % EK_VPB * EK_W;
            corner_forces(a, P[j], b + (size_t)g, o, hb[g]);
          }
        }
      } else {
        // Step 3b: P in F (R read for corotated linear only).
        for (int j = 0; j < nv; j++) {
          const int g = (v0 + j) / EK_VPB, o = (v0 + j) % EK_VPB * EK_W;
          vreal R[9];
          const real *Rsrc = a->R_direct ? a->R_planes + (b + (size_t)g) * 9 * L : Rb[g];
          for (int k = 0; k < 9; k++)
            R[k] = MODEL_READS_R ? vload(Rsrc + k * L + o) : F[j][k];
          material_pk1(&mp, F[j], R, P[j]);
        }
      }
      for (int j = 0; j < nv && !(FVM_FUSED_CORNERS && sigma && !warm); j++) {
        const int g = (v0 + j) / EK_VPB, o = (v0 + j) % EK_VPB * EK_W;
        corner_forces(a, P[j], b + (size_t)g, o, hb[g]);
      }
    }
    if (warm && !a->R_direct)
      for (int g = 0; g < nb; g++)
        scatter_R_warm(a, b + (size_t)g, Rb[g]);
    if (!a->corner)
      for (int g = 0; g < nb; g++)
        scatter_block(a, b + (size_t)g, hb[g]);
  }
}

// The models that can take an SVD: through it (sigma, per rsqrt mode) when
// the table says so for this clamp, else in F.
// The approximate rsqrt (the default) has a wide variant, 4 vectors in
// flight, where the row's svd3_chains is 4 (a->svd->chains; AVX-512, one
// vector per block, only: the copy is built there alone).
EK_INLINE void fvm_blocks_sigma(const fvm_args *a, size_t b0, size_t b1) {
  if (!material_uses_sigma_at(a->mat->clamp))
    fvm_blocks(0, 0, 0, 2, a, b0, b1);
  else if (a->svd->exact_rsqrt)
    fvm_blocks(1, 1, 0, 2, a, b0, b1);
#if EK_VPB == 1
  else if (a->svd->chains == 4)
    fvm_blocks(1, 0, 0, 4, a, b0, b1);
#endif
  else
    fvm_blocks(1, 0, 0, 2, a, b0, b1);
}

// Fixed corotated and ARAP: the warm polar when the driver set R_warm (it
// does so only without clamp), else as the other SVD models.
EK_INLINE void fvm_blocks_rotation(const fvm_args *a, size_t b0, size_t b1) {
  if (!a->R_warm)
    fvm_blocks_sigma(a, b0, b1);
  else if (a->polar_iters == 1)
    fvm_blocks(0, 0, 1, 2, a, b0, b1);
  else if (a->polar_iters == 2)
    fvm_blocks(0, 0, 2, 2, a, b0, b1);
  else if (a->polar_iters == 3)
    fvm_blocks(0, 0, 3, 2, a, b0, b1);
  else
    fvm_blocks(0, 0, a->polar_iters, 2, a, b0, b1);
}

// The model's entry: the warm polar's or the SVD's variants where the
// model has them, else P in F.
EK_INLINE void fvm_model_blocks(const fvm_args *a, size_t b0, size_t b1) {
#if MODEL_WARM_POLAR
  fvm_blocks_rotation(a, b0, b1);
#elif MODEL_CLAMPABLE
  fvm_blocks_sigma(a, b0, b1);
#else
  fvm_blocks(0, 0, 0, 2, a, b0, b1);
#endif
}

#endif
