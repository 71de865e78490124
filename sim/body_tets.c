// The tet body (body.h): the finite-volume force of Teran et al. 2003
// (seed 004) through fvm.h, its energy, fields and CFL limit, the
// projected element Hessians of hessian.h for the implicit integrator and
// the constraints of xpbd.h (StVK or stable neo-Hookean) for XPBD. Corotated linear takes
// R^n = polar(F^n) per tet at the start of each step (seed 000).
#include "body.h"
#include "errbuf.h"
#include "sim_internal.h"

#include <ek/cloth.h>
#include <ek/hessian.h>
#include <ek/polar.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
  sim_body body;
  const ek_mesh *mesh;
  double *F, *R;         // nt x 9, corotated linear only: R^n
  ek_tet_state *R_state; // R^n again, as the force kernel reads it (elements.h)
  int R_ready;           // R^n holds a step's rotations (the warm polar's guess)
  // "polar": "warm" with fixed corotated / ARAP: each tet's rotation, kept
  // by the force kernel from call to call (fvm.h polar_state); NULL else.
  ek_tet_state *polar_state;
  // Energy density at the rest shape per tet, subtracted from the frames'
  // field; NULL for corotated linear, which is 0 there.
  double *psi_rest;
  ek_fvm_opts fvm;
} tets;

static tets *tets_of(const ek_sim *s) { return s->body->data; }

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

// "polar": "warm" with fixed corotated / ARAP: the force kernel keeps each
// tet's rotation from call to call (fvm.h polar_state).
static int uses_warm_force_rotations(const ek_sim *s) {
  return s->scene.polar == EK_POLAR_WARM && ek_model_need(s->mat.model, 0) == EK_NEEDS_POLAR;
}

// (Re)start the force's per-tet rotations at the SVD polar of the current
// F (the identity at rest): at creation, and when ek_sim_set_state replaces
// the state (the last step's rotations may be far from the new ones, and
// the warm polar converges in its few iterations only from a near guess).
static int seed_warm_rotations(ek_sim *s) {
  tets *b = tets_of(s);
  size_t nt = s->nt;
  double *F = malloc(18 * nt * sizeof(double));
  int rc = F ? ek_mesh_deformation_gradients_f64(b->mesh, s->x, F) : EK_ENOMEM;
  ek_svd3_opts so = s->scene.svd;
  if (rc == 0)
    rc = ek_polar3_f64(nt, F, F + 9 * nt, NULL, &so);
  if (rc == 0 && !b->polar_state &&
      !(b->polar_state =
            ek_tet_state_create(ek_mesh_elements(b->mesh), 9, s->scene.precision == 64)))
    rc = EK_ENOMEM;
  if (rc == 0)
    rc = ek_tet_state_set_f64(b->polar_state, F + 9 * nt);
  free(F);
  return rc;
}

// R^n = polar(F(x^n)) per tet, corotated linear only (seed 000); the warm
// polar from R^(n-1) with "polar": "warm".
static int refresh_rotations(ek_sim *s) {
  if (ek_model_need(s->mat.model, 0) != EK_NEEDS_R_INPUT)
    return 0;
  tets *b = tets_of(s);
  double t0 = sim_now();
  int rc = ek_mesh_deformation_gradients_f64(b->mesh, s->x, b->F);
  if (rc == 0 && s->scene.polar == EK_POLAR_WARM && b->R_ready) {
    // The warm polar from R^(n-1) (polar.h), in double like the SVD path.
    ek_polar_warm_opts o = {.isa = s->scene.svd.isa};
    rc = ek_polar3_warm_f64(s->nt, b->F, b->R, &o);
  } else if (rc == 0) {
    ek_svd3_opts o = s->scene.svd;
    rc = ek_polar3_f64(s->nt, b->F, b->R, NULL, &o);
  }
  b->R_ready = rc == 0;
  if (rc == 0)
    rc = ek_tet_state_set_f64(b->R_state, b->R);
  s->times.polar_refresh += sim_now() - t0;
  if (rc)
    return sim_fail(s, "corotated linear: refreshing R^n failed: %s", ek_last_error());
  return 0;
}

