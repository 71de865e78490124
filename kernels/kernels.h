// Internal: kernel signatures and the dispatch table. One row per ISA
// target, the scalar row always there; every entry of a built row is
// callable (a target's row falls back to the scalar kernels it lacks).
#ifndef EK_KERNELS_H
#define EK_KERNELS_H

#include <ek/core.h>
#include <ek/material.h>
#include <stddef.h>

// Knobs of the SVD kernel, resolved from ek_svd3_opts by the driver.
typedef struct {
  int sweeps;      // Jacobi sweeps on A^T A (1..8)
  int refine;      // one-sided Jacobi sweeps on B = A V (0..EK_SVD3_MAX_REFINE)
  int exact_rsqrt; // 1: 1/sqrt, 0: estimate + Newton
  int polar;       // 0: write U, S, V; 1: write R = U V^T into U and
                   // Ssym = V S V^T into V (S untouched)
  int aos;         // 0: AoSoA blocks; 1: AoS matrices (svd3_block's count
                   // is then the number of matrices, U and V may be NULL)
  int chains;      // vectors in flight in svd3_block: 4, or 2 otherwise (0,
                   // what the defaults leave); the drivers pass their row's
                   // svd3_chains. The same bits either way (svd3_block.c).
  int nt;          // the outputs written by streaming stores (vstream),
                   // EK_SVD3_NT_U | _V | _S (U / R, V / Ssym, S), each only
                   // where that array's vectors start on 64 bytes (AoS and
                   // AoSoA); 0 = plain stores (the default). Same bits.
} ek_svd3_knobs;
#define EK_SVD3_NT_U 1
#define EK_SVD3_NT_V 2
#define EK_SVD3_NT_S 4

// Defaults of the SVD knobs per precision (what opts zeroed means).
// AoS drivers' staging (kernels/batch/aosoa.c): OpenMP over chunks of
// `chunk_blocks` AoSoA blocks; each thread allocates nbuf block buffers of
// planes[k] planes (none where planes[k] = 0) and calls run(ctx, i0, m,
// bufs) for the items i0 .. i0 + m - 1 of each of its chunks: run packs or
// gathers its inputs into bufs, runs a block kernel, unpacks its outputs.
// EK_ENOMEM (with "fn: out of memory for staging buffers") when a thread's
// buffers cannot be had; nothing is run then.
#define EK_STAGED_MAX_BUFS 5
typedef void ek_staged_chunk_f32_fn(void *ctx, size_t i0, size_t m, float *const *bufs);
typedef void ek_staged_chunk_f64_fn(void *ctx, size_t i0, size_t m, double *const *bufs);
int ek_staged_chunks_f32(const char *fn, size_t n, size_t chunk_blocks, int nbuf, const int *planes,
                         ek_staged_chunk_f32_fn *run, void *ctx);
int ek_staged_chunks_f64(const char *fn, size_t n, size_t chunk_blocks, int nbuf, const int *planes,
                         ek_staged_chunk_f64_fn *run, void *ctx);

ek_svd3_knobs ek_svd3_default_knobs_f32(void);
ek_svd3_knobs ek_svd3_default_knobs_f64(void);
// Knobs from the sweeps / exact_rsqrt / refine options (0 = default), after
// the one range check they share: EK_EINVAL with a message naming fn.
int ek_svd3_knobs_from_f32(const char *fn, int sweeps, int exact_rsqrt, int refine,
                           ek_svd3_knobs *k);
int ek_svd3_knobs_from_f64(const char *fn, int sweeps, int exact_rsqrt, int refine,
                           ek_svd3_knobs *k);

// svd3_block: nblocks AoSoA blocks; A, U, V 9 planes, S 3 planes (with
// knobs.aos: nblocks AoS matrices, 9 + 9 + 3 + 9 reals each).
typedef void ek_svd3_block_f32_fn(size_t nblocks, const float *A, float *U, float *S, float *V,
                                  const ek_svd3_knobs *k);
typedef void ek_svd3_block_f64_fn(size_t nblocks, const double *A, double *U, double *S, double *V,
                                  const ek_svd3_knobs *k);
