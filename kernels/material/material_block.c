// The material block kernel of one (ISA x precision) build: the block loop
// of material_core.h instantiated once per model (the model a compile-time
// constant in each case, so each gets its own specialised code), chosen
// once per call, never per element.
#include "simd/simd.h"
// simd.h first: the kernel headers below are written against it.
#include "kernels.h"
#include "material/material_core.h"

void EK_SYM(material_block)(size_t nblocks, const real *F, const real *R, const real *dF, real *out,
                            const ek_material_knobs *k) {
  switch (k->model) {
  case EK_MODEL_LINEAR:
    material_blocks(EK_MODEL_LINEAR, nblocks, F, R, dF, out, k);
    break;
  case EK_MODEL_STVK:
    material_blocks(EK_MODEL_STVK, nblocks, F, R, dF, out, k);
    break;
  case EK_MODEL_COROTATED_LINEAR:
    material_blocks(EK_MODEL_COROTATED_LINEAR, nblocks, F, R, dF, out, k);
    break;
  case EK_MODEL_FIXED_COROTATED:
    material_blocks(EK_MODEL_FIXED_COROTATED, nblocks, F, R, dF, out, k);
    break;
  case EK_MODEL_ARAP:
    material_blocks(EK_MODEL_ARAP, nblocks, F, R, dF, out, k);
    break;
  case EK_MODEL_PSI_R:
    material_blocks(EK_MODEL_PSI_R, nblocks, F, R, dF, out, k);
    break;
  case EK_MODEL_NEO_HOOKEAN:
    material_blocks(EK_MODEL_NEO_HOOKEAN, nblocks, F, R, dF, out, k);
    break;
  case EK_MODEL_STABLE_NEO_HOOKEAN:
    material_blocks(EK_MODEL_STABLE_NEO_HOOKEAN, nblocks, F, R, dF, out, k);
    break;
  }
}
