// The material kernel of one (ISA x precision) build: one entry in the
// dispatch table that picks the per-model block kernel (once per call,
// never per element).
#include "../simd/simd.h"
// simd.h first: the kernel headers below are written against it.
#include "../kernels.h"
#include "material_core.h"

#define EK_MATERIAL_MODEL_BLOCK(name)                                                              \
  void EK_SYM(material_##name##_block)(size_t nblocks, const real *F, const real *R,               \
                                       const real *dF, real *out, const ek_material_knobs *k);
EK_MATERIAL_MODEL_BLOCK(linear)
EK_MATERIAL_MODEL_BLOCK(stvk)
EK_MATERIAL_MODEL_BLOCK(corot_linear)
EK_MATERIAL_MODEL_BLOCK(fixed_corot)
EK_MATERIAL_MODEL_BLOCK(arap)
EK_MATERIAL_MODEL_BLOCK(psi_r)
EK_MATERIAL_MODEL_BLOCK(nh)
EK_MATERIAL_MODEL_BLOCK(snh)

void EK_SYM(material_block)(size_t nblocks, const real *F, const real *R, const real *dF, real *out,
                            const ek_material_knobs *k) {
  switch (k->model) {
  case MAT_LINEAR:
    EK_SYM(material_linear_block)(nblocks, F, R, dF, out, k);
    break;
  case MAT_STVK:
    EK_SYM(material_stvk_block)(nblocks, F, R, dF, out, k);
    break;
  case MAT_COROT_LINEAR:
    EK_SYM(material_corot_linear_block)(nblocks, F, R, dF, out, k);
    break;
  case MAT_FIXED_COROT:
    EK_SYM(material_fixed_corot_block)(nblocks, F, R, dF, out, k);
    break;
  case MAT_ARAP:
    EK_SYM(material_arap_block)(nblocks, F, R, dF, out, k);
    break;
  case MAT_PSI_R:
    EK_SYM(material_psi_r_block)(nblocks, F, R, dF, out, k);
    break;
  case MAT_NH:
    EK_SYM(material_nh_block)(nblocks, F, R, dF, out, k);
    break;
  default:
    EK_SYM(material_snh_block)(nblocks, F, R, dF, out, k);
    break;
  }
}
