// One trial of a scene setting (trial.h): run, time, measure, compare.
#include "trial.h"
#include "errbuf.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double trial_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

double ek_trial_body_size(const ek_mesh *mesh) {
  const double *X = ek_mesh_rest_positions(mesh);
  size_t nv = ek_mesh_nverts(mesh);
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = fmin(lo[k], X[3 * i + k]);
      hi[k] = fmax(hi[k], X[3 * i + k]);
    }
  return sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
              (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

// Each model's linearisation at F = I as linear elasticity (material.h,
// "At F = I every model's dP is linear elasticity") and its inverse are in
// its descriptor: the scene's material, linearised, becomes the other
// model's (mu, lambda) for the same small-strain behaviour.
int ek_trial_set_model(ek_scene *s, ek_model model, char *why, size_t whylen) {
  double mu_lin, lambda_lin, mu, lambda;
  ek_model_describe(s->material.model)
      ->linearise(s->material.mu, s->material.lambda, &mu_lin, &lambda_lin);
  if (ek_model_describe(model)->from_linear(mu_lin, lambda_lin, &mu, &lambda, why, whylen) != EK_OK)
    return -1;
  if (mu != s->material.mu || lambda != s->material.lambda) {
    // E and nu as given no longer describe (mu, lambda): XPBD derives E
    // from mu and lambda when young is NaN (sim/xpbd.c).
    s->young = NAN;
    s->poisson = NAN;
  }
  s->material.model = model;
  s->material.mu = mu;
  s->material.lambda = lambda;
  snprintf(s->model_name, sizeof s->model_name, "%s", ek_scene_model_name(model));
  return 0;
}

// The rules (trial.h): the explicit force for the models that need R(F) or
// the clamped singular values, corotated linear's R^n refresh
// (ek_polar3_f64, every loop), the implicit loop's gradient pass for the
// isotropic models (their eigensystems are in the U, V frame, hessian.h).
// XPBD's constraint (StVK, P = F S) takes none.
int ek_trial_uses_svd(const ek_scene *s) {
  const ek_model_desc *d = ek_model_describe(s->material.model);
  if (d->needs == EK_NEEDS_R_INPUT)
    return 1;
  if (s->integrator == EK_INTEGRATOR_XPBD)
    return 0;
  if (s->integrator == EK_INTEGRATOR_IMPLICIT)
    return d->isotropic;
  ek_model_needs need = ek_model_need(s->material.model, s->material.clamp);
  return need == EK_NEEDS_POLAR || need == EK_NEEDS_SVD;
}

// Append to out[0 .. outlen) at *n (snprintf's truncation: *n may pass
// outlen, then nothing more is written).
__attribute__((format(printf, 4, 5))) static void append(char *out, size_t outlen, size_t *n,
                                                         const char *fmt, ...) {
  if (*n >= outlen)
    return;
  va_list ap;
  va_start(ap, fmt);
  int k = vsnprintf(out + *n, outlen - *n, fmt, ap);
  va_end(ap);
  if (k > 0)
    *n += (size_t)k;
}

void ek_trial_setting_text(const ek_scene *s, char *out, size_t outlen) {
  size_t n = 0;
  if (outlen == 0)
    return;
  out[0] = '\0';
  append(out, outlen, &n, "model=%s;precision=f%d", ek_scene_model_name(s->material.model),
         s->precision);
  if (ek_model_need(s->material.model, s->material.clamp) == EK_NEEDS_SVD) // clamp in use
    append(out, outlen, &n, ";clamp=%g", s->material.clamp);
  if (ek_trial_uses_svd(s)) {
    if (s->svd.sweeps)
      append(out, outlen, &n, ";sweeps=%d", s->svd.sweeps);
    else
      append(out, outlen, &n, ";sweeps=default");
    if (s->svd.refine == EK_SVD3_REFINE_NONE)
      append(out, outlen, &n, ";refine=0");
    else if (s->svd.refine)
      append(out, outlen, &n, ";refine=%d", s->svd.refine);
    if (s->svd.exact_rsqrt)
      append(out, outlen, &n, ";rsqrt=%s", s->svd.exact_rsqrt > 0 ? "exact" : "approx");
  }
  append(out, outlen, &n, ";loop=%s;dt=%.4g", ek_scene_integrator_name(s->integrator), s->dt);
  if (s->integrator == EK_INTEGRATOR_IMPLICIT) {
    append(out, outlen, &n, ";newton_tol=%g;cg_tol=%g;max_newton=%ld", s->implicit.newton_tol,
           s->implicit.cg_tol, s->implicit.max_newton);
    // The assembled solvers only: a matrix-free setting keeps the text it
    // had before the key existed (the trade map's rows keep their names).
    if (s->implicit.linear_solver != EK_LINSOLVE_MATRIX_FREE)
      append(out, outlen, &n, ";linear_solver=%s",
             ek_linear_solver_name(s->implicit.linear_solver));
  }
  if (s->integrator == EK_INTEGRATOR_XPBD)
    append(out, outlen, &n, ";substeps=%ld;iterations=%ld", s->xpbd.substeps, s->xpbd.iterations);
}

// Monitor state: R of the previous sample per tet.
typedef struct {
  double *F, *U, *S, *V, *R_prev;
  long prev_step;
} monitor_buf;

static double rotation_angle(const double *R) {
  double c = 0.5 * (R[0] + R[4] + R[8] - 1.0);
  return acos(fmax(-1.0, fmin(1.0, c)));
}

// One sample of the monitored quantities (trial.h) at step n.
static int monitor_sample(const ek_sim *sim, const ek_mesh *mesh, monitor_buf *b, long n,
                          ek_trial_monitor *m) {
  size_t nt = ek_mesh_ntets(mesh);
  if (ek_mesh_deformation_gradients_f64(mesh, ek_sim_positions(sim), b->F) != 0 ||
      ek_svd3_f64(nt, b->F, b->U, b->S, b->V, NULL) != 0)
    return -1;
  for (size_t e = 0; e < nt; ++e) {
    const double *s = b->S + 3 * e, *U = b->U + 9 * e, *V = b->V + 9 * e;
    m->min_J = fmin(m->min_J, s[0] * s[1] * s[2]);
    m->min_sigma = fmin(m->min_sigma, s[2]);
    for (int i = 0; i < 3; ++i)
      m->max_strain = fmax(m->max_strain, fabs(s[i] * s[i] - 1.0));
    double R[9];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        R[3 * i + j] =
            U[3 * i] * V[3 * j] + U[3 * i + 1] * V[3 * j + 1] + U[3 * i + 2] * V[3 * j + 2];
    m->max_rotation = fmax(m->max_rotation, rotation_angle(R));
    double *Rp = b->R_prev + 9 * e;
    if (b->prev_step >= 0 && n > b->prev_step) {
      double D[9]; // Rp^T R
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          D[3 * i + j] = Rp[i] * R[j] + Rp[3 + i] * R[3 + j] + Rp[6 + i] * R[6 + j];
      m->max_rotation_step =
          fmax(m->max_rotation_step, rotation_angle(D) / (double)(n - b->prev_step));
    }
    memcpy(Rp, R, sizeof R);
  }
  b->prev_step = n;
  return 0;
}

static int finite_positions(const double *x, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (!isfinite(x[i]))
      return 0;
  return 1;
}

// Smallest det F over the tets of positions x (F in double), +inf with no
// tets; NaN when F cannot be formed.
static double min_det(const ek_mesh *mesh, const double *x, double *F) {
  if (ek_mesh_deformation_gradients_f64(mesh, x, F) != 0)
    return NAN;
  double m = INFINITY;
  for (size_t e = 0, nt = ek_mesh_ntets(mesh); e < nt; ++e) {
    const double *f = F + 9 * e;
    m = fmin(m, f[0] * (f[4] * f[8] - f[5] * f[7]) - f[1] * (f[3] * f[8] - f[5] * f[6]) +
                    f[2] * (f[3] * f[7] - f[4] * f[6]));
  }
  return m;
}

int ek_trial_run(const ek_scene *scene, const ek_mesh *mesh, double sim_time, int monitor,
                 ek_trial *t) {
  return ek_trial_run_frames(scene, mesh, sim_time, monitor, 0, t);
}

int ek_trial_run_frames(const ek_scene *scene, const ek_mesh *mesh, double sim_time, int monitor,
                        int nframes, ek_trial *t) {
  memset(t, 0, sizeof *t);
  t->sim_time = sim_time;
  t->cost_median = t->cost_min = t->energy_start = t->energy_end = t->energy_drift = NAN;
  t->monitor = (ek_trial_monitor){INFINITY, INFINITY, 0, 0, 0};
  if (!(sim_time > 0) || !(scene->dt > 0)) {
    snprintf(t->error, sizeof t->error, "trial: simulated time %g and dt %g must be > 0", sim_time,
             scene->dt);
    return -1;
  }
  ek_scene s = *scene;
  // A trial runs a setting derived from the scene (the advisor's rows, the
  // loop maps), not the file's values: its messages name no place in the
  // file, but the file and the setting run ("FILE (trial model=...;dt=...)",
  // below, once dt is the trial's).
  memset(&s.where, 0, sizeof s.where);
  const int K = nframes > 0 ? nframes : 1;
  double nsteps = (double)K * ceil(sim_time / ((double)K * s.dt) - 1e-9);
  // Checked before the cast to long, which overflows (undefined) for
  // sim_time 1e300 (issue 28: a table of NaN costs, exit 0).
  if (!(nsteps <= (double)EK_TRIAL_MAX_STEPS)) {
    snprintf(t->error, sizeof t->error,
             "trial: simulated time %g at dt %g is %.3g steps, more than %ld", sim_time, s.dt,
             nsteps, EK_TRIAL_MAX_STEPS);
    return -1;
  }
  s.steps = (long)(nsteps < 1 ? 1 : nsteps);
  s.dt = sim_time / (double)s.steps;
  s.output_file[0] = '\0';
  char setting[512];
  ek_trial_setting_text(&s, setting, sizeof setting);
  snprintf(s.path, sizeof s.path, "%.*s (trial %s)", (int)(sizeof s.path - sizeof setting - 16),
           scene->path, setting);
  t->dt = s.dt;
  size_t nv = ek_mesh_nverts(mesh), nt = ek_mesh_ntets(mesh);
  t->nverts = nv;
  double *step_s = malloc((size_t)s.steps * sizeof(double));
  monitor_buf mb = {0};
  mb.prev_step = -1;
  if (monitor) {
    mb.F = malloc(9 * nt * sizeof(double));
    mb.U = malloc(9 * nt * sizeof(double));
    mb.S = malloc(3 * nt * sizeof(double));
    mb.V = malloc(9 * nt * sizeof(double));
    mb.R_prev = malloc(9 * nt * sizeof(double));
  }
  int rc = 0;
  if (nframes > 0) {
    t->frames = malloc((size_t)nframes * 3 * nv * sizeof(double));
    t->frame_t = malloc((size_t)nframes * sizeof(double));
    t->frame_kinel = malloc((size_t)nframes * sizeof(double));
    t->frame_pot = malloc((size_t)nframes * sizeof(double));
    t->frame_min_J = malloc((size_t)nframes * sizeof(double));
    if (!mb.F)
      mb.F = malloc(9 * nt * sizeof(double));
  }
  if (!step_s || (monitor && !(mb.F && mb.U && mb.S && mb.V && mb.R_prev)) ||
      (nframes > 0 &&
       !(t->frames && t->frame_t && t->frame_kinel && t->frame_pot && t->frame_min_J && mb.F))) {
    snprintf(t->error, sizeof t->error, "trial: out of memory for %ld steps, %zu tets", s.steps,
             nt);
    rc = -1;
    goto done;
  }
  char err[512];
  ek_sim *sim = ek_sim_create_errbuf(&s, mesh, err, sizeof err);
  if (!sim) {
    t->failed = 1;
    snprintf(t->error, sizeof t->error, "%s", err);
    goto done;
  }
  ek_sim_energies e;
  ek_sim_energy(sim, &e);
  t->energy_start = e.kinetic + e.elastic + e.potential;
  const double moving_start = e.kinetic + e.elastic;
  t->kinel0 = moving_start;
  t->pot0 = e.potential;
  const long per_frame = s.steps / K;
  const long every =
      s.steps / EK_TRIAL_MONITOR_SAMPLES > 0 ? s.steps / EK_TRIAL_MONITOR_SAMPLES : 1;
  if (monitor && monitor_sample(sim, mesh, &mb, 0, &t->monitor) != 0) {
    snprintf(t->error, sizeof t->error, "trial: monitor: %s", ek_last_error());
    rc = -1;
    ek_sim_destroy(sim);
    goto done;
  }
  for (long n = 0; n < s.steps; ++n) {
    double t0 = trial_now();
    int src = ek_sim_step(sim);
    step_s[n] = trial_now() - t0;
    if (src != 0) {
      t->failed = 1;
      snprintf(t->error, sizeof t->error, "%s", ek_last_error()); // names the step
      break;
    }
    t->steps = n + 1;
    if (nframes > 0 && (n + 1) % per_frame == 0) {
      const double *x = ek_sim_positions(sim);
      if (!finite_positions(x, 3 * nv))
        break; // reported below
      const int k = t->nframes++;
      memcpy(t->frames + 3 * nv * (size_t)k, x, 3 * nv * sizeof(double));
      t->frame_t[k] = (double)(n + 1) * s.dt;
      ek_sim_energy(sim, &e);
      t->frame_kinel[k] = e.kinetic + e.elastic;
      t->frame_pot[k] = e.potential;
      t->frame_min_J[k] = min_det(mesh, x, mb.F);
    }
    if (monitor && ((n + 1) % every == 0 || n + 1 == s.steps)) {
      if (!finite_positions(ek_sim_positions(sim), 3 * nv))
        break; // reported below
      if (monitor_sample(sim, mesh, &mb, n + 1, &t->monitor) != 0) {
        snprintf(t->error, sizeof t->error, "trial: monitor: %s", ek_last_error());
        rc = -1;
        break;
      }
    }
  }
  if (rc == 0 && !t->failed && !finite_positions(ek_sim_positions(sim), 3 * nv)) {
    t->failed = 1;
    snprintf(t->error, sizeof t->error, "non-finite positions after step %ld", t->steps);
  }
  for (long n = 0; n < t->steps; ++n)
    t->wall += step_s[n];
  if (t->steps > 0) {
    qsort(step_s, (size_t)t->steps, sizeof *step_s, compare_double);
    long k = t->steps;
    double median = k % 2 ? step_s[k / 2] : 0.5 * (step_s[k / 2 - 1] + step_s[k / 2]);
    double per_sim_s = (double)s.steps / sim_time;
    t->cost_median = median * per_sim_s;
    t->cost_min = step_s[0] * per_sim_s;
  }
  if (rc == 0 && !t->failed) {
    if (ek_sim_check(sim, &t->health) != 0) {
      snprintf(t->error, sizeof t->error, "trial: state check: %s", ek_last_error());
      rc = -1;
    } else if (t->health.blown_up && !s.allow_nonfinite) {
      t->failed = 1;
      snprintf(t->error, sizeof t->error,
               "the positions blew up after step %ld (vertex %zu %.3g body sizes from the rest "
               "centre, %zu non-finite values)",
               t->steps, t->health.farthest, t->health.extent, t->health.nonfinite);
    }
  }
  if (rc == 0 && !t->failed) {
    ek_sim_energy(sim, &e);
    t->energy_end = e.kinetic + e.elastic + e.potential;
    double scale = fmax(moving_start, e.kinetic + e.elastic);
    t->energy_drift = scale > 0 ? (t->energy_end - t->energy_start) / scale : NAN;
    t->x = malloc(3 * nv * sizeof(double));
    if (!t->x) {
      snprintf(t->error, sizeof t->error, "trial: out of memory for %zu positions", nv);
      rc = -1;
    } else {
      memcpy(t->x, ek_sim_positions(sim), 3 * nv * sizeof(double));
    }
  }
  ek_sim_destroy(sim);
done:
  free(step_s);
  free(mb.F);
  free(mb.U);
  free(mb.S);
  free(mb.V);
  free(mb.R_prev);
  return rc;
}

void ek_trial_free(ek_trial *t) {
  if (!t)
    return;
  free(t->x);
  free(t->frames);
  free(t->frame_t);
  free(t->frame_kinel);
  free(t->frame_pot);
  free(t->frame_min_J);
  t->x = t->frames = t->frame_t = t->frame_kinel = t->frame_pot = t->frame_min_J = NULL;
  t->nframes = 0;
}
