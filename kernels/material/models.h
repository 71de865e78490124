// The model table: one row per ek_model, the only place that says what a
// model is called and what it needs. The drivers (names, ek_model_need,
// the FVM phase split) and the kernels (which path a model takes) read it;
// its entries are compile-time constants, so in a kernel specialised for
// one model every test on them folds away.
//
// The per-model math (psi, P, dP in F; the singular-value form: psi, g =
// dpsi/dsigma, the Hessian blocks that dP and the projected dP are built
// from) lives in kernels/material/<name>.h with the same function names per
// model; material_core.h selects them with switches that list every model
// and have no default (built with -Werror=switch: a model missing from one
// is a compile error, never another model). The reference keeps its own,
// independent table (reference/material/material_ref.c).
#ifndef EK_KERNELS_MATERIAL_MODELS_H
#define EK_KERNELS_MATERIAL_MODELS_H

#include <ek/material.h>

typedef struct {
  const char *name;      // short name, ek_model_name(): "snh"
  const char *long_name; // scene files: "stable_neo_hookean"
  ek_model_needs needs;  // per element, without clamp
  // 1: P goes through singular values (Irving et al. 2004 sec. 5) and a
  // clamp > 0 applies (then the model needs the full SVD); 0: ignores clamp.
  int clampable;
  // 1: isotropic, so the Hessian has the U, V-frame eigensystem (Teran et
  // al. 2005) through which dP is projected; 0: linear in F's rotation
  // (linear, corotated linear), Hessian constant and PSD.
  int isotropic;
} ek_model_row;

static const ek_model_row ek_model_rows[EK_MODEL_COUNT] = {
    [EK_MODEL_LINEAR] = {"linear", "linear", EK_NEEDS_NOTHING, 0, 0},
    [EK_MODEL_STVK] = {"stvk", "stvk", EK_NEEDS_NOTHING, 0, 1},
    [EK_MODEL_COROTATED_LINEAR] = {"corot_linear", "corotated_linear", EK_NEEDS_R_INPUT, 0, 0},
    [EK_MODEL_FIXED_COROTATED] = {"fixed_corot", "fixed_corotated", EK_NEEDS_POLAR, 1, 1},
    [EK_MODEL_ARAP] = {"arap", "arap", EK_NEEDS_POLAR, 1, 1},
    [EK_MODEL_PSI_R] = {"psi_r", "psi_r", EK_NEEDS_NOTHING, 0, 1},
    [EK_MODEL_NEO_HOOKEAN] = {"nh", "neo_hookean", EK_NEEDS_J, 1, 1},
    [EK_MODEL_STABLE_NEO_HOOKEAN] = {"snh", "stable_neo_hookean", EK_NEEDS_J, 1, 1},
};

// What a model needs for P with this clamp.
static inline ek_model_needs ek_model_row_needs(ek_model model, double clamp) {
  return ek_model_rows[model].clampable && clamp > 0 ? EK_NEEDS_SVD : ek_model_rows[model].needs;
}

// 1 if P (and psi) go through the SVD of F for this clamp.
static inline int ek_model_row_uses_sigma(ek_model model, double clamp) {
  ek_model_needs n = ek_model_row_needs(model, clamp);
  return n == EK_NEEDS_POLAR || n == EK_NEEDS_SVD;
}

#endif
