// The simulation core (sim_internal.h): state, lumped masses, boundary
// conditions, ground, energies and the force check, shared by every
// integrator; the elastic body behind its operations (body.h: tets in
// body_tets.c, triangles in body_cloth.c). Vertices under a boundary
// condition follow it exactly; the ground is friction-free.
#include "errbuf.h"
#include "sim_internal.h"

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

// sim_fail and sim_fail_at: the message, and the scene value it is about.
static int fail_v(ek_sim *s, ek_scene_pos at, const char *fmt, va_list ap) {
  vsnprintf(s->error, sizeof s->error, fmt, ap);
  s->error_at = at;
  ek_set_error("%s", s->error);
  return EK_EINVAL;
}

int sim_fail(ek_sim *s, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  int rc = fail_v(s, (ek_scene_pos){0, 0}, fmt, ap);
  va_end(ap);
  return rc;
}

int sim_fail_at(ek_sim *s, ek_scene_pos at, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  int rc = fail_v(s, at, fmt, ap);
  va_end(ap);
  return rc;
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

static void cross3(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
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
  if (s->body)
    s->body->ops->destroy((sim_body *)s->body);
  ek_mesh_destroy(s->own_mesh);
  ek_trimesh_destroy(s->own_trimesh);
  free(s->x_next);
  free(s->v_next);
  free(s->bc_of);
  free(s);
}

// One constructor for every body: make_body builds it from the scene's
// checked material (NULL: out of memory), ek_sim_create* say which.
typedef sim_body *(*body_maker)(const ek_scene *scene, const ek_material *mat, const void *mesh);

static ek_sim *sim_create(const ek_scene *scene, const void *mesh, int kind_ok,
                          body_maker make_body, char *err, size_t errlen) {
  if (err && errlen)
    err[0] = '\0';
  if (!scene || !mesh || !kind_ok) {
    if (err && errlen)
      snprintf(err, errlen, "ek_sim_create: no scene or mesh, or a mesh of the wrong kind");
    return NULL;
  }
  // Messages about a value of the scene name its place in the file.
  char where[EK_SCENE_AT_MAX];
  if ((unsigned)scene->integrator >= EK_INTEGRATOR_COUNT) {
    if (err && errlen)
      snprintf(err, errlen, "%s: integrator %d: unknown",
               ek_scene_at(scene, scene->where.integrator, where, sizeof where),
               (int)scene->integrator);
    return NULL;
  }
  ek_sim *s = calloc(1, sizeof *s);
  if (!s)
    return NULL;
  s->scene = *scene;
  s->mat = scene->material;
  if (ek_material_check(&s->mat) != 0) {
    if (err && errlen)
      snprintf(err, errlen, "%s: material: %s",
               ek_scene_at(scene, scene->where.material, where, sizeof where), ek_last_error());
    ek_sim_destroy(s);
    return NULL;
  }
  const sim_body *body = s->body = make_body(scene, &s->mat, mesh);
  if (!body) {
    if (err && errlen)
      snprintf(err, errlen, "%s: out of memory", scene->path);
    ek_sim_destroy(s);
    return NULL;
  }
  size_t nv = s->nv = body->nv;
  size_t nt = s->nt = body->ne;
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
  if (!ok) {
    if (err && errlen)
      snprintf(err, errlen, "%s: out of memory for %zu vertices, %zu elements", scene->path, nv,
               nt);
    ek_sim_destroy(s);
    return NULL;
  }

  // Initial state: rest shape scaled about its bounding-box centre, then
  // translated; uniform velocity.
  const double *X = body->X;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = fmin(lo[k], X[3 * i + k]);
      hi[k] = fmax(hi[k], X[3 * i + k]);
    }
  double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                     (hi[2] - lo[2]) * (hi[2] - lo[2]));
  s->body_size = diag;
  for (int k = 0; k < 3; ++k)
    s->body_center[k] = 0.5 * (lo[k] + hi[k]);
  for (size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      double c = 0.5 * (lo[k] + hi[k]);
      s->x[3 * i + k] = c + scene->init_scale[k] * (X[3 * i + k] - c) + scene->init_translate[k];
      s->v[3 * i + k] = scene->init_velocity[k];
    }
  memcpy(s->x0, s->x, 3 * nv * sizeof(double));

  // Lumped masses (body.h: Teran 2003 sec. 4, each tet gives a quarter of
  // its mass to each corner; each triangle a third of its density *
  // thickness * A).
  const double *lumped = body->lumped;
  for (size_t i = 0; i < nv; ++i) {
    s->mass[i] = scene->density * body->mass_scale * lumped[i];
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
                 ek_scene_at(scene, scene->where.region[b], where, sizeof where), b,
                 scene->bc[b].box_min[0], scene->bc[b].box_min[1], scene->bc[b].box_min[2],
                 scene->bc[b].box_max[0], scene->bc[b].box_max[1], scene->bc[b].box_max[2], lo[0],
                 lo[1], lo[2], hi[0], hi[1], hi[2]);
      ek_sim_destroy(s);
      return NULL;
    }
  for (size_t i = 0; i < nv; ++i)
    if (s->bc_of[i] >= 0)
      sim_bc_state(&scene->bc[s->bc_of[i]], s->x0 + 3 * i, 0.0, s->x + 3 * i, s->v + 3 * i);

  // The CFL limit (the body's: element eigenvalue bound for tets, h_min / c
  // for triangles); integrators that it limits check it (their create).
  // Then what the body keeps from the initial state and its rest energy.
  body->ops->cfl(s, &s->h_min, &s->wave_speed, &s->cfl_dt);
  if (body->ops->start(s) != 0) {
    if (err && errlen)
      snprintf(err, errlen, "%s: %s", ek_scene_at(scene, s->error_at, where, sizeof where),
               s->error);
    ek_sim_destroy(s);
    return NULL;
  }

  s->integrator = sim_integrators[scene->integrator];
  if (s->integrator->create && s->integrator->create(s, &s->integrator_data) != 0) {
    if (err && errlen)
      snprintf(err, errlen, "%s: integrator %s: %s",
               ek_scene_at(scene, s->error_at, where, sizeof where), s->integrator->name, s->error);
    ek_sim_destroy(s);
    return NULL;
  }
  return s;
}

