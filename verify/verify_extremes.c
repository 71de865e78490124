// ek-verify --extremes: stability at the extremes, per model and loop.
//
// Each row runs one scene on a small cube (4 x 4 x 4 cells, 384 tets) built
// from a shipped scene (crush.json for the explicit loop, crush_implicit.json
// for the implicit one) with overrides, and judges the end state with the
// verdicts of check_stability.h:
//   rest         the rest shape, undamped, no load: it must stay at rest
//                (Smith et al. 2018, "Stable neo-Hookean flesh simulation",
//                rest stability);
//   crush_plane  every vertex projected onto the mid-plane z = L / 2, plus
//                noise, then let go (damped, no load);
//   crush_point  every vertex moved to the centre, plus noise, then let go
//                (Irving et al. 2004, "Invertible finite elements for
//                robust simulation of large deformation": the body
//                crushed to a plane and to a point recovers);
//   crush_plane at nu = 0.45 / 0.49 / 0.499, E = 1e3 / 1e7 / 1e9 Pa and cube
//                edges L = 1e-4 / 1e-2 / 1 m (base: nu 0.3, E 1e5, L 0.2).
// Loops: explicit at 0.5x, 1x and 2x ek_sim_cfl_dt, implicit at 1/30 s,
// and XPBD at 1/60 s in 10 substeps of 5 Gauss-Seidel sweeps (its tets,
// crush_implicit.json's scene with the XPBD loop) for the models XPBD has
// constraints for (xpbd.h: StVK, expected not to recover, and stable
// neo-Hookean, Macklin & Mueller 2021, expected to), on the cases at the
// base E and L (rest, both crushes, the nu sweep). Precisions f32 and f64
// (the force kernel's; the implicit loop's Hessian products; the XPBD
// sweeps').
//
// --quick (CI) runs the rows whose model, case and loop are all marked
// quick: rest, both crushes and the plane crush at E = 1e9 Pa and L = 1e-4
// m, explicit at 0.5x and 2x CFL and implicit, for StVK, fixed corotated +
// clamp, neo-Hookean and stable neo-Hookean + clamp, in f32 and f64 (120
// rows): each kind of verdict (PASS, xfail,
// broke) appears, none of the full run's known failures does.
//
// Time scales: tc = L / c_s, c_s = sqrt(mu / rho) the shear wave speed. A
// crush runs 30 tc with mass-proportional damping c = 2 / tc (each mode
// of frequency omega decays at min(c / 2, omega^2 / c) >= ~1 / tc), so the
// explicit rows take the same number of steps at every E and L, and the
// implicit rows at least 30 steps. The rest scene runs as long, undamped.
// A row stops early when a step fails (ek_sim_step's error is printed) or
// the state leaves EK_STAB_BLOWUP_FACTOR body sizes.
#include <cjson/cJSON.h>
#include <ek/ek.h>
#include <ek/sim/sim.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "check_stability.h"
#include "scene_find.h"
#include "test_tolerances.h"
#include "verify.h"

// ---- The scenes ----

typedef enum { CASE_REST, CASE_CRUSH_PLANE, CASE_CRUSH_POINT } case_kind;

typedef struct {
  const char *name;
  case_kind kind;
  double E, nu, L; // 0: the base value
  int quick;       // in --quick
} ext_case;

#define BASE_E 1e5
#define BASE_NU 0.3
#define BASE_L 0.2
#define CELLS 4
// Crush noise: uniform in [-a, a] per coordinate, a = NOISE * L, so about
// half the tets start inverted.
#define NOISE 1e-4
// Durations in shear crossing times tc, damping c = DAMPING_TC / tc.
#define DURATION_TC 30.0
#define DAMPING_TC 2.0
#define IMPLICIT_DT (1.0 / 30.0)
#define IMPLICIT_MIN_STEPS 30
// XPBD: the shipped XPBD scenes' step and knobs (drop_xpbd.json), at least
// as many steps as the implicit rows.
#define XPBD_DT (1.0 / 60.0)
#define XPBD_SUBSTEPS 10
#define XPBD_ITERATIONS 5

static const ext_case cases[] = {
    {"rest", CASE_REST, 0, 0, 0, 1},
    {"crush_plane", CASE_CRUSH_PLANE, 0, 0, 0, 1},
    {"crush_point", CASE_CRUSH_POINT, 0, 0, 0, 1},
    {"crush_plane nu=0.45", CASE_CRUSH_PLANE, 0, 0.45, 0, 0},
    {"crush_plane nu=0.49", CASE_CRUSH_PLANE, 0, 0.49, 0, 0},
    {"crush_plane nu=0.499", CASE_CRUSH_PLANE, 0, 0.499, 0, 0},
    {"crush_plane E=1e3", CASE_CRUSH_PLANE, 1e3, 0, 0, 0},
    {"crush_plane E=1e7", CASE_CRUSH_PLANE, 1e7, 0, 0, 0},
    {"crush_plane E=1e9", CASE_CRUSH_PLANE, 1e9, 0, 0, 1},
    {"crush_plane L=1e-4", CASE_CRUSH_PLANE, 0, 0, 1e-4, 1},
    {"crush_plane L=1e-2", CASE_CRUSH_PLANE, 0, 0, 1e-2, 0},
    {"crush_plane L=1", CASE_CRUSH_PLANE, 0, 0, 1.0, 0},
};
#define NCASES (int)(sizeof cases / sizeof cases[0])

