// The scene advisor (advise.h): candidates, their trials, the table, the
// pick.
#include "advise.h"
#include "errbuf.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

// Why a model cannot represent what the reference run reached (NULL: it
// can), from the monitor of trial.h: each model's rule, with its sources,
// is its descriptor's `excluded` (kernels/material/<name>.c); models
// without one are finite for every F (fixed corotated, ARAP, stable
// neo-Hookean: with clamp for inversion, Stomakhin et al. 2012; Smith et
// al. 2018). ARAP and Psi_R also need a scene without a volume term
// (ek_trial_set_model).
static const char *model_excluded(ek_model m, double clamp, const ek_trial_monitor *r, char *why,
                                  size_t len) {
  const ek_model_desc *d = ek_model_describe(m);
  const ek_model_run_stats stats = {r->max_strain, r->max_rotation, r->max_rotation_step,
                                    r->min_sigma, r->min_J};
  return d->excluded ? d->excluded(&stats, clamp, EK_ADVISE_SMALL_STRAIN, why, len) : NULL;
}

typedef struct {
  ek_advice *a;
  size_t cap;
} rows_buf;

// Append a row unless one with the same setting text is there already.
static int add_row(rows_buf *b, const ek_scene *s, const char *skip_reason) {
  ek_advise_row r;
  memset(&r, 0, sizeof r);
  r.setting = *s;
  ek_trial_setting_text(s, r.text, sizeof r.text);
  for (size_t i = 0; i < b->a->n; ++i)
    if (strcmp(b->a->rows[i].text, r.text) == 0)
      return 0;
  if (b->a->n == b->cap) {
    size_t cap = b->cap ? 2 * b->cap : 64;
    ek_advise_row *rows = realloc(b->a->rows, cap * sizeof *rows);
    if (!rows)
      return -1;
    b->a->rows = rows;
    b->cap = cap;
  }
  r.uses_svd = ek_trial_uses_svd(s);
  r.deviation = r.worst_t = r.energy_dev = r.min_J = NAN;
  r.cost = r.cost_lo = r.cost_hi = r.cost_min = NAN;
  if (skip_reason) {
    r.skipped = 1;
    snprintf(r.reason, sizeof r.reason, "%s", skip_reason);
  }
  b->a->rows[b->a->n++] = r;
  return 0;
}

static long row_of(const ek_advice *a, const ek_scene *s) {
  char text[384];
  ek_trial_setting_text(s, text, sizeof text);
  for (size_t i = 0; i < a->n; ++i)
    if (strcmp(a->rows[i].text, text) == 0)
      return (long)i;
  return -1;
}

// The CFL estimate of a setting (ek_sim_cfl_dt) from an explicit sim that
// is built and not stepped.
static double cfl_dt(const ek_scene *s, const ek_mesh *mesh) {
  ek_scene e = *s;
  e.integrator = EK_INTEGRATOR_EXPLICIT;
  e.dt = 1e-30; // below any CFL limit: no warning
  e.output_file[0] = '\0';
  char err[256];
  ek_sim *sim = ek_sim_create_errbuf(&e, mesh, err, sizeof err);
  double dt = sim ? ek_sim_cfl_dt(sim) : NAN;
  ek_sim_destroy(sim);
  return dt;
}

// Append a copy of s with dt = dt (skipped when dt is not > 0).
static int add_dt(rows_buf *b, const ek_scene *s, double dt) {
  if (!(dt > 0) || !isfinite(dt))
    return 0;
  ek_scene v = *s;
  v.dt = dt;
  return add_row(b, &v, NULL);
}

// Copies of the implicit setting s with each assembled linear solver this
// build has (amg, direct: PETSc; advise.h), the matrix-free one being s.
static int add_solvers(rows_buf *b, const ek_scene *s) {
  for (int ls = 0; ls < EK_LINSOLVE_COUNT; ++ls) {
    if (ls == (int)s->implicit.linear_solver || !ek_linear_solver_available((ek_linear_solver)ls))
      continue;
    ek_scene v = *s;
    v.implicit.linear_solver = (ek_linear_solver)ls;
    if (add_row(b, &v, NULL))
      return -1;
  }
  return 0;
}

// The loop knobs a user would try (advise.h), on setting s.
static int add_knobs(rows_buf *b, const ek_scene *s, const ek_mesh *mesh) {
  if (s->integrator == EK_INTEGRATOR_EXPLICIT) {
    static const double f[] = {0.5, 0.9, 1.5, 2, 3};
    const double bound = cfl_dt(s, mesh);
    for (size_t i = 0; i < sizeof f / sizeof f[0]; ++i)
      if (add_dt(b, s, f[i] * bound))
        return -1;
  } else if (s->integrator == EK_INTEGRATOR_IMPLICIT) {
    ek_scene v = *s, w = *s, one = *s;
    v.implicit.newton_tol = 1e-4;
    w.implicit.cg_tol = 1e-2;
    one.implicit.max_newton = 1; // Baraff and Witkin 1998: one linearised solve per step
    if (add_solvers(b, s) || add_row(b, &v, NULL) || add_row(b, &w, NULL) ||
        add_row(b, &one, NULL) || add_dt(b, s, s->dt / 2) || add_dt(b, s, s->dt / 4) ||
        add_dt(b, s, 1.0 / 60) || add_dt(b, s, 1.0 / 120))
      return -1;
  } else {
    static const double fs[] = {0.5, 1, 2, 4}, fi[] = {0.5, 1, 2};
    for (size_t i = 0; i < 4; ++i)
      for (size_t j = 0; j < 3; ++j) {
        ek_scene v = *s;
        v.xpbd.substeps = (long)fmax(1, fmin(100000, floor((double)s->xpbd.substeps * fs[i])));
        v.xpbd.iterations = (long)fmax(1, fmin(100000, floor((double)s->xpbd.iterations * fi[j])));
        if (add_row(b, &v, NULL))
          return -1;
      }
  }
  return 0;
}

