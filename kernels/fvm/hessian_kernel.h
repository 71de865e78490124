// Internal: arguments of the Hessian block kernels (kernels/fvm/
// hessian_block.c) and the state behind ek_fvm_hessian (include/ek/
// hessian.h), shared by the kernel and its driver (kernels/fvm/hessian.c).
//
// What one call does for blocks [b0, b1) of the driver's slot order
// (block planes as in fvm_kernel.h):
//   HESS_GRADIENT (f64 kernels only): gather x, F = Ds Dm^-1, P and psi;
//     corner values V0 P Dm^-T (3 per corner), energy[slot] = V0 psi, and,
//     when cache_out or cache_out_f32 is set, the cache of the products;
//   HESS_APPLY: gather x (the direction p), dF = dDs Dm^-1, dP from the
//     cache, corner values V0 dP Dm^-T (3 per corner);
//   HESS_DIAG: per corner c the 3x3 block V0 G_c^T H G_c of the element
//     Hessian H (G_c: dF of a unit move of corner c), 6 values per corner
//     (xx, xy, xz, yy, yz, zz);
// then out (add, lane order) or corner (write) as in scatter.h;
//   HESS_ELEMENT: the projected 12x12 element Hessian from the cache (rows
//     and columns corner-major, 3 c + k), symmetrised, written to corner
//     as 144 planes per block from b0: corner[((b - b0) * 144 + (d * 4 +
//     c) * 9 + i * 3 + k) * LANES + l], rows (d, i), columns (c, k); out is
//     not used;
//   HESS_ELEMENT_R1 (isotropic models, the frame kernel only): HESS_ELEMENT's
//     matrices and layout from the frame's rank-one columns (hessian_block.c,
//     frame_element_r1_blocks; other bits: the upper-triangle assembly's);
//   hessian_sum (its own table entry, after HESS_ELEMENT on each block of
//     a group): the element Hessians in corner added into values through
//     the runs of asm_h's plan group asm_k (hessian.c,
//     ek_fvm_hessian_assemble_f32/f64, says the order).
//
// Cache: `planes` planes per tet, plane k of block b at
// cache[(b * planes + k) * LANES + l] in the cache's precision (LANES 16
// for float, 8 for double; both orders have the same slots, so the f64
// gradient kernel can write a float cache by slot). Isotropic models:
// HESS_FRAME_PLANES planes, U and V as unit quaternions w x y z (0-3, 4-7),
// the symmetric 3x3 block A (8-13: A00 A01 A02 A11 A12 A22), h (14-16), q
// (17-19) of mat_frame (kernels/material/material_math.h); corotated
// linear: R (9 planes); linear: none.
#ifndef EK_FVM_HESSIAN_KERNEL_H
#define EK_FVM_HESSIAN_KERNEL_H

#include <ek/hessian.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernels.h"

enum { HESS_GRADIENT = 0, HESS_APPLY, HESS_DIAG, HESS_ELEMENT, HESS_ELEMENT_R1 };
#define HESS_FRAME_PLANES 20

#define EK_HESS_ARGS(T, NAME)                                                                      \
  struct NAME {                                                                                    \
    int op;                                                                                        \
    const int32_t *idx;                                                                            \
    const T *dm_inv;                                                                               \
    const T *v0;                                                                                   \
    const int32_t *slot_tet; /* slot -> caller tet, -1 = padding */                                \
    const ek_material *mat;                                                                        \
    const ek_svd3_knobs *svd;                                                                      \
    int project;                                                                                   \
    int planes;                                                                                    \
    const T *x; /* positions (gradient) or the direction p (apply) */                              \
    /* corotated linear's R^n (gradient): 9 planes, f64, Morton slots */                           \
    const double *R_planes;                                                                        \
    const int32_t *morton_slot;                                                                    \
    T *cache_out;         /* gradient: cache in this precision, or */                              \
    float *cache_out_f32; /* gradient (f64 kernel): cache in float */                              \
    const T *cache;       /* apply, diag */                                                        \
    T *energy;            /* gradient: V0 psi per slot */                                          \
    T *out;                                                                                        \
    T *corner;                                                                                     \
    /* assembly (hessian_sum): K's values, the map and plan, the thread */                         \
    double *values;                                                                                \
    /* the upper-triangle assembly: K's upper blocks in this precision */                          \
    T *uvalues;                                                                                    \
    const struct ek_fvm_hessian *asm_h;                                                            \
    int asm_k; /* the plan group (hessian_kernel.h, tgrp) */                                       \
  }