// polar_warm_block: nblocks AoSoA blocks; A 9 planes, R 9 planes (in: the
// guess, out: the rotation), `iters` >= 1 iterations (polar_warm_core.h).
typedef void ek_polar_warm_block_f32_fn(size_t nblocks, const float *A, float *R, int iters);
typedef void ek_polar_warm_block_f64_fn(size_t nblocks, const double *A, double *R, int iters);
// Iterations from the option (0 = the precision's default), after the
// range check every entry point shares: EK_EINVAL with a message naming fn.
int ek_polar_warm_iterations_from_f32(const char *fn, int iterations, int *out);
int ek_polar_warm_iterations_from_f64(const char *fn, int iterations, int *out);
// fma_probe: `iters` rounds of independent FMA chains; returns a value that
// depends on every chain (so nothing is optimised away) and sets *flops.
typedef double ek_fma_probe_fn(long iters, double *flops);
// material_block: nblocks AoSoA blocks; F, R, dF 9 planes (R read for
// corotated linear only, dF for PK1_DIFF only); out 1 / 9 / 9 / 81 planes
// for op = energy / P / dP / Hessian (ek_material_op). Knobs resolved by
// the driver (kernels/material/material.c) from ek_material.
typedef struct {
  ek_material_op op;
  int project;
  double mu, lambda, clamp;
  ek_svd3_knobs svd; // SVD knobs (the precision's defaults)
} ek_material_knobs;
typedef void ek_material_block_f32_fn(size_t nblocks, const float *F, const float *R,
                                      const float *dF, float *out, const ek_material_knobs *k);
typedef void ek_material_block_f64_fn(size_t nblocks, const double *F, const double *R,
                                      const double *dF, double *out, const ek_material_knobs *k);

// fvm_block: FVM forces of AoSoA tet blocks [b0, b1) (contract in
// kernels/fvm/fvm_kernel.h); fvm_F_block: their deformation gradients only
// (9 planes per block), for the phase-split timing.
typedef struct ek_fvm_args_f32 ek_fvm_args_f32;
typedef struct ek_fvm_args_f64 ek_fvm_args_f64;
typedef void ek_fvm_block_f32_fn(const ek_fvm_args_f32 *a, size_t b0, size_t b1);
typedef void ek_fvm_block_f64_fn(const ek_fvm_args_f64 *a, size_t b0, size_t b1);
typedef void ek_fvm_F_block_f32_fn(const ek_fvm_args_f32 *a, size_t b0, size_t b1, float *F);
typedef void ek_fvm_F_block_f64_fn(const ek_fvm_args_f64 *a, size_t b0, size_t b1, double *F);

// hessian_block: gradient, Hessian product or diagonal blocks of AoSoA tet
// blocks [b0, b1) (contract in kernels/fvm/hessian_kernel.h).
typedef struct ek_hess_args_f32 ek_hess_args_f32;
typedef struct ek_hess_args_f64 ek_hess_args_f64;
typedef void ek_hessian_block_f32_fn(const ek_hess_args_f32 *a, size_t b0, size_t b1);
typedef void ek_hessian_block_f64_fn(const ek_hess_args_f64 *a, size_t b0, size_t b1);

// xpbd_block: XPBD constraint blocks [b0, b1) (contract in
// kernels/xpbd/xpbd_kernel.h).
typedef struct ek_xpbd_args_f32 ek_xpbd_args_f32;
typedef struct ek_xpbd_args_f64 ek_xpbd_args_f64;
typedef void ek_xpbd_block_f32_fn(const ek_xpbd_args_f32 *a, size_t b0, size_t b1);
typedef void ek_xpbd_block_f64_fn(const ek_xpbd_args_f64 *a, size_t b0, size_t b1);

