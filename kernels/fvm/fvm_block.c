// The model-independent FVM force passes on AoSoA tet blocks (Teran et al.
// 2003 sec. 4, seed 004), built per (ISA x precision): the phase split's
// F pass (F = Ds Dm^-1 only) and its force pass from a stored P (H = -V0 P
// Dm^-T and the scatter). Each model's fused force kernel (gather -> F ->
// P -> scatter) is fvm_model.h, instantiated in the model's file.
#include "../simd/simd.h"

#include "fvm_vec.h"

// Phase-split pass: H and scatter from a stored P (9 planes per block).
void EK_SYM(fvm_P_block)(const fvm_args *a, size_t b0, size_t b1);
void EK_SYM(fvm_P_block)(const fvm_args *a, size_t b0, size_t b1) {
  _Alignas(64) real hb[16 * L];       // corner_forces' rows of 4 or planes
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  for (size_t b = b0; b < b1; b++) {
    for (int o = 0; o < L; o += EK_W) {
      vreal P[9];
      for (int k = 0; k < 9; k++)
        P[k] = vload(a->P_in + (b * 9 + k) * L + o);
      corner_forces(a, P, b, o, hb);
    }
    if (!a->corner)
      scatter_block(a, b, hb);
  }
  ek_fpmode_leave(mode);
}

// Phase-split pass 1: F only, into F[(b*9 + k)*L + l].
void EK_SYM(fvm_F_block)(const fvm_args *a, size_t b0, size_t b1, real *Fout) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  for (size_t b = b0; b < b1; b++) {
    for (int o = 0; o < L; o += EK_W) {
      vreal F[9];
      deformation_gradient(a, b, o, F);
      for (int k = 0; k < 9; k++)
        vstore(Fout + (b * 9 + k) * L + o, F[k]);
    }
  }
  ek_fpmode_leave(mode);
}

void EK_SYM(fvm_block_fill)(ek_kernel_table *t);
void EK_SYM(fvm_block_fill)(ek_kernel_table *t) {
  t->EK_FIELD(fvm_P_block) = EK_SYM(fvm_P_block);
  t->EK_FIELD(fvm_F_block) = EK_SYM(fvm_F_block);
}
