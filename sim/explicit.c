// The explicit integrator: symplectic (semi-implicit) Euler with the FVM
// force.
//
//   v^{n+1} = v^n + dt M^-1 (f(x^n) + M g - c M v^n)
//   x^{n+1} = x^n + dt v^{n+1}
//
// (Hairer, Lubich, Wanner, "Geometric Numerical Integration", 2nd ed.,
// sec. I.1.2 and VI.3: the symplectic Euler method; undamped it conserves a
// modified energy, so the energy error stays bounded instead of drifting.)
// M is the lumped mass, c the mass-proportional damping coefficient. One
// force evaluation per step; stable for dt up to the CFL limit.
#include "sim_internal.h"

#include "../kernels/team.h"

#include <stdio.h>

// Up to this many vertices the update loop runs on one thread. It takes
// about 5 ns per vertex, and waking a sleeping thread took 12-90 us on the
// 2-core development machine: a second thread pays off only from several
// thousand vertices, and more on a loaded machine. Above it the loop runs
// as chunks of EXPLICIT_CHUNK vertices on the helper team (kernels/team.h),
// as the force does: the calling thread never waits for a helper that has
// not started (an OpenMP region's end waited for every thread, and a thread
// descheduled by another process arrived milliseconds later).
#define EXPLICIT_PARALLEL_GRAIN 20000
#define EXPLICIT_CHUNK 4096

static int explicit_explain(const ek_scene *s, FILE *out, int number) {
  fprintf(out, "  %d. integration: symplectic Euler v += dt M^-1 (f + M g - c M v), x += dt v\n",
          number);
  fprintf(out, "       CFL check at start: dt vs %s\n", sim_cfl_rule(s));
  return number + 1;
}

// Above the CFL limit an explicit step may outrun the fastest wave. The
// limit is for the model linearised at rest, so the scene is warned about,
// not refused.
static int explicit_create(ek_sim *s, void **data) {
  *data = NULL;
  char where[EK_SCENE_AT_MAX];
  if (s->scene.dt > s->cfl_dt)
    sim_warn(s,
             "%s: dt = %g is above the CFL limit %g (h_min = %g, c = sqrt((lambda + 2 mu) / "
             "rho) = %g, h_min / c = %g): the explicit loop may be unstable",
             ek_scene_at(&s->scene, s->scene.where.dt, where, sizeof where), s->scene.dt, s->cfl_dt,
             s->h_min, s->wave_speed, s->h_min / s->wave_speed);
  return 0;
}

typedef struct {
  ek_sim *s;
  double t_next;
} integrate_job;

// Symplectic Euler (free vertices), exact motion (constrained ones), then
// the ground, for vertices [i0, i1).
static void integrate(const integrate_job *j, size_t i0, size_t i1) {
  ek_sim *s = j->s;
  const ek_scene *sc = &s->scene;
  const double dt = sc->dt, c = sc->damping, t_next = j->t_next;
  const double *g = sc->gravity, *f = s->f;
  double *xn = s->x_next, *vn = s->v_next;
  for (size_t i = i0; i < i1; ++i) {
    const ek_scene_bc *bc = sim_bc_at(s, i, t_next);
    if (bc) {
      sim_bc_state(bc, s->x0 + 3 * i, t_next, xn + 3 * i, vn + 3 * i);
      continue;
    }
    double im = s->inv_mass[i];
    for (int k = 0; k < 3; ++k) {
      double v = s->v[3 * i + k];
      // v += dt M^-1 (f + m g - c m v); a massless vertex stays put.
      double a = im > 0 ? f[3 * i + k] * im + g[k] - c * v : 0.0;
      vn[3 * i + k] = v + dt * a;
      xn[3 * i + k] = s->x[3 * i + k] + dt * vn[3 * i + k];
    }
    sim_ground_contact(s, xn + 3 * i, vn + 3 * i);
  }
}

static void integrate_chunk(void *ctx, size_t k) {
  const integrate_job *j = ctx;
  const size_t i0 = k * EXPLICIT_CHUNK, i1 = i0 + EXPLICIT_CHUNK;
  integrate(j, i0, i1 < j->s->nv ? i1 : j->s->nv);
}

static int explicit_step(ek_sim *s, void *data) {
  (void)data;
  int rc = sim_forces(s, s->x);
  if (rc)
    return rc;

  double t0 = sim_now();
  if ((rc = sim_check_forces(s, s->x)) != 0) {
    s->times.integration += sim_now() - t0;
    return rc;
  }
  // Vertices are independent: any thread count gives the same bits.
  integrate_job j = {s, s->t + s->scene.dt};
  const size_t nv = s->nv, nchunks = (nv + EXPLICIT_CHUNK - 1) / EXPLICIT_CHUNK;
  if (nv > EXPLICIT_PARALLEL_GRAIN)
    ek_team_run(nchunks, integrate_chunk, &j);
  else
    integrate(&j, 0, nv);
  s->times.integration += sim_now() - t0;
  return 0;
}

const sim_integrator sim_integrator_explicit = {
    .name = "explicit",
    .description = "symplectic Euler (Hairer, Lubich, Wanner sec. VI.3): one force evaluation "
                   "per step, stable up to the CFL limit",
    .explain = explicit_explain,
    .create = explicit_create,
    .destroy = NULL,
    .step = explicit_step,
};