// The candidates of one model (advise.h).
static int add_model(rows_buf *b, const ek_scene *scene, const ek_mesh *mesh, ek_model m,
                     const ek_trial_monitor *reach, double sim_time) {
  ek_scene base = *scene;
  char why[400];
  const char *excluded = NULL;
  if (ek_trial_set_model(&base, m, why, sizeof why) != 0)
    excluded = why;
  else
    excluded = model_excluded(m, base.material.clamp, reach, why, sizeof why);
  if (excluded) {
    base.material.model = m;
    snprintf(base.model_name, sizeof base.model_name, "%s", ek_scene_model_name(m));
    return add_row(b, &base, excluded);
  }
  // XPBD has constraints for StVK and stable neo-Hookean only (xpbd.h):
  // another model runs only in the other loops.
  const int own_loop = scene->integrator != EK_INTEGRATOR_XPBD || ek_xpbd_supports(m);
  static const int precisions[] = {64, 32};
  for (int p = 0; p < 2 && own_loop; ++p) {
    ek_scene s = base;
    s.precision = precisions[p];
    if (add_row(b, &s, NULL))
      return -1;
    if (ek_trial_uses_svd(&s)) {
      // McAdams et al. 2011 as published; the cheapest setting.
      const ek_svd3_opts svd[] = {{4, -1, s.svd.isa, EK_SVD3_REFINE_NONE},
                                  {2, -1, s.svd.isa, EK_SVD3_REFINE_NONE}};
      for (int k = 0; k < 2; ++k) {
        ek_scene v = s;
        v.svd = svd[k];
        if (add_row(b, &v, NULL))
          return -1;
      }
    }
    if (m == scene->material.model) {
      if (add_knobs(b, &s, mesh))
        return -1;
    } else if (s.integrator == EK_INTEGRATOR_EXPLICIT) {
      // The model's own stability bound (its Lame parameters differ).
      const double bound = cfl_dt(&s, mesh);
      if (add_dt(b, &s, 0.5 * bound) || add_dt(b, &s, 0.9 * bound))
        return -1;
    }
  }
  // The other loops, the scene's precision, their default knobs (those of
  // a scene that names none: parsed once).
  static const char defaults_text[] =
      "{\"mesh\": {\"box\": [1, 1, 1], \"size\": [1, 1, 1]}, \"material\": {\"model\": "
      "\"stvk\", \"E\": 1, \"nu\": 0, \"density\": 1}, \"dt\": 1, \"steps\": 1}";
  ek_scene defaults;
  char err[256];
  if (ek_scene_parse_errbuf(defaults_text, "defaults", NULL, &defaults, err, sizeof err) != 0)
    return -1;
  const double frame_dt = fmax(scene->dt, fmin(1.0 / 60, sim_time / 5));
  for (int L = 0; L < EK_INTEGRATOR_COUNT; ++L) {
    if (L == (int)scene->integrator || (L == EK_INTEGRATOR_XPBD && !ek_xpbd_supports(m)))
      continue;
    ek_scene v = base;
    v.integrator = (ek_integrator_type)L;
    v.implicit = defaults.implicit;
    v.xpbd = defaults.xpbd;
    if (L == EK_INTEGRATOR_EXPLICIT) {
      const double bound = cfl_dt(&v, mesh);
      if (add_dt(b, &v, 0.5 * bound) || add_dt(b, &v, 0.9 * bound))
        return -1;
    } else if (L == EK_INTEGRATOR_IMPLICIT) {
      if (add_dt(b, &v, frame_dt) || add_dt(b, &v, 1.0 / 240))
        return -1;
      // The scene's model also with each assembled solver, at the frame
      // step (where the implicit loop is cheapest).
      if (m == scene->material.model && frame_dt > 0 && isfinite(frame_dt)) {
        ek_scene w = v;
        w.dt = frame_dt;
        if (add_solvers(b, &w))
          return -1;
      }
    } else {
      ek_scene w = v;
      w.dt = frame_dt;
      w.xpbd.substeps = v.xpbd.substeps * 4;
      if (add_dt(b, &v, frame_dt) || add_row(b, &w, NULL))
        return -1;
    }
  }
  return 0;
}

