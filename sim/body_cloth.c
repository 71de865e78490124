// The triangle body (body.h): a cloth, membrane and bending through the
// cloth kernels (cloth_force.h) in the scene's precision, its energy,
// fields and CFL length; the Hessian products and diagonal blocks of
// cloth_force.h (double) for the implicit integrator and its XPBD
// constraints (triangles and hinges, double) for XPBD.
#include "body.h"
#include "sim_internal.h"

#include <ek/cloth.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
  sim_body body;
  const ek_trimesh *trimesh;
  const ek_cloth *cloth;
  // The membrane and bending parameters per unit area (cloth_force.h).
  ek_cloth_params p;
} triangles;

static triangles *tris_of(const ek_sim *s) { return s->body->data; }

// ---- Core ----

static void tris_destroy(sim_body *body) { free(body ? body->data : NULL); }

// Smallest height of any rest triangle, 2 A / (longest edge): the CFL
// length of an explicit membrane step.
static double min_tri_height(const ek_trimesh *m) {
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

// The CFL rule h_min / c (Courant, Friedrichs, Lewy 1928) with the smallest
// triangle height and the membrane's (plane-stress) P-wave speed
// sqrt((lambda_2D + 2 mu) h / (rho h)).
static void tris_cfl(const ek_sim *s, double *h_min, double *wave_speed, double *cfl_dt) {
  const triangles *b = tris_of(s);
  *h_min = min_tri_height(b->trimesh);
  *wave_speed = sqrt((b->p.lambda + 2.0 * b->p.mu) / (s->scene.density * s->scene.thickness));
  *cfl_dt = *h_min / *wave_speed;
}

// Flat rest: 0 up to rounding; a bent rest mesh is bent from flat
// (cloth_force.h).
static int tris_start(ek_sim *s) {
  const triangles *b = tris_of(s);
  s->elastic_rest = ek_cloth_energy_f64(b->cloth, &b->p, b->body.X);
  return 0;
}

static int tris_set_state(ek_sim *s) {
  (void)s; // nothing kept from the old state
  return 0;
}

static int tris_forces(ek_sim *s, const double *x64, const float *x32, double *f64, float *f32) {
  const triangles *b = tris_of(s);
  ek_cloth_phase_times pt = {0, 0, 0};
  ek_cloth_force_opts o = {.isa = s->scene.svd.isa, .phase_times = s->time_phases ? &pt : NULL};
  int rc = x32 ? ek_cloth_forces_f32(b->cloth, &b->p, x32, f32, &o)
               : ek_cloth_forces_f64(b->cloth, &b->p, x64, f64, &o);
  if (s->time_phases) {
    s->times.cloth_membrane += pt.membrane;
    s->times.cloth_bending += pt.bending;
    s->times.cloth_gather += pt.gather;
  }
  return rc;
}

static int tris_bad_force(ek_sim *s, const double *x, size_t bad_vertex, const char *hint) {
  (void)x; // every membrane model here is defined at every finite F
  const double *f = s->f + 3 * bad_vertex;
  return sim_fail(s, "non-finite force (%g, %g, %g) at vertex %zu from finite positions%s", f[0],
                  f[1], f[2], bad_vertex, hint);
}

// A triangle in 3D has no orientation to lose.
static size_t tris_inverted_count(const ek_sim *s, const double *x, size_t *first,
                                  double *first_J) {
  (void)s, (void)x, (void)first, (void)first_J;
  return 0;
}

static double tris_energy(const ek_sim *s, const double *x) {
  const triangles *b = tris_of(s);
  return ek_cloth_energy_f64(b->cloth, &b->p, x);
}

// The area: sum of A0 J.
static double tris_measure(const ek_sim *s) {
  const triangles *b = tris_of(s);
  double A = 0, *J = malloc(s->nt * sizeof(double));
  if (!J || ek_cloth_fields_f64(b->cloth, &b->p, s->x, J, NULL, NULL, NULL) != 0) {
    free(J);
    return NAN;
  }
  const double *A0 = ek_cloth_rest_areas(b->cloth);
  for (size_t t = 0; t < s->nt; ++t)
    A += A0[t] * J[t];
  free(J);
  return A;
}

static int tris_fields(const ek_sim *s, double *J, double *smax, double *smin, double *psi) {
  const triangles *b = tris_of(s);
  return ek_cloth_fields_f64(b->cloth, &b->p, s->x, J, smax, smin, psi);
}

// L = Fdot F^+ per triangle (cloth.h, seed 003 eqs. 28-31); the principal
// strain rates in the deformed plane (the third is 0).
static int tris_rate_fields(const ek_sim *s, double *D, double *W, double *rates) {
  size_t ne = s->nt;
  // Corners and their velocities, n x 9 (cloth.h's AoS layout).
  const int32_t *T = ek_cloth_tris(tris_of(s)->cloth);
  double *xc = malloc(9 * ne * sizeof(double));
  double *vc = malloc(9 * ne * sizeof(double));
  int rc = xc && vc ? 0 : EK_ENOMEM;
  for (size_t t = 0; rc == 0 && t < ne; ++t)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) {
        xc[9 * t + 3 * c + k] = s->x[3 * (size_t)T[3 * t + c] + k];
        vc[9 * t + 3 * c + k] = s->v[3 * (size_t)T[3 * t + c] + k];
      }
  if (rc == 0)
    rc = ek_tri_velocity_gradient_f64(ne, xc, vc, NULL, D, W, NULL);
  for (size_t e = 0; rc == 0 && rates && e < ne; ++e) {
    const double *d = D + 9 * e;
    double *r = rates + 3 * e;
    // In the deformed plane: t1 along the first edge, t2 = n x t1; the 2x2
    // form M = [t_a . D t_b] and its eigenvalues.
    const double *x0 = xc + 9 * e, *x1 = x0 + 3, *x2 = x0 + 6;
    double t1[3], e2[3], n[3], t2[3];
    for (int k = 0; k < 3; ++k)
      t1[k] = x1[k] - x0[k], e2[k] = x2[k] - x0[k];
    n[0] = t1[1] * e2[2] - t1[2] * e2[1];
    n[1] = t1[2] * e2[0] - t1[0] * e2[2];
    n[2] = t1[0] * e2[1] - t1[1] * e2[0];
    double l1 = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    double ln = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(l1 > 0) || !(ln > 0)) {
      r[0] = r[1] = r[2] = NAN; // a collapsed triangle has no plane
      continue;
    }
    for (int k = 0; k < 3; ++k)
      t1[k] /= l1, n[k] /= ln;
    t2[0] = n[1] * t1[2] - n[2] * t1[1];
    t2[1] = n[2] * t1[0] - n[0] * t1[2];
    t2[2] = n[0] * t1[1] - n[1] * t1[0];
    double M[3] = {0, 0, 0}; // M00, M01, M11
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        M[0] += t1[i] * d[3 * i + j] * t1[j];
        M[1] += t1[i] * d[3 * i + j] * t2[j];
        M[2] += t2[i] * d[3 * i + j] * t2[j];
      }
    double m = 0.5 * (M[0] + M[2]), h = hypot(0.5 * (M[0] - M[2]), M[1]);
    r[0] = m + h;
    r[1] = m - h;
    r[2] = 0;
  }
  free(xc);
  free(vc);
  return rc;
}

