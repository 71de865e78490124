// The elastic energy's gradient and its Hessian as a matrix-free operator,
// for implicit integration (Newton on backward Euler: sim/implicit.c).
// E(x) = sum_e V0_e Psi(F_e) over the tets of an element layer
// (elements.h), F_e = Ds Dm^-1 (Teran et al. 2003 sec. 4; seed 004):
//   grad E:  per tet G = V0 P(F) Dm^-T, columns to corners 1..3,
//            -(sum of columns) to corner 0 (the FVM force with the sign
//            flipped, fvm.h);
//   K p:     per tet dF = dDs(p) Dm^-1, dP = dP(F; dF), V0 dP Dm^-T
//            scattered the same way; K = sum_e of the element Hessians,
//            each projected to positive semi-definite (ek_projection).
// The gradient pass caches per tet what the products need, in the
// product's precision and the AoSoA layout of the element blocks: the
// U, V-frame eigensystem of the isotropic models (U and V as unit
// quaternions, the 3x3 block over the singular values and the flip/twist
// pairs: Teran et al. 2005; Smith et al. 2019; 20 planes), R for
// corotated linear (9), nothing for linear. A
// product is then one fused pass (gather p, dF, dP from the cache, scatter)
// with no SVD and no assembled matrix.
//
// Threads: each pass in fixed chunks on the library's helper threads (as
// many as omp_get_max_threads()), the scatter too; with every scatter
// strategy but EK_SCATTER_ATOMIC the gradient, the energy (summed in slot
// order), the products and the diagonal blocks have the same bits for any
// thread count.
#ifndef EK_HESSIAN_H
#define EK_HESSIAN_H

#include <stddef.h>
#include <stdint.h>

#include "core.h"
#include "elements.h"
#include "fvm.h"
#include "material.h"