// ---- Core ----

static void tets_destroy(sim_body *body) {
  if (!body)
    return;
  tets *b = body->data;
  free(b->F);
  free(b->R);
  ek_tet_state_destroy(b->R_state);
  ek_tet_state_destroy(b->polar_state);
  free(b->psi_rest);
  free(b);
}

// CFL: an explicit step must not outrun the fastest (dilatational) wave
// across the smallest element, dt <= h_min / c, c = sqrt((lambda + 2 mu)
// / rho) (Courant, Friedrichs, Lewy 1928; the P-wave speed of linear
// elasticity). That is an estimate: on tets, symplectic Euler diverged at
// rest from 0.95 h_min / c (ek-verify --extremes), so the limit is the
// element eigenvalue bound instead (element_cfl_dt: 0.64-0.82 h_min / c on
// the shipped meshes), h_min / c kept for the messages.
static void tets_cfl(const ek_sim *s, double *h_min, double *wave_speed, double *cfl_dt) {
  const tets *b = tets_of(s);
  *h_min = min_tet_height(b->mesh);
  *wave_speed = sqrt((s->mat.lambda + 2.0 * s->mat.mu) / s->scene.density);
  *cfl_dt = element_cfl_dt(b->mesh, s->mat.lambda, s->mat.mu, s->scene.density);
}

static int tets_start(ek_sim *s) {
  tets *b = tets_of(s);
  const ek_scene *scene = &s->scene;
  b->fvm.scatter = scene->scatter;
  b->fvm.isa = scene->svd.isa;
  b->fvm.svd_sweeps = scene->svd.sweeps;
  b->fvm.svd_exact_rsqrt = scene->svd.exact_rsqrt;
  b->fvm.svd_refine = scene->svd.refine;
  b->fvm.R = b->R;
  if (ek_model_need(s->mat.model, 0) == EK_NEEDS_R_INPUT) {
    b->R_state = ek_tet_state_create(ek_mesh_elements(b->mesh), 9, scene->precision == 64);
    if (!b->R_state)
      return sim_fail(s, "%s", ek_last_error());
    b->fvm.R_state = b->R_state;
  }
  if (uses_warm_force_rotations(s)) {
    int rc = seed_warm_rotations(s);
    if (rc != 0)
      return sim_fail(s, "polar \"warm\": initial rotations: %s",
                      rc == EK_ENOMEM ? "out of memory" : ek_last_error());
    b->fvm.polar_state = b->polar_state;
  }
  if (refresh_rotations(s) != 0)
    return EK_EINVAL;
  s->times.polar_refresh = 0;
  // Corotated linear is 0 at rest (R = polar(I) = I); the others are
  // evaluated, per tet for the frames' field and summed for the energy.
  s->elastic_rest = 0.0;
  if (b->psi_rest) {
    const double *X = b->body.X;
    s->elastic_rest = ek_mesh_fvm_energy_f64(b->mesh, &s->mat, X);
    ek_fvm_opts o = b->fvm;
    o.psi = b->psi_rest;
    o.polar_state = NULL; // a double pass: the SVD (the state is in the scene's precision)
    if (ek_mesh_fvm_forces_ex_f64(b->mesh, &s->mat, X, s->f, &o) != 0)
      return sim_fail(s, "energy density at rest: %s", ek_last_error());
  }
  return 0;
}

static int tets_begin_step(ek_sim *s) { return refresh_rotations(s); }

// The rotations kept from the old state: corotated linear's R^n is the new
// state's, by the SVD polar (no warm guess); the warm force rotations
// restart there too.
static int tets_set_state(ek_sim *s) {
  tets_of(s)->R_ready = 0;
  if (refresh_rotations(s) != 0)
    return EK_EINVAL;
  if (uses_warm_force_rotations(s) && seed_warm_rotations(s) != 0)
    return sim_fail(s, "ek_sim_set_state: warm polar rotations: %s", ek_last_error());
  return 0;
}