// ---- The loops ----

typedef enum { LOOP_EXPLICIT, LOOP_IMPLICIT, LOOP_XPBD } loop_kind;
typedef struct {
  const char *name;
  loop_kind kind;
  double cfl_factor; // explicit: dt = factor * ek_sim_cfl_dt
  int quick;
} ext_loop;

static const ext_loop loops[] = {
    {"explicit 0.5cfl", LOOP_EXPLICIT, 0.5, 1}, {"explicit 1cfl", LOOP_EXPLICIT, 1.0, 0},
    {"explicit 2cfl", LOOP_EXPLICIT, 2.0, 1},   {"implicit 1/30", LOOP_IMPLICIT, 0, 1},
    {"xpbd 1/60 10x5", LOOP_XPBD, 0, 0},
};
#define NLOOPS (int)(sizeof loops / sizeof loops[0])

// ---- Expectations: what the literature says each model survives ----
//
// SURVIVE rows fail the run when they do not survive; NOT rows are expected
// not to survive (reported, and an unexpected survival is noted); NONE rows
// make no claim (reported only).
typedef enum { EXPECT_NONE, EXPECT_SURVIVE, EXPECT_NOT } expectation;
static const char *const expect_names[] = {"none", "survive", "not"};

typedef struct {
  const char *name;  // row label
  const char *model; // its short name (ek_model_from_name)
  int clamp;         // 1: the base scene's clamp (Irving et al. 2004 sec. 5)
  int quick;
  // Crush scenes (plane, point and the sweeps): explicit at <= 1x CFL,
  // implicit. Rest is SURVIVE for every model at <= 1x CFL and implicit
  // (Smith et al. 2018: P(I) = 0 is required of every model; ek takes
  // stable neo-Hookean's a = 1 + 3 mu / (4 lambda), material.h).
  // Explicit at 2x CFL is NONE everywhere: symplectic Euler is stable for
  // dt omega_max <= 2 and ek_sim_cfl_dt is that limit by the element
  // eigenvalue bound (sim.h), so 2x is expected to blow up; the row says so.
  expectation crush_explicit, crush_implicit;
  // 1: the tangent stiffness grows away from F = I (a volumetric term of
  // degree > 2 in F: lambda/2 (J - 1)^2 is of degree 6), so the rest CFL
  // step does not bound the states a crush passes through (below,
  // NEAR_INCOMPRESSIBLE_NU); 0: linear, corotated linear (constant K in a
  // step), ARAP (no lambda term, |F - R|^2 is bounded by 2 mu).
  int stiffens;
  const char *source;
} ext_variant;

static const ext_variant variants[] = {
    {"linear", "linear", 0, 0, EXPECT_SURVIVE, EXPECT_SURVIVE, 0,
     "linear in x: f = -K (x - X), K constant and PSD, so a damped body returns to X whatever "
     "the crush (no inversion exists for it; it is not rotation-invariant)"},
    {"stvk", "stvk", 0, 1, EXPECT_NOT, EXPECT_NOT, 1,
     "Irving et al. 2004: StVK's restoring force vanishes as an element flattens and its "
     "reflection F = diag(1,1,-1) has zero energy: it can stay inverted"},
    {"corot_linear", "corot_linear", 0, 0, EXPECT_NONE, EXPECT_NONE, 0,
     "no published claim for linear elasticity about a lagged R^n = polar(F^n) under "
     "inversion (seed 000); reported only"},
    {"fixed_corot", "fixed_corot", 0, 0, EXPECT_SURVIVE, EXPECT_SURVIVE, 1,
     "Stomakhin et al. 2012: fixed corotated with the rotation-variant R is finite "
     "and restoring for inverted and flat elements"},
    {"fixed_corot+clamp", "fixed_corot", 1, 1, EXPECT_SURVIVE, EXPECT_SURVIVE, 1,
     "Irving 2004 sec. 5 (clamped singular values) on fixed corotated (Stomakhin 2012)"},
    {"arap", "arap", 0, 0, EXPECT_SURVIVE, EXPECT_SURVIVE, 0,
     "fixed corotated with lambda = 0: its mu |F - R(F)|^2 term is the one Stomakhin 2012 "
     "shows restoring under inversion"},
    {"arap+clamp", "arap", 1, 0, EXPECT_SURVIVE, EXPECT_SURVIVE, 0, "Irving 2004 sec. 5 on ARAP"},
    {"psi_r", "psi_r", 0, 0, EXPECT_NOT, EXPECT_NOT, 1,
     "a function of F^T F like StVK: the reflection has zero energy (Irving et al. 2004)"},
    {"nh", "nh", 0, 1, EXPECT_NOT, EXPECT_NOT, 1,
     "log J is undefined for J <= 0 (Smith et al. 2018; material.h): an inverted start is "
     "refused (EK_SIM_EINVERTED)"},
    {"nh+clamp", "nh", 1, 0, EXPECT_NONE, EXPECT_SURVIVE, 1,
     "Irving 2004 sec. 5: finite, restoring; explicit NONE: its stiffness at the clamp is "
     "~(1/clamp)^2 the rest stiffness, so the rest CFL step does not bound it"},
    {"snh", "snh", 0, 0, EXPECT_SURVIVE, EXPECT_SURVIVE, 1,
     "Smith et al. 2018: finite, restoring under inversion, bounded stiffness"},
    {"snh+clamp", "snh", 1, 1, EXPECT_SURVIVE, EXPECT_SURVIVE, 1,
     "Smith 2018 with Irving 2004 sec. 5's clamp"},
};
#define NVARIANTS (int)(sizeof variants / sizeof variants[0])

