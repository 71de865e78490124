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
  r.deviation = r.cost = r.cost_min = r.drift = NAN;
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
    if (s.integrator == EK_INTEGRATOR_IMPLICIT) {
      ek_scene v = s;
      v.implicit.newton_tol = 1e-4;
      ek_scene w = s;
      w.implicit.cg_tol = 1e-2;
      ek_scene one = s; // Baraff and Witkin 1998: one linearised solve per step
      one.implicit.max_newton = 1;
      if (add_row(b, &v, NULL) || add_row(b, &w, NULL) || add_row(b, &one, NULL))
        return -1;
    } else if (s.integrator == EK_INTEGRATOR_XPBD) {
      ek_scene v = s, w = s, u = s;
      v.xpbd.substeps = s.xpbd.substeps > 1 ? s.xpbd.substeps / 2 : 1;
      w.xpbd.iterations = s.xpbd.iterations > 1 ? s.xpbd.iterations / 2 : 1;
      u.xpbd.substeps = s.xpbd.substeps * 2 <= 100000 ? s.xpbd.substeps * 2 : 100000;
      if (add_row(b, &v, NULL) || add_row(b, &w, NULL) || add_row(b, &u, NULL))
        return -1;
    }
  }
  // The other loops at their usual step, the scene's precision, their
  // default knobs (those of a scene that names none: parsed once).
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
      v.dt = 0.5 * cfl_dt(&v, mesh);
      if (!(v.dt > 0))
        continue;
    } else {
      v.dt = frame_dt;
    }
    if (add_row(b, &v, NULL))
      return -1;
  }
  return 0;
}

long ek_advice_pick(const ek_advice *a, double tol) {
  long best = -1;
  for (size_t i = 0; i < a->n; ++i) {
    const ek_advise_row *r = &a->rows[i];
    if (r->skipped || r->failed || !(r->deviation <= tol))
      continue;
    if (best < 0 || r->cost < a->rows[best].cost)
      best = (long)i;
  }
  return best;
}

