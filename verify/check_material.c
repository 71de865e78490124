// The material input set of ek-verify's "material" family, shared with the
// speed/accuracy map (bench/tradeoff_kernels.c) so both measure the same
// elements: F with singular values in [0.2, 5] (near identity, large,
// inverted, near-flat, rotations), a rotation R per element and dF with
// entries in [-1, 1].
#include "check.h"

#include <stdlib.h>

static void make_F(ek_rng *rng, int kind, double F[9]) {
  double s[3];
  switch (kind) {
  case 0: // near identity
    for (int k = 0; k < 9; k++)
      F[k] = (k % 4 == 0) + 0.4 * (ek_rng_uniform(rng) - 0.5);
    return;
  case 1: // large
    for (int i = 0; i < 3; i++)
      s[i] = 0.2 + 4.8 * ek_rng_uniform(rng);
    break;
  case 2: // inverted, away from sigma_i + sigma_j = 0
    s[0] = 0.8 + 1.2 * ek_rng_uniform(rng), s[1] = 0.8 + 1.2 * ek_rng_uniform(rng);
    s[2] = -(0.1 + 0.4 * ek_rng_uniform(rng));
    break;
  case 3: // near-flat
    s[0] = 0.8 + 1.2 * ek_rng_uniform(rng), s[1] = 0.8 + 1.2 * ek_rng_uniform(rng);
    s[2] = 0.2 + 0.05 * ek_rng_uniform(rng);
    break;
  default: // rotation
    s[0] = s[1] = s[2] = 1;
    break;
  }
  ek_rng_with_sigma(rng, s, F);
}

void ek_check_material_inputs(uint64_t seed, int f32, size_t n, double *F, double *R, double *dF) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, f32 ? "material f32" : "material f64"));
  for (size_t e = 0; e < n; e++) {
    make_F(&rng, (int)(5 * ek_rng_uniform(&rng)), F + 9 * e);
    ek_rng_rotation(&rng, R + 9 * e);
    for (int k = 0; k < 9; k++)
      dF[9 * e + k] = 2 * ek_rng_uniform(&rng) - 1;
  }
  if (f32) // the reference sees exactly the float input
    for (size_t i = 0; i < n * 9; i++)
      F[i] = (float)F[i], R[i] = (float)R[i], dF[i] = (float)dF[i];
}

int ek_check_run_material(int f32, const ek_material *m, ek_material_op op, ek_isa isa, size_t n,
                          const double *F, const double *R, const double *dF, double *out,
                          int project) {
  const size_t nout = op == EK_MAT_ENERGY ? 1 : op == EK_MAT_HESSIAN ? 81 : 9;
  if (!f32)
    return ek_material_eval_f64(m, op, isa, n, F, R, dF, out, project);
  float *Ff = ek_check_malloc(n * 9 * sizeof(float)), *Rf = ek_check_malloc(n * 9 * sizeof(float));
  float *dFf = ek_check_malloc(n * 9 * sizeof(float)),
        *Of = ek_check_malloc(n * nout * sizeof(float));
  for (size_t i = 0; i < n * 9; i++)
    Ff[i] = (float)F[i], Rf[i] = R ? (float)R[i] : 0, dFf[i] = dF ? (float)dF[i] : 0;
  int rc = ek_material_eval_f32(m, op, isa, n, Ff, R ? Rf : NULL, dF ? dFf : NULL, Of, project);
  if (rc >= 0)
    ek_check_from_f32(n * nout, Of, out);
  free(Ff), free(Rf), free(dFf), free(Of);
  return rc;
}