// XPBD rows: the variants without a clamp (XPBD has none) whose model has
// XPBD constraints, on the cases at the base E and L.
static int xpbd_row(const ext_variant *v, const ext_case *c) {
  ek_model m = EK_MODEL_COUNT;
  return !v->clamp && ek_model_from_name(v->model, &m) == 0 && ek_xpbd_supports(m) && c->E == 0 &&
         c->L == 0;
}

// Whether (variant, case, loop) is a row at all.
static int is_row(const ext_variant *v, const ext_case *c, const ext_loop *l) {
  return l->kind != LOOP_XPBD || xpbd_row(v, c);
}

// Stable neo-Hookean without a clamp crushed to a point: F = 0 is a
// degenerate stationary point of ek's psi (material.h: P = mu F (1 - 1 /
// (I_C + 1)) + lambda (J - a) cof F, every term O(|F|^2) at F = 0: P(0) = 0
// and dP(0) = 0), so the restoring force of a body crushed to within
// NOISE L of a point is ~|F|^2 ~ 1e-7 of the rest scale and the escape
// takes a time ~ 1 / |F|. The model does recover, later than the row's 30
// tc: measured (explicit, 1x CFL, f64, seed 1) V/V0 1.6e-11 at 30 tc,
// > 0.5 at ~70 tc and 1 from ~80 tc on; from noise 1e-3 L V/V0 > 0.5 at
// ~12 tc, from 1e-2 L restored within 30 tc (test_sim_explicit 5. holds both
// ends). With the clamp (sigma_hat >= clamp) P(F_hat) is O(1) there and the
// snh+clamp rows recover (PASS). So the point rows expect no recovery
// within the run (xfail; an xpass would be reported), as the XPBD rows do.
#define SNH_POINT_SOURCE                                                                           \
  "stable neo-Hookean at F = 0: P(0) = 0 and dP(0) = 0 (every term of P is O(|F|^2)), so a "       \
  "body crushed to within 1e-4 L of a point escapes only after ~70 tc (measured), past the "       \
  "row's 30 tc; it recovers from 1e-2 L within 30 tc"
static int snh_point(const ext_variant *v, const ext_case *c) {
  return c->kind == CASE_CRUSH_POINT && !v->clamp && strcmp(v->model, "snh") == 0;
}

// Neo-Hookean + clamp crushed to a point: the model itself does not come
// back. Its resolved dynamics, the explicit loop far below its step limit
// from the row's start state (a 0.2 m cube of 4^3 cells, noise 1e-4 L,
// damping 2 / tc, 30 tc; test_sim_implicit's crush set-up), settle within
// ~10 tc into a tangled state with every tet uninverted and the body not
// restored: f64, seed 1, at 0.1 / 0.05 / 0.02 / 0.01x CFL: V/V0 0.914 /
// 0.926 / 0.891 / 0.892, shape error 0.67 / 0.71 / 0.52 / 0.60 (bound
// 0.01), 0 inverted; 0.05x CFL, seeds 2-5: V/V0 0.87-0.89, shape error
// 0.62-0.83; f32 seed 1: 0.888, 0.66. Stable neo-Hookean + clamp and fixed
// corotated + clamp from the same states in the same loop restore every
// time (shape error <= 2.5e-9), as their implicit rows do. Every singular
// value of those end states is above the clamp (the smallest 0.076-0.126
// over these runs), so the clamp is inactive there: the state is an
// equilibrium of neo-Hookean itself, and it stays: leaving it flattens
// some tet, and neo-Hookean's energy at the clamp (sigma = (1, 1, 0.05), nu
// = 0.3) is 9.2 mu above rest (its log J terms), against 1.0 mu for stable
// neo-Hookean and 1.6 mu for fixed corotated. The implicit rows end
// unrestored too (seed 1: V/V0 0.87, shape error 0.62, one tet inverted
// where Newton stops at max_newton, sim/implicit.c), so they expect no
// recovery (xfail); the plane crushes recover (PASS) and keep SURVIVE.
#define NH_CLAMP_POINT_SOURCE                                                                      \
  "neo-Hookean + clamp from a point crush settles into a tangled, uninverted equilibrium of "      \
  "neo-Hookean itself (explicit at 0.01-0.1x CFL, seeds 1-5, f32/f64: V/V0 0.87-0.93, shape "      \
  "error 0.52-0.83, 0 inverted, measured; stable neo-Hookean and fixed corotated + clamp "         \
  "restore from the same states): flattening a tet costs 9.2 mu at the clamp 0.05 vs 1.0-1.6 mu"