static int tets_forces(ek_sim *s, const double *x64, const float *x32, double *f64, float *f32) {
  tets *b = tets_of(s);
  ek_fvm_opts o = b->fvm;
  ek_fvm_phase_times pt = {0, 0, 0, 0};
  if (s->time_phases)
    o.phase_times = &pt;
  int rc = x32 ? ek_mesh_fvm_forces_ex_f32(b->mesh, &s->mat, x32, f32, &o)
               : ek_mesh_fvm_forces_ex_f64(b->mesh, &s->mat, x64, f64, &o);
  if (s->time_phases) {
    s->times.deformation_gradient += pt.deformation_gradient;
    s->times.svd_polar += pt.svd;
    s->times.pk1 += pt.pk1;
    s->times.scatter += pt.scatter;
  }
  return rc;
}

// Elements outside the model's domain (neo-Hookean without clamp, J <= 0:
// material.h), or a finite state whose force overflows.
static int tets_bad_force(ek_sim *s, const double *x, size_t bad_vertex, const char *hint) {
  const tets *b = tets_of(s);
  const double *f = s->f + 3 * bad_vertex;
  const int32_t *T = ek_mesh_tets(b->mesh);
  size_t inverted = 0, first = 0;
  double first_J = 0;
  const double *V0 = ek_mesh_rest_volumes(b->mesh);
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
             "%zu of %zu tets inverted (J <= 0; first: tet %zu, J = %.3g); model %s is undefined "
             "there (use an invertible model or material.clamp > 0)",
             inverted, s->nt, first, first_J, ek_scene_model_name(s->mat.model));
    ek_set_error("%s", s->error);
    return EK_SIM_EINVERTED;
  }
  return sim_fail(s,
                  "non-finite force (%g, %g, %g) at vertex %zu from finite positions (%zu of %zu "
                  "tets with J <= 0; model %s is finite for every finite F there, so a value "
                  "overflowed)%s",
                  f[0], f[1], f[2], bad_vertex, inverted, s->nt, ek_scene_model_name(s->mat.model),
                  hint);
}

static size_t tets_inverted_count(const ek_sim *s, const double *x, size_t *first,
                                  double *first_J) {
  const ek_mesh *m = tets_of(s)->mesh;
  const int32_t *T = ek_mesh_tets(m);
  if (!x)
    x = s->x;
  size_t n = 0;
  for (size_t e = 0; e < s->nt; ++e) {
    const double V = tet_volume(x, T + 4 * e);
    if (!(V > 0) && n++ == 0) {
      if (first)
        *first = e;
      if (first_J)
        *first_J = V / ek_mesh_rest_volumes(m)[e];
    }
  }
  return n;
}

static double tets_energy(const ek_sim *s, const double *x) {
  const tets *b = tets_of(s);
  return ek_mesh_fvm_energy_ex_f64(b->mesh, &s->mat, x, b->R);
}

static double tets_measure(const ek_sim *s) {
  const int32_t *T = ek_mesh_tets(tets_of(s)->mesh);
  double V = 0;
  for (size_t e = 0; e < s->nt; ++e)
    V += tet_volume(s->x, T + 4 * e);
  return V;
}

static int tets_fields(const ek_sim *s, double *J, double *smax, double *smin, double *psi) {
  (void)smax; // a tet's fields have no sigma_max (body.h)
  const tets *b = tets_of(s);
  // The FVM kernel computes the fields in double in a separate pass
  // (fvm.h); the force it returns alongside is discarded.
  double *scratch = malloc(3 * s->nv * sizeof(double));
  if (!scratch)
    return EK_ENOMEM;
  ek_fvm_opts o = b->fvm;
  o.J = J;
  o.sigma_min = smin;
  o.psi = psi;
  o.phase_times = NULL;
  o.R_state = NULL; // in the scene's precision; this pass is double and has R
  o.polar_state = NULL;
  int rc = ek_mesh_fvm_forces_ex_f64(b->mesh, &s->mat, s->x, scratch, &o);
  free(scratch);
  // Measured from the rest shape, like ek_sim_energy's elastic energy:
  // sum_e V0_e psi_e is that energy.
  if (rc == 0 && psi && b->psi_rest)
    for (size_t e = 0; e < s->nt; ++e)
      psi[e] -= b->psi_rest[e];
  return rc;
}