// cloth_membrane_block / cloth_bending_block: corner forces of AoSoA
// (cloth_membrane_energy_block / _hessian_block: the membrane energy per
// triangle and the corners of its Hessian product, same arguments)
// triangle / hinge blocks [b0, b1) (contract in
// kernels/cloth_force/cloth_force_kernel.h).
typedef struct ek_cloth_force_args_f32 ek_cloth_force_args_f32;
typedef struct ek_cloth_force_args_f64 ek_cloth_force_args_f64;
typedef void ek_cloth_force_block_f32_fn(const ek_cloth_force_args_f32 *a, size_t b0, size_t b1);
typedef void ek_cloth_force_block_f64_fn(const ek_cloth_force_args_f64 *a, size_t b0, size_t b1);

// cloth blocks (kernels/cloth/cloth_block.c): nblocks AoSoA blocks, two
// inputs and up to three outputs (an output may be NULL where the kernel
// says so; unused ones are ignored):
//   cloth_tri_F:       x (9 planes), Dm_inv (4)      -> F (6)
//   cloth_polar32:     F (6), unused                 -> R (6), Uc (4 or NULL)
//   cloth_tri_velgrad: x (9), v (9)                  -> L, D, W (9 each or NULL)
//   cloth_tet_velgrad: x (12), v (12)                -> L, D, W (9 each or NULL)
// count is blocks of AoSoA batches (aos = 0) or items of AoS arrays (aos =
// 1: transposed in registers; not cloth_tet_velgrad, AoSoA only).
typedef void ek_cloth_block_f32_fn(size_t count, int aos, const float *a, const float *b, float *o0,
                                   float *o1, float *o2);
typedef void ek_cloth_block_f64_fn(size_t count, int aos, const double *a, const double *b,
                                   double *o0, double *o1, double *o2);

// A row of the kernel table: every kernel of one ISA target. A row starts
// from the scalar kernels and the target's own kernels override them
// (BLIS's context), so a target that lacks a kernel still has a callable
// entry and a port can land one kernel at a time. The per-model entries
// are indexed by ek_model (each model file fills its own, model_kernels.h).
typedef struct {
  ek_isa isa;
  int lanes_f32, lanes_f64; // EK_W of the target
  // Per-microarchitecture tuning, set when the row is made (dispatch.c):
  // independent vectors svd3_block keeps in flight (ek_svd3_knobs.chains).
  int svd3_chains;
  ek_svd3_block_f32_fn *svd3_block_f32;
  ek_svd3_block_f64_fn *svd3_block_f64;
  ek_polar_warm_block_f32_fn *polar_warm_block_f32;
  ek_polar_warm_block_f64_fn *polar_warm_block_f64;
  // The same on n AoS matrices (count = matrices, A and R 9 reals each),
  // transposed in registers (polar_warm_block.c); the same bits per matrix.
  ek_polar_warm_block_f32_fn *polar_warm_aos_f32;
  ek_polar_warm_block_f64_fn *polar_warm_aos_f64;
  ek_fma_probe_fn *fma_probe_f32;
  ek_fma_probe_fn *fma_probe_f64;
  ek_material_block_f32_fn *material_block_f32[EK_MODEL_COUNT];
  ek_material_block_f64_fn *material_block_f64[EK_MODEL_COUNT];
  ek_fvm_block_f32_fn *fvm_block_f32[EK_MODEL_COUNT];
  ek_fvm_block_f64_fn *fvm_block_f64[EK_MODEL_COUNT];
  ek_fvm_block_f32_fn *fvm_P_block_f32; // the phase split's pass from a stored P
  ek_fvm_block_f64_fn *fvm_P_block_f64;
  ek_fvm_F_block_f32_fn *fvm_F_block_f32;
  ek_fvm_F_block_f64_fn *fvm_F_block_f64;
  ek_hessian_block_f32_fn *hessian_block_f32[EK_MODEL_COUNT];
  ek_hessian_block_f64_fn *hessian_block_f64[EK_MODEL_COUNT];
  // The product and diagonal blocks every isotropic model shares (from the
  // cached eigensystem its gradient pass wrote).
  ek_hessian_block_f32_fn *hessian_frame_block_f32;
  ek_hessian_block_f64_fn *hessian_frame_block_f64;
  // The assembly's sums of one block's element Hessians into K's values
  // (hessian_kernel.h).
  ek_hessian_block_f32_fn *hessian_sum_f32;
  ek_hessian_block_f64_fn *hessian_sum_f64;
  ek_xpbd_block_f32_fn *xpbd_block_f32;
  ek_xpbd_block_f64_fn *xpbd_block_f64;
  ek_cloth_force_block_f32_fn *cloth_membrane_block_f32, *cloth_bending_block_f32;
  ek_cloth_force_block_f64_fn *cloth_membrane_block_f64, *cloth_bending_block_f64;
  ek_cloth_force_block_f32_fn *cloth_membrane_energy_block_f32, *cloth_membrane_hessian_block_f32;
  ek_cloth_force_block_f64_fn *cloth_membrane_energy_block_f64, *cloth_membrane_hessian_block_f64;
  ek_cloth_block_f32_fn *cloth_tri_F_block_f32;
  ek_cloth_block_f64_fn *cloth_tri_F_block_f64;
  ek_cloth_block_f32_fn *cloth_polar32_block_f32;
  ek_cloth_block_f64_fn *cloth_polar32_block_f64;
  ek_cloth_block_f32_fn *cloth_tri_velgrad_block_f32;
  ek_cloth_block_f64_fn *cloth_tri_velgrad_block_f64;
  ek_cloth_block_f32_fn *cloth_tet_velgrad_block_f32;
  ek_cloth_block_f64_fn *cloth_tet_velgrad_block_f64;
} ek_kernel_table;