void ek_advise_measure_trial(const ek_mesh *mesh, const ek_trial *c, const ek_trial *ref,
                             int allow_inverted, ek_advise_measure *m) {
  memset(m, 0, sizeof *m);
  m->deviation = m->worst_t = m->energy_dev = m->min_J = m->motion = NAN;
  m->worst_frame = -1;
  const size_t nv = ek_mesh_nverts(mesh);
  const double *X = ek_mesh_rest_positions(mesh);
  const double L = ek_trial_body_size(mesh);
  if (c->failed) {
    m->failed = 1;
    snprintf(m->reason, sizeof m->reason, "%s", c->error);
    return;
  }
  if (c->nframes != ref->nframes || c->nframes <= 0) {
    m->failed = 1;
    snprintf(m->reason, sizeof m->reason, "%d frames against the reference's %d", c->nframes,
             ref->nframes);
    return;
  }
  const int K = c->nframes;
  // The scales: the reference's largest displacement, its smallest J and
  // its energy scale.
  double ref_motion = 0, ref_min_J = INFINITY, escale = ref->kinel0;
  for (int k = 0; k < K; ++k) {
    const double *xr = ref->frames + 3 * nv * (size_t)k;
    for (size_t i = 0; i < nv; ++i) {
      double d2 = 0;
      for (int j = 0; j < 3; ++j)
        d2 += (xr[3 * i + j] - X[3 * i + j]) * (xr[3 * i + j] - X[3 * i + j]);
      ref_motion = fmax(ref_motion, d2);
    }
    ref_min_J = fmin(ref_min_J, ref->frame_min_J[k]);
    escale = fmax(escale, ref->frame_kinel[k] + fabs(ref->frame_pot[k] - ref->pot0));
  }
  ref_motion = sqrt(ref_motion);
  const double scale = ref_motion > 0 ? fmin(L, ref_motion) : L;
  double worst = 0, motion = 0, edev = 0, min_J = INFINITY;
  int worst_k = 0, min_J_k = 0, edev_k = 0;
  for (int k = 0; k < K; ++k) {
    const double *x = c->frames + 3 * nv * (size_t)k, *xr = ref->frames + 3 * nv * (size_t)k;
    double d2max = 0;
    for (size_t i = 0; i < nv; ++i) {
      double d2 = 0, m2 = 0;
      for (int j = 0; j < 3; ++j) {
        d2 += (x[3 * i + j] - xr[3 * i + j]) * (x[3 * i + j] - xr[3 * i + j]);
        m2 += (x[3 * i + j] - X[3 * i + j]) * (x[3 * i + j] - X[3 * i + j]);
      }
      d2max = fmax(d2max, d2);
      motion = fmax(motion, m2);
    }
    if (!(d2max <= INFINITY)) {
      m->failed = 1;
      snprintf(m->reason, sizeof m->reason, "non-finite positions at t = %g", c->frame_t[k]);
      return;
    }
    if (d2max > worst * worst) {
      worst = sqrt(d2max);
      worst_k = k;
    }
    if (c->frame_min_J[k] < min_J) {
      min_J = c->frame_min_J[k];
      min_J_k = k;
    }
    const double de =
        fabs(c->frame_kinel[k] + c->frame_pot[k] - ref->frame_kinel[k] - ref->frame_pot[k]);
    if (escale > 0 && de / escale > edev) {
      edev = de / escale;
      edev_k = k;
    }
  }
  m->deviation = worst / scale;
  m->worst_frame = worst_k;
  m->worst_t = c->frame_t[worst_k];
  m->energy_dev = edev;
  m->min_J = min_J;
  m->motion = sqrt(motion) / L;
  const double flat = EK_ADVISE_FLAT_J * fmin(1.0, ref_min_J);
  if (!allow_inverted && !(min_J > 0)) {
    m->failed = 1;
    snprintf(m->reason, sizeof m->reason,
             "inverted: smallest J %.3g (<= 0) at t = %g (the scene's allow.inverted is not set)",
             min_J, c->frame_t[min_J_k]);
  } else if (!allow_inverted && ref_min_J > 0 && min_J < flat) {
    m->failed = 1;
    snprintf(m->reason, sizeof m->reason,
             "flattened: smallest J %.3g at t = %g, below %g x the reference's %.3g", min_J,
             c->frame_t[min_J_k], EK_ADVISE_FLAT_J, ref_min_J);
  } else if (sqrt(motion) > EK_ADVISE_RUNAWAY * ref_motion + L) {
    m->failed = 1;
    snprintf(m->reason, sizeof m->reason,
             "runs away: a vertex %.3g body sizes from rest (the reference's largest "
             "displacement: %.3g)",
             sqrt(motion) / L, ref_motion / L);
  } else if (edev > EK_ADVISE_ENERGY_MAX) {
    m->failed = 1;
    snprintf(m->reason, sizeof m->reason,
             "energy: at t = %g the total energy differs from the reference's by %.3g of its "
             "scale (%.3g J; bound %g)",
             c->frame_t[edev_k], edev, escale, EK_ADVISE_ENERGY_MAX);
  }
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

long ek_advice_pick(const ek_advice *a, double tol) {
  long cheapest = -1;
  for (size_t i = 0; i < a->n; ++i) {
    const ek_advise_row *r = &a->rows[i];
    if (r->skipped || r->failed || !(r->deviation <= tol) ||
        (i == a->reference && a->refine.extrapolated))
      continue;
    if (cheapest < 0 || r->cost < a->rows[cheapest].cost)
      cheapest = (long)i;
  }
  if (cheapest < 0)
    return -1;
  // Tied: the passing rows whose interval overlaps the cheapest's.
  const ek_advise_row *c = &a->rows[cheapest];
  long best = cheapest;
  for (size_t i = 0; i < a->n; ++i) {
    const ek_advise_row *r = &a->rows[i], *b = &a->rows[best];
    if (r->skipped || r->failed || !(r->deviation <= tol) || !(r->cost_lo <= c->cost_hi) ||
        (i == a->reference && a->refine.extrapolated))
      continue;
    if (r->deviation < b->deviation || (r->deviation == b->deviation && r->cost < b->cost))
      best = (long)i;
  }
  return best;
}

// The number of common frames: the largest divisor <= EK_ADVISE_MAX_FRAMES
// of N = the steps of the coarsest candidate, so that its steps stay its
// own (N itself up to the cap when N has no divisor at least half that).
static int frame_count(const ek_advice *a, double sim_time) {
  double dt = 0;
  for (size_t i = 0; i < a->n; ++i)
    if (!a->rows[i].skipped)
      dt = fmax(dt, a->rows[i].setting.dt);
  long N = dt > 0 ? (long)floor(sim_time / dt + 1e-6) : 1;
  if (N < 1)
    N = 1;
  const long cap = N < EK_ADVISE_MAX_FRAMES ? N : EK_ADVISE_MAX_FRAMES;
  long K = 1;
  for (long d = cap; d >= 1; --d)
    if (N % d == 0) {
      K = d;
      break;
    }
  return (int)(2 * K < cap ? cap : K);
}

// Richardson's extrapolation of two runs at dt and dt / 2 of a first-order
// method (symplectic Euler: the error is c dt + O(dt^2)): 2 x_fine -
// x_coarse, per frame, for the positions and the energies; J and the
// rest from the fine run. 0, or -1 (out of memory).
static int extrapolate(const ek_trial *fine, const ek_trial *coarse, size_t nv, ek_trial *e) {
  *e = *fine;
  e->x = NULL;
  const size_t K = (size_t)fine->nframes, n = K * 3 * nv;
  e->frames = malloc(n * sizeof(double));
  e->frame_t = malloc(K * sizeof(double));
  e->frame_kinel = malloc(K * sizeof(double));
  e->frame_pot = malloc(K * sizeof(double));
  e->frame_min_J = malloc(K * sizeof(double));
  if (!e->frames || !e->frame_t || !e->frame_kinel || !e->frame_pot || !e->frame_min_J) {
    ek_trial_free(e);
    return -1;
  }
  for (size_t i = 0; i < n; ++i)
    e->frames[i] = 2 * fine->frames[i] - coarse->frames[i];
  for (size_t k = 0; k < K; ++k) {
    e->frame_t[k] = fine->frame_t[k];
    e->frame_kinel[k] = 2 * fine->frame_kinel[k] - coarse->frame_kinel[k];
    e->frame_pot[k] = 2 * fine->frame_pot[k] - coarse->frame_pot[k];
    e->frame_min_J[k] = fine->frame_min_J[k];
  }
  e->cost_median = fine->cost_median + coarse->cost_median;
  e->cost_min = fine->cost_min + coarse->cost_min;
  return 0;
}

// The converged reference (advise.h): runs[0 .. f->runs) the refinement's
// runs (kept for the table's ladder rows), *ref the reference (the last
// run, or the extrapolation of the last two). 0, or < 0 (err; runs freed).
static int refine_reference(const ek_scene *scene, const ek_mesh *mesh, const ek_advise_opts *o,
                            double budget, ek_advice *a, ek_scene *rs, ek_trial *runs,
                            ek_trial *ref, char *err, size_t errlen) {
  ek_advise_refinement *f = &a->refine;
  const size_t nv = ek_mesh_nverts(mesh);
  ek_scene s = *scene;
  s.integrator = EK_INTEGRATOR_EXPLICIT;
  s.precision = 64;
  s.svd = (ek_svd3_opts){0, 0, scene->svd.isa, 0};
  s.polar = EK_POLAR_SVD;
  const double bound = cfl_dt(&s, mesh);
  double dt = 0.5 * bound;
  if (scene->integrator == EK_INTEGRATOR_EXPLICIT)
    dt = fmin(dt, scene->dt);
  if (!(dt > 0) || !isfinite(dt)) {
    snprintf(err, errlen, "%s: no stability bound for the reference (%g)", scene->path, bound);
    return EK_EINVAL;
  }
  // A reference the scene states (scene.h, "advise"): one run, trusted.
  const int trusted = scene->advise_reference_dt > 0;
  if (trusted)
    dt = scene->advise_reference_dt;
  ek_trial ext[EK_ADVISE_MAX_REFINE + 1];
  memset(ext, 0, sizeof ext);
  memset(ref, 0, sizeof *ref);
  double spent = 0;
  const double target = a->tol / 10;
  int best = -1, best_ext = 0, k = 0;
  for (k = 0; k <= EK_ADVISE_MAX_REFINE; ++k) {
    s.dt = dt;
    if (o->progress)
      fprintf(o->progress, "advise: reference run %d, explicit f64 at dt %.4g\n", k + 1, dt);
    ek_trial *t = &runs[k];
    f->runs = k + 1;
    if (ek_trial_run_frames(&s, mesh, a->sim_time, 1, a->nframes, t) != 0) {
      snprintf(err, errlen, "advise: reference: %s", t->error);
      goto fail;
    }
    f->dt[k] = t->dt;
    f->wall[k] = t->wall;
    f->change[k] = f->ext_change[k] = NAN;
    spent += t->wall;
    const int ok = !t->failed && t->nframes == a->nframes;
    if (ok) {
      best = k;
      best_ext = 0;
    }
    if (ok && k > 0 && !runs[k - 1].failed && runs[k - 1].nframes == a->nframes) {
      ek_advise_measure m;
      ek_advise_measure_trial(mesh, &runs[k - 1], t, 1, &m);
      f->change[k] = m.deviation;
      if (extrapolate(t, &runs[k - 1], nv, &ext[k]) != 0) {
        snprintf(err, errlen, "advise: out of memory");
        goto fail;
      }
      if (k > 1 && ext[k - 1].frames) {
        ek_advise_measure_trial(mesh, &ext[k - 1], &ext[k], 1, &m);
        f->ext_change[k] = m.deviation;
      }
    }
    if (trusted) {
      f->converged = ok;
      snprintf(f->stop, sizeof f->stop,
               "trusted: the scene's advise.reference_dt %g (not refined here)", dt);
      break;
    }
    if (ok && f->change[k] <= target) {
      f->converged = 1;
      snprintf(f->stop, sizeof f->stop, "converged: change %.3g <= tol / 10 = %.3g", f->change[k],
               target);
      break;
    }
    if (ok && f->ext_change[k] <= target) {
      f->converged = 1;
      best_ext = 1;
      snprintf(f->stop, sizeof f->stop,
               "converged: the extrapolations 2 x_k - x_(k-1) of runs %d and %d change by %.3g "
               "<= tol / 10 = %.3g; the reference is the last extrapolation",
               k, k + 1, f->ext_change[k], target);
      break;
    }
    if (k == EK_ADVISE_MAX_REFINE) {
      snprintf(f->stop, sizeof f->stop, "NOT converged: %d halvings (the cap)",
               EK_ADVISE_MAX_REFINE);
      break;
    }
    if (spent + 2.2 * t->wall > budget && k > 0) {
      snprintf(f->stop, sizeof f->stop,
               "NOT converged: the next run (~%.3g s) would pass the %g s budget", 2 * f->wall[k],
               budget);
      break;
    }
    dt /= 2;
  }
  if (best < 0) {
    // A reference step the scene states: named at its place in the file.
    char where[EK_SCENE_AT_MAX], why[sizeof runs[0].error];
    ek_advise_reason_text(runs[f->runs - 1].error, why, sizeof why); // the setting named once
    snprintf(err, errlen, "%s: the reference (explicit f64, dt %g) failed: %s",
             ek_scene_at(scene, trusted ? scene->where.reference_dt : (ek_scene_pos){0, 0}, where,
                         sizeof where),
             f->dt[f->runs - 1], why);
    goto fail;
  }
  f->extrapolated = best_ext;
  *rs = s;
  rs->dt = f->dt[best];
  if (best_ext) {
    *ref = ext[best];
    ext[best].frames = NULL; // moved
    memset(&ext[best], 0, sizeof ext[best]);
  } else {
    // A copy of the run's frames (the run stays a ladder row).
    if (extrapolate(&runs[best], &runs[best], nv, ref) != 0) {
      snprintf(err, errlen, "advise: out of memory");
      goto fail;
    }
    ref->cost_median = runs[best].cost_median;
    ref->cost_min = runs[best].cost_min;
  }
  for (int j = 0; j <= EK_ADVISE_MAX_REFINE; ++j)
    ek_trial_free(&ext[j]);
  return 0;
fail:
  for (int j = 0; j <= EK_ADVISE_MAX_REFINE; ++j) {
    ek_trial_free(&ext[j]);
    ek_trial_free(&runs[j]);
  }
  return err[0] && strstr(err, "memory") ? EK_ENOMEM : EK_EINVAL;
}

int ek_advise(const ek_scene *scene, const ek_mesh *mesh, const ek_advise_opts *o, ek_advice *a,
              char *err, size_t errlen) {
  memset(a, 0, sizeof *a);
  a->scene_row = a->pick = -1;
  if (scene->triangles || !mesh) {
    char where[EK_SCENE_AT_MAX];
    snprintf(err, errlen, "%s: mesh: the advisor takes tet scenes only",
             ek_scene_at(scene, scene->where.mesh, where, sizeof where));
    return EK_EINVAL;
  }
  if (!(o->tol >= 0 && o->tol < 1) || !(o->sim_time > 0)) {
    snprintf(err, errlen,
             "advise: tol %g must be in [0, 1) (holding still deviates by 1) and the simulated "
             "time %g > 0",
             o->tol, o->sim_time);
    return EK_EINVAL;
  }
  // At least one step of the scene's dt: a shorter time runs one step of
  // that length, judging each candidate at a dt it does not use (issue 28:
  // --time 1e-300 ran one step of 1e-300 s and priced candidates at 1e294 s
  // per simulated second). At most EK_TRIAL_MAX_STEPS steps.
  if (o->sim_time < scene->dt || o->sim_time / scene->dt > (double)EK_TRIAL_MAX_STEPS) {
    snprintf(err, errlen,
             "advise: simulated time %g must be between the scene's dt %g (one step) and %ld "
             "steps of it (%g s)",
             o->sim_time, scene->dt, EK_TRIAL_MAX_STEPS, scene->dt * (double)EK_TRIAL_MAX_STEPS);
    return EK_EINVAL;
  }
  const int rounds = o->rounds > 0 ? o->rounds : EK_ADVISE_ROUNDS;
  const double budget = o->ref_budget > 0 ? o->ref_budget : EK_ADVISE_REF_BUDGET;
  a->tol = o->tol;
  a->sim_time = o->sim_time;
  a->body_size = ek_trial_body_size(mesh);
  a->threads = omp_get_max_threads();
  rows_buf b = {a, 0};

  // The reference's row first (its dt set below), then the scene's own
  // setting and every model's candidates (the reach of a first, coarse
  // run decides which models are valid; the refined reference's reach is
  // the one reported).
  ek_scene rs = *scene;
  rs.integrator = EK_INTEGRATOR_EXPLICIT;
  rs.precision = 64;
  rs.dt = 0; // a placeholder text, unlike every candidate's
  if (add_row(&b, &rs, NULL) != 0)
    goto oom;
  ek_trial rt, runs[EK_ADVISE_MAX_REFINE + 1];
  memset(&rt, 0, sizeof rt);
  memset(runs, 0, sizeof runs);
  {
    // A monitor run of the scene's own setting for the models' validity.
    if (o->progress)
      fprintf(o->progress,
              "advise: the scene's setting, %g s simulated (monitoring J, strain, rotation)\n",
              o->sim_time);
    ek_trial mt;
    if (ek_trial_run(scene, mesh, o->sim_time, 1, &mt) != 0) {
      snprintf(err, errlen, "advise: %s", mt.error);
      ek_trial_free(&mt);
      ek_advice_free(a);
      return EK_ENOMEM;
    }
    a->reach = mt.monitor;
    ek_trial_free(&mt);
  }
  if (add_row(&b, scene, NULL) != 0)
    goto oom;
  if (add_model(&b, scene, mesh, scene->material.model, &a->reach, o->sim_time))
    goto oom;
  for (int m = 0; m < EK_MODEL_COUNT; ++m)
    if (m != (int)scene->material.model &&
        add_model(&b, scene, mesh, (ek_model)m, &a->reach, o->sim_time))
      goto oom;
  a->nframes = frame_count(a, o->sim_time);
  {
    int rc = refine_reference(scene, mesh, o, budget, a, &rs, runs, &rt, err, errlen);
    if (rc != 0) {
      ek_advice_free(a);
      return rc;
    }
  }
  a->reference_inverted = scene->allow_inverted ? 0 : rt.health.inverted;
  {
    ek_advise_row *r0 = &a->rows[0];
    r0->setting = rs;
    ek_trial_setting_text(&rs, r0->text, sizeof r0->text);
    r0->uses_svd = ek_trial_uses_svd(&rs);
    ek_advise_measure m;
    ek_advise_measure_trial(mesh, &rt, &rt, 1, &m);
    r0->deviation = 0;
    r0->worst_t = m.worst_t;
    r0->energy_dev = 0;
    r0->min_J = m.min_J;
    r0->cost = r0->cost_lo = r0->cost_hi = rt.cost_median;
    r0->cost_min = rt.cost_min;
    r0->rounds = 1;
    r0->steps = rt.steps;
    if (rt.health.inverted > 0 && !scene->allow_inverted) {
      r0->failed = 1; // the rows are still measured against it
      snprintf(r0->reason, sizeof r0->reason, "ends with %zu of %zu tets inverted (J <= 0)",
               rt.health.inverted, rt.health.elements);
    }
    // The position scale of the deviation (advise.h).
    const size_t nv = ek_mesh_nverts(mesh);
    const double *X = ek_mesh_rest_positions(mesh);
    double mo = 0;
    for (int k = 0; k < rt.nframes; ++k)
      for (size_t i = 0; i < nv; ++i) {
        const double *x = rt.frames + 3 * nv * (size_t)k + 3 * i;
        mo = fmax(mo, sqrt((x[0] - X[3 * i]) * (x[0] - X[3 * i]) +
                           (x[1] - X[3 * i + 1]) * (x[1] - X[3 * i + 1]) +
                           (x[2] - X[3 * i + 2]) * (x[2] - X[3 * i + 2])));
      }
    a->motion = mo;
    a->scale = mo > 0 ? fmin(a->body_size, mo) : a->body_size;
  }
  // A candidate with the reference's own setting text is the reference.
  for (size_t i = 1; i < a->n; ++i)
    if (!a->refine.extrapolated && strcmp(a->rows[i].text, a->rows[0].text) == 0) {
      a->rows[i].skipped = 1;
      snprintf(a->rows[i].reason, sizeof a->rows[i].reason, "the reference (#1)");
    }
  if (a->refine.extrapolated) {
    char text[sizeof a->rows[0].text];
    snprintf(text, sizeof text, "Richardson 2 x(dt) - x(2 dt) of %.300s", a->rows[0].text);
    snprintf(a->rows[0].text, sizeof a->rows[0].text, "%s", text);
  }
  // The refinement's runs (advise.h), measured already.
  for (int j = 0; j < a->refine.runs; ++j) {
    ek_scene v = rs;
    v.dt = a->refine.dt[j];
    if ((!a->refine.extrapolated && v.dt == rs.dt) || !runs[j].frames)
      continue; // row 1 itself, or a run that failed before its frames
    if (add_row(&b, &v, NULL) != 0) {
      for (int q = 0; q <= EK_ADVISE_MAX_REFINE; ++q)
        ek_trial_free(&runs[q]);
      goto oom_rt;
    }
    ek_advise_row *r = &a->rows[row_of(a, &v)];
    ek_advise_measure m;
    ek_advise_measure_trial(mesh, &runs[j], &rt, scene->allow_inverted, &m);
    r->skipped = 0;
    r->ladder = 1;
    r->failed = m.failed;
    snprintf(r->reason, sizeof r->reason, "%s", m.failed ? m.reason : "");
    r->deviation = m.deviation;
    r->worst_t = m.worst_t;
    r->energy_dev = m.energy_dev;
    r->min_J = m.min_J;
    r->cost = r->cost_lo = r->cost_hi = runs[j].cost_median;
    r->cost_min = runs[j].cost_min;
    r->rounds = 1;
    r->steps = runs[j].steps;
  }
  // The step the tolerance needs: the explicit error is first order, so
  // the finest run's deviation e at dt predicts dt tol / e; candidates at
  // 0.7 of that, in f64 and f32, when the finest run misses tol (at most
  // 64 x its steps).
  {
    const int last = a->refine.runs - 1;
    ek_advise_measure m;
    memset(&m, 0, sizeof m);
    m.deviation = NAN;
    if (runs[last].frames)
      ek_advise_measure_trial(mesh, &runs[last], &rt, 1, &m);
    const double dt_last = a->refine.dt[last],
                 dt_need = m.deviation > 0 ? 0.7 * dt_last * a->tol / m.deviation : NAN;
    if (m.deviation > a->tol && dt_need >= dt_last / 64) {
      for (int p = 0; p < 2; ++p) {
        ek_scene v = rs;
        v.precision = p ? 32 : 64;
        v.dt = dt_need;
        if (add_row(&b, &v, NULL) != 0) {
          for (int q = 0; q <= EK_ADVISE_MAX_REFINE; ++q)
            ek_trial_free(&runs[q]);
          goto oom_rt;
        }
      }
    }
  }
  for (int q = 0; q <= EK_ADVISE_MAX_REFINE; ++q)
    ek_trial_free(&runs[q]);
  a->scene_row = row_of(a, scene);

  size_t nrun = 0, k = 0;
  for (size_t i = 1; i < a->n; ++i)
    nrun += !a->rows[i].skipped && !a->rows[i].ladder;
  double *costs = malloc((size_t)rounds * a->n * sizeof(double));
  if (!costs)
    goto oom_rt;
  for (size_t i = 1; i < a->n; ++i) {
    ek_advise_row *r = &a->rows[i];
    if (r->ladder)
      costs[i * (size_t)rounds] = r->cost;
    if (r->skipped || r->ladder)
      continue;
    if (o->progress)
      fprintf(o->progress, "advise: candidate %zu of %zu: %s\n", ++k, nrun, r->text);
    ek_trial t;
    if (ek_trial_run_frames(&r->setting, mesh, o->sim_time, 0, a->nframes, &t) != 0) {
      snprintf(err, errlen, "advise: %s", t.error);
      ek_trial_free(&t);
      goto trial_failed;
    }
    ek_advise_measure m;
    ek_advise_measure_trial(mesh, &t, &rt, scene->allow_inverted, &m);
    // The dt that ran (a whole number of steps per frame).
    if (t.dt > 0 && t.steps > 0) {
      r->setting.dt = t.dt;
      ek_trial_setting_text(&r->setting, r->text, sizeof r->text);
    }
    r->failed = m.failed;
    if (m.failed)
      snprintf(r->reason, sizeof r->reason, "%s", m.reason);
    r->deviation = m.deviation;
    r->worst_t = m.worst_t;
    r->energy_dev = m.energy_dev;
    r->min_J = m.min_J;
    r->cost = r->cost_lo = r->cost_hi = t.cost_median;
    r->cost_min = t.cost_min;
    r->rounds = 1;
    costs[i * (size_t)rounds] = t.cost_median;
    r->steps = t.steps;
    ek_trial_free(&t);
  }
  costs[0] = rt.cost_median;
  // Timing rounds 2.. of the rows within tol, interleaved (advise.h).
  for (int q = 1; q < rounds; ++q) {
    for (size_t j = 0; j < a->n; ++j) {
      const size_t i = q % 2 ? a->n - 1 - j : j;
      ek_advise_row *r = &a->rows[i];
      if (r->skipped || r->failed || !(r->deviation <= a->tol) ||
          (i == a->reference && a->refine.extrapolated))
        continue;
      if (o->progress)
        fprintf(o->progress, "advise: timing round %d of %d: #%zu\n", q + 1, rounds, i + 1);
      ek_trial t;
      if (ek_trial_run(&r->setting, mesh, o->sim_time, 0, &t) != 0) {
        snprintf(err, errlen, "advise: %s", t.error);
        ek_trial_free(&t);
        goto trial_failed;
      }
      if (!t.failed)
        costs[i * (size_t)rounds + (size_t)r->rounds++] = t.cost_median;
      ek_trial_free(&t);
    }
  }
  for (size_t i = 0; i < a->n; ++i) {
    ek_advise_row *r = &a->rows[i];
    if (r->skipped || r->rounds < 2)
      continue;
    double *c = costs + i * (size_t)rounds;
    qsort(c, (size_t)r->rounds, sizeof *c, compare_double);
    const int n = r->rounds;
    r->cost = n % 2 ? c[n / 2] : 0.5 * (c[n / 2 - 1] + c[n / 2]);
    r->cost_lo = c[0];
    r->cost_hi = c[n - 1];
  }
  free(costs);
  a->ref = rt; // ek_advice_free frees it
  a->pick = ek_advice_pick(a, o->tol);
  return 0;
trial_failed: // err holds the trial's message
  free(costs);
  ek_trial_free(&rt);
  ek_advice_free(a);
  return EK_ENOMEM;
oom_rt:
  ek_trial_free(&rt);
oom:
  ek_advice_free(a);
  snprintf(err, errlen, "advise: out of memory");
  return EK_ENOMEM;
}

void ek_advise_reason_text(const char *reason, char *out, size_t n) {
  const char *p = strstr(reason, " (trial ");
  const char *q = p ? strchr(p, ')') : NULL; // a setting's text has no parenthesis
  if (q)
    snprintf(out, n, "%.*s%s", (int)(p - reason), reason, q + 1);
  else
    snprintf(out, n, "%s", reason);
}

void ek_advice_print(const ek_advice *a, FILE *out) {
  const ek_trial_monitor *m = &a->reach;
  const ek_advise_refinement *f = &a->refine;
  fprintf(out,
          "advise     %g s simulated per candidate, %d frames compared, tol %g, %d threads\n"
          "metric     deviation = worst frame's largest vertex distance from the reference / "
          "%.4g m (min of the body size %.4g m and the reference's largest displacement %.4g "
          "m; holding still deviates by >= 1)\n"
          "checks     FAILURE for: a failed run (error, NaN/inf, blow-up), J <= 0 at a frame, "
          "J < %g x min(1, the reference's smallest J), a vertex further from rest than %g x "
          "the reference's largest displacement + 1 body size, total energy off the "
          "reference's by > %g of its scale at a frame\n",
          a->sim_time, a->nframes, a->tol, a->threads, a->scale, a->body_size, a->motion,
          EK_ADVISE_FLAT_J, EK_ADVISE_RUNAWAY, EK_ADVISE_ENERGY_MAX);
  {
    // The solver axis (issue 24): which linear solvers the implicit
    // candidates use, and the ones this build cannot run.
    int implicit_rows = 0;
    for (size_t i = 0; i < a->n; ++i)
      implicit_rows += a->rows[i].setting.integrator == EK_INTEGRATOR_IMPLICIT;
    char have[128] = "", lack[128] = "";
    size_t nh = 0, nl = 0;
    for (int ls = 0; ls < EK_LINSOLVE_COUNT; ++ls) {
      const int ok = ek_linear_solver_available((ek_linear_solver)ls);
      char *buf = ok ? have : lack;
      size_t *n = ok ? &nh : &nl;
      int w = snprintf(buf + *n, sizeof have - *n, "%s%s", *n ? ", " : "",
                       ek_linear_solver_name((ek_linear_solver)ls));
      if (w > 0 && (size_t)w < sizeof have - *n)
        *n += (size_t)w;
    }
    if (implicit_rows)
      fprintf(out, "solvers    the implicit candidates' linear solvers: %s%s%s%s\n", have,
              nl ? "; skipped: " : "", lack, nl ? " (need PETSc; this build has none)" : "");
  }
  fprintf(out,
          "reference  %s, dt halved until two runs (or their extrapolations 2 x_k - x_(k-1)) "
          "differ by <= tol / 10:\n",
          a->rows[0].text);
  for (int k = 0; k < f->runs; ++k) {
    fprintf(out, "             run %d: dt %.4g, %.3g s wall", k + 1, f->dt[k], f->wall[k]);
    if (!isnan(f->change[k]))
      fprintf(out, ", change from run %d: %.3e", k, f->change[k]);
    if (!isnan(f->ext_change[k]))
      fprintf(out, ", extrapolation 2 x_%d - x_%d changes by %.3e", k + 1, k, f->ext_change[k]);
    fprintf(out, "\n");
  }
  fprintf(out, "             %s\n", f->stop);
  fprintf(out,
          "reached    (the scene's setting) min J %.4g, min sigma %.4g, max |F^T F - I| %.3g, max "
          "rotation %.3g rad, max rotation per step %.3g rad\n",
          m->min_J, m->min_sigma, m->max_strain, m->max_rotation, m->max_rotation_step);
  if (a->reference_inverted > 0)
    fprintf(out,
            "inverted   the reference run ends with %zu tets inverted (J <= 0): it and every "
            "setting that does so fail (the scene's allow.inverted is not set)\n",
            a->reference_inverted);
  fprintf(out, "%4s  %-10s  %-7s  %-8s  %-8s  %-30s  %-4s  %-9s  %s\n", "#", "deviation", "at t",
          "energy", "min J", "cost s/sim-s median [min max] n", "svd", "verdict", "setting");
  long cheapest = -1;
  if (a->pick >= 0)
    for (size_t i = 0; i < a->n; ++i) {
      const ek_advise_row *r = &a->rows[i];
      if (!r->skipped && !r->failed && r->deviation <= a->tol &&
          !(i == a->reference && a->refine.extrapolated) &&
          (cheapest < 0 || r->cost < a->rows[cheapest].cost))
        cheapest = (long)i;
    }
  for (size_t i = 0; i < a->n; ++i) {
    const ek_advise_row *r = &a->rows[i];
    const int within = !r->skipped && !r->failed && r->deviation <= a->tol;
    const char *verdict = r->skipped                                                 ? "skipped"
                          : r->failed                                                ? "FAILURE"
                          : (long)i == a->pick                                       ? "PICK"
                          : i == a->reference                                        ? "reference"
                          : !within                                                  ? "over tol"
                          : cheapest >= 0 && r->cost_lo <= a->rows[cheapest].cost_hi ? "tied"
                                                                                     : "within";
    char dev[32] = "-", at[32] = "-", en[32] = "-", mj[32] = "-", cost[64] = "-";
    if (!r->skipped && !isnan(r->deviation)) {
      snprintf(dev, sizeof dev, "%.3e", r->deviation);
      if (i != a->reference)
        snprintf(at, sizeof at, "%.4g", r->worst_t);
      snprintf(en, sizeof en, "%.2e", r->energy_dev);
      snprintf(mj, sizeof mj, "%.4g", r->min_J);
    }
    if (!r->skipped && !isnan(r->cost))
      snprintf(cost, sizeof cost, "%.4g [%.4g %.4g] %d", r->cost, r->cost_lo, r->cost_hi,
               r->rounds);
    char reason[sizeof r->reason];
    ek_advise_reason_text(r->reason, reason, sizeof reason);
    fprintf(out, "%4zu  %-10s  %-7s  %-8s  %-8s  %-30s  %-4s  %-9s  %s%s%s%s%s\n", i + 1, dev, at,
            en, mj, cost,
            r->skipped    ? "-"
            : r->uses_svd ? "yes"
                          : "no",
            verdict, r->text, i == a->reference ? " (reference)" : "",
            (long)i == a->scene_row ? " (the scene's)" : "", r->skipped || r->failed ? ": " : "",
            r->skipped || r->failed ? reason : "");
  }
  fprintf(out, "rule       among the rows within tol with no failed check, the cheapest median "
               "cost; rows whose [min max] overlaps it are tied; of the tied the smallest "
               "deviation, then the cheaper median, then the earlier row\n");
  if (a->pick < 0) {
    fprintf(out, "pick       none within tol %g\n", a->tol);
    return;
  }
  const ek_advise_row *p = &a->rows[a->pick];
  fprintf(out, "pick       #%ld %s: deviation %.3e <= %g at %.4g s per simulated s", a->pick + 1,
          p->text, p->deviation, a->tol, p->cost);
  if (a->scene_row >= 0 && a->rows[a->scene_row].cost > 0 && !a->rows[a->scene_row].failed &&
      !a->rows[a->scene_row].skipped)
    fprintf(out, " (%.2fx the scene's own setting, #%ld)", p->cost / a->rows[a->scene_row].cost,
            a->scene_row + 1);
  fprintf(out, "\n");
  if (!f->converged)
    fprintf(out,
            "warning    the reference did not converge (%s): the deviations are measured "
            "against a reference that may itself be off by more than tol / 10\n",
            f->stop);
}

void ek_advice_free(ek_advice *a) {
  if (!a)
    return;
  free(a->rows);
  a->rows = NULL;
  a->n = 0;
  ek_trial_free(&a->ref);
}