// Eigenvalues of a symmetric 3x3 A (row-major), descending, in closed
// form (Smith 1961, CACM 4(4): A = q I + p B, det B = 2 cos(3 phi)).
static void sym3_eigenvalues(const double *A, double e[3]) {
  double p1 = A[1] * A[1] + A[2] * A[2] + A[5] * A[5];
  double q = (A[0] + A[4] + A[8]) / 3;
  double p2 = (A[0] - q) * (A[0] - q) + (A[4] - q) * (A[4] - q) + (A[8] - q) * (A[8] - q) + 2 * p1;
  if (!(p2 > 0)) {
    e[0] = e[1] = e[2] = q;
    return;
  }
  double p = sqrt(p2 / 6), B[9];
  for (int k = 0; k < 9; ++k)
    B[k] = (A[k] - (k % 4 == 0 ? q : 0)) / p;
  double r = 0.5 * (B[0] * (B[4] * B[8] - B[5] * B[7]) - B[1] * (B[3] * B[8] - B[5] * B[6]) +
                    B[2] * (B[3] * B[7] - B[4] * B[6]));
  r = r < -1 ? -1 : r > 1 ? 1 : r;
  double phi = acos(r) / 3;
  e[0] = q + 2 * p * cos(phi);
  e[2] = q + 2 * p * cos(phi + 2.0943951023931955 /* 2 pi / 3 */);
  e[1] = 3 * q - e[0] - e[2];
}

// L = Fdot F^-1 per tet (cloth.h, seed 003 eqs. 28-31); the principal
// strain rates are the eigenvalues of D.
static int tets_rate_fields(const ek_sim *s, double *D, double *W, double *rates) {
  int rc = ek_mesh_velocity_gradient_f64(tets_of(s)->mesh, s->x, s->v, NULL, D, W);
  for (size_t e = 0; rc == 0 && rates && e < s->nt; ++e)
    sym3_eigenvalues(D + 9 * e, rates + 3 * e);
  return rc;
}

// ---- Implicit integrator: the projected element Hessians (hessian.h) ----

typedef struct {
  ek_fvm_hessian *H;
  // Corotated linear: R^n in double for the gradient, refreshed from the
  // body's R at each step's start, in an f32 scene and in a part (whose
  // tets are its own, not the mesh's: part_elems maps its tet i to the
  // mesh's); NULL else (the gradient reads the body's R_state).
  ek_tet_state *R64;
  int f32;
  ek_tets *part;      // hessian_create_part: the part's elements (H's), owned
  size_t *part_elems; // corotated linear in a part: the part's tets (count), owned
  double *part_R;     // count x 9: their R^n, gathered
  size_t count;
} tets_hessian;

static void tets_hessian_destroy(void *h) {
  tets_hessian *th = h;
  if (!th)
    return;
  ek_fvm_hessian_destroy(th->H);
  ek_tet_state_destroy(th->R64);
  ek_tets_destroy(th->part);
  free(th->part_elems);
  free(th->part_R);
  free(th);
}

