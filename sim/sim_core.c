// The simulation core (sim_internal.h): state, lumped masses, boundary
// conditions, ground, energies, per-tet fields, CFL estimate, R^n for
// corotated linear and the force evaluation, shared by every integrator.
//
// f is the finite-volume force of Teran et al. 2003 (seed 004) through
// fvm.h, M the lumped mass (density times the vertex's share V0/4 of each
// incident tet). Corotated linear takes R^n = polar(F^n) per tet at the
// start of each step (seed 000). Vertices under a boundary condition follow
// it exactly; the ground is friction-free.
#include "errbuf.h"
#include "sim_internal.h"
#include <ek/polar.h>

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

const sim_integrator *const sim_integrators[EK_INTEGRATOR_COUNT] = {
    [EK_INTEGRATOR_EXPLICIT] = &sim_integrator_explicit,
    [EK_INTEGRATOR_IMPLICIT] = &sim_integrator_implicit,
    [EK_INTEGRATOR_XPBD] = &sim_integrator_xpbd,
};

const char *ek_scene_integrator_name(ek_integrator_type type) {
  return (unsigned)type < EK_INTEGRATOR_COUNT ? sim_integrators[type]->name : NULL;
}

const char *ek_scene_integrator_description(ek_integrator_type type) {
  return (unsigned)type < EK_INTEGRATOR_COUNT ? sim_integrators[type]->description : NULL;
}

int ek_scene_integrator_explain(const ek_scene *scene, FILE *out, int number) {
  if ((unsigned)scene->integrator >= EK_INTEGRATOR_COUNT)
    return number;
  return sim_integrators[scene->integrator]->explain(scene, out, number);
}

double sim_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int sim_fail(ek_sim *s, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(s->error, sizeof s->error, fmt, ap);
  va_end(ap);
  ek_set_error("%s", s->error);
  return EK_EINVAL;
}

void sim_warn(ek_sim *s, const char *fmt, ...) {
  if (s->warning[0])
    return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(s->warning, sizeof s->warning, fmt, ap);
  va_end(ap);
}

const char *ek_sim_warning(ek_sim *s) {
  if (!s || !s->warning[0])
    return NULL;
  snprintf(s->warning_out, sizeof s->warning_out, "%s", s->warning);
  s->warning[0] = '\0';
  return s->warning_out;
}

static double det3(const double *A) {
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
         A[2] * (A[3] * A[7] - A[4] * A[6]);
}

// Signed volume of tet e at positions x: det[x1-x0, x2-x0, x3-x0] / 6.
static double tet_volume(const double *x, const int32_t *t) {
  const double *a = x + 3 * t[0];
  double D[9];
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k)
      D[3 * k + c] = x[3 * t[c + 1] + k] - a[k];
  return det3(D) / 6.0;
}

