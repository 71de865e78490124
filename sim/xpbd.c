// The XPBD integrator (Macklin, Mueller, Chentanez 2016, alg. 1, in
// substeps: Macklin et al. 2019) on the body's constraints (body.h): seed
// 001's Hookean constraint or the stable neo-Hookean pair (scene model
// "stvk" or "snh") on the tets or on one-ring clusters
// (include/ek/xpbd.h), or a cloth's triangles and hinges (cloth_force.h);
// the scene's knobs in ek_scene_xpbd (sim.h). Per substep of h = dt / K:
//   x~ = x + h (v + h g) / (1 + c h),  w_i = 1 / (m_i (1 + c h))
//   lambda = 0;  N sweeps of the solver from x = x~
//   v = (x - x_start) / h;  ground contact
// Damping c enters as in the implicit loop's incremental potential (the
// mass scaled by 1 + c h and x~ moved), so at c = 0 this is the seed's
// x~ = x + h v + h^2 g and both loops minimise the same objective.
// Positions stay double between substeps. f64 sweeps run on the
// positions; f32 sweeps on float displacements from a float x~ (the base of
// ek_xpbd_iterate_f32), so their updates round to the displacements' size
// and the state is x~ + displacement in double. (A double base would only
// add a gather per member: double positions round to 1e-16 of |x|.)
#include "sim_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
  const sim_body *body;
  void *c; // the body's constraints (body.h: xpbd_create)
  int f32; // sweeps on float displacements from a float x~
  double young;
  double *xs, *vs, *xp_pred, *w; // substep start, prediction, weights
  float *xf, *xf_pred;           // f32 sweeps: displacements, float x~
} xpbd_data;

static void xpbd_destroy(void *data) {
  xpbd_data *d = data;
  if (!d)
    return;
  if (d->c)
    d->body->ops->xpbd_destroy(d->c);
  free(d->xs);
  free(d->vs);
  free(d->xp_pred);
  free(d->w);
  free(d->xf);
  free(d->xf_pred);
  free(d);
}

// E from the scene (or from mu, lambda when those were given).
static double young_of(const ek_sim *s) {
  if (!isnan(s->scene.young))
    return s->scene.young;
  const double mu = s->mat.mu, la = s->mat.lambda;
  return mu * (3 * la + 2 * mu) / (la + mu);
}

static int xpbd_create(ek_sim *s, void **data) {
  *data = NULL;
  xpbd_data *d = calloc(1, sizeof *d);
  if (!d)
    return sim_fail(s, "out of memory");
  *data = d;
  const size_t n3 = 3 * s->nv;
  d->young = young_of(s);
  d->body = s->body;
  // The body checks the model and the knobs against its constraints.
  if (!(d->c = s->body->ops->xpbd_create(s, d->young, &d->f32)))
    return EK_EINVAL; // the message is in s->error
  d->xs = malloc(n3 * sizeof(double));
  d->vs = malloc(n3 * sizeof(double));
  d->xp_pred = malloc(n3 * sizeof(double));
  d->w = malloc(s->nv * sizeof(double));
  int ok = d->xs && d->vs && d->xp_pred && d->w;
  if (d->f32) {
    d->xf = malloc(n3 * sizeof(float));
    d->xf_pred = malloc(n3 * sizeof(float));
    ok = ok && d->xf && d->xf_pred;
  }
  if (!ok)
    return sim_fail(s, "out of memory for %zu vertices", s->nv);
  return 0;
}

static int xpbd_explain(const ek_scene *s, FILE *out, int number) {
  const ek_scene_xpbd *k = &s->xpbd;
  fprintf(out,
          "  %d. XPBD (Macklin 2016), %ld substeps of h = dt / %ld: x~ = x + h (v + h g) / "
          "(1 + c h), lambda = 0\n",
          number, k->substeps, k->substeps);
  const int snh = s->material.model == EK_MODEL_STABLE_NEO_HOOKEAN;
  fprintf(out, "       %ld %s sweeps per substep over %s (%s),\n", k->iterations,
          k->solver == EK_XPBD_JACOBI ? "Jacobi (averaged)" : "coloured Gauss-Seidel",
          k->elements == EK_XPBD_CLUSTERS ? "one-ring shape-matching clusters" : "the tets",
          snh ? "Macklin & Mueller 2021: C_D = sqrt(I_C - log(1 + I_C)), alpha_D = 1 / (V mu); "
                "C_H = J - a, alpha_H = 1 / (V lambda)"
              : "seed 001: C = sqrt(2 W_StVK / E), alpha = 1 / (V E)");
  if (snh)
    fprintf(out,
            "       per block of %d elements: gather members -> F -> C_D, C_H, their gradients "
            "-> coupled 2x2 dlambda -> x += w (grad C_D dl_D + grad C_H dl_H)\n",
            s->precision == 32 ? EK_LANES_F32 : EK_LANES_F64);
  else
    fprintf(out,
            "       per block of %d constraints: gather members -> F -> W, P = F S -> grad C, "
            "dlambda -> x += w grad C dlambda\n",
            s->precision == 32 ? EK_LANES_F32 : EK_LANES_F64);
  fprintf(out,
          "  %d. v = (x - x_start) / h, ground; the FVM force kernel (fvm.h) is not used by this "
          "loop (it gives the frames' fields)\n",
          number + 1);
  return number + 2;
}