static int nh_clamp_point(const ext_variant *v, const ext_case *c) {
  return c->kind == CASE_CRUSH_POINT && v->clamp && strcmp(v->model, "nh") == 0;
}

// The explicit loop's step is ek_sim_cfl_dt, the element eigenvalue bound
// of the model linearised at rest with the P-wave modulus lambda + 2 mu
// (body_tets.c; sim.h): right for the rest state (the rest rows hold it at
// nu = 0.499 too). A plane crush stores ~lambda/2 per unit volume; let go,
// the body re-expands at about the P-wave speed and overshoots (max J 1.6
// after 2 steps, 2.5 after 7 at nu = 0.49), and a volumetric term of degree
// 6 in F stiffens there: the largest eigenvalue of the per-element Hessian
// d2psi/dF2, over the elements, relative to its value at F = I (its
// stiffness against the CFL step's), measured for fixed corotated at 1x CFL
// (seed 1; the kernel's P matches the reference to 3e-15 relative up to the
// blow-up, so no kernel defect): nu = 0.3: peak 2.8, survives; nu = 0.45:
// 4.4, survives; nu = 0.49: 2.5 at step 2, 9.6 at step 17, 12 / 19 / 250 at
// steps 18 / 19 / 20, non-finite at 24; at 0.5x CFL nu = 0.49 peaks at 15.6
// and survives, nu = 0.499 runs away from step ~45. Stable neo-Hookean and
// the clamped variants end the same (steps 19-52). So at nu >= 0.49 the
// rest CFL step is not a stability bound for the crushed rows of a model
// that stiffens: they claim nothing (NONE, reported) instead of SURVIVE;
// whether such a model recovers from the crush at nu >= 0.49 is the
// implicit rows' claim (fixed corotated and stable neo-Hookean: PASS).
// Linear (constant K) and ARAP (no lambda) keep SURVIVE.
#define NEAR_INCOMPRESSIBLE_NU 0.49
#define STIFFENED_SOURCE                                                                           \
  "explicit at the rest CFL step, nu >= 0.49: the re-expanding crush overshoots (J to 1.6-2.5) "   \
  "where lambda (J - 1)^2 stiffens: per-element tangent stiffness 2.5x the rest one after 2 "      \
  "steps, 12-250x just before the blow-up (fixed corotated, measured); the rest CFL step does "    \
  "not bound those states"
static int explicit_stiffened(const ext_variant *v, const ext_case *c, const ext_loop *l) {
  return l->kind == LOOP_EXPLICIT && c->kind == CASE_CRUSH_PLANE && v->stiffens &&
         c->nu >= NEAR_INCOMPRESSIBLE_NU;
}

static expectation expect_for(const ext_variant *v, const ext_case *c, const ext_loop *l) {
  if (l->kind == LOOP_XPBD) {
    // Rest: the pair's forces vanish at F = I (P(I) = 0, xpbd.h), so x = X
    // is the projection's fixed point. Crushes: stable neo-Hookean's C_H
    // = J - a has the gradient cof F, restoring under inversion (Macklin &
    // Mueller 2021; Smith et al. 2018); StVK's constraint is 0 at every
    // reflection (Irving et al. 2004): not expected to recover.
    // The point crush: F = 0 is a stationary point of stable neo-Hookean's
    // psi (P(0) = 0): there grad C_D is 0/0 (dropped) and grad C_H = cof F
    // ~ |F|^2, so the projection barely moves a body crushed to a point
    // within noise 1e-4 L (measured V/V0 1.6e-11 after 30 tc, f64 and f32;
    // the explicit and implicit snh rows without a clamp end the same).
    if (c->kind == CASE_REST)
      return EXPECT_SURVIVE;
    if (c->kind == CASE_CRUSH_POINT)
      return EXPECT_NOT;
    return strcmp(v->model, "snh") == 0 ? EXPECT_SURVIVE : EXPECT_NOT;
  }
  if (l->kind == LOOP_EXPLICIT && l->cfl_factor > 1.0)
    return EXPECT_NONE;
  if (c->kind == CASE_REST)
    return EXPECT_SURVIVE;
  expectation e = l->kind == LOOP_EXPLICIT ? v->crush_explicit : v->crush_implicit;
  if (e == EXPECT_SURVIVE && (snh_point(v, c) || nh_clamp_point(v, c)))
    return EXPECT_NOT;
  if (e == EXPECT_SURVIVE && explicit_stiffened(v, c, l))
    return EXPECT_NONE;
  return e;
}

// Why a row expects what it does (the JSON's expect_source).
static const char *expect_source(const ext_variant *v, const ext_case *c, const ext_loop *l,
                                 expectation e) {
  if (e == EXPECT_NONE && l->cfl_factor > 1.0)
    return "2x the CFL step: past symplectic Euler's limit";
  if (c->kind == CASE_REST)
    return "Smith et al. 2018: rest stability";
  if (l->kind != LOOP_XPBD && snh_point(v, c))
    return SNH_POINT_SOURCE;
  if (e == EXPECT_NOT && nh_clamp_point(v, c))
    return NH_CLAMP_POINT_SOURCE;
  if (explicit_stiffened(v, c, l) && e == EXPECT_NONE && v->crush_explicit == EXPECT_SURVIVE)
    return STIFFENED_SOURCE;
  return v->source;
}