const char *sim_cfl_rule(const ek_scene *scene) {
  return scene->triangles ? "h_min / c (c the membrane's dilatational wave speed)"
                          : "2 / omega_max (element eigenvalue bound)";
}

static sim_body *make_tets(const ek_scene *scene, const ek_material *mat, const void *mesh) {
  return sim_body_tets_create(scene, mat, mesh);
}

static sim_body *make_triangles(const ek_scene *scene, const ek_material *mat, const void *mesh) {
  return sim_body_triangles_create(scene, mat, mesh);
}

ek_sim *ek_sim_create_errbuf(const ek_scene *scene, const ek_mesh *mesh, char *err, size_t errlen) {
  return sim_create(scene, mesh, scene && !scene->triangles, make_tets, err, errlen);
}

ek_sim *ek_sim_create_cloth_errbuf(const ek_scene *scene, const ek_trimesh *mesh, char *err,
                                   size_t errlen) {
  return sim_create(scene, mesh, scene && scene->triangles, make_triangles, err, errlen);
}

ek_sim *ek_sim_create_scene(const ek_scene *scene) {
  if (!scene) {
    ek_set_error("ek_sim_create_scene: no scene");
    return NULL;
  }
  ek_sim *s = NULL;
  if (scene->triangles) {
    ek_trimesh *m = ek_scene_trimesh(scene);
    if (m && !(s = ek_sim_create_cloth(scene, m)))
      ek_trimesh_destroy(m);
    if (s)
      s->own_trimesh = m;
  } else {
    ek_mesh *m = ek_scene_mesh(scene);
    if (m && !(s = ek_sim_create(scene, m)))
      ek_mesh_destroy(m);
    if (s)
      s->own_mesh = m;
  }
  return s;
}

size_t sim_count_unused(size_t nverts, const int32_t *elems, size_t count, int corners,
                        size_t *first) {
  unsigned char *used = calloc(nverts ? nverts : 1, 1);
  if (!used)
    return 0; // a warning only: none rather than a failure
  for (size_t i = 0; i < count * (size_t)corners; i++)
    if (elems[i] >= 0 && (size_t)elems[i] < nverts)
      used[elems[i]] = 1;
  size_t unused = 0;
  for (size_t v = nverts; v-- > 0;)
    if (!used[v]) {
      unused++;
      *first = v;
    }
  free(used);
  return unused;
}

size_t sim_unused_vertices(const ek_sim *s, size_t *first, size_t *nverts) {
  const sim_body *b = s->body;
  if (s->own_trimesh) {
    size_t n = sim_trimesh_dropped(s->own_trimesh, first);
    *nverts = b->nv + n;
    return n;
  }
  *nverts = b->nv;
  return sim_count_unused(b->nv, b->caller_elems, b->ne, b->corners, first);
}