// The whole mesh's Hessian (part NULL) or that of the tets `part` holds.
static void *hessian_create_on(ek_sim *s, sim_hessian_info *info, ek_tets *part) {
  const ek_scene *sc = &s->scene;
  tets_hessian *th = calloc(1, sizeof *th);
  if (!th) {
    ek_tets_destroy(part);
    sim_fail(s, "out of memory");
    return NULL;
  }
  th->part = part;
  th->f32 = sc->precision == 32;
  info->f32 = th->f32;
  info->residual_merit = ek_model_need(s->mat.model, s->mat.clamp) == EK_NEEDS_SVD;
  info->split_timing = 1;
  ek_fvm_hessian_opts o = {.scatter = sc->scatter,
                           .isa = sc->svd.isa,
                           .svd_sweeps = sc->svd.sweeps,
                           .svd_exact_rsqrt = sc->svd.exact_rsqrt,
                           .svd_refine = sc->svd.refine,
                           .projection = sc->implicit.projection,
                           .precision = sc->precision};
  const ek_tets *el = part ? part : ek_mesh_elements(tets_of(s)->mesh);
  if (!(th->H = ek_fvm_hessian_create(el, &s->mat, &o)) ||
      (ek_model_need(s->mat.model, 0) == EK_NEEDS_R_INPUT && (th->f32 || part) &&
       !(th->R64 = ek_tet_state_create(el, 9, 1)))) {
    sim_fail(s, "%s", ek_last_error());
    tets_hessian_destroy(th);
    return NULL;
  }
  return th;
}

static void *tets_hessian_create(ek_sim *s, sim_hessian_info *info) {
  return hessian_create_on(s, info, NULL);
}

// The part's tets, with every vertex of the mesh (the same rest positions,
// so each tet's Dm^-1 and V0 have the bits of the whole mesh's).
// Corotated linear: the part keeps its tets' R^n (R64), gathered from the
// body's R (every rank refreshes R^n for the whole mesh from the
// replicated state: tets_begin_step) at each step's start.
static void *tets_hessian_create_part(ek_sim *s, sim_hessian_info *info, const size_t *elems,
                                      size_t count) {
  const int32_t *all = s->body->elems;
  int32_t *t = malloc((4 * count + 1) * sizeof *t);
  if (!t) {
    sim_fail(s, "out of memory");
    return NULL;
  }
  for (size_t i = 0; i < count; i++)
    memcpy(t + 4 * i, all + 4 * elems[i], 4 * sizeof *t);
  ek_tets *part = ek_tets_create(s->body->nv, s->body->X, count, t);
  free(t);
  if (!part) {
    sim_fail(s, "%s", ek_last_error());
    return NULL;
  }
  tets_hessian *th = hessian_create_on(s, info, part);
  if (th && th->R64) {
    th->count = count;
    th->part_elems = malloc(count * sizeof *th->part_elems);
    th->part_R = malloc(9 * count * sizeof *th->part_R);
    if (!th->part_elems || !th->part_R) {
      tets_hessian_destroy(th);
      sim_fail(s, "out of memory");
      return NULL;
    }
    memcpy(th->part_elems, elems, count * sizeof *elems);
  }
  return th;
}

static int tets_hessian_begin_step(ek_sim *s, void *h) {
  tets_hessian *th = h;
  const double *R = tets_of(s)->R;
  if (th->part_R) {
    for (size_t i = 0; i < th->count; i++)
      memcpy(th->part_R + 9 * i, R + 9 * th->part_elems[i], 9 * sizeof *R);
    R = th->part_R;
  }
  if (th->R64 && ek_tet_state_set_f64(th->R64, R) < 0)
    return sim_fail(s, "%s", ek_last_error());
  return 0;
}

static int tets_gradient(const ek_sim *s, void *h, const double *x, double *grad, double *E,
                         int cache) {
  tets_hessian *th = h;
  const ek_tet_state *R = ek_model_need(s->mat.model, 0) != EK_NEEDS_R_INPUT ? NULL
                          : th->R64                                          ? th->R64
                                                                             : tets_of(s)->R_state;
  return ek_fvm_hessian_gradient_f64(th->H, x, R, grad, E, cache);
}

static int tets_hessian_apply(void *h, const double *p, double *q, const float *p32, float *q32) {
  const tets_hessian *th = h;
  return th->f32 ? ek_fvm_hessian_apply_f32(th->H, p32, q32)
                 : ek_fvm_hessian_apply_f64(th->H, p, q);
}