// ---- One row ----

typedef struct {
  int finite, restoring, volume; // verdicts (1 / 0)
  double measure;                // crush: shape error; rest: max displacement (/ L diag)
  double volume_ratio;
  size_t inverted;
  long steps, planned;
  double dt, dt_cfl;
  long unconverged; // implicit steps above newton_tol
  char error[200];
  double seconds;
} ext_result;

// A message on one line (truncated to n - 1 bytes); dst may be src.
static void copy_error(char *dst, size_t n, const char *src) {
  size_t i = 0;
  for (; i + 1 < n && src[i]; i++)
    dst[i] = src[i] == '\n' || src[i] == '"' ? ' ' : src[i];
  dst[i] = '\0';
}

// Set the crushed start state: every vertex projected onto the mid-plane
// (plane) or onto the centre (point), plus noise from a stream that depends
// on the seed and the case only, so every model starts from the same state.
static void crush_state(const ext_case *c, uint64_t seed, size_t nv, const double *X, double L,
                        double *x) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, c->name));
  double a = NOISE * L;
  for (size_t i = 0; i < nv; i++)
    for (int k = 0; k < 3; k++) {
      double centre = 0.5 * L;
      int flatten = c->kind == CASE_CRUSH_POINT || k == 2;
      x[3 * i + k] = (flatten ? centre : X[3 * i + k]) + a * (2.0 * ek_rng_uniform(&rng) - 1.0);
    }
}

