// Invariants of the explicit loop (symplectic Euler + FVM force):
//  1. An undamped, unpinned, gravity-free elastic body, initially stretched
//     and moving, keeps its total energy within EK_SIM_ENERGY_TOL over 1000
//     steps and its momentum within EK_SIM_MOMENTUM_TOL_F64 (internal
//     forces sum to zero per tet).
//  2. The shipped cantilever (scenes/cantilever.json), damped to rest under
//     gravity, has the Euler-Bernoulli tip deflection q L^4 / (8 E I)
//     within EK_SIM_CANTILEVER_TOL.
//  3. The shipped crushed cube (scenes/crush.json, invertible model) goes
//     back to its rest volume within EK_SIM_VOLUME_TOL after release; the
//     same crush with plain neo-Hookean is reported as an inversion
//     (EK_SIM_EINVERTED, state kept, no crash).
//  4. The same run gives the same bits at 1, 2 and 3 threads.
//  5. ek-verify --extremes' expectations at the extremes (verify_extremes.c)
//     rest on two measured facts, held here so a change shows: stable
//     neo-Hookean crushed to within 1e-4 L of a point is still a point
//     after 30 shear crossing times (P = O(|F|^2) at F = 0) while from
//     1e-2 L it recovers its volume; and a plane crush at nu = 0.49 drives
//     fixed corotated to states stiffer than rest (the rest CFL step does
//     not bound them) while linear elasticity (constant K) at nu = 0.499
//     recovers at 1x the CFL step (the step is right for the P-wave).
//
// Mesh sizes keep the test under ~60 s on 2 cores: the energy body is
// 4 x 4 x 4 cubes (384 tets, 1000 steps). The cantilever is 100 x 1 x 10
// cells (6000 tets): linear tets lock in bending, and 10 elements through
// the thickness are what brings the tip within the budget (4 gave a beam
// 17% too stiff; the width needs 1, the beam does not bend across it);
// 15000 f32 steps at dt = 0.76 h_min / c reach rest (critical damping of
// the first mode). The crushed cube is 6 x 6 x 6 cubes (1296 tets). The
// long runs use 1 thread: results do not depend on the thread count
// (checked by the threads test) and 1 thread keeps the run time steady on
// a shared 2-core machine.
#include <ek/sim/sim.h>

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "material/material_ref.h"
#include "test_sim_common.h"
#include "test_tolerances.h"

static unsigned long long rng_state;
static double uniform(double lo, double hi) {
  rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
  return lo + (hi - lo) * (double)(rng_state >> 11) / 9007199254740992.0;
}

static int load_scene(const char *name, ek_scene *s) {
  char path[1200];
  snprintf(path, sizeof path, "%s/%s.json", scenes_dir, name);
  if (ek_scene_load(path, s) != 0) {
    printf("cannot load %s: %s\n", path, ek_last_error());
    failures++;
    return -1;
  }
  s->output_file[0] = '\0'; // tests write no frames
  return 0;
}

// ------------------------------------------------------------ 1. energy