EK_HESS_ARGS(float, ek_hess_args_f32);
EK_HESS_ARGS(double, ek_hess_args_f64);

// Slot blocks per group of the assembly's plan: one run sums a K block's
// contributions from all of the group's blocks, so a K block is loaded and
// stored fewer times (docs/perf.md, "Hessian assembly"); the group's
// element Hessians, 144 planes per block (16 blocks: 144 KB f32, L2), sit
// in a heap buffer per thread (hessian.c). 4 blocks (L1) were slower than
// 8; 16 faster than 8 (fewer runs: each K block's loads, prefetch and
// store shared by twice the tets), since the buffers left the stack (eighth
// round). The plan's element offsets are 16-bit: (144 j + 9 dc) lanes + l
// below 144 HESS_GROUP lanes (hessian_assemble.c checks it).
#define HESS_GROUP 16
// One thread's element Hessian buffer (abuf below): HESS_GROUP blocks of
// 144 planes, 16 lanes of float or 8 of double, the same bytes.
#define HESS_ABUF_BYTES ((size_t)HESS_GROUP * 144 * 64)
_Static_assert(HESS_ABUF_BYTES % 4096 == 0, "the element Hessian buffers: whole pages");
// Part t's buffer starts at t * HESS_ABUF_STRIDE: an untouched buffer's
// length between two parts' buffers. Back to back (in either order), two
// parts run together took 27-37 ns per tet against 22-24 a buffer apart
// (Zen 4, StVK f32 upper, 101 400 tets): likely a prefetcher running past
// one core's buffer into the lines the other core writes (docs/perf.md,
// "Twentieth round: a gap between the parts' element Hessian buffers").
#define HESS_ABUF_STRIDE (2 * HESS_ABUF_BYTES)

// One run of the assembly's plan: the element blocks of one group of slot
// blocks that add into the 3x3 block of K at values + p (rows rs apart), n of
// them, in ascending slot order; first: the run starts the block's sum
// (its first contribution: written as 0 + e).
typedef struct {
  int32_t p, rs;
  uint16_t n, first;
} ek_hess_run;