static int run_row(const ek_scene *base, const ext_variant *v, const ext_case *c, const ext_loop *l,
                   int precision, uint64_t seed, ext_result *r) {
  memset(r, 0, sizeof *r);
  struct timespec ts0, ts1;
  clock_gettime(CLOCK_MONOTONIC, &ts0);
  ek_scene s = *base;
  double L = c->L > 0 ? c->L : BASE_L, E = c->E > 0 ? c->E : BASE_E,
         nu = c->nu > 0 ? c->nu : BASE_NU;
  s.mesh_file[0] = '\0';
  for (int k = 0; k < 3; k++) {
    s.box_cells[k] = CELLS;
    s.box_size[k] = L;
    s.init_scale[k] = 1;
    s.init_translate[k] = 0;
    s.init_velocity[k] = 0;
    s.gravity[k] = 0;
  }
  s.nbc = 0;
  s.has_ground = 0;
  s.output_file[0] = '\0';
  ek_model model = EK_MODEL_COUNT;
  ek_model_from_name(v->model, &model);
  s.material.model = model;
  s.material.clamp = v->clamp ? base->material.clamp : 0.0;
  s.young = E;
  s.poisson = nu;
  if (ek_lame_from_young_poisson(E, nu, &s.material.mu, &s.material.lambda) != 0) {
    copy_error(r->error, sizeof r->error, ek_last_error());
    return -1;
  }
  snprintf(s.model_name, sizeof s.model_name, "%s", ek_scene_model_name(model));
  s.precision = precision;
  double c_s = sqrt(s.material.mu / s.density), tc = L / c_s, duration = DURATION_TC * tc;
  s.damping = c->kind == CASE_REST ? 0.0 : DAMPING_TC / tc;

  ek_mesh *mesh = ek_scene_mesh(&s);
  if (!mesh) {
    copy_error(r->error, sizeof r->error, ek_last_error());
    return -1;
  }
  // The CFL step is the sim's (ek_sim_cfl_dt); a first sim at a small dt
  // reads it, the row's sim is built at its multiple.
  if (l->kind == LOOP_EXPLICIT) {
    s.dt = 1e-30;
    ek_sim *probe = ek_sim_create(&s, mesh);
    if (!probe) {
      copy_error(r->error, sizeof r->error, ek_last_error());
      ek_mesh_destroy(mesh);
      return -1;
    }
    r->dt_cfl = ek_sim_cfl_dt(probe);
    ek_sim_destroy(probe);
    s.dt = l->cfl_factor * r->dt_cfl;
    r->planned = (long)ceil(duration / s.dt);
  } else if (l->kind == LOOP_XPBD) {
    s.integrator = EK_INTEGRATOR_XPBD;
    s.xpbd.substeps = XPBD_SUBSTEPS;
    s.xpbd.iterations = XPBD_ITERATIONS;
    s.xpbd.solver = EK_XPBD_GAUSS_SEIDEL;
    s.xpbd.elements = EK_XPBD_TETS;
    s.dt = XPBD_DT;
    r->planned = (long)fmax(ceil(duration / s.dt), IMPLICIT_MIN_STEPS);
  } else {
    s.dt = IMPLICIT_DT;
    r->planned = (long)fmax(ceil(duration / s.dt), IMPLICIT_MIN_STEPS);
  }
  s.steps = r->planned;
  r->dt = s.dt;
  // The explicit loop warns on stderr when dt is above the CFL step; the 2x
  // rows ask for that on purpose (their dt is in the JSON), so the warning
  // is silenced for them and stderr keeps the progress lines.
  int quiet = l->kind == LOOP_EXPLICIT && l->cfl_factor > 1.0;
  int saved_stderr = -1;
  if (quiet) {
    fflush(stderr);
    int devnull = open("/dev/null", O_WRONLY);
    saved_stderr = devnull >= 0 ? dup(STDERR_FILENO) : -1;
    if (saved_stderr >= 0)
      dup2(devnull, STDERR_FILENO);
    if (devnull >= 0)
      close(devnull);
  }
  ek_sim *sim = ek_sim_create(&s, mesh);
  if (saved_stderr >= 0) {
    fflush(stderr);
    dup2(saved_stderr, STDERR_FILENO);
    close(saved_stderr);
  }
  if (!sim) {
    copy_error(r->error, sizeof r->error, ek_last_error());
    ek_mesh_destroy(mesh);
    return -1;
  }
  if (l->kind != LOOP_EXPLICIT)
    r->dt_cfl = ek_sim_cfl_dt(sim);

  size_t nv = ek_mesh_nverts(mesh), nt = ek_mesh_ntets(mesh);
  const double *X = ek_mesh_rest_positions(mesh);
  const int32_t *T = ek_mesh_tets(mesh);
  double size = sqrt(3.0) * L, centre[3] = {0.5 * L, 0.5 * L, 0.5 * L};
  double V0 = ek_stab_volume(nt, T, X);
  int rc = 0;
  if (c->kind != CASE_REST) {
    double *x = malloc(3 * nv * sizeof(double));
    if (!x) {
      ek_sim_destroy(sim);
      ek_mesh_destroy(mesh);
      snprintf(r->error, sizeof r->error, "out of memory");
      return -1;
    }
    crush_state(c, seed, nv, X, L, x);
    rc = ek_sim_set_state(sim, x, NULL);
    free(x);
    if (rc) {
      copy_error(r->error, sizeof r->error, ek_last_error());
      ek_sim_destroy(sim);
      ek_mesh_destroy(mesh);
      return -1;
    }
  }

  r->finite = 1;
  for (long n = 0; n < r->planned; n++) {
    rc = ek_sim_step(sim);
    if (rc) {
      char msg[160];
      snprintf(msg, sizeof msg, "%s", ek_last_error());
      snprintf(r->error, sizeof r->error, "%s%s",
               rc == EK_SIM_EINVERTED      ? "inverted: "
               : rc == EK_SIM_EUNCONVERGED ? "not converged: "
                                           : "step failed: ",
               msg);
      copy_error(r->error, sizeof r->error, r->error);
      // A non-finite force is a blow-up; an inverted element outside the
      // model's domain and a Newton solve that failed (EK_SIM_EUNCONVERGED)
      // are refusals with the state still finite: the row fails as not
      // restored, its note says why.
      if (rc != EK_SIM_EINVERTED && rc != EK_SIM_EUNCONVERGED)
        r->finite = 0;
      break;
    }
    r->steps = n + 1;
    if (!ek_stab_finite(3 * nv, ek_sim_positions(sim), centre, size)) {
      r->finite = 0;
      snprintf(r->error, sizeof r->error, "diverged at step %ld (t = %.3g s)", n + 1,
               ek_sim_time(sim));
      break;
    }
  }
  const double *x = ek_sim_positions(sim);
  r->finite = r->finite && ek_stab_finite(3 * nv, x, centre, size);
  r->inverted = ek_stab_inverted(nt, T, x);
  r->volume_ratio = ek_stab_volume(nt, T, x) / V0;
  r->volume =
      r->finite && ek_stab_volume_recovered(ek_stab_volume(nt, T, x), V0, EK_SIM_VOLUME_TOL);
  if (c->kind == CASE_REST) {
    r->measure = ek_stab_max_displacement(nv, X, x, size);
    r->restoring = r->finite && r->measure <= ek_stab_rest_tol(precision);
  } else {
    r->measure = ek_stab_shape_error(nv, X, x, ek_sim_masses(sim), size);
    r->restoring = r->finite && r->inverted == 0 && r->measure <= EK_STAB_SHAPE_TOL;
  }
  r->unconverged = ek_sim_timings(sim)->unconverged_steps;
  ek_sim_destroy(sim);
  ek_mesh_destroy(mesh);
  clock_gettime(CLOCK_MONOTONIC, &ts1);
  r->seconds = (double)(ts1.tv_sec - ts0.tv_sec) + 1e-9 * (double)(ts1.tv_nsec - ts0.tv_nsec);
  return 0;
}

static const char *yes_no(int v) { return v ? "yes" : "no"; }

// The row's status from its expectation and whether it survived.
static const char *status_of(expectation e, int survived, int setup_error) {
  if (setup_error)
    return "ERROR";
  switch (e) {
  case EXPECT_SURVIVE:
    return survived ? "PASS" : "FAIL";
  case EXPECT_NOT:
    return survived ? "xpass" : "xfail";
  case EXPECT_NONE:
    break;
  }
  return survived ? "ok" : "broke";
}