int ek_advise(const ek_scene *scene, const ek_mesh *mesh, const ek_advise_opts *o, ek_advice *a,
              char *err, size_t errlen) {
  memset(a, 0, sizeof *a);
  a->scene_row = a->pick = -1;
  if (scene->triangles || !mesh) {
    snprintf(err, errlen, "%s: the advisor takes tet scenes only", scene->path);
    return EK_EINVAL;
  }
  if (!(o->tol >= 0) || !(o->sim_time > 0)) {
    snprintf(err, errlen, "advise: tol %g must be >= 0 and the simulated time %g > 0", o->tol,
             o->sim_time);
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
  a->tol = o->tol;
  a->sim_time = o->sim_time;
  a->body_size = ek_trial_body_size(mesh);
  a->threads = omp_get_max_threads();
  rows_buf b = {a, 0};

  // The reference (advise.h), run first with the monitor.
  ek_scene ref = *scene;
  ref.precision = 64;
  ref.svd = (ek_svd3_opts){0, 0, scene->svd.isa, 0};
  ref.implicit.newton_tol = fmin(ref.implicit.newton_tol, 1e-8);
  ref.implicit.cg_tol = fmin(ref.implicit.cg_tol, 1e-6);
  ref.xpbd.substeps = ref.xpbd.substeps * 4 <= 100000 ? ref.xpbd.substeps * 4 : 100000;
  if (add_row(&b, &ref, NULL)) {
    snprintf(err, errlen, "advise: out of memory");
    return EK_ENOMEM;
  }
  if (o->progress)
    fprintf(o->progress, "advise: reference run, %g s simulated (monitoring J, strain, rotation)\n",
            o->sim_time);
  ek_trial rt;
  if (ek_trial_run(&ref, mesh, o->sim_time, 1, &rt) != 0 || rt.failed) {
    snprintf(err, errlen, "%s: the reference setting (%s) failed: %s", scene->path, a->rows[0].text,
             rt.error);
    ek_trial_free(&rt);
    ek_advice_free(a);
    return EK_EINVAL;
  }
  a->reach = rt.monitor;
  a->reference_inverted = scene->allow_inverted ? 0 : rt.health.inverted;
  ek_advise_row *r0 = &a->rows[0];
  r0->deviation = 0;
  r0->cost = rt.cost_median;
  r0->cost_min = rt.cost_min;
  r0->drift = rt.energy_drift;
  r0->steps = rt.steps;
  if (rt.health.inverted > 0 && !scene->allow_inverted) {
    r0->failed = 1; // the rows are still measured against it (the reach)
    snprintf(r0->reason, sizeof r0->reason, "ends with %zu of %zu tets inverted (J <= 0)",
             rt.health.inverted, rt.health.elements);
  }

  // Candidates: the scene's own setting first, then every model.
  if (add_row(&b, scene, NULL) != 0)
    goto oom;
  if (add_model(&b, scene, mesh, scene->material.model, &a->reach, o->sim_time))
    goto oom;
  for (int m = 0; m < EK_MODEL_COUNT; ++m)
    if (m != (int)scene->material.model &&
        add_model(&b, scene, mesh, (ek_model)m, &a->reach, o->sim_time))
      goto oom;
  a->scene_row = row_of(a, scene);

  size_t nrun = 0, k = 0;
  for (size_t i = 1; i < a->n; ++i)
    nrun += !a->rows[i].skipped;
  for (size_t i = 1; i < a->n; ++i) {
    ek_advise_row *r = &a->rows[i];
    if (r->skipped)
      continue;
    if (o->progress)
      fprintf(o->progress, "advise: candidate %zu of %zu: %s\n", ++k, nrun, r->text);
    ek_trial t;
    if (ek_trial_run(&r->setting, mesh, o->sim_time, 0, &t) != 0) {
      snprintf(err, errlen, "advise: %s", t.error);
      ek_trial_free(&t);
      ek_trial_free(&rt);
      ek_advice_free(a);
      return EK_ENOMEM;
    }
    r->failed = t.failed;
    if (t.failed)
      snprintf(r->reason, sizeof r->reason, "%s", t.error);
    // A candidate that turns the body inside out is no answer (issue 25),
    // however close its positions come to the reference's.
    if (!t.failed && t.health.inverted > 0 && !scene->allow_inverted) {
      r->failed = 1;
      snprintf(r->reason, sizeof r->reason, "ends with %zu of %zu tets inverted (J <= 0)",
               t.health.inverted, t.health.elements);
    }
    r->deviation = ek_trial_deviation(mesh, t.x, rt.x);
    r->cost = t.cost_median;
    r->cost_min = t.cost_min;
    r->drift = t.energy_drift;
    r->steps = t.steps;
    ek_trial_free(&t);
  }
  ek_trial_free(&rt);
  a->pick = ek_advice_pick(a, o->tol);
  return 0;
oom:
  ek_trial_free(&rt);
  ek_advice_free(a);
  snprintf(err, errlen, "advise: out of memory");
  return EK_ENOMEM;
}

void ek_advice_print(const ek_advice *a, FILE *out) {
  const ek_trial_monitor *m = &a->reach;
  fprintf(out,
          "advise     %g s simulated per candidate, tol %g of the body size (%.4g m), %d "
          "threads; cost = median step wall time x steps per simulated second\n",
          a->sim_time, a->tol, a->body_size, a->threads);
  fprintf(out,
          "reached    (reference run) min J %.4g, min sigma %.4g, max |F^T F - I| %.3g, max "
          "rotation %.3g rad, max rotation per step %.3g rad\n",
          m->min_J, m->min_sigma, m->max_strain, m->max_rotation, m->max_rotation_step);
  if (a->reference_inverted > 0)
    fprintf(out,
            "inverted   the reference run ends with %zu tets inverted (J <= 0): it and every "
            "setting that does so fail (the scene's allow.inverted is not set)\n",
            a->reference_inverted);
  fprintf(out, "%4s  %-10s  %-12s  %-9s  %-4s  %-10s  %s\n", "#", "deviation", "cost s/sim-s",
          "drift", "svd", "verdict", "setting");
  for (size_t i = 0; i < a->n; ++i) {
    const ek_advise_row *r = &a->rows[i];
    const char *verdict = r->skipped               ? "skipped"
                          : r->failed              ? "failed"
                          : (long)i == a->pick     ? "PICK"
                          : i == a->reference      ? "reference"
                          : r->deviation <= a->tol ? "within"
                                                   : "over tol";
    char dev[32] = "-", cost[32] = "-", drift[32] = "-";
    if (!r->skipped && !r->failed) {
      snprintf(dev, sizeof dev, "%.3e", r->deviation);
      snprintf(cost, sizeof cost, "%.4g", r->cost);
      snprintf(drift, sizeof drift, "%+.3g", r->drift);
    }
    fprintf(out, "%4zu  %-10s  %-12s  %-9s  %-4s  %-10s  %s%s%s%s%s\n", i + 1, dev, cost, drift,
            r->skipped    ? "-"
            : r->uses_svd ? "yes"
                          : "no",
            verdict, r->text, i == a->reference ? " (reference)" : "",
            (long)i == a->scene_row ? " (the scene's)" : "", r->skipped || r->failed ? ": " : "",
            r->skipped || r->failed ? r->reason : "");
  }
  if (a->pick < 0) {
    fprintf(out, "pick       none within tol %g\n", a->tol);
    return;
  }
  const ek_advise_row *p = &a->rows[a->pick];
  fprintf(out, "pick       #%ld %s: deviation %.3e <= %g at %.4g s per simulated s", a->pick + 1,
          p->text, p->deviation, a->tol, p->cost);
  if (a->scene_row >= 0 && a->rows[a->scene_row].cost > 0 && !a->rows[a->scene_row].failed)
    fprintf(out, " (%.2fx the scene's own setting, #%ld)", p->cost / a->rows[a->scene_row].cost,
            a->scene_row + 1);
  fprintf(out, "\n");
}

void ek_advice_free(ek_advice *a) {
  if (!a)
    return;
  free(a->rows);
  a->rows = NULL;
  a->n = 0;
}