static double norm3(const double *a) { return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
static void cross3(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

// Smallest height of any rest tet: 3 V / (area of the opposite face),
// minimised over the four faces. The CFL length of an explicit FEM step.
static double min_tet_height(const ek_mesh *m) {
  const double *X = ek_mesh_rest_positions(m);
  const int32_t *T = ek_mesh_tets(m);
  size_t nt = ek_mesh_ntets(m);
  double h = INFINITY;
  for (size_t e = 0; e < nt; ++e) {
    const int32_t *t = T + 4 * e;
    double V = fabs(tet_volume(X, t));
    for (int skip = 0; skip < 4; ++skip) {
      int f[3], k = 0;
      for (int c = 0; c < 4; ++c)
        if (c != skip)
          f[k++] = t[c];
      double a[3], b[3], n[3];
      for (int i = 0; i < 3; ++i) {
        a[i] = X[3 * f[1] + i] - X[3 * f[0] + i];
        b[i] = X[3 * f[2] + i] - X[3 * f[0] + i];
      }
      cross3(a, b, n);
      double area = 0.5 * norm3(n);
      if (area > 0 && 3.0 * V / area < h)
        h = 3.0 * V / area;
    }
  }
  return h;
}

// Largest squared natural frequency of one tet alone: the largest
// generalised eigenvalue of its linear-elastic stiffness K_e against its
// lumped mass (rho V / 4 per vertex), by power iteration. K_e x: the
// displacement gradient H = sum_a x_a g_a^T (g_a the shape-function
// gradients), sigma = lambda tr(eps) I + 2 mu eps with eps = sym(H), and
// f_a = V sigma g_a. The rigid modes are K_e's null space, so the iteration
// finds the largest eigenvalue from any start with a component along it.
//
// Scale-free (issue 28: a box of edge 1e100 or 1e-100, or density 1e-300,
// printed its CFL limit as inf: |M^-1 K x|^2 under- or overflowed): the
// iteration runs on the element scaled by 2^-e (its largest edge
// component in [0.5, 1)), lambda and mu by 2^-a and rho by 2^-b, all
// powers of two, so every product and quotient is the unscaled one times
// a power of two, exactly (rounding commutes with such scaling between
// DBL_MIN and DBL_MAX): where the unscaled iteration stayed in range the
// result is the same bits. omega^2 = *w2 2^*k, returned split because it
// may itself be beyond a double (rho 1e-300 on a small element).
static void tet_omega2_max(const double *X, const int32_t *t, double lambda, double mu, double rho,
                           double *w2, int *k) {
  *w2 = 0, *k = 0;
  double D[3][3], g[4][3], dmax = 0;
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < 3; ++i) {
      D[i][c] = X[3 * t[c + 1] + i] - X[3 * t[0] + i];
      dmax = fmax(dmax, fabs(D[i][c]));
    }
  int e = 0, a = 0, b = 0;
  frexp(dmax, &e);
  frexp(fmax(mu, fabs(lambda)), &a);
  frexp(rho, &b);
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < 3; ++i)
      D[i][c] = ldexp(D[i][c], -e);
  mu = ldexp(mu, -a), lambda = ldexp(lambda, -a), rho = ldexp(rho, -b);
  double det = D[0][0] * (D[1][1] * D[2][2] - D[1][2] * D[2][1]) -
               D[0][1] * (D[1][0] * D[2][2] - D[1][2] * D[2][0]) +
               D[0][2] * (D[1][0] * D[2][1] - D[1][1] * D[2][0]);
  double V = fabs(det) / 6.0;
  if (!(V > 0))
    return;
  // Rows of D^-1 are the gradients of the shape functions of vertices 1..3.
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      g[i + 1][j] = (D[j1][i1] * D[j2][i2] - D[j1][i2] * D[j2][i1]) / det; // (D^-1)_ij
    }
  for (int i = 0; i < 3; ++i)
    g[0][i] = -(g[1][i] + g[2][i] + g[3][i]);
  double x[12], y[12], rq = 0;
  for (int k = 0; k < 12; ++k)
    x[k] = 1.0 + 0.37 * k - 0.05 * k * k; // generic: not orthogonal to the top mode
  for (int it = 0; it < 200; ++it) {
    double H[3][3] = {{0}}, S[3][3];
    for (int a = 0; a < 4; ++a)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          H[i][j] += x[3 * a + i] * g[a][j];
    double tr = H[0][0] + H[1][1] + H[2][2];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        S[i][j] = mu * (H[i][j] + H[j][i]) + (i == j ? lambda * tr : 0.0);
    double xx = 0, xy = 0, yy = 0, m = rho * V / 4.0;
    for (int a = 0; a < 4; ++a)
      for (int i = 0; i < 3; ++i) {
        double f = V * (S[i][0] * g[a][0] + S[i][1] * g[a][1] + S[i][2] * g[a][2]);
        y[3 * a + i] = f / m; // M^-1 K x
      }
    for (int k = 0; k < 12; ++k)
      xx += x[k] * x[k], xy += x[k] * y[k], yy += y[k] * y[k];
    // Rayleigh quotient of M^-1 K in the M inner product (M = m I).
    double prev = rq;
    rq = xy / xx;
    double n = sqrt(yy);
    if (!(n > 0))
      return;
    for (int k = 0; k < 12; ++k)
      x[k] = y[k] / n;
    if (it > 20 && fabs(rq - prev) <= 1e-12 * rq)
      break;
  }
  // M^-1 K scales as stiffness / (density length^2): 2^(a - b - 2e).
  *w2 = rq;
  *k = a - b - 2 * e;
}

// The explicit step's stability limit: symplectic Euler is stable for
// dt omega_max <= 2 (undamped), and omega_max^2 of the assembled mesh is at
// most the largest over its elements alone (the element eigenvalue
// inequality: x^T K x = sum_e x_e^T K_e x_e <= max_e omega_e^2 x^T M x;
// Belytschko, Liu, Moran, "Nonlinear Finite Elements for Continua and
// Structures", sec. 6.3), so 2 / max_e omega_e is a step that cannot be
// unstable for the linearised model at rest. The maximum is kept as a
// fraction in [0.5, 1) and a power of two, so the limit is finite and
// non-zero wherever a double holds it (sim.h, ek_sim_cfl_dt), and the same
// bits as 2 / sqrt(max_e omega_e^2) wherever that is in range.
static double element_cfl_dt(const ek_mesh *m, double lambda, double mu, double rho) {
  const double *X = ek_mesh_rest_positions(m);
  const int32_t *T = ek_mesh_tets(m);
  size_t nt = ek_mesh_ntets(m);
  double wmax = 0; // max_e omega_e^2 = wmax 2^kmax, wmax in [0.5, 1) or 0
  int kmax = 0;
  for (size_t e = 0; e < nt; ++e) {
    double w2;
    int k, ke;
    tet_omega2_max(X, T + 4 * e, lambda, mu, rho, &w2, &k);
    if (!(w2 > 0))
      continue;
    w2 = frexp(w2, &ke);
    k += ke;
    if (wmax == 0 || k > kmax || (k == kmax && w2 > wmax))
      wmax = w2, kmax = k;
  }
  if (wmax == 0)
    return INFINITY;
  // 2 / sqrt(wmax 2^kmax), the exponent made even so the root is exact.
  if (kmax % 2)
    wmax *= 2, kmax -= 1;
  return ldexp(2.0 / sqrt(wmax), -kmax / 2);
}

