// FVM force kernel on AoSoA tet blocks (Teran et al. 2003 sec. 4, seed 004),
// written once against the vector API and built per (ISA x precision).
// Per tet: Ds = [x1-x0, x2-x0, x3-x0], F = Ds Dm^-1, P = P(F) (the
// material's inline stress, kernels/material/material_core.h),
// H = -V0 P Dm^-T, h1..h3 to vertices 1..3 and -(h1+h2+h3) to vertex 0.
// The block loop is instantiated per model (and, for the models that take
// an SVD, per rsqrt mode) with the model a compile-time constant, so no
// model is switched per vector; the models that take an SVD run two
// vectors' Jacobi chains side by side (svd3_core_n), as the SVD kernel
// does. The argument contract is in fvm_kernel.h; the scatter strategies
// (which call this with f or corner set) live in the driver, fvm.c.
#include "../simd/simd.h"

#include "../material/material_core.h"
#include "../polar/polar_warm_core.h"
#include "../svd3/svd3_core.h"
#include "fvm_kernel.h"
#include "fvm_tet.h"

#if defined(EK_REAL_F32)
typedef struct ek_fvm_args_f32 fvm_args;
#else
typedef struct ek_fvm_args_f64 fvm_args;
#endif

#define L EK_LANES
// Blocks per group and vectors per group: a group holds two vectors (or
// more), so two SVD chains can be in flight; AVX-512 (one vector per block)
// takes two blocks at a time.
#define GROUP_BLOCKS (EK_VPB >= 2 ? 1 : 2)

// Rotations of corotated linear for block b's lanes (identity in padding
// lanes), from the per-element state or the caller-order array.
static void gather_R(const fvm_args *a, size_t b, real *Rb) {
  for (int l = 0; l < L; l++) {
    int32_t t = a->slot_tet[b * L + l];
    for (int k = 0; k < 9; k++) {
      real v = (real)(k % 4 == 0);
      if (t >= 0 && a->R_planes) {
        size_t s = (size_t)a->morton_slot[t];
        v = a->R_planes[(s / L * 9 + (size_t)k) * L + s % L];
      } else if (t >= 0) {
        v = (real)a->R[(size_t)t * 9 + k];
      }
      Rb[k * L + l] = v;
    }
  }
}

// The warm polar's rotations of block b's lanes from the per-element state
// (identity in padding lanes), and back (real lanes only): the blocks of
// the coloured order hold other tets than the state's Morton blocks.
static void gather_R_warm(const fvm_args *a, size_t b, real *Rb) {
  for (int l = 0; l < L; l++) {
    int32_t t = a->slot_tet[b * L + l];
    size_t s = t >= 0 ? (size_t)a->morton_slot[t] : 0;
    for (int k = 0; k < 9; k++)
      Rb[k * L + l] = t >= 0 ? a->R_warm[(s / L * 9 + (size_t)k) * L + s % L] : (real)(k % 4 == 0);
  }
}

static void scatter_R_warm(const fvm_args *a, size_t b, const real *Rb) {
  for (int l = 0; l < L; l++) {
    int32_t t = a->slot_tet[b * L + l];
    if (t < 0)
      continue;
    size_t s = (size_t)a->morton_slot[t];
    for (int k = 0; k < 9; k++)
      a->R_warm[(s / L * 9 + (size_t)k) * L + s % L] = Rb[k * L + l];
  }
}

// Steps 1-2 (gather, F = Ds Dm^-1) and 4-5 (H = -V0 P Dm^-T, scatter) are
// fvm_tet.h's, shared with the Hessian kernels.
static inline void deformation_gradient(const fvm_args *a, size_t b, int o, vreal F[9]) {
  tet_gradient(a->x, a->idx + b * 4 * L, a->dm_inv + b * 9 * L, o, 1, F);
}

static inline void corner_forces(const vreal P[9], const real *dm_inv, const real *v0, int o,
                                 real *hb) {
  tet_corner_values(P, dm_inv, vneg(vload(v0 + o)), o, hb);
}

static void scatter_block(const fvm_args *a, size_t b, const real *hb) {
  tet_scatter_block(a->idx + b * 4 * L, hb, 3, a->f);
}