int ek_sim_elements_of(const ek_sim *s, ek_sim_elements *e) {
  if (!s || !e) {
    ek_set_error("ek_sim_elements_of: NULL argument");
    return EK_EINVAL;
  }
  const sim_body *b = s->body;
  *e = (ek_sim_elements){b->kind, b->ne, b->corners,  b->caller_elems,
                         b->nv,   b->X,  b->has_smax, b->oriented};
  return 0;
}

const char *ek_sim_describe(const ek_sim *s, char *buf, size_t len) {
  if (buf && len)
    s->body->ops->describe(s, buf, len);
  return buf;
}

int ek_sim_force_phases(const ek_sim *s, const char **names, double *seconds, int max) {
  const sim_body *b = s->body;
  int n = b->nphases < max ? b->nphases : max;
  for (int i = 0; i < n; ++i) {
    if (names)
      names[i] = b->phase_names[i];
    if (seconds)
      memcpy(&seconds[i], (const char *)&s->times + b->phase_times[i], sizeof(double));
  }
  return n;
}

int ek_sim_is_cloth(const ek_sim *s) { return s->body->ops == &sim_body_triangles; }

const char *ek_sim_integrator_name(const ek_sim *s) { return s->integrator->name; }

size_t ek_sim_inverted_count(const ek_sim *s) {
  return s->body->ops->inverted_count(s, NULL, NULL, NULL);
}

int ek_sim_check(const ek_sim *s, ek_sim_health *h) {
  if (!s || !h) {
    ek_set_error("ek_sim_check: NULL argument");
    return EK_EINVAL;
  }
  *h = (ek_sim_health){0};
  h->elements = s->body->ne;
  h->inverted = s->body->ops->inverted_count(s, NULL, &h->first_inverted, &h->first_inverted_J);
  h->allow_inverted = s->scene.allow_inverted;
  h->allow_nonfinite = s->scene.allow_nonfinite;
  // Relative to the rest bounding box (centre c, diagonal L): scale-free,
  // so a millimetre body and a 100 m one blow up at the same ratio.
  double r2 = 0;
  for (size_t i = 0; i < s->nv; ++i) {
    double d2 = 0;
    const size_t before = h->nonfinite;
    for (int k = 0; k < 3; ++k) {
      const double x = s->x[3 * i + k], v = s->v[3 * i + k];
      h->nonfinite += !isfinite(x) + !isfinite(v);
      d2 += (x - s->body_center[k]) * (x - s->body_center[k]);
    }
    if (before == 0 && h->nonfinite > 0)
      h->first_nonfinite = i;
    if (d2 > r2) // NaN compares false: counted above instead
      r2 = d2, h->farthest = i;
  }
  if (h->nonfinite > 0)
    h->farthest = h->first_nonfinite;
  h->extent = s->body_size > 0 ? sqrt(r2) / s->body_size : (r2 > 0 ? INFINITY : 0);
  h->blown_up = h->nonfinite > 0 || !(h->extent <= EK_SIM_BLOWUP_EXTENT);
  return 0;
}

size_t ek_count_nonfinite(const double *a, size_t n) {
  size_t c = 0;
  for (size_t i = 0; a && i < n; ++i)
    c += !isfinite(a[i]);
  return c;
}

int sim_forces(ek_sim *s, const double *x) {
  const sim_body_ops *ops = s->body->ops;
  size_t n3 = 3 * s->nv;
  double t0 = sim_now();
  int rc;
  if (s->scene.precision == 32) {
    for (size_t i = 0; i < n3; ++i)
      s->xf[i] = (float)x[i];
    rc = ops->forces(s, NULL, s->xf, NULL, s->ff);
    for (size_t i = 0; rc == 0 && i < n3; ++i)
      s->f[i] = (double)s->ff[i];
  } else {
    rc = ops->forces(s, x, NULL, s->f, NULL);
  }
  double t1 = sim_now();
  if (s->time_phases)
    s->times.phase_timed_steps++;
  else
    s->times.forces += t1 - t0;
  if (rc)
    return sim_fail(s, "%s force kernel failed (rc %d): %s", ops->force_kernel, rc,
                    ek_last_error());
  return 0;
}