// Rodrigues' rotation of p about unit axis k by angle theta.
static void rotate(const double *k, double theta, const double *p, double *out) {
  double c = cos(theta), s = sin(theta), kxp[3];
  cross3(k, p, kxp);
  double kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
  for (int i = 0; i < 3; ++i)
    out[i] = p[i] * c + kxp[i] * s + k[i] * kp * (1.0 - c);
}

void sim_bc_state(const ek_scene_bc *b, const double x0[3], double t, double x[3], double v[3]) {
  double tm = t < b->until ? t : b->until; // motion stops at `until`
  int moving = t < b->until;
  switch (b->kind) {
  case EK_BC_PIN:
    for (int i = 0; i < 3; ++i) {
      x[i] = x0[i];
      v[i] = 0;
    }
    break;
  case EK_BC_TWIST: {
    double r[3], rr[3];
    for (int i = 0; i < 3; ++i)
      r[i] = x0[i] - b->center[i];
    rotate(b->axis, b->rate * tm, r, rr);
    double w[3] = {b->rate * b->axis[0], b->rate * b->axis[1], b->rate * b->axis[2]}, wr[3];
    cross3(w, rr, wr); // v = omega x (x - c)
    for (int i = 0; i < 3; ++i) {
      x[i] = b->center[i] + rr[i];
      v[i] = moving ? wr[i] : 0;
    }
    break;
  }
  case EK_BC_STRETCH:
    for (int i = 0; i < 3; ++i) {
      x[i] = x0[i] + b->velocity[i] * tm;
      v[i] = moving ? b->velocity[i] : 0;
    }
    break;
  }
}

// "polar": "warm" with fixed corotated / ARAP: the force kernel keeps each
// tet's rotation from call to call (fvm.h polar_state).
static int uses_warm_force_rotations(const ek_sim *s) {
  return s->mesh && s->scene.polar == EK_POLAR_WARM &&
         ek_model_need(s->mat.model, 0) == EK_NEEDS_POLAR;
}

// (Re)start the force's per-tet rotations at the SVD polar of the current
// F (the identity at rest): at creation, and when ek_sim_set_state replaces
// the state (the last step's rotations may be far from the new ones, and
// the warm polar converges in its few iterations only from a near guess).
static int seed_warm_rotations(ek_sim *s) {
  size_t nt = s->nt;
  double *F = malloc(18 * nt * sizeof(double));
  int rc = F ? ek_mesh_deformation_gradients_f64(s->mesh, s->x, F) : EK_ENOMEM;
  ek_svd3_opts so = s->scene.svd;
  if (rc == 0)
    rc = ek_polar3_f64(nt, F, F + 9 * nt, NULL, &so);
  if (rc == 0 && !s->polar_state &&
      !(s->polar_state =
            ek_tet_state_create(ek_mesh_elements(s->mesh), 9, s->scene.precision == 64)))
    rc = EK_ENOMEM;
  if (rc == 0)
    rc = ek_tet_state_set_f64(s->polar_state, F + 9 * nt);
  free(F);
  return rc;
}

static int refresh_rotations(ek_sim *s) {
  if (ek_model_need(s->mat.model, 0) != EK_NEEDS_R_INPUT)
    return 0;
  double t0 = sim_now();
  int rc = ek_mesh_deformation_gradients_f64(s->mesh, s->x, s->F);
  if (rc == 0 && s->scene.polar == EK_POLAR_WARM && s->R_ready) {
    // The warm polar from R^(n-1) (polar.h), in double like the SVD path.
    ek_polar_warm_opts o = {.isa = s->scene.svd.isa};
    rc = ek_polar3_warm_f64(s->nt, s->F, s->R, &o);
  } else if (rc == 0) {
    ek_svd3_opts o = s->scene.svd;
    rc = ek_polar3_f64(s->nt, s->F, s->R, NULL, &o);
  }
  s->R_ready = rc == 0;
  if (rc == 0)
    rc = ek_tet_state_set_f64(s->R_state, s->R);
  s->times.polar_refresh += sim_now() - t0;
  if (rc)
    return sim_fail(s, "corotated linear: refreshing R^n failed: %s", ek_last_error());
  return 0;
}

