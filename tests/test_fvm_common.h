// Shared by tests/test_fvm_ref.c and tests/test_fvm.c: random small meshes
// (a jittered box with randomly renumbered vertices, so caller order and
// the mesh's internal order differ), random deformations, the model list,
// and the force error metric of include/ek/fvm.h.
#ifndef EK_TEST_FVM_COMMON_H
#define EK_TEST_FVM_COMMON_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ek/fvm.h>

#include "check.h"
#include "check_box.h"
#include "fvm/fvm_ref.h"

typedef struct {
  size_t nverts, ntets;
  double *X;  // rest, nverts x 3
  int32_t *T; // ntets x 4
} test_mesh;

static inline void test_mesh_free(test_mesh *t) {
  free(t->X);
  free(t->T);
}

// Box of nx*ny*nz cells of size h (ek_check_box_create, ek_mesh_box's
// mesh), interior vertices moved by up to `jitter` cells, vertices
// renumbered at random.
static inline test_mesh test_mesh_random(ek_rng *rng, int nx, int ny, int nz, double jitter) {
  ek_check_box box;
  if (ek_check_box_create(&box, nx, ny, nz, nx * 0.1, ny * 0.1, nz * 0.1) != 0) {
    printf("ek_check_box_create: %s\n", ek_last_error());
    exit(1);
  }
  test_mesh t = {box.nverts, box.ntets, NULL, NULL};
  t.X = malloc(t.nverts * 3 * sizeof(double));
  t.T = malloc(t.ntets * 4 * sizeof(int32_t));
  int32_t *perm = malloc(t.nverts * sizeof(int32_t));
  for (size_t v = 0; v < t.nverts; v++)
    perm[v] = (int32_t)v;
  for (size_t v = t.nverts - 1; v > 0; v--) {
    size_t j = (size_t)(ek_rng_uniform(rng) * (double)(v + 1));
    int32_t tmp = perm[v];
    perm[v] = perm[j];
    perm[j] = tmp;
  }
  const double *X = box.X;
  double len[3] = {nx * 0.1, ny * 0.1, nz * 0.1};
  for (size_t v = 0; v < t.nverts; v++)
    for (int k = 0; k < 3; k++) {
      double x = X[v * 3 + k];
      int interior = x > 1e-9 && x < len[k] - 1e-9;
      t.X[perm[v] * 3 + k] = x + (interior ? jitter * 0.1 * (2 * ek_rng_uniform(rng) - 1) : 0);
    }
  for (size_t i = 0; i < t.ntets * 4; i++)
    t.T[i] = perm[box.T[i]];
  free(perm);
  ek_check_box_destroy(&box);
  return t;
}

// x = A X + c + noise: A = Q (I + strain G) (a rotation times a random
// stretch), noise up to `noise` of a cell per component.
static inline void test_deform(ek_rng *rng, const test_mesh *t, double strain, double noise,
                               double *x) {
  double A[9];
  ek_rng_deformation(rng, strain, A);
  double c[3] = {ek_rng_gauss(rng), ek_rng_gauss(rng), ek_rng_gauss(rng)};
  for (size_t v = 0; v < t->nverts; v++)
    for (int i = 0; i < 3; i++) {
      double s = c[i];
      for (int k = 0; k < 3; k++)
        s += A[i * 3 + k] * t->X[v * 3 + k];
      x[v * 3 + i] = s + noise * 0.1 * (2 * ek_rng_uniform(rng) - 1);
    }
}

typedef struct {
  const char *name;
  ek_material mat;
} test_model;

// Every model; the clamped variants with a clamp below every singular
// value the deformations above produce (the clamp's extension is checked
// by the material tests; here it must not change the force).
static const test_model test_models[] = {
    {"linear", {EK_MODEL_LINEAR, 1.0, 2.0, 0}},
    {"stvk", {EK_MODEL_STVK, 1.0, 2.0, 0}},
    {"corot_linear", {EK_MODEL_COROTATED_LINEAR, 1.0, 2.0, 0}},
    {"fixed_corot", {EK_MODEL_FIXED_COROTATED, 1.0, 2.0, 0}},
    {"fixed_corot+clamp", {EK_MODEL_FIXED_COROTATED, 1.0, 2.0, 0.05}},
    {"arap", {EK_MODEL_ARAP, 1.0, 0.0, 0}},
    {"psi_r", {EK_MODEL_PSI_R, 1.0, 0.0, 0}},
    {"nh", {EK_MODEL_NEO_HOOKEAN, 1.0, 2.0, 0}},
    {"nh+clamp", {EK_MODEL_NEO_HOOKEAN, 1.0, 2.0, 0.05}},
    {"snh", {EK_MODEL_STABLE_NEO_HOOKEAN, 1.0, 2.0, 0}},
    {"snh+clamp", {EK_MODEL_STABLE_NEO_HOOKEAN, 1.0, 2.0, 0.05}},
};
static const int test_nmodels = sizeof test_models / sizeof test_models[0];

static inline ek_material_ref test_ref_material(const ek_material *m) {
  ek_material_ref r = {(int)m->model, m->mu, m->lambda, m->clamp};
  return r;
}

// Per-tet random rotations (corotated linear's R input).
static inline double *test_rotations(ek_rng *rng, size_t ntets) {
  double *R = malloc(ntets * 9 * sizeof(double));
  for (size_t e = 0; e < ntets; e++)
    ek_rng_rotation(rng, R + e * 9);
  return R;
}

// The force error of include/ek/fvm.h: max_i |f_i - f_ref_i| / max_i s_i.
// *worst_i receives the component index of the largest error.
static inline double test_force_error(size_t n3, const double *f, const double *fref,
                                      const double *fscale, size_t *worst_i) {
  double scale = 0, err = 0;
  size_t wi = 0;
  for (size_t i = 0; i < n3; i++)
    scale = fmax(scale, fscale[i]);
  for (size_t i = 0; i < n3; i++) {
    double e = fabs(f[i] - fref[i]);
    if (!(e <= err)) { // NaN counts as the worst
      err = e;
      wi = i;
      if (isnan(e))
        break;
    }
  }
  if (worst_i)
    *worst_i = wi;
  return isnan(err) ? NAN : err / (scale > 0 ? scale : 1);
}

#endif