static void energy_test(const char *model, int precision) {
  char json[1024], what[96];
  // Random stretch and drift (seeded): the body starts away from rest.
  double sx = uniform(1.05, 1.15), sy = uniform(0.9, 1.0), sz = uniform(1.0, 1.1);
  double vx = uniform(-0.5, 0.5), vy = uniform(-0.5, 0.5), vz = uniform(-0.5, 0.5);
  snprintf(json, sizeof json,
           "{\"mesh\": {\"box\": [4, 4, 4], \"size\": [0.1, 0.1, 0.1]},"
           " \"initial\": {\"scale\": [%.17g, %.17g, %.17g], \"velocity\": [%.17g, %.17g, %.17g]},"
           " \"material\": {\"model\": \"%s\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000},"
           " \"precision\": \"f%d\", \"dt\": 1e-5, \"steps\": 1000}",
           sx, sy, sz, vx, vy, vz, model, precision);
  ek_scene s;
  if (ek_scene_parse(json, "energy.json", ".", &s) != 0) {
    printf("energy scene: %s\n", ek_last_error());
    failures++;
    return;
  }
  ek_mesh *m = ek_scene_mesh(&s);
  ek_sim *sim = m ? ek_sim_create(&s, m) : NULL;
  if (!sim) {
    printf("energy sim: %s\n", ek_last_error());
    failures++;
    ek_mesh_destroy(m);
    return;
  }
  // The bound EK_SIM_ENERGY_TOL is stated for dt = EK_SIM_ENERGY_DT_CFL *
  // ek_sim_cfl_dt.
  s.dt = EK_SIM_ENERGY_DT_CFL * ek_sim_cfl_dt(sim);
  ek_sim_destroy(sim);
  sim = ek_sim_create(&s, m);
  size_t nv = ek_mesh_nverts(m);
  const double *mass = ek_sim_masses(sim);
  ek_sim_energies e;
  ek_sim_energy(sim, &e);
  double E0 = e.kinetic + e.elastic + e.potential, p0[3], p[3];
  // ek_sim_energy measures the elastic part from the rest shape, so E0 is
  // the energy available to move.
  double E_avail = E0;
  ek_sim_momentum(sim, p0);
  double max_dE = 0, max_dp = 0, scale_p = 0, worst_t = 0;
  int rc = 0;
  for (int n = 0; n < 1000 && rc == 0; ++n) {
    rc = ek_sim_step(sim);
    ek_sim_energy(sim, &e);
    double dE = fabs(e.kinetic + e.elastic + e.potential - E0);
    if (!(dE <= max_dE)) {
      max_dE = dE;
      worst_t = ek_sim_time(sim);
    }
    ek_sim_momentum(sim, p);
    const double *v = ek_sim_velocities(sim);
    double sum_mv = 0;
    for (size_t i = 0; i < nv; ++i)
      sum_mv += mass[i] * sqrt(v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] +
                               v[3 * i + 2] * v[3 * i + 2]);
    scale_p = fmax(scale_p, sum_mv);
    double dp = sqrt((p[0] - p0[0]) * (p[0] - p0[0]) + (p[1] - p0[1]) * (p[1] - p0[1]) +
                     (p[2] - p0[2]) * (p[2] - p0[2]));
    max_dp = fmax(max_dp, dp);
  }
  char detail[256];
  snprintf(detail, sizeof detail, "E0 %.6g J, max |E - E0| %.3g J at t = %.3g, dt %.3g, rc %d",
           E_avail, max_dE, worst_t, s.dt, rc);
  snprintf(what, sizeof what, "energy, %s f%d, 1000 steps", model, precision);
  report(what, rc == 0 ? max_dE / E_avail : INFINITY, EK_SIM_ENERGY_TOL, detail);
  if (rc)
    printf("    step failed: %s\n", ek_last_error());
  if (precision == 64) {
    snprintf(what, sizeof what, "momentum, %s f64", model);
    snprintf(detail, sizeof detail, "|p0| = %.6g, max |p - p0| = %.3g",
             sqrt(p0[0] * p0[0] + p0[1] * p0[1] + p0[2] * p0[2]), max_dp);
    report(what, max_dp / scale_p, EK_SIM_MOMENTUM_TOL_F64, detail);
  }
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

// ------------------------------------------------------------ 2. cantilever