void ek_sim_destroy(ek_sim *s) {
  if (!s)
    return;
  if (s->integrator && s->integrator->destroy)
    s->integrator->destroy(s->integrator_data);
  free(s->ring_off);
  free(s->ring);
  free(s->ring_P);
  free(s->ring_Q);
  free(s->x);
  free(s->v);
  free(s->x0);
  free(s->mass);
  free(s->inv_mass);
  free(s->f);
  free(s->xf);
  free(s->ff);
  free(s->F);
  free(s->R);
  ek_tet_state_destroy(s->R_state);
  ek_tet_state_destroy(s->polar_state);
  free(s->psi_rest);
  free(s->x_next);
  free(s->v_next);
  free(s->bc_of);
  free(s);
}

// One constructor for both kinds: a tet mesh (mesh) or a cloth (tm).
static ek_sim *sim_create(const ek_scene *scene, const ek_mesh *mesh, const ek_trimesh *tm,
                          char *err, size_t errlen) {
  if (err && errlen)
    err[0] = '\0';
  if (!scene || (!mesh && !tm) || (tm && !scene->triangles) || (mesh && scene->triangles)) {
    if (err && errlen)
      snprintf(err, errlen, "ek_sim_create: no scene or mesh, or a mesh of the wrong kind");
    return NULL;
  }
  if ((unsigned)scene->integrator >= EK_INTEGRATOR_COUNT) {
    if (err && errlen)
      snprintf(err, errlen, "%s: integrator %d: unknown", scene->path, (int)scene->integrator);
    return NULL;
  }
  ek_sim *s = calloc(1, sizeof *s);
  if (!s)
    return NULL;
  s->scene = *scene;
  s->mesh = mesh;
  s->trimesh = tm;
  s->mat = scene->material;
  if (ek_material_check(&s->mat) != 0) {
    if (err && errlen)
      snprintf(err, errlen, "%s: material: %s", scene->path, ek_last_error());
    ek_sim_destroy(s);
    return NULL;
  }
  size_t nv = s->nv = mesh ? ek_mesh_nverts(mesh) : ek_trimesh_nverts(tm);
  size_t nt = s->nt = mesh ? ek_mesh_ntets(mesh) : ek_trimesh_ntris(tm);
  if (tm) {
    // Membrane per unit area: mu h and the plane-stress lambda
    // 2 mu lambda / (lambda + 2 mu) times h (a thin sheet has no stress
    // through its thickness: sigma_33 = 0 eliminates eps_33); k_b as given.
    double mu = s->mat.mu, lam = s->mat.lambda, h = scene->thickness;
    s->cloth = ek_trimesh_cloth(tm);
    s->cloth_p =
        (ek_cloth_params){(ek_membrane_model)ek_model_describe(s->mat.model)->membrane, mu * h,
                          2 * mu * lam / (lam + 2 * mu) * h, scene->bending_stiffness};
  }
  s->x = malloc(3 * nv * sizeof(double));
  s->v = malloc(3 * nv * sizeof(double));
  s->x0 = malloc(3 * nv * sizeof(double));
  s->x_next = malloc(3 * nv * sizeof(double));
  s->v_next = malloc(3 * nv * sizeof(double));
  s->f = malloc(3 * nv * sizeof(double));
  s->mass = malloc(nv * sizeof(double));
  s->inv_mass = malloc(nv * sizeof(double));
  s->bc_of = malloc(nv);
  int ok =
      s->x && s->v && s->x0 && s->x_next && s->v_next && s->f && s->mass && s->inv_mass && s->bc_of;
  if (scene->precision == 32) {
    s->xf = malloc(3 * nv * sizeof(float));
    s->ff = malloc(3 * nv * sizeof(float));
    ok = ok && s->xf && s->ff;
  }
  if (ek_model_need(s->mat.model, 0) == EK_NEEDS_R_INPUT) {
    s->F = malloc(9 * nt * sizeof(double));
    s->R = malloc(9 * nt * sizeof(double));
    ok = ok && s->F && s->R;
  } else if (mesh) {
    s->psi_rest = malloc(nt * sizeof(double));
    ok = ok && s->psi_rest;
  }
  if (!ok) {
    if (err && errlen)
      snprintf(err, errlen, "%s: out of memory for %zu vertices, %zu elements", scene->path, nv,
               nt);
    ek_sim_destroy(s);
    return NULL;
  }

  // Initial state: rest shape scaled about its bounding-box centre, then
  // translated; uniform velocity.
  const double *X = mesh ? ek_mesh_rest_positions(mesh) : ek_trimesh_rest_positions(tm);
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = fmin(lo[k], X[3 * i + k]);
      hi[k] = fmax(hi[k], X[3 * i + k]);
    }
  double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                     (hi[2] - lo[2]) * (hi[2] - lo[2]));
  s->body_size = diag;
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      double c = 0.5 * (lo[k] + hi[k]);
      s->x[3 * i + k] = c + scene->init_scale[k] * (X[3 * i + k] - c) + scene->init_translate[k];
      s->v[3 * i + k] = scene->init_velocity[k];
    }
  memcpy(s->x0, s->x, 3 * nv * sizeof(double));

  // Lumped masses (Teran 2003 sec. 4: each tet gives a quarter of its mass
  // to each corner; each triangle a third of its density * thickness * A).
  const double *lumped = mesh ? ek_mesh_lumped_volume(mesh) : ek_cloth_lumped_area(s->cloth);
  double areal = mesh ? 1.0 : scene->thickness;
  for (size_t i = 0; i < nv; ++i) {
    s->mass[i] = scene->density * areal * lumped[i];
    s->inv_mass[i] = s->mass[i] > 0 ? 1.0 / s->mass[i] : 0.0;
  }

  // Boundary conditions: the first condition whose box holds the vertex's
  // rest position owns it.
  double tol = 1e-9 * diag;
  size_t counts[EK_SCENE_MAX_BC] = {0};
  for (size_t i = 0; i < nv; ++i) {
    s->bc_of[i] = -1;
    for (int b = 0; b < scene->nbc && s->bc_of[i] < 0; ++b) {
      const ek_scene_bc *c = &scene->bc[b];
      int in = 1;
      for (int k = 0; k < 3; ++k)
        in &= X[3 * i + k] >= c->box_min[k] - tol && X[3 * i + k] <= c->box_max[k] + tol;
      if (in) {
        s->bc_of[i] = (signed char)b;
        counts[b]++;
      }
    }
  }
  for (int b = 0; b < scene->nbc; ++b)
    if (counts[b] == 0) {
      if (err && errlen)
        snprintf(err, errlen,
                 "%s: boundary[%d].region = [%g %g %g]..[%g %g %g]: holds no vertex of the mesh "
                 "(its bounding box is [%g %g %g]..[%g %g %g])",
                 scene->path, b, scene->bc[b].box_min[0], scene->bc[b].box_min[1],
                 scene->bc[b].box_min[2], scene->bc[b].box_max[0], scene->bc[b].box_max[1],
                 scene->bc[b].box_max[2], lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
      ek_sim_destroy(s);
      return NULL;
    }
  for (size_t i = 0; i < nv; ++i)
    if (s->bc_of[i] >= 0)
      sim_bc_state(&scene->bc[s->bc_of[i]], s->x0 + 3 * i, 0.0, s->x + 3 * i, s->v + 3 * i);

  // CFL: an explicit step must not outrun the fastest (dilatational) wave
  // across the smallest element, dt <= h_min / c, c = sqrt((lambda + 2 mu)
  // / rho) (Courant, Friedrichs, Lewy 1928; the P-wave speed of linear
  // elasticity). That is an estimate: on tets, symplectic Euler diverged
  // at rest from 0.95 h_min / c (ek-verify --extremes), so the tet limit is
  // the element eigenvalue bound instead (element_cfl_dt: 0.64-0.82
  // h_min / c on the shipped meshes), h_min / c kept for the messages.
  // Integrators that it limits check it (their create). Cloth: the
  // smallest triangle height and the membrane's (plane-stress) P-wave
  // speed sqrt((lambda_2D + 2 mu) h / (rho h)).
  s->h_min = mesh ? min_tet_height(mesh) : sim_cloth_min_height(tm);
  s->wave_speed =
      mesh ? sqrt((s->mat.lambda + 2.0 * s->mat.mu) / scene->density)
           : sqrt((s->cloth_p.lambda + 2.0 * s->cloth_p.mu) / (scene->density * scene->thickness));
  s->cfl_dt = mesh ? element_cfl_dt(mesh, s->mat.lambda, s->mat.mu, scene->density)
                   : s->h_min / s->wave_speed;

  s->fvm.scatter = scene->scatter;
  s->fvm.isa = scene->svd.isa;
  s->fvm.svd_sweeps = scene->svd.sweeps;
  s->fvm.svd_exact_rsqrt = scene->svd.exact_rsqrt;
  s->fvm.svd_refine = scene->svd.refine;
  s->fvm.R = s->R;
  if (ek_model_need(s->mat.model, 0) == EK_NEEDS_R_INPUT) {
    s->R_state = ek_tet_state_create(ek_mesh_elements(mesh), 9, scene->precision == 64);
    if (!s->R_state) {
      if (err && errlen)
        snprintf(err, errlen, "%s: %s", scene->path, ek_last_error());
      ek_sim_destroy(s);
      return NULL;
    }
    s->fvm.R_state = s->R_state;
  }
  if (uses_warm_force_rotations(s)) {
    int rc = seed_warm_rotations(s);
    if (rc != 0) {
      if (err && errlen)
        snprintf(err, errlen, "%s: polar \"warm\": initial rotations: %s", scene->path,
                 rc == EK_ENOMEM ? "out of memory" : ek_last_error());
      ek_sim_destroy(s);
      return NULL;
    }
    s->fvm.polar_state = s->polar_state;
  }
  if (refresh_rotations(s) != 0) {
    if (err && errlen)
      snprintf(err, errlen, "%s: %s", scene->path, s->error);
    ek_sim_destroy(s);
    return NULL;
  }
  s->times.polar_refresh = 0;
  // Corotated linear is 0 at rest (R = polar(I) = I); the others are
  // evaluated, per tet for the frames' field and summed for the energy.
  s->elastic_rest = 0.0;
  if (tm) // flat rest: 0 up to rounding; a bent rest mesh is bent from flat (cloth_force.h)
    s->elastic_rest = ek_cloth_energy_f64(s->cloth, &s->cloth_p, X);
  if (s->psi_rest) {
    s->elastic_rest = ek_mesh_fvm_energy_f64(mesh, &s->mat, X);
    ek_fvm_opts o = s->fvm;
    o.psi = s->psi_rest;
    o.polar_state = NULL; // a double pass: the SVD (the state is in the scene's precision)
    if (ek_mesh_fvm_forces_ex_f64(mesh, &s->mat, X, s->f, &o) != 0) {
      if (err && errlen)
        snprintf(err, errlen, "%s: energy density at rest: %s", scene->path, ek_last_error());
      ek_sim_destroy(s);
      return NULL;
    }
  }

  s->integrator = sim_integrators[scene->integrator];
  if (s->integrator->create && s->integrator->create(s, &s->integrator_data) != 0) {
    if (err && errlen)
      snprintf(err, errlen, "%s: integrator %s: %s", scene->path, s->integrator->name, s->error);
    ek_sim_destroy(s);
    return NULL;
  }
  return s;
}