// Behind ek_fvm_hessian.
struct ek_fvm_hessian {
  const ek_tets *el;
  ek_material mat;
  ek_scatter scatter; // resolved
  ek_isa isa;         // resolved
  const ek_kernel_table *kt;
  ek_svd3_knobs svd; // the gradient pass's (double)
  int project;       // mat_frame_prepare's: 0 exact, 1 clamp, 2 mirror
  int precision;     // 32 or 64: the cache's and the products'
  int planes;        // cache planes per tet
  void *cache;       // nslots * planes values, or NULL (no planes)
  size_t cache_bytes;
  double *energy; // nslots
  int cached;     // a caching gradient pass ran
  // The product in parts (ek_fvm_hessian_apply_part, THREAD_BUFFERS only):
  // EK_FVM_PARTS buffers of nverts x 3 values of the precision, or NULL.
  void *part_buf;
  // Assembly (hessian_assemble.c), built on first use: K's pattern over
  // vertex blocks (bptr nverts + 1, bcol: block rows, columns ascending),
  // the scalar CSR (row_ptr, col), and the element-to-nonzero map per slot
  // of the cache's order: slot_p (16 per slot, d * 4 + c: the offset in
  // the values of entry (0, 0) of block (row corner d, column corner c)),
  // slot_rs (4 per slot: the row stride 3 nb of corner d's block row),
  // slot_first (bit d * 4 + c: this slot is the block's first, lowest,
  // contribution), slot_lower (bit d * 4 + c: the block lies below the
  // block diagonal, column vertex < row vertex: not summed, copied from its
  // mirror); mirror (per block (v, w): the index of block (w, v));
  // isolated: vertices in no tet (diagonal block 0).
  int32_t *bptr, *bcol, *row_ptr, *col, *slot_p, *slot_rs, *mirror, *isolated;
  uint16_t *slot_first, *slot_lower;
  size_t nblocks, nisolated;
  // The upper block triangle (ek_fvm_hessian_pattern_upper): per vertex row
  // the blocks (v, w), w >= v, ascending (ubptr nverts + 1, ubcol); udiag:
  // the index of row v's diagonal block in bcol (its upper blocks are
  // bcol[udiag[v] .. bptr[v + 1]), upper block ubptr[v] + q - udiag[v]).
  int32_t *ubptr, *ubcol, *udiag;
  size_t nublocks;
  // The threads' plan for plan_threads threads: vertex rows owned per
  // thread (slot_own, 4 per slot: the owner of corner d's row, 0xff
  // padding), and per thread t the slot blocks touching its rows,
  // ascending: tblk[tptr[t] .. tptr[t + 1]).
  // Thread t's entries are taken HESS_GROUP at a time (its last group may
  // be shorter): groups tgrp[t] .. tgrp[t + 1], group g's entries from
  // tptr[t] + (g - tgrp[t]) HESS_GROUP; their element Hessians side by
  // side in the thread's buffer (entry j of the group at 144 j LANES).
  int plan_threads;
  uint8_t *slot_own, *row_own; // row_own: per vertex, its row's thread
  int32_t *tptr, *tblk, *tgrp;
  // The CSR's lower blocks (v, w), w < v, whose mirror row w another thread
  // owns than row v (copied once every part has summed, hessian.c
  // copy_lower, the team's second job): per
  // thread t the pairs xlow[2 i] = v, xlow[2 i + 1] = the block's index in
  // bcol, i in xptr[t] .. xptr[t + 1].
  int32_t *xptr, *xlow;
  // The groups' element Hessians, HESS_GROUP * 144 * LANES values of the
  // cache's precision per part (144 KB in both precisions; a part runs on
  // one thread), part t's at t * HESS_ABUF_STRIDE: allocated with the plan, kept across calls (no
  // allocation, page faults or heap trims in the timed call).
  void *abuf;
  // Per group g: the runs runs[krun[g] .. krun[g + 1]) and their element
  // blocks' plane offsets (144 j + (d * 4 + c) * 9) * LANES + l in the
  // element buffer (entry j of the group, lane l), from run_e[kcon[g]], n
  // per run.
  int32_t *krun, *kcon;
  ek_hess_run *runs;
  uint16_t *run_e;
  // Per run: its K block's offset 9 u in the upper triangle's values
  // (block u of ek_fvm_hessian_pattern_upper; the run's p and rs are the
  // scalar CSR's).
  int32_t *run_up;
};

void ek_hessian_assembly_free(ek_fvm_hessian *h);

// The diagonal blocks in the cache's precision (hessian.c, per precision).
int ek_fvm_hessian_diag_f32(const ek_fvm_hessian *h, float *blocks);
int ek_fvm_hessian_diag_f64(const ek_fvm_hessian *h, double *blocks);
// The element Hessians in the cache's precision added into K's values
// through the map and plan above (hessian.c, per precision).
int ek_fvm_hessian_assemble_f32(const ek_fvm_hessian *h, double *values);
int ek_fvm_hessian_assemble_f64(const ek_fvm_hessian *h, double *values);
// The upper block triangle in the cache's precision (hessian.c, per
// precision; ek_fvm_hessian_assemble_upper_f32/f64 check and call them).
int ek_fvm_hessian_assemble_upper_run_f32(const ek_fvm_hessian *h, float *values);
int ek_fvm_hessian_assemble_upper_run_f64(const ek_fvm_hessian *h, double *values);

#endif