// What a non-finite force from finite positions x says about the state:
// "; the positions reach E body sizes from the rest centre (the state blew
// up)" when E > 10 (issue 26: a diverged crush must read as a blow-up, not
// as a model's domain), and ", dt D is above the CFL limit C" for an
// explicit scene stepped above its limit (the likely cause), else "".
static const char *cfl_hint(const ek_sim *s, const double *x, char *buf, size_t len) {
  buf[0] = '\0';
  // The largest coordinate offset (not the distance: its square overflows
  // for positions near 1e160, which a blow-up reaches).
  double far = 0;
  for (size_t i = 0; x && i < s->nv; ++i)
    for (int k = 0; k < 3; ++k)
      far = fmax(far, fabs(x[3 * i + k] - s->body_center[k]));
  const double extent = s->body_size > 0 ? far / s->body_size : 0;
  size_t used = 0;
  if (extent > 10)
    used = (size_t)snprintf(buf, len,
                            "; the positions reach %.3g body sizes from the rest centre (the "
                            "state blew up)",
                            extent);
  if (used < len && s->integrator == &sim_integrator_explicit && s->scene.dt > s->cfl_dt)
    snprintf(buf + used, len - used, "; dt %g is %.3g times the CFL limit %g", s->scene.dt,
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
  char hint[256];
  // Three causes, told apart (issue 28: a NaN state was reported as every
  // tet "inverted (J = -nan) ... use an invertible model", even for fixed
  // corotated): positions that are not finite (a blow-up the state check
  // missed, e.g. a line-search trial point), elements outside the model's
  // domain (neo-Hookean without clamp, J <= 0: material.h), or a finite
  // state whose force overflows; the body tells the last two apart.
  for (size_t i = 0; i < 3 * s->nv; ++i)
    if (!isfinite(x[i]))
      return sim_fail(s, "non-finite state: vertex %zu has a non-finite position (%g, %g, %g)%s",
                      i / 3, x[i - i % 3], x[i - i % 3 + 1], x[i - i % 3 + 2],
                      cfl_hint(s, NULL, hint, sizeof hint));
  return s->body->ops->bad_force(s, x, bad_vertex, cfl_hint(s, x, hint, sizeof hint));
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
    char hint[256];
    return sim_fail(s,
                    "non-finite state after the step: vertex %zu has position (%g, %g, %g), "
                    "velocity (%g, %g, %g)%s",
                    i / 3, x[0], x[1], x[2], v[0], v[1], v[2],
                    cfl_hint(s, s->x, hint, sizeof hint));
  }
  return 0;
}

// A failed step's message, whatever check gave it, begins with where in
// the run: "step N (t = T0 s to T1 s): " (N counted from 1, as ek-sim's
// progress line; [T0, T1] the step's interval). The checks name the first
// offending vertex or element and its value themselves.
static int step_failed(ek_sim *s, int rc) {
  char why[sizeof s->error - 80]; // room for the prefix (-Wformat-truncation)
  snprintf(why, sizeof why, "%.*s", (int)sizeof why - 1, s->error[0] ? s->error : ek_last_error());
  snprintf(s->error, sizeof s->error, "step %ld (t = %g s to %g s): %s", s->n + 1, s->t,
           s->t + s->scene.dt, why);
  ek_set_error("%s", s->error);
  return rc;
}

int ek_sim_step(ek_sim *s) {
  if (!s)
    return EK_EINVAL;
  s->error[0] = '\0';
  int rc = s->body->ops->begin_step ? s->body->ops->begin_step(s) : 0;
  if (rc == 0)
    rc = s->integrator->step(s, s->integrator_data);
  if (rc == 0)
    rc = check_state(s);
  if (rc)
    return step_failed(s, rc);
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
  snprintf(s->error, sizeof s->error, "stopped inside the step, at %s %ld of %ld; not applied",
           where, i, n);
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
  s->state_epoch++;
  // What the body kept from the old state (rotations) restarts here.
  return s->body->ops->set_state(s);
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
  e->elastic = s->body->ops->energy(s, s->x) - s->elastic_rest;
  return isnan(e->elastic) ? EK_EINVAL : 0;
}

void ek_sim_momentum(const ek_sim *s, double p[3]) {
  p[0] = p[1] = p[2] = 0;
  for (size_t i = 0; i < s->nv; ++i)
    for (int k = 0; k < 3; ++k)
      p[k] += s->mass[i] * s->v[3 * i + k];
}

double ek_sim_volume(const ek_sim *s) { return s->body->ops->measure(s); }

int ek_sim_fields(const ek_sim *s, double *J, double *smin, double *psi, double *smax) {
  return s->body->ops->fields(s, J, s->body->has_smax ? smax : NULL, smin, psi);
}

int ek_sim_tet_fields(const ek_sim *s, double *J, double *smin, double *psi) {
  return s->body->ops->fields(s, J, NULL, smin, psi);
}

int ek_sim_cloth_fields(const ek_sim *s, double *J, double *s1, double *s2, double *psi) {
  if (!ek_sim_is_cloth(s))
    return sim_fail((ek_sim *)s, "ek_sim_cloth_fields: not a cloth scene");
  return s->body->ops->fields(s, J, s1, s2, psi);
}