// Blocks [b0, b1) for one model (a compile-time constant at every call
// below), group by group: gather, F of every vector, P (through the SVD for
// `sigma`, two vectors at a time; or through `warm` iterations of the warm
// polar when warm > 0), corner forces, scatter.
EK_INLINE void fvm_blocks(ek_model model, int sigma, int exact, int warm, const fvm_args *a,
                          size_t b0, size_t b1) {
  _Alignas(64) real Rb[GROUP_BLOCKS][9 * L];
  _Alignas(64) real hb[GROUP_BLOCKS][12 * L];
  const ek_material_lanes mp =
      material_lanes_make(model, a->mat->mu, a->mat->lambda, a->mat->clamp, a->svd);
  for (size_t b = b0; b < b1; b += GROUP_BLOCKS) {
    const int nb = b1 - b < GROUP_BLOCKS ? (int)(b1 - b) : GROUP_BLOCKS;
    if (model == EK_MODEL_COROTATED_LINEAR && !a->R_direct)
      for (int g = 0; g < nb; g++)
        gather_R(a, b + (size_t)g, Rb[g]);
    if (warm && !a->R_direct)
      for (int g = 0; g < nb; g++)
        gather_R_warm(a, b + (size_t)g, Rb[g]);
    for (int v0 = 0; v0 < nb * EK_VPB; v0 += 2) {
      // 1 only for the last block of an odd range on AVX-512 (one vector per block).
      const int nv = nb * EK_VPB - v0 < 2 ? 1 : 2;
      vreal F[2][9], P[2][9];
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
        // Step 3a: the SVD of both vectors side by side, then P from it.
        vreal U[2][9], S[2][3], V[2][9];
        svd3_core_pair(nv, (const vreal(*)[9])F, U, S, V, mp.svd.sweeps, mp.svd.refine, exact);
        for (int j = 0; j < nv; j++)
          material_pk1_svd(&mp, U[j], S[j], V[j], P[j]);
      } else {
        // Step 3b: P in F (R read for corotated linear only).
        for (int j = 0; j < nv; j++) {
          const int g = (v0 + j) / EK_VPB, o = (v0 + j) % EK_VPB * EK_W;
          vreal R[9];
          const real *Rsrc = a->R_direct ? a->R_planes + (b + (size_t)g) * 9 * L : Rb[g];
          for (int k = 0; k < 9; k++)
            R[k] = model == EK_MODEL_COROTATED_LINEAR ? vload(Rsrc + k * L + o) : F[j][k];
          material_pk1(&mp, F[j], R, P[j]);
        }
      }
      for (int j = 0; j < nv; j++) {
        const int g = (v0 + j) / EK_VPB, o = (v0 + j) % EK_VPB * EK_W;
        const size_t bg = b + (size_t)g;
        corner_forces(P[j], a->dm_inv + bg * 9 * L, a->v0 + bg * L, o,
                      a->corner ? a->corner + bg * 12 * L : hb[g]);
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

// Phase-split pass: H and scatter from a stored P (9 planes per block).
static void fvm_blocks_from_P(const fvm_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[12 * L];
  for (size_t b = b0; b < b1; b++) {
    for (int o = 0; o < L; o += EK_W) {
      vreal P[9];
      for (int k = 0; k < 9; k++)
        P[k] = vload(a->P_in + (b * 9 + k) * L + o);
      corner_forces(P, a->dm_inv + b * 9 * L, a->v0 + b * L, o,
                    a->corner ? a->corner + b * 12 * L : hb);
    }
    if (!a->corner)
      scatter_block(a, b, hb);
  }
}

// The models that can take an SVD: through it (sigma, per rsqrt mode) when
// the table says so for this clamp, else in F.
EK_INLINE void fvm_blocks_sigma(ek_model model, const fvm_args *a, size_t b0, size_t b1) {
  if (!ek_model_row_uses_sigma(model, a->mat->clamp))
    fvm_blocks(model, 0, 0, 0, a, b0, b1);
  else if (a->svd->exact_rsqrt)
    fvm_blocks(model, 1, 1, 0, a, b0, b1);
  else
    fvm_blocks(model, 1, 0, 0, a, b0, b1);
}

// Fixed corotated and ARAP: the warm polar when the driver set R_warm (it
// does so only without clamp), else as the other SVD models.
EK_INLINE void fvm_blocks_rotation(ek_model model, const fvm_args *a, size_t b0, size_t b1) {
  if (!a->R_warm)
    fvm_blocks_sigma(model, a, b0, b1);
  else if (a->polar_iters == 1)
    fvm_blocks(model, 0, 0, 1, a, b0, b1);
  else if (a->polar_iters == 2)
    fvm_blocks(model, 0, 0, 2, a, b0, b1);
  else if (a->polar_iters == 3)
    fvm_blocks(model, 0, 0, 3, a, b0, b1);
  else
    fvm_blocks(model, 0, 0, a->polar_iters, a, b0, b1);
}

void EK_SYM(fvm_block)(const fvm_args *a, size_t b0, size_t b1) {
  if (a->P_in) {
    fvm_blocks_from_P(a, b0, b1);
    return;
  }
  switch (a->mat->model) {
  case EK_MODEL_LINEAR:
    fvm_blocks(EK_MODEL_LINEAR, 0, 0, 0, a, b0, b1);
    break;
  case EK_MODEL_STVK:
    fvm_blocks(EK_MODEL_STVK, 0, 0, 0, a, b0, b1);
    break;
  case EK_MODEL_COROTATED_LINEAR:
    fvm_blocks(EK_MODEL_COROTATED_LINEAR, 0, 0, 0, a, b0, b1);
    break;
  case EK_MODEL_PSI_R:
    fvm_blocks(EK_MODEL_PSI_R, 0, 0, 0, a, b0, b1);
    break;
  case EK_MODEL_FIXED_COROTATED:
    fvm_blocks_rotation(EK_MODEL_FIXED_COROTATED, a, b0, b1);
    break;
  case EK_MODEL_ARAP:
    fvm_blocks_rotation(EK_MODEL_ARAP, a, b0, b1);
    break;
  case EK_MODEL_NEO_HOOKEAN:
    fvm_blocks_sigma(EK_MODEL_NEO_HOOKEAN, a, b0, b1);
    break;
  case EK_MODEL_STABLE_NEO_HOOKEAN:
    fvm_blocks_sigma(EK_MODEL_STABLE_NEO_HOOKEAN, a, b0, b1);
    break;
  }
}

// Phase-split pass 1: F only, into F[(b*9 + k)*L + l].
void EK_SYM(fvm_F_block)(const fvm_args *a, size_t b0, size_t b1, real *Fout) {
  for (size_t b = b0; b < b1; b++) {
    for (int o = 0; o < L; o += EK_W) {
      vreal F[9];
      deformation_gradient(a, b, o, F);
      for (int k = 0; k < 9; k++)
        vstore(Fout + (b * 9 + k) * L + o, F[k]);
    }
  }
}
