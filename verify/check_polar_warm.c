// Inputs and errors of the warm-started polar (check_polar_warm.h).
#include "check_polar_warm.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ek/batch.h>
#include <ek/fvm.h>
#include <ek/polar.h>
#include <ek/sim/sim.h>

#include "svd3/svd3_ref.h"

void ek_check_axis_angle(const double n[3], double angle, double R[9]) {
  double c = cos(angle), s = sin(angle), t = 1 - c, x = n[0], y = n[1], z = n[2];
  // Rodrigues' formula.
  double M[9] = {c + x * x * t,     x * y * t - z * s, x * z * t + y * s,
                 y * x * t + z * s, c + y * y * t,     y * z * t - x * s,
                 z * x * t - y * s, z * y * t + x * s, c + z * z * t};
  memcpy(R, M, sizeof M);
}

void ek_check_warm_cases(ek_rng *rng, size_t n, double s_min, double s_max, double deg_min,
                         double deg_max, double *A, double *G) {
  const double pi = 3.14159265358979323846;
  for (size_t e = 0; e < n; e++) {
    double Rs[9], Q[9], QS[9], S[9], E[9], axis[3], s[3];
    ek_rng_rotation(rng, Rs);
    ek_rng_rotation(rng, Q);
    double lo = fabs(s_min), hi = fabs(s_max);
    for (int i = 0; i < 3; i++)
      s[i] = lo + (hi - lo) * ek_rng_uniform(rng);
    if (s_min < 0) { // negate the smallest: then R* is A's SVD polar (svd3.h convention)
      int k = s[0] < s[1] ? (s[0] < s[2] ? 0 : 2) : (s[1] < s[2] ? 1 : 2);
      s[k] = -s[k];
    } else if (s_max < 0) { // negate the largest: the SVD polar is R* turned by 180 degrees
      int k = s[0] > s[1] ? (s[0] > s[2] ? 0 : 2) : (s[1] > s[2] ? 1 : 2);
      s[k] = -s[k];
    }
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++)
        QS[i * 3 + j] = Q[i * 3 + j] * s[j];
    ek_mul3_bt(QS, Q, S);
    ek_mul3(Rs, S, A + e * 9);
    double n2;
    do {
      axis[0] = ek_rng_gauss(rng), axis[1] = ek_rng_gauss(rng), axis[2] = ek_rng_gauss(rng);
      n2 = axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2];
    } while (n2 < 1e-12);
    for (int i = 0; i < 3; i++)
      axis[i] /= sqrt(n2);
    double deg = deg_min + (deg_max - deg_min) * ek_rng_uniform(rng);
    ek_check_axis_angle(axis, deg * pi / 180, E);
    ek_mul3(E, Rs, G + e * 9);
  }
}

double ek_check_rdiff9(const double R[9], const double R_ref[9]) {
  double d = 0;
  for (int i = 0; i < 9; i++) {
    double x = fabs(R[i] - R_ref[i]);
    if (isnan(x))
      return NAN;
    d = x > d ? x : d;
  }
  return d;
}

double ek_check_polar_error(int bits, const double A[9], const double R[9]) {
  double a[9], Rr[9];
  for (int i = 0; i < 9; i++)
    a[i] = bits == 32 ? (double)(float)A[i] : A[i];
  ek_polar3_ref(a, Rr, NULL);
  return ek_check_rdiff9(R, Rr);
}

int ek_check_run_polar_warm(int bits, int aosoa, size_t n, const double *A, double *R, ek_isa isa,
                            int iterations) {
  ek_polar_warm_opts o = {.iterations = iterations, .isa = isa};
  int rc;
  if (bits == 64 && !aosoa)
    return ek_polar3_warm_f64(n, A, R, &o);
  if (bits == 64) {
    double *a = ek_aosoa_alloc_f64(n, 9), *r = ek_aosoa_alloc_f64(n, 9);
    ek_aosoa_pack_f64(n, 9, A, a);
    ek_aosoa_pack_f64(n, 9, R, r);
    rc = ek_polar3_warm_aosoa_f64(ek_aosoa_blocks_f64(n), a, r, &o);
    if (rc == 0)
      ek_aosoa_unpack_f64(n, 9, r, R);
    ek_free(a), ek_free(r);
    return rc;
  }
  float *a = ek_check_malloc(n * 9 * sizeof(float) + 1),
        *r = ek_check_malloc(n * 9 * sizeof(float) + 1);
  ek_check_to_f32(n * 9, A, a);
  ek_check_to_f32(n * 9, R, r);
  if (!aosoa) {
    rc = ek_polar3_warm_f32(n, a, r, &o);
  } else {
    float *pa = ek_aosoa_alloc_f32(n, 9), *pr = ek_aosoa_alloc_f32(n, 9);
    ek_aosoa_pack_f32(n, 9, a, pa);
    ek_aosoa_pack_f32(n, 9, r, pr);
    rc = ek_polar3_warm_aosoa_f32(ek_aosoa_blocks_f32(n), pa, pr, &o);
    if (rc == 0)
      ek_aosoa_unpack_f32(n, 9, pr, r);
    ek_free(pa), ek_free(pr);
  }
  if (rc == 0)
    ek_check_from_f32(n * 9, r, R);
  free(a), free(r);
  return rc;
}