ek_sim *ek_sim_create_errbuf(const ek_scene *scene, const ek_mesh *mesh, char *err, size_t errlen) {
  return sim_create(scene, mesh, NULL, err, errlen);
}

ek_sim *ek_sim_create_cloth_errbuf(const ek_scene *scene, const ek_trimesh *mesh, char *err,
                                   size_t errlen) {
  return sim_create(scene, NULL, mesh, err, errlen);
}

int ek_sim_is_cloth(const ek_sim *s) { return s->cloth != NULL; }

const char *ek_sim_integrator_name(const ek_sim *s) { return s->integrator->name; }

size_t ek_sim_inverted_count(const ek_sim *s) {
  if (s->cloth) // a triangle in 3D has no orientation to lose
    return 0;
  const int32_t *T = ek_mesh_tets(s->mesh);
  size_t n = 0;
  for (size_t e = 0; e < s->nt; ++e)
    n += !(tet_volume(s->x, T + 4 * e) > 0);
  return n;
}

int sim_forces(ek_sim *s, const double *x) {
  if (s->cloth)
    return sim_cloth_forces(s, x);
  ek_fvm_opts o = s->fvm;
  ek_fvm_phase_times pt = {0, 0, 0, 0};
  if (s->time_phases)
    o.phase_times = &pt;
  size_t n3 = 3 * s->nv;
  double t0 = sim_now();
  int rc;
  if (s->scene.precision == 32) {
    for (size_t i = 0; i < n3; ++i)
      s->xf[i] = (float)x[i];
    rc = ek_mesh_fvm_forces_ex_f32(s->mesh, &s->mat, s->xf, s->ff, &o);
    for (size_t i = 0; rc == 0 && i < n3; ++i)
      s->f[i] = (double)s->ff[i];
  } else {
    rc = ek_mesh_fvm_forces_ex_f64(s->mesh, &s->mat, x, s->f, &o);
  }
  double t1 = sim_now();
  if (s->time_phases) {
    s->times.deformation_gradient += pt.deformation_gradient;
    s->times.svd_polar += pt.svd;
    s->times.pk1 += pt.pk1;
    s->times.scatter += pt.scatter;
    s->times.phase_timed_steps++;
  } else {
    s->times.forces += t1 - t0;
  }
  if (rc)
    return sim_fail(s, "FVM force kernel failed (rc %d): %s", rc, ek_last_error());
  return 0;
}

