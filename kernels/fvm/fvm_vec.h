// The FVM force kernels' shared steps on AoSoA tet blocks (Teran et al.
// 2003 sec. 4, seed 004): the argument type of this precision, F of a
// vector of tets, corner forces, the scatter, and the per-element rotations
// (corotated linear's R^n, the warm polar's state) gathered into a block
// and back. Used by fvm_block.c (the model-independent passes) and
// fvm_model.h (each model's force kernel). Include after simd/simd.h.
#ifndef EK_FVM_VEC_H
#define EK_FVM_VEC_H

#include "../svd3/svd3_core.h" // kernels.h, and the SVD of the force kernels
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
// The wide variant's group (4 vectors, fvm_model.h) and the larger of the two.
#define GROUP_BLOCKS_WIDE (EK_VPB >= 4 ? 1 : 4 / EK_VPB)
#define GROUP_BLOCKS_MAX GROUP_BLOCKS_WIDE

// Rotations of corotated linear for block b's lanes (identity in padding
// lanes), from the per-element state or the caller-order array.
static inline void gather_R(const fvm_args *a, size_t b, real *Rb) {
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
static inline void gather_R_warm(const fvm_args *a, size_t b, real *Rb) {
  for (int l = 0; l < L; l++) {
    int32_t t = a->slot_tet[b * L + l];
    size_t s = t >= 0 ? (size_t)a->morton_slot[t] : 0;
    for (int k = 0; k < 9; k++)
      Rb[k * L + l] = t >= 0 ? a->R_warm[(s / L * 9 + (size_t)k) * L + s % L] : (real)(k % 4 == 0);
  }
}

static inline void scatter_R_warm(const fvm_args *a, size_t b, const real *Rb) {
  for (int l = 0; l < L; l++) {
    int32_t t = a->slot_tet[b * L + l];
    if (t < 0)
      continue;
    size_t s = (size_t)a->morton_slot[t];
    for (int k = 0; k < 9; k++)
      a->R_warm[(s / L * 9 + (size_t)k) * L + s % L] = Rb[k * L + l];
  }
}

// Start the cache misses of block b's vertex rows: the positions its
// gather reads and, when it adds into f, the force rows its scatter
// updates. Issued a group ahead (fvm_model.h) on meshes whose vertex
// arrays outgrow the core's caches (fvm.c, prefetch): the hardware
// prefetchers follow the packed planes but not these indexed rows.
// A padding lane (index -1) prefetches the row before the array, which
// is harmless (a prefetch never faults). No clamp of the index and the f
// test out of the loop: the loop had ~12 instructions per corner (48 per
// tet; perf at 998 250 tets put ~20% of the force kernel's own samples on
// it), then 8.
// The addresses in integers: the padding lane's is outside the arrays.
// fs: bytes per force row, 0 for none; a constant at each call, and the
// loop unrolled by 8: 5 instructions per corner (index load, lea, shift,
// two prefetches) instead of 8 (imul by the run-time stride, the loop's
// add, compare and branch); the NH force at 998 250 tets ran 107
// instructions per tet, 32 of them this loop (docs/perf.md, FVM).
// Both EK_INLINE: a function of prefetches alone is const to GCC, which
// then drops its calls (and so the prefetches) when it is not inlined.
EK_INLINE void prefetch_rows(const int32_t *idx, uintptr_t x, uintptr_t f, uintptr_t fs) {
#pragma GCC unroll 8
  for (int k = 0; k < 4 * L; k++) {
    const uintptr_t i = (uintptr_t)(intptr_t)idx[k];
    __builtin_prefetch((const void *)(x + i * (3 * sizeof(real))), 0, 3);
    if (fs)
      __builtin_prefetch((const void *)(f + i * fs), 1, 3);
  }
}

EK_INLINE void prefetch_vertices(const fvm_args *a, size_t b) {
  const int32_t *idx = a->idx + b * 4 * L;
  const uintptr_t x = (uintptr_t)a->x, f = (uintptr_t)a->f;
  if (a->f && a->fstride == 4)
    prefetch_rows(idx, x, f, 4 * sizeof(real));
  else if (a->f)
    prefetch_rows(idx, x, f, (uintptr_t)a->fstride * sizeof(real));
  else
    prefetch_rows(idx, x, 0, 0);
}

// Start the cache misses of block b's packed planes (indices, Dm^-1, V0),
// issued two groups ahead (fvm_model.h), on every mesh (14 prefetches per
// block of f32; the planes outgrow L2 from ~20 000 tets): prefetch_vertices
// reads the indices a group ahead, and without this it waited on them (and
// F on the Dm^-1 planes): perf on fixed corotated at 998 250 tets put ~20%
// of the force kernel's own samples on the loop of prefetch_vertices and
// ~12% on one Dm^-1 load. The hardware prefetchers follow these streams
// but stop at each 4 KiB page (a page is 7 blocks of Dm^-1 in f32).
static inline void prefetch_planes(const fvm_args *a, size_t b) {
  const char *idx = (const char *)(a->idx + b * 4 * L),
             *dmi = (const char *)(a->dm_inv + b * 9 * L);
  for (size_t o = 0; o < 4 * L * sizeof(int32_t); o += 64)
    __builtin_prefetch(idx + o, 0, 3);
  for (size_t o = 0; o < 9 * L * sizeof(real); o += 64)
    __builtin_prefetch(dmi + o, 0, 3);
  __builtin_prefetch(a->v0 + b * L, 0, 3);
}

// Steps 1-2 (gather, F = Ds Dm^-1) and 4-5 (H = -V0 P Dm^-T, scatter) are
// fvm_tet.h's, shared with the Hessian kernels.
static inline void deformation_gradient(const fvm_args *a, size_t b, int o, vreal F[9]) {
#if defined(EK_TARGET_AVX512)
  tet_gradient_rolled(a->x, a->idx + b * 4 * L, a->dm_inv + b * 9 * L, o, 1, F);
#else
  tet_gradient(a->x, a->idx + b * 4 * L, a->dm_inv + b * 9 * L, o, 1, F);
#endif
}

// The corner forces of the vector at o of block b: rows of 4 into hb
// (16 L reals per block; tet_corner_rows4) for the padded thread buffers
// (fstride 4, fvm.c), else planes into a->corner's block or hb (12 L).
static inline void corner_forces(const fvm_args *a, const vreal P[9], size_t b, int o, real *hb) {
  const real *dmi = a->dm_inv + b * 9 * L;
  const vreal s = vneg(vload(a->v0 + b * L + o));
#if defined(EK_HAVE_VROWS4)
  if (a->fstride == 4 && !a->corner) {
    tet_corner_rows4(P, dmi, s, o, hb);
    return;
  }
#endif
  tet_corner_values(P, dmi, s, o, a->corner ? a->corner + b * 12 * L : hb);
}

// Add block b's corner forces (corner_forces' hb) into a->f.
static inline void scatter_block(const fvm_args *a, size_t b, const real *hb) {
  const int32_t *idx = a->idx + b * 4 * L;
#if defined(EK_HAVE_VROWS4)
  if (a->fstride == 4)
    tet_scatter_rows4(idx, hb, a->f);
#else
  if (a->fstride == 4)
    tet_scatter_block_rows4(idx, hb, a->f);
#endif
  else
    tet_scatter_block(idx, hb, 3, a->f);
}

#endif