// Each kernel source of each (ISA x precision) build ends with a fill
// function, ek_<source>_fill_<isa>_<prec> (EK_SYM(<source>_fill)), that
// enters its kernels in a row; CMake tells dispatch.c which exist per ISA
// (EK_FILLS_<ISA>).
typedef void ek_kernel_fill_fn(ek_kernel_table *t);

// Table of a resolved target (see ek_isa_resolve), NULL if not available.
const ek_kernel_table *ek_kernels_for(ek_isa isa);
// Resolve opts-style request and return its table; NULL (with
// ek_last_error set) on error.
const ek_kernel_table *ek_kernels_resolve(ek_isa requested);

// Record an error message for ek_last_error (printed only with EK_VERBOSE).
void ek_set_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

// An EK_* environment variable (env.c, the one rule): 0 when unset or
// empty; 1 when it is one of the n words, exactly (*index = which); else
// EK_EINVAL with ek_last_error "NAME='value' is not one of w0, w1".
int ek_env_choice(const char *name, int n, const char *const *words, int *index);
// EK_VERBOSE=1 (any other value is off here; ek_env_check reports it).
int ek_env_verbose(void);

// The batch argument check every batch entry point makes before it reads or
// writes anything (EK_OK, or EK_EINVAL with ek_last_error set):
//   - count items of item_bytes each (AoS: n and the bytes of its largest
//     per-item array; AoSoA: nblocks and a whole block's largest array)
//     must stay below PTRDIFF_MAX bytes with EK_BATCH_SLACK items to spare
//     for the drivers' rounding up to whole chunks, so no byte count, chunk
//     count or pointer offset wraps (n = SIZE_MAX is refused, not run as a
//     small batch);
//   - every non-NULL array must be aligned to `align` (the alignment of its
//     element type, as core.h documents); names[i] names arrays[i].
#define EK_BATCH_SLACK 4096
int ek_batch_check(const char *fn, size_t count, size_t item_bytes, size_t align, int narrays,
                   const void *const *arrays, const char *const *names);

// AoS drivers: how many of the n records of rec_bytes each at p to take on
// their own (a partial vector) so that the rest starts on a 64-byte line,
// and every vector of EK_LANES records then spans whole lines: fewer than
// EK_LANES, 0 when p already is on a line or no count gets there. A batch
// from malloc (16 bytes into a line) otherwise splits a load or store of
// every vector across two lines: the warm polar's AoS path took 5.4 ns per
// f32 matrix on 2^20 such matrices against 4.2 on a 64-byte array (Zen 5,
// AVX-512, 1 thread). Each record's result does not depend on its lane.
size_t ek_aos_head(const void *p, size_t rec_bytes, size_t n);

#endif
