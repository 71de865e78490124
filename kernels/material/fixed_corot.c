// Block kernel of one material model (math in fixed_corot.h): the shared block loop
// of material_core.h with the model fixed at compile time, so each model
// gets its own specialised code. Built once per (ISA x precision).
#include "../simd/simd.h"
// simd.h first: the kernel headers below are written against it.
#include "../kernels.h"
#include "material_core.h"

void EK_SYM(material_fixed_corot_block)(size_t nblocks, const real *F, const real *R,
                                        const real *dF, real *out, const ek_material_knobs *k) {
  material_blocks(MAT_FIXED_COROT, nblocks, F, R, dF, out, k);
}