// ", dt D is above the CFL limit C" for an explicit scene stepped above its
// limit, else "": the likely cause of a blow-up, said where it is reported.
static const char *cfl_hint(const ek_sim *s, char *buf, size_t len) {
  buf[0] = '\0';
  if (s->integrator == &sim_integrator_explicit && s->scene.dt > s->cfl_dt)
    snprintf(buf, len, "; dt %g is %.3g times the CFL limit %g", s->scene.dt,
             s->scene.dt / s->cfl_dt, s->cfl_dt);
  return buf;
}

int sim_check_forces(ek_sim *s, const double *x) {
  size_t bad_vertex = (size_t)-1;
  for (size_t i = 0; i < s->nv && bad_vertex == (size_t)-1; ++i)
    for (int k = 0; k < 3; ++k)
      if (!isfinite(s->f[3 * i + k]))
        bad_vertex = i;
  if (bad_vertex == (size_t)-1)
    return 0;
  char hint[128];
  const double *f = s->f + 3 * bad_vertex;
  // Three causes, told apart (issue 28: a NaN state was reported as every
  // tet "inverted (J = -nan) ... use an invertible model", even for fixed
  // corotated): positions that are not finite (a blow-up the state check
  // missed, e.g. a line-search trial point), elements outside the model's
  // domain (neo-Hookean without clamp, J <= 0: material.h), or a finite
  // state whose force overflows.
  for (size_t i = 0; i < 3 * s->nv; ++i)
    if (!isfinite(x[i]))
      return sim_fail(s, "step %ld (t = %g): non-finite state: vertex %zu position (%g, %g, %g)%s",
                      s->n, s->t, i / 3, x[i - i % 3], x[i - i % 3 + 1], x[i - i % 3 + 2],
                      cfl_hint(s, hint, sizeof hint));
  if (s->cloth)
    return sim_fail(s,
                    "step %ld (t = %g): non-finite force (%g, %g, %g) at vertex %zu from finite "
                    "positions%s",
                    s->n, s->t, f[0], f[1], f[2], bad_vertex, cfl_hint(s, hint, sizeof hint));
  const int32_t *T = ek_mesh_tets(s->mesh);
  size_t inverted = 0, first = 0;
  double first_J = 0;
  const double *V0 = ek_mesh_rest_volumes(s->mesh);
  for (size_t e = 0; e < s->nt; ++e) {
    double J = tet_volume(x, T + 4 * e) / V0[e];
    if (J <= 0 && inverted++ == 0) {
      first = e;
      first_J = J;
    }
  }
  const int domain_limited = s->mat.model == EK_MODEL_NEO_HOOKEAN && !(s->mat.clamp > 0);
  if (inverted && domain_limited) {
    snprintf(s->error, sizeof s->error,
             "step %ld (t = %g): %zu of %zu tets inverted (J <= 0; first: tet %zu, J = %.3g); "
             "model %s is undefined there (use an invertible model or material.clamp > 0)",
             s->n, s->t, inverted, s->nt, first, first_J, ek_scene_model_name(s->mat.model));
    ek_set_error("%s", s->error);
    return EK_SIM_EINVERTED;
  }
  return sim_fail(s,
                  "step %ld (t = %g): non-finite force (%g, %g, %g) at vertex %zu from finite "
                  "positions (%zu of %zu tets with J <= 0; model %s is finite for every finite "
                  "F there, so a value overflowed)%s",
                  s->n, s->t, f[0], f[1], f[2], bad_vertex, inverted, s->nt,
                  ek_scene_model_name(s->mat.model), cfl_hint(s, hint, sizeof hint));
}