static int xpbd_step(ek_sim *s, void *data) {
  xpbd_data *d = data;
  const ek_scene *sc = &s->scene;
  const ek_scene_xpbd *k = &sc->xpbd;
  const long K = k->substeps, N = k->iterations;
  const double h = sc->dt / (double)K, c = sc->damping, damp = 1.0 / (1.0 + c * h);
  const double *g = sc->gravity;
  const size_t nv = s->nv, n3 = 3 * nv;
  const sim_body_ops *ops = d->body->ops;
  const int f32 = d->f32;
  memcpy(d->xs, s->x, n3 * sizeof(double));
  memcpy(d->vs, s->v, n3 * sizeof(double));
  int rc = 0;
  for (long sub = 0; sub < K && rc == 0; sub++) {
    if (sim_stop_requested(s, "XPBD substep", sub + 1, K))
      return EK_SIM_ESTOPPED;
    double t0 = sim_now();
    const double t1 = s->t + (double)(sub + 1) * h;
    for (size_t i = 0; i < nv; i++) {
      double *xp = d->xp_pred + 3 * i;
      const ek_scene_bc *bc = sim_bc_at(s, i, t1);
      double vb[3];
      if (bc) {
        sim_bc_state(bc, s->x0 + 3 * i, t1, xp, vb);
        d->w[i] = 0;
      } else if (s->inv_mass[i] == 0) {
        memcpy(xp, d->xs + 3 * i, 3 * sizeof(double));
        d->w[i] = 0;
      } else {
        for (int j = 0; j < 3; j++)
          xp[j] = d->xs[3 * i + j] + h * (d->vs[3 * i + j] + h * g[j]) * damp;
        d->w[i] = s->inv_mass[i] * damp;
      }
    }
    rc = ops->xpbd_begin(d->c, d->w, h);
    if (f32) {
      for (size_t i = 0; i < n3; i++)
        d->xf_pred[i] = (float)d->xp_pred[i];
      memset(d->xf, 0, n3 * sizeof(float));
    } else {
      memcpy(s->x_next, d->xp_pred, n3 * sizeof(double));
    }
    s->times.integration += sim_now() - t0;
    t0 = sim_now();
    // The sweeps in slices between looks at the stop flag (issue 28: 1e5
    // substeps x 1e5 iterations ignored SIGINT); the multipliers live in
    // the solver from begin on, so slices give the same bits as one call.
    const long slice = s->stop_flag ? EK_SIM_STOP_SWEEPS : N;
    long done = 0;
    do {
      if (done > 0 && sim_stop_requested(s, "XPBD sweep", done + 1, N))
        return EK_SIM_ESTOPPED;
      const int n = (int)(N - done < slice ? N - done : slice);
      if (rc == 0)
        rc = ops->xpbd_iterate(d->c, d->xf_pred, d->xf, s->x_next, n);
      done += n;
    } while (rc == 0 && done < N);
    s->times.xpbd_solve += sim_now() - t0;
    s->times.xpbd_sweeps += N;
    if (rc)
      break;
    if (sub == K - 1) {
      double r = NAN, cm = NAN;
      rc = ops->xpbd_residual(d->c, d->xf_pred, d->xf, s->x_next, &r, &cm);
      s->times.xpbd_last_residual = r;
      s->times.xpbd_last_cmax = cm;
      if (!(r <= s->times.xpbd_worst_residual))
        s->times.xpbd_worst_residual = r;
      if (s->time_phases && rc == 0 && ops->xpbd_profile) {
        double sec[3];
        rc = ops->xpbd_profile(d->c, d->xf_pred, d->xf, s->x_next, sec);
        s->times.xpbd_sweep_F += sec[0];
        s->times.xpbd_sweep_eval += sec[1] - sec[0];
        s->times.xpbd_sweep_project += sec[2] - sec[1];
        s->times.xpbd_profiles++;
      }
    }
    // v = (x - x_start) / h; prescribed vertices take their motion's.
    t0 = sim_now();
    for (size_t i = 0; i < nv; i++) {
      double *x = s->x_next + 3 * i, *v = d->vs + 3 * i, *xs = d->xs + 3 * i;
      if (f32)
        for (int j = 0; j < 3; j++)
          x[j] = d->xp_pred[3 * i + j] + (double)d->xf[3 * i + j];
      const ek_scene_bc *bc = sim_bc_at(s, i, t1);
      if (bc) {
        sim_bc_state(bc, s->x0 + 3 * i, t1, x, v);
      } else {
        for (int j = 0; j < 3; j++)
          v[j] = (x[j] - xs[j]) / h;
        sim_ground_contact(s, x, v);
      }
      memcpy(xs, x, 3 * sizeof(double));
    }
    s->times.integration += sim_now() - t0;
  }
  if (rc)
    return sim_fail(s, "%s", ek_last_error());
  // A non-finite position (a blown-up solve) stops the run.
  for (size_t i = 0; i < n3; i++)
    if (!isfinite(d->xs[i]))
      return sim_fail(s,
                      "XPBD gave vertex %zu a non-finite position (%g, %g, %g) (dt = %g, %ld "
                      "substeps, %ld iterations)",
                      i / 3, d->xs[i - i % 3], d->xs[i - i % 3 + 1], d->xs[i - i % 3 + 2], sc->dt,
                      K, N);
  memcpy(s->x_next, d->xs, n3 * sizeof(double));
  memcpy(s->v_next, d->vs, n3 * sizeof(double));
  return 0;
}

size_t ek_sim_xpbd_constraints(const ek_sim *s) {
  if (!s || s->integrator != &sim_integrator_xpbd || !s->integrator_data)
    return 0;
  const xpbd_data *d = s->integrator_data;
  return d->body->ops->xpbd_count(d->c);
}

const sim_integrator sim_integrator_xpbd = {
    .name = "xpbd",
    .description = "XPBD (Macklin et al. 2016) with seed 001's Hookean constraint on tets or "
                   "shape-matching clusters, in substeps (Macklin et al. 2019)",
    .explain = xpbd_explain,
    .create = xpbd_create,
    .destroy = xpbd_destroy,
    .step = xpbd_step,
};