#ifdef __cplusplus
extern "C" {
#endif

// Error budgets against the double reference (tests/test_hessian.c):
//   max_i |(Kp)_i - (Kp)_ref,i| / max_i s_i,
// s_i the sum over the contributions to entry i of their absolute values
// (the cancellation-free size, as EK_FVM_TOL_*). f32: the products run in
// float from an eigensystem computed in double and rounded once.
#define EK_HESSIAN_TOL_F32 1e-4
#define EK_HESSIAN_TOL_F64 1e-10

typedef struct ek_fvm_hessian ek_fvm_hessian;

// Options; zero means default.
//   scatter, isa, svd_sweeps, svd_exact_rsqrt, svd_refine: as in ek_fvm_opts.
//   projection: how each element Hessian is made positive semi-definite
//     (what Newton needs: a descent direction, CG on an SPD system), in
//     its eigensystem (the U, V frame's 3x3 block and flip/twist pairs):
//     CLAMP negative eigenvalues to 0 (the default; Teran et al. 2005),
//     ABS replaces them by their absolute value (Chen et al. 2024,
//     "Stabler neo-Hookean simulation: absolute eigenvalue filtering for
//     projected Newton", proposed for faster convergence under
//     compression; on ek's crush scenes it took as many Newton iterations
//     as CLAMP or more: 4.9 vs 4.1 per step with fixed corotated + clamp,
//     6.9 vs 5.8 with neo-Hookean),
//     NONE keeps the exact, indefinite Hessian (for checks against finite
//     differences). Linear and corotated linear are PSD already.
//   precision: 32 or 64 (0 = 64): the precision of the cached eigensystems
//     and of ek_fvm_hessian_apply_*. The gradient is computed in double
//     either way.
typedef enum {
  EK_PROJECT_CLAMP = 0,
  EK_PROJECT_ABS,
  EK_PROJECT_NONE,
  EK_PROJECT_COUNT
} ek_projection;

// "clamp", "abs", "none"; "invalid" for others.
const char *ek_projection_name(ek_projection p);

typedef struct {
  ek_scatter scatter;
  ek_isa isa;
  int svd_sweeps;
  int svd_exact_rsqrt;
  int svd_refine;
  ek_projection projection;
  int precision;
} ek_fvm_hessian_opts;

// NULL with ek_last_error on a bad argument or no memory. Keeps pointers
// to el (alive until destroy); copies mat and opts.
ek_fvm_hessian *ek_fvm_hessian_create(const ek_tets *el, const ek_material *mat,
                                      const ek_fvm_hessian_opts *opts);
void ek_fvm_hessian_destroy(ek_fvm_hessian *h);

// grad = dE/dx at x (nverts x 3; overwritten), *energy = E(x) summed in
// slot order (may be NULL), and the cache for the products at x. R_state:
// corotated linear's rotations (9 planes, f64, elements.h), NULL for the
// other models. E is +inf when an element is outside the model's domain
// (neo-Hookean with J <= 0 and no clamp); grad is then NaN at its vertices
// and the cache is not usable. cache_eigensystems 0 skips the cache (a
// gradient only; products then refuse until a pass caches again).
int ek_fvm_hessian_gradient_f64(ek_fvm_hessian *h, const double *x, const ek_tet_state *R_state,
                                double *grad, double *energy, int cache_eigensystems);

// y = K p (nverts x 3 each; y overwritten) at the x of the last caching
// gradient pass; the function of the cache's precision (opts.precision).
int ek_fvm_hessian_apply_f32(const ek_fvm_hessian *h, const float *p, float *y);
int ek_fvm_hessian_apply_f64(const ek_fvm_hessian *h, const double *p, double *y);

// The same product in parts, for a caller that runs its own parallel loop
// (sim/implicit.c's CG, where no thread waits for one that has not
// started): ek_fvm_hessian_apply_parts is EK_FVM_PARTS with the
// THREAD_BUFFERS scatter (0 otherwise: use ek_fvm_hessian_apply_*), and
// *parallel whether ek_fvm_hessian_apply_* runs on more than one thread
// (EK_FVM_PARALLEL_MIN_TETS); each
// part's call writes the products of its fixed share of the tets into a
// buffer of the Hessian's own (parts may run at the same time on
// different threads), then ek_fvm_hessian_apply_rows_* writes rows [v0,
// v1) of y, each the sum of the parts' rows in part order (disjoint row
// ranges may run at the same time). After every part, every row: y has
// the bits of ek_fvm_hessian_apply_* (the same kernels and sums, at any
// thread count). One product at a time per Hessian.
int ek_fvm_hessian_apply_parts(const ek_fvm_hessian *h, int *parallel);
int ek_fvm_hessian_apply_part_f32(const ek_fvm_hessian *h, const float *p, int part);
int ek_fvm_hessian_apply_part_f64(const ek_fvm_hessian *h, const double *p, int part);
void ek_fvm_hessian_apply_rows_f32(const ek_fvm_hessian *h, size_t v0, size_t v1, float *y);
void ek_fvm_hessian_apply_rows_f64(const ek_fvm_hessian *h, size_t v0, size_t v1, double *y);

// The 3x3 diagonal blocks of K, one per vertex (nverts x 6: xx, xy, xz, yy,
// yz, zz), from the cache (in its precision, returned in double): the
// Jacobi and block-Jacobi preconditioners of CG.
int ek_fvm_hessian_diagonal_f64(const ek_fvm_hessian *h, double *blocks);

// ---- The assembled Hessian ----
// K as a CSR matrix of 3 nverts rows (dof 3 v + k: vertex v, axis k): per
// vertex pair sharing a tet, and per vertex with itself (even one in no
// tet, whose block is 0), a dense 3x3 block; each row's columns ascending.
// row_ptr (nrows + 1) and col (nnz) belong to the Hessian (alive until
// destroy). The pattern is built on the first call (from the element
// incidence; about a sort of 16 entries per tet) and kept.
typedef struct {
  size_t nrows, nnz;
  const int32_t *row_ptr, *col;
} ek_csr_pattern;
int ek_fvm_hessian_pattern(ek_fvm_hessian *h, ek_csr_pattern *pattern);

// values (nnz, the pattern's order) = K at the x of the last caching
// gradient pass: each tet's projected 12x12 Hessian (the product's, from
// the same cache: K p = the product of ek_fvm_hessian_apply_* to the
// precision's rounding) computed by the vector kernel of the cache's
// precision and symmetrised ((H + H^T) / 2, so K is symmetric to the bit),
// then summed per nonzero in double in the mesh's slot order: the same
// bits for any thread count. Scratch: the plan for the thread count (built
// on the first call at that count) and 144 KB of element Hessians per
// thread, kept until destroy (one call at a time per Hessian). Error
// budgets against the double reference as EK_HESSIAN_TOL_* (entry-wise,
// scaled by the sum of the absolute contributions).
int ek_fvm_hessian_assemble(ek_fvm_hessian *h, double *values);

// ---- The assembled Hessian, upper block triangle ----
// K's blocks (v, w) with w >= v only (K is symmetric: block (w, v) is
// block (v, w)^T), each 3x3 block's 9 values contiguous and row-major
// (value 3 i + m: row 3 v + i, column 3 w + m), in the cache's precision:
// the layout of a block symmetric matrix (PETSc's SBAIJ with bs = 3, whose
// MatSetValuesBlocked takes row-oriented blocks by default). Per block row
// v (one per vertex), its blocks bptr[v] .. bptr[v + 1] - 1, the diagonal
// first, columns ascending. Owned by the Hessian (alive until destroy),
// built with ek_fvm_hessian_pattern's.
typedef struct {
  size_t nbrows, nblocks;
  const int32_t *bptr, *bcol;
} ek_bsr_pattern;
int ek_fvm_hessian_pattern_upper(ek_fvm_hessian *h, ek_bsr_pattern *pattern);

// values (9 nblocks, the upper pattern's order) = K's upper block
// triangle at the x of the last caching gradient pass: the projected
// element Hessians of ek_fvm_hessian_assemble (for the isotropic models
// formed from the eigen-frame's rank-one columns: fewer operations, other
// roundoff), summed per value in the cache's precision (float for f32:
// half the bytes of the double CSR) in the mesh's slot order from 0: the
// same bits for any thread count, not ek_fvm_hessian_assemble's.
// The function of the cache's precision (opts.precision). Error budgets
// against the double reference as EK_HESSIAN_TOL_* (entry-wise, scaled by
// the sum of the absolute contributions).
int ek_fvm_hessian_assemble_upper_f32(ek_fvm_hessian *h, float *values);
int ek_fvm_hessian_assemble_upper_f64(ek_fvm_hessian *h, double *values);

// The cache's size in bytes and planes per tet (20 for the isotropic
// models' eigensystem, 9 for corotated linear's R, 0 for linear).
size_t ek_fvm_hessian_cache_bytes(const ek_fvm_hessian *h);
int ek_fvm_hessian_cache_planes(const ek_fvm_hessian *h);

#ifdef __cplusplus
}
#endif
#endif