// The scene, its model made one that takes a polar when it takes none.
static int open_scene(const char *path, ek_scene *sc, ek_mesh **mesh, ek_sim **sim) {
  *mesh = NULL, *sim = NULL;
  if (ek_scene_load(path, sc) != 0)
    return -1;
  sc->output_file[0] = '\0';
  // The warm polar stands in for R(F) of the models that need it (fixed
  // corotated, ARAP); a scene of another model runs fixed corotated.
  if (ek_model_need(sc->material.model, 0) != EK_NEEDS_POLAR) {
    ek_model_from_name("fixed_corotated", &sc->material.model);
    snprintf(sc->model_name, sizeof sc->model_name, "fixed_corotated");
  }
  if (!(*mesh = ek_scene_mesh(sc)))
    return -1;
  if (!(*sim = ek_sim_create(sc, *mesh))) {
    ek_mesh_destroy(*mesh);
    *mesh = NULL;
    return -1;
  }
  return 0;
}

int ek_check_sim_F(const char *scene_path, long steps, long stride, double **F_out, double **R_out,
                   size_t *ntets, size_t *nsamples, char *err, size_t errlen) {
  ek_scene sc;
  ek_mesh *mesh;
  ek_sim *sim;
  if (stride < 1 || steps < stride) {
    snprintf(err, errlen, "ek_check_sim_F: steps %ld, stride %ld", steps, stride);
    return -1;
  }
  if (open_scene(scene_path, &sc, &mesh, &sim) != 0) {
    snprintf(err, errlen, "%s", ek_last_error());
    return -1;
  }
  size_t nt = ek_mesh_ntets(mesh), ns = (size_t)(steps / stride) + 1;
  double *F = ek_check_malloc(ns * nt * 9 * sizeof(double));
  double *R = ek_check_malloc(ns * nt * 9 * sizeof(double));
  size_t k = 0;
  int rc = 0;
  for (long n = 0; rc == 0 && n <= steps; n++) {
    if (n % stride == 0) {
      ek_mesh_deformation_gradients_f64(mesh, ek_sim_positions(sim), F + k * nt * 9);
      for (size_t e = 0; e < nt; e++)
        ek_polar3_ref(F + (k * nt + e) * 9, R + (k * nt + e) * 9, NULL);
      k++;
    }
    if (n < steps && ek_sim_step(sim) != 0) {
      snprintf(err, errlen, "%s: %s", scene_path, ek_last_error()); // names the step
      rc = -1;
    }
  }
  ek_sim_destroy(sim);
  ek_mesh_destroy(mesh);
  if (rc) {
    free(F), free(R);
    return -1;
  }
  *F_out = F, *R_out = R, *ntets = nt, *nsamples = k;
  return 0;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return x < y ? -1 : x > y;
}

int ek_check_polar_warm_sim(const char *scene_path, long steps, long stride, int bits, ek_isa isa,
                            int iterations, ek_check_warm_run *out, char *err, size_t errlen) {
  double *F, *R_svd;
  size_t nt, ns;
  if (ek_check_sim_F(scene_path, steps, stride, &F, &R_svd, &nt, &ns, err, errlen) != 0)
    return -1;
  if (bits == 32) { // the reference sees the kernel's input: F rounded to float
    for (size_t i = 0; i < ns * nt * 9; i++)
      F[i] = (double)(float)F[i];
    for (size_t e = 0; e < ns * nt; e++)
      ek_polar3_ref(F + e * 9, R_svd + e * 9, NULL);
  }
  double *R = ek_check_malloc(nt * 9 * sizeof(double));
  double *errs = ek_check_malloc(ns * nt * sizeof(double) + 1);
  memcpy(R, R_svd, nt * 9 * sizeof(double)); // sample 0: the loop's first step takes the SVD
  memset(out, 0, sizeof *out);
  size_t m = 0;
  int rc = 0;
  for (size_t k = 1; k < ns && rc == 0; k++) {
    rc = ek_check_run_polar_warm(bits, 0, nt, F + k * nt * 9, R, isa, iterations);
    for (size_t e = 0; rc == 0 && e < nt; e++) {
      const double *Rr = R_svd + (k * nt + e) * 9, *Rp = R_svd + ((k - 1) * nt + e) * 9;
      double d = ek_check_rdiff9(R + e * 9, Rr);
      errs[m++] = isnan(d) ? INFINITY : d;
      // Angle between consecutive SVD polars: cos = (tr(Rp^T Rr) - 1) / 2.
      double tr = 0;
      for (int i = 0; i < 9; i++)
        tr += Rp[i] * Rr[i];
      double c = fmin(1, fmax(-1, (tr - 1) / 2));
      double deg = acos(c) * 180 / 3.14159265358979323846;
      out->max_angle_deg = deg > out->max_angle_deg ? deg : out->max_angle_deg;
    }
  }
  if (rc != 0)
    snprintf(err, errlen, "warm polar kernel failed (rc %d): %s", rc, ek_last_error());
  if (rc == 0 && m > 0) {
    qsort(errs, m, sizeof *errs, cmp_double);
    out->max = errs[m - 1];
    out->p99 = errs[(size_t)(0.99 * (double)(m - 1))];
  }
  out->tets = nt, out->samples = ns > 0 ? ns - 1 : 0;
  free(F), free(R_svd), free(R), free(errs);
  return rc ? -1 : 0;
}