// The state a step wrote must be finite (issue 28: at dt = 1e3 the state
// was NaN after the last step and the run ended with success; gravity 1e308
// gave inf positions and a NaN energy). A step that leaves a non-finite
// position or velocity fails there, before it is applied, so the state and
// every frame written hold finite values only. One read of x and v per
// step, next to a force evaluation per tet.
static int check_state(ek_sim *s) {
  const size_t n3 = 3 * s->nv;
  for (size_t i = 0; i < n3; ++i) {
    if (isfinite(s->x_next[i]) && isfinite(s->v_next[i]))
      continue;
    const double *x = s->x_next + (i - i % 3), *v = s->v_next + (i - i % 3);
    char hint[128];
    return sim_fail(s,
                    "step %ld (t = %g): non-finite state after the step: vertex %zu position "
                    "(%g, %g, %g), velocity (%g, %g, %g)%s",
                    s->n, s->t, i / 3, x[0], x[1], x[2], v[0], v[1], v[2],
                    cfl_hint(s, hint, sizeof hint));
  }
  return 0;
}

int ek_sim_step(ek_sim *s) {
  if (!s)
    return EK_EINVAL;
  s->error[0] = '\0';
  int rc = refresh_rotations(s);
  if (rc == 0)
    rc = s->integrator->step(s, s->integrator_data);
  if (rc == 0)
    rc = check_state(s);
  if (rc)
    return rc;
  double *tmp = s->x;
  s->x = s->x_next;
  s->x_next = tmp;
  tmp = s->v;
  s->v = s->v_next;
  s->v_next = tmp;
  s->t += s->scene.dt;
  s->n++;
  s->times.steps++;
  return 0;
}

void ek_sim_set_stop_flag(ek_sim *s, const volatile sig_atomic_t *flag) {
  if (s)
    s->stop_flag = flag;
}

int sim_stop_requested(ek_sim *s, const char *where, long i, long n) {
  if (!s->stop_flag || !*s->stop_flag)
    return 0;
  snprintf(s->error, sizeof s->error,
           "step %ld (t = %g): stopped inside the step, at %s %ld of "
           "%ld; the step is not applied",
           s->n, s->t, where, i, n);
  ek_set_error("%s", s->error);
  return EK_SIM_ESTOPPED;
}