// ---- Implicit integrator: gradient, products and blocks in double
// (cloth_force.h), in either scene precision ----

typedef struct {
  const triangles *b;
  size_t nv;
  // The point of the Hessian products (the last gradient's x, as the tets'
  // cache is) and the 3x3 diagonal blocks.
  double *hx, *blocks9;
} tris_hessian;

static void tris_hessian_destroy(void *h) {
  tris_hessian *th = h;
  if (!th)
    return;
  free(th->hx);
  free(th->blocks9);
  free(th);
}

static void *tris_hessian_create(ek_sim *s, sim_hessian_info *info) {
  tris_hessian *th = calloc(1, sizeof *th);
  info->f32 = 0;
  info->residual_merit = 0; // the cloth energy is the potential its forces derive from
  info->split_timing = 0;
  if (th) {
    th->b = tris_of(s);
    th->nv = s->nv;
    th->hx = calloc(3 * s->nv, sizeof(double));
    th->blocks9 = calloc(9 * s->nv, sizeof(double));
  }
  if (!th || !th->hx || !th->blocks9) {
    tris_hessian_destroy(th);
    sim_fail(s, "out of memory");
    return NULL;
  }
  return th;
}

// grad E = -f; the products are taken at this x (the accepted point is the
// last one evaluated, as with the tets' cache).
static int tris_gradient(const ek_sim *s, void *h, const double *x, double *grad, double *E,
                         int cache) {
  (void)cache;
  tris_hessian *th = h;
  const size_t n3 = 3 * s->nv;
  int rc = ek_cloth_forces_f64(th->b->cloth, &th->b->p, x, grad, NULL);
  if (rc < 0)
    return rc;
  for (size_t i = 0; i < n3; ++i)
    grad[i] = -grad[i];
  *E = ek_cloth_energy_f64(th->b->cloth, &th->b->p, x);
  memcpy(th->hx, x, n3 * sizeof(double));
  return 0;
}

static int tris_hessian_apply(void *h, const double *p, double *q, const float *p32, float *q32) {
  (void)p32, (void)q32; // double only (info.f32 = 0)
  const tris_hessian *th = h;
  return ek_cloth_hessian_apply_f64(th->b->cloth, &th->b->p, th->hx, 1, p, q);
}

static int tris_hessian_diagonal(void *h, double *blocks) {
  tris_hessian *th = h;
  int rc = ek_cloth_hessian_diagonal_f64(th->b->cloth, &th->b->p, th->hx, th->blocks9);
  for (size_t v = 0; rc == 0 && v < th->nv; ++v) { // 3x3 -> xx, xy, xz, yy, yz, zz
    const double *b = th->blocks9 + 9 * v;
    double *o = blocks + 6 * v;
    o[0] = b[0], o[1] = b[1], o[2] = b[2], o[3] = b[4], o[4] = b[5], o[5] = b[8];
  }
  return rc;
}

// ---- XPBD integrator: triangles and hinges (cloth_force.h), double ----