static void cantilever_test(void) {
  omp_set_num_threads(1);
  ek_scene s;
  if (load_scene("cantilever", &s))
    return;
  ek_mesh *m = ek_scene_mesh(&s);
  ek_sim *sim = m ? ek_sim_create(&s, m) : NULL;
  if (!sim) {
    printf("cantilever: %s\n", ek_last_error());
    failures++;
    ek_mesh_destroy(m);
    return;
  }
  double L = s.box_size[0], b = s.box_size[1], h = s.box_size[2];
  // Tip deflection: mean vertical displacement of the free end face (the
  // beam axis' deflection at x = L).
  double tip_prev = 0, tip = 0;
  int rc = 0;
  long check_at = s.steps * 9 / 10;
  for (long n = 0; n < s.steps && rc == 0; ++n) {
    rc = ek_sim_step(sim);
    if (n + 1 == check_at || n + 1 == s.steps) {
      tip_prev = tip;
      tip = -end_face_dz(m, ek_sim_positions(sim), L);
    }
  }
  // Euler-Bernoulli, uniform load q = rho g A on a clamped beam:
  // delta = q L^4 / (8 E I), I = b h^3 / 12 (Timoshenko & Gere, Mechanics of
  // Materials, table of beam deflections, case "cantilever, uniform load").
  double q = s.density * fabs(s.gravity[2]) * b * h;
  double I = b * h * h * h / 12.0;
  double delta_eb = q * L * L * L * L / (8.0 * s.young * I);
  char detail[256];
  snprintf(detail, sizeof detail,
           "tip %.6e m, Euler-Bernoulli %.6e m, change over last 10%% of steps %.2e", tip, delta_eb,
           fabs(tip - tip_prev) / delta_eb);
  report("cantilever tip deflection vs Euler-Bernoulli",
         rc ? INFINITY : fabs(tip - delta_eb) / delta_eb, EK_SIM_CANTILEVER_TOL, detail);
  if (rc)
    printf("    step failed: %s\n", ek_last_error());
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

// ------------------------------------------------------------ 3. crush

static void crush_test(void) {
  omp_set_num_threads(1);
  ek_scene s;
  if (load_scene("crush", &s))
    return;
  char detail[256];
  ek_mesh *m = ek_scene_mesh(&s);
  ek_sim *sim = m ? ek_sim_create(&s, m) : NULL;
  if (!sim) {
    printf("crush: %s\n", ek_last_error());
    failures++;
    ek_mesh_destroy(m);
    return;
  }
  double V0 = ek_sim_volume(sim), Vmin = V0;
  size_t max_inverted = 0;
  int rc = 0;
  for (long n = 0; n < s.steps && rc == 0; ++n) {
    rc = ek_sim_step(sim);
    double V = ek_sim_volume(sim);
    if (V < Vmin) {
      Vmin = V;
      max_inverted = ek_sim_inverted_count(sim);
    }
  }
  double V = ek_sim_volume(sim);
  ek_sim_energies e;
  ek_sim_energy(sim, &e);
  snprintf(detail, sizeof detail,
           "V0 %.6g, smallest V %.3g V0 (%zu tets inverted then), final V %.6g, kinetic %.2e J", V0,
           Vmin / V0, max_inverted, V, e.kinetic);
  char what[96];
  snprintf(what, sizeof what, "crushed cube (%s, clamp %g) rest volume", s.model_name,
           s.material.clamp);
  report(what, rc ? INFINITY : fabs(V - V0) / V0, EK_SIM_VOLUME_TOL, detail);
  if (rc)
    printf("    step failed: %s\n", ek_last_error());
  ek_sim_destroy(sim);

  // Neo-Hookean without clamp is undefined for J <= 0: push the top face
  // past the base (until 0.7 s: 0.252 m of travel on a 0.2 m cube) so some
  // tets must invert, and expect the loop to say so.
  s.material.model = EK_MODEL_NEO_HOOKEAN;
  s.material.clamp = 0;
  snprintf(s.model_name, sizeof s.model_name, "neo_hookean");
  s.bc[1].until = 0.7;
  sim = ek_sim_create(&s, m);
  rc = 0;
  long n = 0;
  for (; n < s.steps && rc == 0; ++n)
    rc = ek_sim_step(sim);
  const double *x = ek_sim_positions(sim);
  int finite = 1;
  for (size_t i = 0; i < 3 * ek_mesh_nverts(m); ++i)
    finite &= isfinite(x[i]) != 0;
  const char *msg = ek_last_error();
  snprintf(detail, sizeof detail, "rc %d at step %ld, state finite %d: %s", rc, n - 1, finite, msg);
  check("neo-Hookean crush reports inversion",
        rc == EK_SIM_EINVERTED && finite && strstr(msg, "inverted") && strstr(msg, "neo_hookean") &&
            n > 1,
        detail);
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

// ------------------------------------------------------------ 4. threads

// The same run of scene s (steps steps) at 1, 2 and 3 threads (3: more
// threads than the 2-core hosts' cores); m is destroyed.
static void same_bits_threads(ek_scene *s, ek_mesh *m, int steps, const char *name) {
  size_t n3 = 3 * ek_mesh_nverts(m);
  double *x1 = malloc(n3 * sizeof(double));
  int ok = 1;
  long mismatches = 0;
  for (int threads = 1; threads <= 3; ++threads) {
    omp_set_num_threads(threads);
    ek_sim *sim = ek_sim_create(s, m);
    int rc = sim ? 0 : -1;
    for (int n = 0; n < steps && rc == 0; ++n)
      rc = ek_sim_step(sim);
    ok &= rc == 0;
    const double *x = sim ? ek_sim_positions(sim) : NULL;
    if (!x)
      ;
    else if (threads == 1)
      memcpy(x1, x, n3 * sizeof(double));
    else
      for (size_t i = 0; i < n3; ++i)
        mismatches += memcmp(&x[i], &x1[i], sizeof(double)) != 0;
    ek_sim_destroy(sim);
  }
  omp_set_num_threads(1);
  char what[128], detail[128];
  snprintf(what, sizeof what, "%s: same bits at 1, 2 and 3 threads", name);
  snprintf(detail, sizeof detail, "%d steps: %ld of %zu coordinates differ", steps, mismatches, n3);
  check(what, ok && mismatches == 0, detail);
  free(x1);
  ek_mesh_destroy(m);
}

// The cantilever (6000 tets, an SVD model) is above the force's parallel
// grain (EK_FVM_PARALLEL_MIN_TETS_SVD), so its 2-thread run really splits
// the work; the smaller scenes run their force on one thread. A box of
// 24 025 vertices is above the integration's grain (explicit.c
// EXPLICIT_PARALLEL_GRAIN), pinned at one end, falling onto the ground.
static void threads_test(void) {
  ek_scene s;
  if (load_scene("cantilever", &s))
    return;
  ek_mesh *m = ek_scene_mesh(&s);
  if (!m) {
    printf("cantilever: %s\n", ek_last_error());
    failures++;
    return;
  }
  if (ek_mesh_ntets(m) < EK_FVM_PARALLEL_MIN_TETS_SVD) {
    printf("threads test: %zu tets, below the parallel grain: FAIL\n", ek_mesh_ntets(m));
    failures++;
  }
  same_bits_threads(&s, m, 300, "cantilever");
  const char *box = "{\"mesh\": {\"box\": [30, 30, 24], \"size\": [0.3, 0.3, 0.24]},"
                    " \"initial\": {\"velocity\": [0, 0, -1]},"
                    " \"material\": {\"model\": \"neo_hookean\", \"E\": 1e5, \"nu\": 0.3,"
                    " \"density\": 1000}, \"precision\": \"f32\", \"damping\": 1,"
                    " \"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": [0, 0, 0],"
                    " \"max\": [0, 0.3, 0.24]}}], \"gravity\": [0, 0, -9.81],"
                    " \"ground\": {\"height\": 0.0001}, \"dt\": 1e-5, \"steps\": 1}";
  if (ek_scene_parse(box, "box.json", ".", &s) != 0 || !(m = ek_scene_mesh(&s))) {
    printf("box scene: %s\n", ek_last_error());
    failures++;
    return;
  }
  same_bits_threads(&s, m, 4, "box of 24025 vertices");
}

// ------------------------------------------------------------ 5. extremes

// The crush of ek-verify --extremes on its 0.2 m cube of 4^3 cells (E 1e5
// Pa, density 1000): every vertex on the mid-plane (or at the centre, point)
// plus uniform noise of `noise` L per coordinate, damping 2 / tc (tc = L /
// sqrt(mu / rho)), dt = cfl x ek_sim_cfl_dt, 30 tc of steps.
static int crushed(run *r, const char *model, double nu, int point, double noise, double cfl) {
  const double L = 0.2, E = 1e5, rho = 1000, tc = L / sqrt(E / (2 * (1 + nu)) / rho);
  char json[1024];
  double dt = 1e-30; // below any CFL limit: no warning; the first sim reads the limit
  for (int pass = 0; pass < 2; pass++) {
    snprintf(json, sizeof json,
             "{\"mesh\": {\"box\": [4, 4, 4], \"size\": [%g, %g, %g]},"
             " \"material\": {\"model\": \"%s\", \"E\": %g, \"nu\": %g, \"density\": %g},"
             " \"damping\": %.17g, \"dt\": %.17g, \"steps\": %ld}",
             L, L, L, model, E, nu, rho, 2 / tc, dt, pass ? (long)ceil(30 * tc / dt) : 1L);
    if (start(r, json, 0))
      return -1;
    if (pass == 0) {
      dt = cfl * ek_sim_cfl_dt(r->sim);
      finish(r);
    }
  }
  size_t n3 = 3 * ek_mesh_nverts(r->mesh);
  const double *X = ek_mesh_rest_positions(r->mesh);
  double *x = malloc(n3 * sizeof(double));
  for (size_t i = 0; x && i < n3; i++)
    x[i] = (point || i % 3 == 2 ? 0.5 * L : X[i]) + noise * L * uniform(-1, 1);
  int rc = x ? ek_sim_set_state(r->sim, x, NULL) : -1;
  free(x);
  if (rc) {
    check("crushed start state", 0, ek_last_error());
    finish(r);
    return -1;
  }
  return 0;
}

// Runs the crush to its end (or its first failed step); V / V0 at the end.
static double crush_volume_ratio(run *r, int *rc) {
  const double V0 = 0.2 * 0.2 * 0.2;
  *rc = 0;
  for (long n = 0; n < r->scene.steps && *rc == 0; n++)
    *rc = ek_sim_step(r->sim);
  return ek_sim_volume(r->sim) / V0;
}

// Largest eigenvalue of a symmetric 9x9 matrix: power iteration on H + s I,
// s = |H|_F >= every |eigenvalue|, so the top of the shifted spectrum is
// the top of H's.
static double max_eigenvalue9(const double *H) {
  double s = 0, v[9], w[9], top = 0;
  for (int k = 0; k < 81; k++)
    s += H[k] * H[k];
  s = sqrt(s);
  for (int i = 0; i < 9; i++)
    v[i] = 1.0 + 0.1 * i;
  for (int it = 0; it < 2000; it++) {
    double n = 0;
    for (int i = 0; i < 9; i++) {
      w[i] = s * v[i];
      for (int j = 0; j < 9; j++)
        w[i] += 0.5 * (H[9 * i + j] + H[9 * j + i]) * v[j];
      n += w[i] * w[i];
    }
    n = sqrt(n);
    for (int i = 0; i < 9; i++)
      v[i] = w[i] / n;
    top = n - s;
  }
  return top;
}

// Max over the tets of the largest eigenvalue of d2psi/dF2 at the sim's
// state, over the same at F = I (the reference Hessian, material_ref.h).
static double stiffness_ratio(const run *r, const ek_material_ref *m) {
  size_t nt = ek_mesh_ntets(r->mesh);
  double *F = malloc(9 * nt * sizeof(double)), H[81], top = 0;
  const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  if (!F || ek_mesh_deformation_gradients_f64(r->mesh, ek_sim_positions(r->sim), F) != 0) {
    free(F);
    return NAN;
  }
  for (size_t e = 0; e < nt; e++) {
    ek_hessian_ref(m, F + 9 * e, NULL, H, 0);
    top = fmax(top, max_eigenvalue9(H));
  }
  free(F);
  ek_hessian_ref(m, I, NULL, H, 0);
  return top / max_eigenvalue9(H);
}

static void extremes_test(void) {
  omp_set_num_threads(1);
  char detail[256];
  run r;
  int rc;
  // Stable neo-Hookean at F = 0: P(eps A) scales as eps^2 (P(0) = 0, dP(0)
  // = 0), the reason a point crush within 1e-4 L does not recover in 30 tc.
  const ek_material snh = {EK_MODEL_STABLE_NEO_HOOKEAN, 3.8e4, 5.8e4, 0};
  double A[18] = {0.9, 0.2, -0.1, 0.1, 1.1, 0.3, -0.2, 0.1, 1.0}, P[18], nP[2] = {0, 0};
  for (int k = 0; k < 9; k++)
    A[9 + k] = 1e-5 * A[k], A[k] *= 1e-2;
  ek_pk1_f64(&snh, 2, A, NULL, P);
  for (int k = 0; k < 9; k++)
    nP[0] += P[k] * P[k], nP[1] += P[9 + k] * P[9 + k];
  double order = log(sqrt(nP[0] / nP[1])) / log(10.0);
  snprintf(detail, sizeof detail, "|P(1e-2 A)| / |P(1e-5 A)| = 10^%.3f (|F|^2: 10^6)", order);
  check("stable neo-Hookean: P = O(|F|^2) at F = 0", fabs(order - 6) < 0.05, detail);
  if (crushed(&r, "stable_neo_hookean", 0.3, 1, 1e-4, 1.0) == 0) {
    double ratio = crush_volume_ratio(&r, &rc);
    snprintf(detail, sizeof detail, "V/V0 %.3g after 30 tc (rc %d)", ratio, rc);
    check("stable neo-Hookean point crush within 1e-4 L: still a point after 30 tc",
          rc == 0 && ratio < 1e-6, detail);
    finish(&r);
  }
  if (crushed(&r, "stable_neo_hookean", 0.3, 1, 1e-2, 1.0) == 0) {
    double ratio = crush_volume_ratio(&r, &rc);
    snprintf(detail, sizeof detail, "V/V0 %.6g after 30 tc (rc %d)", ratio, rc);
    report("stable neo-Hookean point crush within 1e-2 L: volume after 30 tc",
           rc ? INFINITY : fabs(ratio - 1), EK_SIM_VOLUME_TOL, detail);
    finish(&r);
  }
  // Fixed corotated, plane crush at nu = 0.49, 1x CFL: two steps re-expand
  // it past rest (measured max J 1.6), where its Hessian is 2.5x the rest
  // one, above what the rest CFL step bounds.
  if (crushed(&r, "fixed_corotated", 0.49, 0, 1e-4, 1.0) == 0) {
    rc = ek_sim_step(r.sim);
    if (rc == 0)
      rc = ek_sim_step(r.sim);
    ek_material_ref m = {EK_MODEL_FIXED_COROTATED, r.scene.material.mu, r.scene.material.lambda, 0};
    double ratio = rc ? NAN : stiffness_ratio(&r, &m);
    snprintf(detail, sizeof detail, "largest element Hessian after 2 steps %.3g x the rest one",
             ratio);
    check("fixed corotated plane crush at nu = 0.49: stiffer than rest after 2 steps",
          rc == 0 && ratio > 2, detail);
    finish(&r);
  }
  // Linear elasticity (constant K) at nu = 0.499, 1x the CFL step: the
  // step bounds its every state, and the body recovers.
  if (crushed(&r, "linear", 0.499, 0, 1e-4, 1.0) == 0) {
    double ratio = crush_volume_ratio(&r, &rc);
    snprintf(detail, sizeof detail, "V/V0 %.6g after 30 tc, dt %g (rc %d)", ratio, r.scene.dt, rc);
    report("linear plane crush at nu = 0.499, 1x CFL: volume after 30 tc",
           rc ? INFINITY : fabs(ratio - 1), EK_SIM_VOLUME_TOL, detail);
    finish(&r);
  }
}

int main(int argc, char **argv) {
  unsigned long long seed = scenes_dir_init(argc, argv);
  printf("test_sim_explicit --seed %llu (scenes from %s)\n", seed, scenes_dir);
  rng_state = seed;
  energy_test("fixed_corotated", 64);
  energy_test("stable_neo_hookean", 64);
  energy_test("stvk", 64);
  energy_test("fixed_corotated", 32);
  threads_test();
  crush_test();
  cantilever_test();
  extremes_test();
  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