static int tets_hessian_apply_parts(void *h, int *parallel) {
  const tets_hessian *th = h;
  return ek_fvm_hessian_apply_parts(th->H, parallel);
}

static int tets_hessian_apply_part(void *h, int part, const double *p, const float *p32) {
  const tets_hessian *th = h;
  return th->f32 ? ek_fvm_hessian_apply_part_f32(th->H, p32, part)
                 : ek_fvm_hessian_apply_part_f64(th->H, p, part);
}

static void tets_hessian_apply_rows(void *h, size_t v0, size_t v1, double *q, float *q32) {
  const tets_hessian *th = h;
  if (th->f32)
    ek_fvm_hessian_apply_rows_f32(th->H, v0, v1, q32);
  else
    ek_fvm_hessian_apply_rows_f64(th->H, v0, v1, q);
}

static int tets_hessian_pattern(void *h, ek_csr_pattern *pattern) {
  return ek_fvm_hessian_pattern(((tets_hessian *)h)->H, pattern);
}

static int tets_hessian_assemble(void *h, double *values) {
  return ek_fvm_hessian_assemble(((tets_hessian *)h)->H, values);
}

static int tets_hessian_diagonal(void *h, double *blocks) {
  return ek_fvm_hessian_diagonal_f64(((tets_hessian *)h)->H, blocks);
}

// ---- XPBD integrator: seed 001's Hookean constraints or the stable
// neo-Hookean pair (xpbd.h) ----

typedef struct {
  ek_xpbd *xp;
  int f32;
} tets_xpbd;

static void tets_xpbd_destroy(void *c) {
  tets_xpbd *tx = c;
  if (!tx)
    return;
  ek_xpbd_destroy(tx->xp);
  free(tx);
}

static void *tets_xpbd_create(ek_sim *s, double young, int *f32) {
  if (!ek_xpbd_supports(s->mat.model)) {
    sim_fail_at(s, s->scene.where.model,
                "material.model = %s: XPBD has constraints for \"stvk\" (seed 001's Hookean "
                "energy) and \"snh\" (stable neo-Hookean, Macklin & Mueller 2021; xpbd.h) only",
                s->scene.model_name);
    return NULL;
  }
  tets_xpbd *tx = calloc(1, sizeof *tx);
  if (!tx) {
    sim_fail(s, "out of memory");
    return NULL;
  }
  const ek_scene_xpbd *k = &s->scene.xpbd;
  ek_xpbd_opts o = {.elements = k->elements,
                    .solver = k->solver,
                    .isa = s->scene.svd.isa,
                    .precision = s->scene.precision};
  tx->f32 = *f32 = s->scene.precision == 32;
  tx->xp = ek_xpbd_create(ek_mesh_elements(tets_of(s)->mesh), &s->mat, young, s->mass, &o);
  if (!tx->xp) {
    sim_fail(s, "%s", ek_last_error());
    free(tx);
    return NULL;
  }
  return tx;
}

static int tets_xpbd_begin(void *c, const double *w, double h) {
  tets_xpbd *tx = c;
  int rc = ek_xpbd_set_weights(tx->xp, w);
  return rc == 0 ? ek_xpbd_begin(tx->xp, h) : rc;
}

static int tets_xpbd_iterate(void *c, const float *x_base, float *xf, double *x, int n) {
  tets_xpbd *tx = c;
  return tx->f32 ? ek_xpbd_iterate_f32(tx->xp, x_base, xf, n)
                 : ek_xpbd_iterate_f64(tx->xp, NULL, x, n);
}

static int tets_xpbd_residual(const void *c, const float *x_base, const float *xf, const double *x,
                              double *r, double *cmax) {
  const tets_xpbd *tx = c;
  return tx->f32 ? ek_xpbd_residual_f32(tx->xp, x_base, xf, r, cmax)
                 : ek_xpbd_residual_f64(tx->xp, NULL, x, r, cmax);
}