static void *tris_xpbd_create(ek_sim *s, double young, int *f32) {
  *f32 = 0;
  // Membrane modulus per unit area: E h (the tets' C = sqrt(2 W / E) with
  // W per unit area). Gauss-Seidel over colours is the one solver.
  const ek_scene_xpbd *k = &s->scene.xpbd;
  if (k->elements != EK_XPBD_TETS || k->solver != EK_XPBD_GAUSS_SEIDEL) {
    const int el = k->elements != EK_XPBD_TETS;
    sim_fail_at(s, el ? s->scene.where.elements : s->scene.where.solver,
                "integrator.%s = \"%s\": a cloth takes the default elements and solver (its "
                "triangles and hinges, coloured Gauss-Seidel)",
                el ? "elements" : "solver", el ? "clusters" : "jacobi");
    return NULL;
  }
  const triangles *b = tris_of(s);
  ek_cloth_xpbd *cx = ek_cloth_xpbd_create(b->cloth, &b->p, young * s->scene.thickness);
  if (!cx)
    sim_fail(s, "%s", ek_last_error());
  return cx;
}

static void tris_xpbd_destroy(void *c) { ek_cloth_xpbd_destroy(c); }

static int tris_xpbd_begin(void *c, const double *w, double h) {
  return ek_cloth_xpbd_begin(c, w, h);
}

static int tris_xpbd_iterate(void *c, const float *x_base, float *xf, double *x, int n) {
  (void)x_base, (void)xf; // double only
  return ek_cloth_xpbd_iterate(c, x, n);
}

static int tris_xpbd_residual(const void *c, const float *x_base, const float *xf, const double *x,
                              double *r, double *cmax) {
  (void)x_base, (void)xf;
  return ek_cloth_xpbd_residual(c, x, r, cmax);
}

static size_t tris_xpbd_count(const void *c) { return ek_cloth_xpbd_count(c); }

static void tris_describe(const ek_sim *s, char *buf, size_t len) {
  const triangles *b = s->body->data;
  snprintf(buf, len, "%zu triangles, %zu hinges, membrane %s", s->body->ne,
           ek_cloth_nhinges(b->cloth), s->scene.model_name);
}

const sim_body_ops sim_body_triangles = {
    .destroy = tris_destroy,
    .describe = tris_describe,
    .cfl = tris_cfl,
    .start = tris_start,
    .begin_step = NULL,
    .set_state = tris_set_state,
    .forces = tris_forces,
    .force_kernel = "cloth",
    .bad_force = tris_bad_force,
    .inverted_count = tris_inverted_count,
    .energy = tris_energy,
    .measure = tris_measure,
    .fields = tris_fields,
    .rate_fields = tris_rate_fields,
    .hessian_create = tris_hessian_create,
    .hessian_destroy = tris_hessian_destroy,
    .hessian_begin_step = NULL,
    .gradient = tris_gradient,
    .hessian_apply = tris_hessian_apply,
    .hessian_diagonal = tris_hessian_diagonal,
    .xpbd_create = tris_xpbd_create,
    .xpbd_destroy = tris_xpbd_destroy,
    .xpbd_begin = tris_xpbd_begin,
    .xpbd_iterate = tris_xpbd_iterate,
    .xpbd_residual = tris_xpbd_residual,
    .xpbd_profile = NULL,
    .xpbd_count = tris_xpbd_count,
};

sim_body *sim_body_triangles_create(const ek_scene *scene, const ek_material *mat,
                                    const ek_trimesh *tm) {
  triangles *b = calloc(1, sizeof *b);
  if (!b)
    return NULL;
  b->trimesh = tm;
  b->cloth = ek_trimesh_cloth(tm);
  // Membrane per unit area: mu h and the plane-stress lambda
  // 2 mu lambda / (lambda + 2 mu) times h (a thin sheet has no stress
  // through its thickness: sigma_33 = 0 eliminates eps_33); k_b as given.
  double mu = mat->mu, lam = mat->lambda, h = scene->thickness;
  b->p = (ek_cloth_params){(ek_membrane_model)ek_model_describe(mat->model)->membrane, mu * h,
                           2 * mu * lam / (lam + 2 * mu) * h, scene->bending_stiffness};
  b->body = (sim_body){
      .ops = &sim_body_triangles,
      .data = b,
      .nv = ek_trimesh_nverts(tm),
      .ne = ek_trimesh_ntris(tm),
      .corners = 3,
      .elems = ek_cloth_tris(b->cloth),
      .X = ek_trimesh_rest_positions(tm),
      .lumped = ek_cloth_lumped_area(b->cloth),
      .mass_scale = scene->thickness,
      .kind = "triangles",
      .caller_elems = ek_trimesh_tris(tm),
      .has_smax = 1,
      .oriented = 0,
      .nphases = 3,
      .phase_names = {"membrane (F, P, corners)", "bending (hinges)", "gather (per vertex)"},
      .phase_times = {offsetof(ek_sim_times, cloth_membrane), offsetof(ek_sim_times, cloth_bending),
                      offsetof(ek_sim_times, cloth_gather)}};
  return &b->body;
}