// One line per model, one column per loop: how many of its rows ended in
// each status (from the rows already emitted).
static void print_summary(struct cJSON *rows_json) {
  static const char *const statuses[] = {"PASS", "FAIL", "xfail", "xpass", "ok", "broke", "ERROR"};
  enum { NSTATUS = sizeof statuses / sizeof statuses[0] };
  printf("\nsummary (rows per status):\n%-18s", "model");
  for (int li = 0; li < NLOOPS; li++)
    printf(" | %-24s", loops[li].name);
  printf("\n");
  for (int vi = 0; vi < NVARIANTS; vi++) {
    int counts[NLOOPS][NSTATUS] = {{0}}, any = 0;
    cJSON *row;
    cJSON_ArrayForEach(row, rows_json) {
      if (strcmp(cJSON_GetObjectItem(row, "model")->valuestring, variants[vi].name) != 0)
        continue;
      const char *loop = cJSON_GetObjectItem(row, "loop")->valuestring;
      const char *status = cJSON_GetObjectItem(row, "status")->valuestring;
      for (int li = 0; li < NLOOPS; li++)
        for (int k = 0; k < NSTATUS && strcmp(loop, loops[li].name) == 0; k++)
          if (strcmp(status, statuses[k]) == 0) {
            counts[li][k]++;
            any = 1;
          }
    }
    if (!any)
      continue;
    printf("%-18s", variants[vi].name);
    for (int li = 0; li < NLOOPS; li++) {
      char cell[64] = "";
      size_t used = 0;
      for (int k = 0; k < NSTATUS; k++)
        if (counts[li][k] && used < sizeof cell)
          used += (size_t)snprintf(cell + used, sizeof cell - used, "%s%d %s", used ? " " : "",
                                   counts[li][k], statuses[k]);
      printf(" | %-24s", cell[0] ? cell : "-");
    }
    printf("\n");
  }
}

