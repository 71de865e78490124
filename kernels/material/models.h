// The model table and the shape of a model file.
//
// A model is one file, kernels/material/<name>.c: its traits (the MODEL_*
// macros below), its math on registers (psi, P, dP in F and/or the
// singular-value form), its descriptor (ek_model_desc, include/ek/
// material.h) and, through model_kernels.h, its material, force and
// Hessian kernels. CMake builds the file once per (ISA x precision) for the
// kernels and once more with EK_MODEL_DESCRIPTOR for the descriptor.
// Adding a model: its file, its reference (reference/material/<name>_ref.c
// with a row in material_ref.c's table), its enum value in material.h and
// one line in models.c and in kernels/CMakeLists.txt.
//
// Traits a model file defines before including model.h (compile-time
// constants, so every test on them folds away in the kernels):
//   MODEL            symbol token (snh -> ek_snh_fvm_block_avx2_f32)
//   MODEL_ID         its ek_model
//   MODEL_NAME, MODEL_LONG_NAME   short and scene-file names
//   MODEL_NEEDS      ek_model_needs without clamp
//   MODEL_CLAMPABLE  1: P through clamped singular values when clamp > 0;
//                    defines model_sigma_grad
//   MODEL_ISOTROPIC  1: defines model_sigma (psi, g, the Hessian blocks)
//   MODEL_F_FORM     1: defines model_psi, model_pk1, model_diff in F
//   MODEL_READS_R    1: takes a rotation per element (corotated linear)
//   MODEL_WARM_POLAR 1: P from F and R(F): model_pk1_rotation, so the
//                    warm-started polar can stand in for the SVD
//   MODEL_J_DOMAIN   1: defined for J > 0 only unless clamped
//   MODEL_VOLUME_TERM 0: lambda is ignored
#ifndef EK_KERNELS_MATERIAL_MODELS_H
#define EK_KERNELS_MATERIAL_MODELS_H

#include <ek/material.h>

#include "../fvm/hessian_kernel.h" // HESS_FRAME_PLANES

// Every model's descriptor, indexed by ek_model (models.c).
extern const ek_model_desc *const ek_models[EK_MODEL_COUNT];

// What a model needs for P with this clamp.
static inline ek_model_needs ek_model_row_needs(ek_model model, double clamp) {
  const ek_model_desc *d = ek_models[model];
  return d->clampable && clamp > 0 ? EK_NEEDS_SVD : d->needs;
}

// 1 if P (and psi) go through the SVD of F for this clamp.
static inline int ek_model_row_uses_sigma(ek_model model, double clamp) {
  ek_model_needs n = ek_model_row_needs(model, clamp);
  return n == EK_NEEDS_POLAR || n == EK_NEEDS_SVD;
}

// Descriptor pieces several models share (models.c).
void ek_model_lame_same(double mu, double lambda, double *mu_lin, double *lambda_lin);
int ek_model_lame_same_inverse(double mu_lin, double lambda_lin, double *mu, double *lambda,
                               char *why, size_t whylen);
void ek_model_lame_no_volume(double mu, double lambda, double *mu_lin, double *lambda_lin);
int ek_model_lame_no_volume_inverse(double mu_lin, double lambda_lin, double *mu, double *lambda,
                                    char *why, size_t whylen);
const char *ek_model_excluded_past_peak(const ek_model_run_stats *r, double clamp,
                                        double small_strain, char *why, size_t whylen);

// The descriptor's fields that the traits give (the model file adds its
// functions).
#define EK_MODEL_DESC_TRAITS                                                                       \
  .model = MODEL_ID, .name = MODEL_NAME, .long_name = MODEL_LONG_NAME, .needs = MODEL_NEEDS,       \
  .clampable = MODEL_CLAMPABLE, .isotropic = MODEL_ISOTROPIC, .volume_term = MODEL_VOLUME_TERM,    \
  .cache_planes = MODEL_CACHE_PLANES, .j_domain = MODEL_J_DOMAIN

// Per-element planes of the Hessian cache (hessian.h): the U, V-frame
// eigensystem of the isotropic models (20), corotated linear's R (9), none
// for linear elasticity (its Hessian is constant).
#define MODEL_CACHE_PLANES (MODEL_ISOTROPIC ? HESS_FRAME_PLANES : MODEL_READS_R ? 9 : 0)

#endif