static int tets_xpbd_profile(void *c, const float *x_base, const float *xf, const double *x,
                             double sec[3]) {
  tets_xpbd *tx = c;
  return tx->f32 ? ek_xpbd_profile_f32(tx->xp, x_base, xf, sec)
                 : ek_xpbd_profile_f64(tx->xp, NULL, x, sec);
}

static size_t tets_xpbd_count(const void *c) { return ek_xpbd_count(((const tets_xpbd *)c)->xp); }

static void tets_describe(const ek_sim *s, char *buf, size_t len) {
  const tets *b = tets_of(s);
  snprintf(buf, len, "%zu tets, %d colours, model %s", ek_mesh_ntets(b->mesh),
           ek_mesh_ncolors(b->mesh), s->scene.model_name);
}

const sim_body_ops sim_body_tets = {
    .destroy = tets_destroy,
    .describe = tets_describe,
    .cfl = tets_cfl,
    .start = tets_start,
    .begin_step = tets_begin_step,
    .set_state = tets_set_state,
    .forces = tets_forces,
    .force_kernel = "FVM",
    .bad_force = tets_bad_force,
    .inverted_count = tets_inverted_count,
    .energy = tets_energy,
    .measure = tets_measure,
    .fields = tets_fields,
    .rate_fields = tets_rate_fields,
    .hessian_create = tets_hessian_create,
    .hessian_create_part = tets_hessian_create_part,
    .hessian_destroy = tets_hessian_destroy,
    .hessian_begin_step = tets_hessian_begin_step,
    .gradient = tets_gradient,
    .hessian_apply = tets_hessian_apply,
    .hessian_apply_parts = tets_hessian_apply_parts,
    .hessian_apply_part = tets_hessian_apply_part,
    .hessian_apply_rows = tets_hessian_apply_rows,
    .hessian_diagonal = tets_hessian_diagonal,
    .hessian_pattern = tets_hessian_pattern,
    .hessian_assemble = tets_hessian_assemble,
    .xpbd_create = tets_xpbd_create,
    .xpbd_destroy = tets_xpbd_destroy,
    .xpbd_begin = tets_xpbd_begin,
    .xpbd_iterate = tets_xpbd_iterate,
    .xpbd_residual = tets_xpbd_residual,
    .xpbd_profile = tets_xpbd_profile,
    .xpbd_count = tets_xpbd_count,
};

sim_body *sim_body_tets_create(const ek_scene *scene, const ek_material *mat, const ek_mesh *mesh) {
  (void)scene;
  tets *b = calloc(1, sizeof *b);
  if (!b)
    return NULL;
  size_t nt = ek_mesh_ntets(mesh);
  b->mesh = mesh;
  b->body =
      (sim_body){.ops = &sim_body_tets,
                 .data = b,
                 .nv = ek_mesh_nverts(mesh),
                 .ne = nt,
                 .corners = 4,
                 .elems = ek_mesh_tets(mesh),
                 .X = ek_mesh_rest_positions(mesh),
                 .lumped = ek_mesh_lumped_volume(mesh),
                 .mass_scale = 1.0,
                 .kind = "tets",
                 .caller_elems = ek_mesh_tets(mesh),
                 .has_smax = 0,
                 .oriented = 1,
                 .nphases = 4,
                 .phase_names = {"deformation gradient", "SVD/polar", "P(F)", "scatter"},
                 .phase_times = {offsetof(ek_sim_times, deformation_gradient),
                                 offsetof(ek_sim_times, svd_polar), offsetof(ek_sim_times, pk1),
                                 offsetof(ek_sim_times, scatter)}};
  int ok = 1;
  if (ek_model_need(mat->model, 0) == EK_NEEDS_R_INPUT) {
    b->F = malloc(9 * nt * sizeof(double));
    b->R = malloc(9 * nt * sizeof(double));
    ok = b->F && b->R;
  } else {
    b->psi_rest = malloc(nt * sizeof(double));
    ok = b->psi_rest != NULL;
  }
  if (!ok) {
    tets_destroy(&b->body);
    return NULL;
  }
  return &b->body;
}