static double now_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int verify_extremes(ek_verify_ctx *ctx, struct cJSON *rows_json, struct cJSON *known_json) {
  int quick = ek_verify_quick(ctx);
  uint64_t seed = ek_verify_seed(ctx);
  ek_scene base[2];
  const char *base_names[2] = {"crush", "crush_implicit"};
  for (int b = 0; b < 2; b++) {
    char path[1024], err[1024] = "";
    if (ek_shipped_scene(base_names[b], path, sizeof path, err, sizeof err) != 0 ||
        ek_scene_load(path, &base[b]) != 0) {
      fprintf(stderr, "ek-verify --extremes: base scene %s: %s\n", base_names[b],
              err[0] ? err : ek_last_error());
      return -1;
    }
  }
  ek_verify_note(ctx,
                 "extremes: cube of %d^3 cells x 6 tets from scenes crush.json (explicit) and "
                 "crush_implicit.json (implicit); crush noise %g L; %g shear crossing times, "
                 "damping %g / tc; rest undamped",
                 CELLS, NOISE, DURATION_TC, DAMPING_TC);
  ek_verify_note(ctx,
                 "extremes: restoring = no inverted tet and shape error (Kabsch-aligned max "
                 "vertex distance / body diagonal) <= %g; rest: max displacement / body "
                 "diagonal <= %g (f64), %g (f32); volume: |V/V0 - 1| <= %g",
                 EK_STAB_SHAPE_TOL, EK_STAB_REST_TOL_F64, EK_STAB_REST_TOL_F32, EK_SIM_VOLUME_TOL);
  ek_verify_note(ctx,
                 "extremes: XPBD at 1/60 s, %d substeps x %d Gauss-Seidel sweeps, on "
                 "crush_implicit.json's scene, for stvk (expected not to recover) and snh "
                 "(Macklin & Mueller 2021 constraints), cases at the base E and L",
                 XPBD_SUBSTEPS, XPBD_ITERATIONS);

  // Count the rows first, for the progress line.
  int total = 0;
  for (int vi = 0; vi < NVARIANTS; vi++)
    for (int ci = 0; ci < NCASES; ci++)
      for (int li = 0; li < NLOOPS; li++)
        for (int p = 0; p < 2; p++) {
          const ext_variant *v = &variants[vi];
          const ext_case *c = &cases[ci];
          const ext_loop *l = &loops[li];
          char var[64];
          snprintf(var, sizeof var, "%s %s", l->name, p ? "f32" : "f64");
          if ((!quick || (v->quick && c->quick && l->quick)) && is_row(v, c, l) &&
              ek_verify_selected(ctx, v->name, var, c->name))
            total++;
        }

  printf("\n%-18s %-16s %-4s %-21s %-8s %-7s %-6s %-9s %-6s %-9s %-8s %-11s %-6s %s\n", "model",
         "loop", "prec", "case", "expect", "finite", "restor", "measure", "volume", "V/V0",
         "inverted", "steps", "status", "note");
  int done = 0, failures = 0, setup_errors = 0;
  double t0 = now_s(), last_progress = t0;
  for (int vi = 0; vi < NVARIANTS; vi++)
    for (int ci = 0; ci < NCASES; ci++)
      for (int li = 0; li < NLOOPS; li++)
        for (int p = 0; p < 2; p++) {
          const ext_variant *v = &variants[vi];
          const ext_case *c = &cases[ci];
          const ext_loop *l = &loops[li];
          int precision = p ? 32 : 64;
          char var[64];
          snprintf(var, sizeof var, "%s %s", l->name, p ? "f32" : "f64");
          if ((quick && !(v->quick && c->quick && l->quick)) || !is_row(v, c, l) ||
              !ek_verify_selected(ctx, v->name, var, c->name))
            continue;
          ext_result r;
          const ek_scene *b = &base[l->kind != LOOP_EXPLICIT];
          int setup = run_row(b, v, c, l, precision, seed, &r) != 0;
          expectation e = expect_for(v, c, l);
          // A row whose step failed (a refusal with a finite state) did not
          // survive, whatever the state it stopped at.
          int survived = !setup && r.finite && r.restoring && r.volume && r.steps == r.planned;
          const char *status = status_of(e, survived, setup);
          int failed = setup || (e == EXPECT_SURVIVE && !survived);
          failures += failed;
          setup_errors += setup;
          char steps[32];
          snprintf(steps, sizeof steps, "%ld/%ld", r.steps, r.planned);
          printf("%-18s %-16s %-4s %-21s %-8s %-7s %-6s %9.2e %-6s %9.3g %-8zu %-11s %-6s", v->name,
                 l->name, p ? "f32" : "f64", c->name, expect_names[e],
                 setup ? "-" : yes_no(r.finite), setup ? "-" : yes_no(r.restoring), r.measure,
                 setup ? "-" : yes_no(r.volume), r.volume_ratio, r.inverted, steps, status);
          if (r.unconverged)
            printf(" [%ld steps above newton_tol]", r.unconverged);
          if (r.error[0])
            printf(" %s", r.error);
          printf("\n");

          cJSON *j = cJSON_CreateObject();
          cJSON_AddStringToObject(j, "model", v->name);
          cJSON_AddStringToObject(j, "loop", l->name);
          cJSON_AddStringToObject(j, "precision", p ? "f32" : "f64");
          cJSON_AddStringToObject(j, "case", c->name);
          cJSON_AddStringToObject(j, "expect", expect_names[e]);
          cJSON_AddStringToObject(j, "expect_source", expect_source(v, c, l, e));
          cJSON_AddBoolToObject(j, "finite", !setup && r.finite);
          cJSON_AddBoolToObject(j, "restoring", !setup && r.restoring);
          cJSON_AddBoolToObject(j, "volume_recovered", !setup && r.volume);
          cJSON_AddStringToObject(j, "measure_name",
                                  c->kind == CASE_REST ? "max_displacement" : "shape_error");
          cJSON_AddNumberToObject(j, "measure", isfinite(r.measure) ? r.measure : 1e308);
          cJSON_AddNumberToObject(
              j, "bound", c->kind == CASE_REST ? ek_stab_rest_tol(precision) : EK_STAB_SHAPE_TOL);
          cJSON_AddNumberToObject(j, "volume_ratio",
                                  isfinite(r.volume_ratio) ? r.volume_ratio : 1e308);
          cJSON_AddNumberToObject(j, "inverted", (double)r.inverted);
          cJSON_AddNumberToObject(j, "steps", (double)r.steps);
          cJSON_AddNumberToObject(j, "steps_planned", (double)r.planned);
          cJSON_AddNumberToObject(j, "dt", r.dt);
          cJSON_AddNumberToObject(j, "dt_cfl", r.dt_cfl);
          cJSON_AddNumberToObject(j, "unconverged_steps", (double)r.unconverged);
          cJSON_AddNumberToObject(j, "seconds", r.seconds);
          if (r.error[0])
            cJSON_AddStringToObject(j, "error", r.error);
          cJSON_AddStringToObject(j, "status", status);
          cJSON_AddItemToArray(rows_json, j);
          if (failed) {
            char line[400];
            snprintf(line, sizeof line, "%s | %s %s | %s: %s%s%s", v->name, l->name,
                     p ? "f32" : "f64", c->name,
                     setup                 ? "setup error"
                     : !r.finite           ? "not finite"
                     : r.steps < r.planned ? "step refused"
                     : !r.restoring
                         ? (c->kind == CASE_REST ? "did not stay at rest" : "not restored")
                         : "volume not recovered",
                     r.error[0] ? " - " : "", r.error);
            cJSON_AddItemToArray(known_json, cJSON_CreateString(line));
          }

          done++;
          double t = now_s();
          if (t - last_progress > 5.0 || done == total) {
            fprintf(stderr, "ek-verify --extremes: %d/%d rows, %.0f s\n", done, total, t - t0);
            last_progress = t;
          }
        }
  print_summary(rows_json);
  int nknown = cJSON_GetArraySize(known_json);
  if (nknown) {
    printf("\nknown failures (an expectation from the literature that did not hold):\n");
    for (int k = 0; k < nknown; k++)
      printf("  %s\n", cJSON_GetArrayItem(known_json, k)->valuestring);
  }
  printf("\nextremes: %d rows, %d failing, %.1f s\n", done, failures, now_s() - t0);
  return setup_errors ? -1 : failures;
}
