// The kernels of one model, instantiated at the end of its file
// (kernels/material/<name>.c, kernel build) from its traits and model_*
// functions: the material block kernel (psi, P, dP, Hessian of F batches),
// the FVM force kernel and the Hessian kernels of tet blocks, and the fill
// function that enters them in a kernel table row (dispatch.c). Every
// model-independent stage (the SVD pair, loading and storing the cached
// frame) is shared: the SVD is called out of line (svd3_core.h), the rest
// is inline and small.
#ifndef EK_KERNELS_MATERIAL_MODEL_KERNELS_H
#define EK_KERNELS_MATERIAL_MODEL_KERNELS_H

#include "../fvm/fvm_model.h"
#include "../fvm/hessian_model.h"
#include "material_core.h"

// ek_<MODEL>_<name>_<isa>_<prec>
#define EK_MCAT_(m, n) m##_##n
#define EK_MCAT(m, n) EK_MCAT_(m, n)
#define EK_MSYM(name) EK_SYM2_(EK_MCAT(MODEL, name), EK_TARGET_TOKEN, EK_PREC_TOKEN)

void EK_MSYM(material_block)(size_t nblocks, const real *F, const real *R, const real *dF,
                             real *out, const ek_material_knobs *k);
void EK_MSYM(material_block)(size_t nblocks, const real *F, const real *R, const real *dF,
                             real *out, const ek_material_knobs *k) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  material_blocks(nblocks, F, R, dF, out, k);
  ek_fpmode_leave(mode);
}

void EK_MSYM(fvm_block)(const fvm_args *a, size_t b0, size_t b1);
void EK_MSYM(fvm_block)(const fvm_args *a, size_t b0, size_t b1) {
  ek_fpmode mode = ek_fpmode_enter();
  fvm_model_blocks(a, b0, b1);
  ek_fpmode_leave(mode);
}

void EK_MSYM(hessian_block)(const hess_args *a, size_t b0, size_t b1);
void EK_MSYM(hessian_block)(const hess_args *a, size_t b0, size_t b1) {
  ek_fpmode mode = ek_fpmode_enter();
  hess_model_blocks(a, b0, b1);
  ek_fpmode_leave(mode);
}

void EK_MSYM(fill)(ek_kernel_table *t);
void EK_MSYM(fill)(ek_kernel_table *t) {
  t->EK_FIELD(material_block)[MODEL_ID] = EK_MSYM(material_block);
  t->EK_FIELD(fvm_block)[MODEL_ID] = EK_MSYM(fvm_block);
  t->EK_FIELD(hessian_block)[MODEL_ID] = EK_MSYM(hessian_block);
}

#endif
