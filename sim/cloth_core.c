// The cloth parts of the simulation core (sim_internal.h): forces through
// the cloth kernels (cloth_force.h) in the scene's precision, the CFL
// length and the per-triangle fields.
#include "sim_internal.h"

#include <math.h>
#include <stdlib.h>

int sim_cloth_forces(ek_sim *s, const double *x) {
  ek_cloth_phase_times pt = {0, 0, 0};
  ek_cloth_force_opts o = {.isa = s->scene.svd.isa, .phase_times = s->time_phases ? &pt : NULL};
  size_t n3 = 3 * s->nv;
  double t0 = sim_now();
  int rc;
  if (s->scene.precision == 32) {
    for (size_t i = 0; i < n3; ++i)
      s->xf[i] = (float)x[i];
    rc = ek_cloth_forces_f32(s->cloth, &s->cloth_p, s->xf, s->ff, &o);
    for (size_t i = 0; rc == 0 && i < n3; ++i)
      s->f[i] = (double)s->ff[i];
  } else {
    rc = ek_cloth_forces_f64(s->cloth, &s->cloth_p, x, s->f, &o);
  }
  double t1 = sim_now();
  if (s->time_phases) {
    s->times.cloth_membrane += pt.membrane;
    s->times.cloth_bending += pt.bending;
    s->times.cloth_gather += pt.gather;
    s->times.phase_timed_steps++;
  } else {
    s->times.forces += t1 - t0;
  }
  if (rc)
    return sim_fail(s, "cloth force kernel failed (rc %d): %s", rc, ek_last_error());
  return 0;
}

// Smallest height of any rest triangle, 2 A / (longest edge): the CFL
// length of an explicit membrane step.
double sim_cloth_min_height(const ek_trimesh *m) {
  const ek_cloth *cl = ek_trimesh_cloth(m);
  const double *X = ek_trimesh_rest_positions(m), *A = ek_cloth_rest_areas(cl);
  const int32_t *T = ek_trimesh_tris(m);
  double h = INFINITY;
  for (size_t t = 0; t < ek_trimesh_ntris(m); ++t) {
    double longest = 0;
    for (int c = 0; c < 3; ++c) {
      const double *a = X + 3 * (size_t)T[3 * t + c], *b = X + 3 * (size_t)T[3 * t + (c + 1) % 3];
      double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                      (a[2] - b[2]) * (a[2] - b[2]));
      longest = fmax(longest, d);
    }
    h = fmin(h, 2 * A[t] / longest);
  }
  return h;
}

int ek_sim_cloth_fields(const ek_sim *s, double *J, double *s1, double *s2, double *psi) {
  if (!s->cloth)
    return sim_fail((ek_sim *)s, "ek_sim_cloth_fields: not a cloth scene");
  return ek_cloth_fields_f64(s->cloth, &s->cloth_p, s->x, J, s1, s2, psi);
}
