// The model table (one line per model, in ek_model order) and the
// descriptor pieces several models share. Each descriptor is written in
// its model's file (kernels/material/<name>.c, descriptor build).
#include <math.h>
#include <stdio.h>

#include "models.h"

extern const ek_model_desc ek_model_linear, ek_model_stvk, ek_model_corot_linear,
    ek_model_fixed_corot, ek_model_arap, ek_model_psi_r, ek_model_nh, ek_model_snh;

const ek_model_desc *const ek_models[EK_MODEL_COUNT] = {
    &ek_model_linear, &ek_model_stvk,  &ek_model_corot_linear, &ek_model_fixed_corot,
    &ek_model_arap,   &ek_model_psi_r, &ek_model_nh,           &ek_model_snh,
};

const ek_model_desc *ek_model_describe(ek_model model) {
  return (unsigned)model < EK_MODEL_COUNT ? ek_models[model] : NULL;
}

// Most models linearise to linear elasticity with their own mu and lambda.
void ek_model_lame_same(double mu, double lambda, double *mu_lin, double *lambda_lin) {
  *mu_lin = mu, *lambda_lin = lambda;
}

int ek_model_lame_same_inverse(double mu_lin, double lambda_lin, double *mu, double *lambda,
                               char *why, size_t whylen) {
  (void)why, (void)whylen;
  *mu = mu_lin, *lambda = lambda_lin;
  return EK_OK;
}

// ARAP and Psi_R have no volume term: (mu, lambda) -> (mu, 0).
void ek_model_lame_no_volume(double mu, double lambda, double *mu_lin, double *lambda_lin) {
  (void)lambda;
  *mu_lin = mu, *lambda_lin = 0;
}

int ek_model_lame_no_volume_inverse(double mu_lin, double lambda_lin, double *mu, double *lambda,
                                    char *why, size_t whylen) {
  if (lambda_lin != 0) {
    snprintf(why, whylen,
             "no volume term: the same material only when the linearised lambda is 0 (it "
             "is %g)",
             lambda_lin);
    return EK_EINVAL;
  }
  *mu = mu_lin, *lambda = lambda_lin;
  return EK_OK;
}

// StVK and Psi_R (Psi_R is StVK's shear term, mu/4 |F^T F - I|^2): no
// inversion and no compression past sigma = 1/sqrt(3). In 1-D,
// P(s) = k s (s^2 - 1) / 2 peaks in compression at s = 1/sqrt(3) and falls
// to 0 at s = 0 (dP/ds = k (3 s^2 - 1) / 2): beyond it the material
// softens and can collapse (Irving et al. 2004, sec. 5; material.h: "no
// resistance at a flat element").
const char *ek_model_excluded_past_peak(const ek_model_run_stats *r, double clamp,
                                        double small_strain, char *why, size_t whylen) {
  (void)clamp, (void)small_strain;
  if (r->min_sigma <= 1 / sqrt(3.0)) {
    snprintf(why, whylen,
             "compressed to sigma_min = %.3g <= 1/sqrt(3): past the peak of its compressive "
             "stress (softens, can invert)",
             r->min_sigma);
    return why;
  }
  return NULL;
}