void ek_sim_time_phases(ek_sim *s, int on) { s->time_phases = on; }
const ek_sim_times *ek_sim_timings(const ek_sim *s) { return &s->times; }
const ek_sim_newton_trace *ek_sim_last_newton(const ek_sim *s) { return &s->newton; }
double ek_sim_time(const ek_sim *s) { return s->t; }
long ek_sim_steps_done(const ek_sim *s) { return s->n; }
const double *ek_sim_positions(const ek_sim *s) { return s->x; }
const double *ek_sim_velocities(const ek_sim *s) { return s->v; }
const double *ek_sim_masses(const ek_sim *s) { return s->mass; }
double ek_sim_cfl_dt(const ek_sim *s) { return s->cfl_dt; }

int ek_sim_set_state(ek_sim *s, const double *x, const double *v) {
  size_t n3 = 3 * s->nv;
  for (size_t i = 0; i < n3; ++i)
    if (!isfinite(x[i]) || (v && !isfinite(v[i])))
      return sim_fail(s, "ek_sim_set_state: vertex %zu: non-finite %s (%g)", i / 3,
                      isfinite(x[i]) ? "velocity" : "position", isfinite(x[i]) ? v[i] : x[i]);
  memcpy(s->x, x, n3 * sizeof(double));
  if (v)
    memcpy(s->v, v, n3 * sizeof(double));
  // The rotations kept from the old state: corotated linear's R^n is the
  // new state's, by the SVD polar (no warm guess); the warm force
  // rotations restart there too.
  s->R_ready = 0;
  if (s->mesh && refresh_rotations(s) != 0)
    return EK_EINVAL;
  if (uses_warm_force_rotations(s) && seed_warm_rotations(s) != 0)
    return sim_fail(s, "ek_sim_set_state: warm polar rotations: %s", ek_last_error());
  return 0;
}

size_t ek_sim_constrained_count(const ek_sim *s) {
  size_t n = 0;
  for (size_t i = 0; i < s->nv; ++i)
    n += sim_bc_at(s, i, s->t) != NULL;
  return n;
}

int ek_sim_energy(const ek_sim *s, ek_sim_energies *e) {
  double kinetic = 0, potential = 0;
  const double *g = s->scene.gravity;
  for (size_t i = 0; i < s->nv; ++i) {
    const double *v = s->v + 3 * i, *x = s->x + 3 * i;
    kinetic += 0.5 * s->mass[i] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    potential -= s->mass[i] * (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]);
  }
  e->kinetic = kinetic;
  e->potential = potential;
  e->elastic = (s->cloth ? ek_cloth_energy_f64(s->cloth, &s->cloth_p, s->x)
                         : ek_mesh_fvm_energy_ex_f64(s->mesh, &s->mat, s->x, s->R)) -
               s->elastic_rest;
  return isnan(e->elastic) ? EK_EINVAL : 0;
}

void ek_sim_momentum(const ek_sim *s, double p[3]) {
  p[0] = p[1] = p[2] = 0;
  for (size_t i = 0; i < s->nv; ++i)
    for (int k = 0; k < 3; ++k)
      p[k] += s->mass[i] * s->v[3 * i + k];
}

double ek_sim_volume(const ek_sim *s) {
  if (s->cloth) {
    double A = 0, *J = malloc(s->nt * sizeof(double));
    if (!J || ek_cloth_fields_f64(s->cloth, &s->cloth_p, s->x, J, NULL, NULL, NULL) != 0) {
      free(J);
      return NAN;
    }
    const double *A0 = ek_cloth_rest_areas(s->cloth);
    for (size_t t = 0; t < s->nt; ++t)
      A += A0[t] * J[t];
    free(J);
    return A;
  }
  const int32_t *T = ek_mesh_tets(s->mesh);
  double V = 0;
  for (size_t e = 0; e < s->nt; ++e)
    V += tet_volume(s->x, T + 4 * e);
  return V;
}

int ek_sim_tet_fields(const ek_sim *s, double *J, double *smin, double *psi) {
  if (s->cloth)
    return ek_sim_cloth_fields(s, J, NULL, smin, psi);
  // The FVM kernel computes the fields in double in a separate pass
  // (fvm.h); the force it returns alongside is discarded.
  double *scratch = malloc(3 * s->nv * sizeof(double));
  if (!scratch)
    return EK_ENOMEM;
  ek_fvm_opts o = s->fvm;
  o.J = J;
  o.sigma_min = smin;
  o.psi = psi;
  o.phase_times = NULL;
  o.R_state = NULL; // in the scene's precision; this pass is double and has R
  o.polar_state = NULL;
  int rc = ek_mesh_fvm_forces_ex_f64(s->mesh, &s->mat, s->x, scratch, &o);
  free(scratch);
  // Measured from the rest shape, like ek_sim_energy's elastic energy:
  // sum_e V0_e psi_e is that energy.
  if (rc == 0 && psi && s->psi_rest)
    for (size_t e = 0; e < s->nt; ++e)
      psi[e] -= s->psi_rest[e];
  return rc;
}
