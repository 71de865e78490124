// The simulation API a program uses without knowing the element kind
// (sim.h; ek-sim runs on it) and the state check every loop reports
// (ek_sim_check, issue 25):
//  1. ek_sim_create_scene on a tet scene (drop) and a cloth (cloth_hang)
//     gives the mesh ek_scene_mesh / ek_scene_trimesh build: the same
//     counts, corners, incidence and rest positions, bit for bit; the
//     fields of ek_sim_fields equal ek_sim_tet_fields / ek_sim_cloth_fields
//     bit for bit after some steps; the force's phase names and their count
//     (4 tets, 3 triangles); a describe line naming the element count.
//  2. ek_sim_check: at rest nothing inverted, nothing non-finite, the extent
//     is 0.5 body sizes (a vertex at a corner of the rest bounding box); the
//     tests/data/inverts.json scene ends with all its 24 tets inverted; a
//     body thrown at 1e9 m/s is blown up; the scene's allow flags are
//     copied.
#include <ek/sim/sim.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_sim_common.h"

static int same_bits(const void *a, const void *b, size_t bytes) {
  return a && b && memcmp(a, b, bytes) == 0;
}

static void kind_test(const char *name, int cloth, int steps) {
  char path[1200], what[96], detail[160];
  ek_scene s;
  snprintf(path, sizeof path, "%s/%s.json", scenes_dir, name);
  if (ek_scene_load(path, &s) != 0) {
    printf("cannot load %s: %s\n", path, ek_last_error());
    failures++;
    return;
  }
  s.output_file[0] = '\0';
  ek_sim *sim = ek_sim_create_scene(&s);
  ek_mesh *m = cloth ? NULL : ek_scene_mesh(&s);
  ek_trimesh *tm = cloth ? ek_scene_trimesh(&s) : NULL;
  ek_sim *ref =
      cloth ? (tm ? ek_sim_create_cloth(&s, tm) : NULL) : (m ? ek_sim_create(&s, m) : NULL);
  snprintf(what, sizeof what, "%s: ek_sim_create_scene", name);
  check(what, sim && ref, sim && ref ? "" : ek_last_error());
  if (!sim || !ref)
    goto done;
  ek_sim_elements e;
  ek_sim_elements_of(sim, &e);
  size_t nv = cloth ? ek_trimesh_nverts(tm) : ek_mesh_nverts(m);
  size_t ne = cloth ? ek_trimesh_ntris(tm) : ek_mesh_ntets(m);
  const int32_t *inc = cloth ? ek_trimesh_tris(tm) : ek_mesh_tets(m);
  const double *X = cloth ? ek_trimesh_rest_positions(tm) : ek_mesh_rest_positions(m);
  const int corners = cloth ? 3 : 4;
  snprintf(what, sizeof what, "%s: elements (kind, counts, incidence, rest)", name);
  snprintf(detail, sizeof detail, "%s %zu x %d, %zu vertices", e.kind, e.count, e.corners,
           e.nverts);
  check(what,
        strcmp(e.kind, cloth ? "triangles" : "tets") == 0 && e.count == ne &&
            e.corners == corners && e.nverts == nv && e.has_smax == cloth && e.oriented == !cloth &&
            same_bits(e.incidence, inc, ne * (size_t)corners * sizeof(int32_t)) &&
            same_bits(e.rest, X, 3 * nv * sizeof(double)),
        detail);
  char line[160];
  snprintf(what, sizeof what, "%s: describe", name);
  ek_sim_describe(sim, line, sizeof line);
  char want[64];
  snprintf(want, sizeof want, "%zu %s, ", ne, e.kind);
  check(what, strncmp(line, want, strlen(want)) == 0, line);

  int ok = 1;
  ek_sim_time_phases(sim, 1);
  for (int n = 0; n < steps && ok; ++n)
    ok = ek_sim_step(sim) == 0 && ek_sim_step(ref) == 0;
  const char *names[EK_SIM_MAX_PHASES];
  double secs[EK_SIM_MAX_PHASES];
  int np = ek_sim_force_phases(sim, names, secs, EK_SIM_MAX_PHASES);
  snprintf(what, sizeof what, "%s: force phases", name);
  snprintf(detail, sizeof detail, "%d phases, first \"%s\" %.3g s", np, np > 0 ? names[0] : "",
           np > 0 ? secs[0] : NAN);
  check(what, ok && np == (cloth ? 3 : 4) && secs[0] >= 0, detail);

  double *f[8];
  for (int i = 0; i < 8; ++i)
    f[i] = calloc(ne, sizeof(double));
  int frc = ek_sim_fields(sim, f[0], f[1], f[2], f[3]);
  int rrc = cloth ? ek_sim_cloth_fields(ref, f[4], f[7], f[5], f[6])
                  : ek_sim_tet_fields(ref, f[4], f[5], f[6]);
  int same = frc == 0 && rrc == 0;
  for (int i = 0; i < 3 && same; ++i)
    same = same_bits(f[i], f[4 + i], ne * sizeof(double));
  if (cloth && same)
    same = same_bits(f[3], f[7], ne * sizeof(double));
  snprintf(what, sizeof what, "%s: ek_sim_fields = the kind's fields", name);
  snprintf(detail, sizeof detail, "after %d steps, bit for bit", steps);
  check(what, same, detail);
  for (int i = 0; i < 8; ++i)
    free(f[i]);
done:
  ek_sim_destroy(sim);
  ek_sim_destroy(ref);
  ek_mesh_destroy(m);
  ek_trimesh_destroy(tm);
}

static void health_test(void) {
  char detail[160];
  // At rest.
  run r;
  if (start(&r, "drop", 1) == 0) {
    ek_sim_health h;
    ek_sim_set_state(r.sim, ek_mesh_rest_positions(r.mesh), NULL);
    int rc = ek_sim_check(r.sim, &h);
    snprintf(detail, sizeof detail, "%zu of %zu inverted, %zu non-finite, extent %.17g", h.inverted,
             h.elements, h.nonfinite, h.extent);
    check("check at rest: clean, extent 0.5",
          rc == 0 && h.inverted == 0 && h.nonfinite == 0 && fabs(h.extent - 0.5) < 1e-12 &&
              !h.blown_up,
          detail);
    finish(&r);
  }
  // tests/data/inverts.json: the top face driven through the bottom.
  char path[1200];
  snprintf(path, sizeof path, "%s/../tests/data/inverts.json", scenes_dir);
  ek_scene s;
  if (ek_scene_load(path, &s) != 0) {
    check("load tests/data/inverts.json", 0, ek_last_error());
    return;
  }
  ek_sim *sim = ek_sim_create_scene(&s);
  int ok = sim != NULL;
  for (long n = 0; ok && n < s.steps; ++n)
    ok = ek_sim_step(sim) == 0;
  ek_sim_health h = {0};
  ok = ok && ek_sim_check(sim, &h) == 0;
  snprintf(detail, sizeof detail, "%zu of %zu inverted (ek_sim_inverted_count %zu)", h.inverted,
           h.elements, sim ? ek_sim_inverted_count(sim) : 0);
  check("inverts.json ends with every tet inverted",
        ok && h.elements == 24 && h.inverted == 24 && !h.blown_up && !h.allow_inverted, detail);
  // The first inverted tet and its J = V / V0, for the messages: from the
  // positions and the scene's mesh (the same box) here.
  ek_mesh *im = ek_scene_mesh(&s);
  size_t first = (size_t)-1;
  double first_J = NAN;
  for (size_t e = 0; ok && im && e < ek_mesh_ntets(im) && first == (size_t)-1; ++e) {
    const int32_t *t = ek_mesh_tets(im) + 4 * e;
    const double *x = ek_sim_positions(sim), *a = x + 3 * t[0];
    double D[3][3];
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k)
        D[k][c] = x[3 * t[c + 1] + k] - a[k];
    const double V = (D[0][0] * (D[1][1] * D[2][2] - D[1][2] * D[2][1]) -
                      D[0][1] * (D[1][0] * D[2][2] - D[1][2] * D[2][0]) +
                      D[0][2] * (D[1][0] * D[2][1] - D[1][1] * D[2][0])) /
                     6;
    if (!(V > 0))
      first = e, first_J = V / ek_mesh_rest_volumes(im)[e];
  }
  snprintf(detail, sizeof detail, "first inverted %zu, J %.17g (from the positions: %zu, %.17g)",
           h.first_inverted, h.first_inverted_J, first, first_J);
  check("inverts.json: the first inverted tet and its J named",
        ok && h.first_inverted == first &&
            fabs(h.first_inverted_J - first_J) <= 1e-12 * fabs(first_J),
        detail);
  ek_mesh_destroy(im);
  ek_sim_destroy(sim);
  // The same scene allowed: the flag is copied.
  s.allow_inverted = 1;
  s.allow_nonfinite = 1;
  sim = ek_sim_create_scene(&s);
  ok = sim && ek_sim_check(sim, &h) == 0;
  check("allow flags copied", ok && h.allow_inverted && h.allow_nonfinite, "");
  ek_sim_destroy(sim);
  // A body thrown at 1e9 m/s for 20 s: finite, 2e10 m away.
  const char *blow = "{\"mesh\": {\"box\": [1, 1, 1], \"size\": [1, 1, 1]},"
                     " \"initial\": {\"velocity\": [1e9, 0, 0]},"
                     " \"material\": {\"model\": \"stvk\", \"E\": 1e5, \"nu\": 0.3, \"density\": "
                     "1000}, \"dt\": 10, \"steps\": 2}";
  if (start(&r, blow, 0) == 0) {
    ok = ek_sim_step(r.sim) == 0 && ek_sim_step(r.sim) == 0 && ek_sim_check(r.sim, &h) == 0;
    snprintf(detail, sizeof detail, "extent %.3g body sizes (limit %g)", h.extent,
             EK_SIM_BLOWUP_EXTENT);
    check("a finite blow-up is blown_up",
          ok && h.blown_up && h.nonfinite == 0 && h.extent > EK_SIM_BLOWUP_EXTENT, detail);
    // The vertex at the extent: the first farthest from the rest box's
    // centre, from the positions.
    const double *X = ek_mesh_rest_positions(r.mesh), *x = ek_sim_positions(r.sim);
    const size_t nv = ek_mesh_nverts(r.mesh);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < nv; ++i)
      for (int k = 0; k < 3; ++k)
        lo[k] = fmin(lo[k], X[3 * i + k]), hi[k] = fmax(hi[k], X[3 * i + k]);
    size_t far = 0;
    double r2 = -1;
    for (size_t i = 0; i < nv; ++i) {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = x[3 * i + k] - 0.5 * (lo[k] + hi[k]);
        d2 += d * d;
      }
      if (d2 > r2)
        r2 = d2, far = i;
    }
    snprintf(detail, sizeof detail, "farthest %zu (from the positions: %zu)", h.farthest, far);
    check("a blow-up names the farthest vertex", ok && h.farthest == far, detail);
    finish(&r);
  }
  check("ek_sim_check(NULL) refused", ek_sim_check(NULL, &h) == EK_EINVAL, ek_last_error());
  const double v[4] = {1, NAN, INFINITY, -INFINITY};
  check("ek_count_nonfinite", ek_count_nonfinite(v, 4) == 3 && ek_count_nonfinite(NULL, 4) == 0,
        "");
}

int main(int argc, char **argv) {
  unsigned long long seed = scenes_dir_init(argc, argv);
  (void)report; // test_sim_common.h: this test has no budgets
  printf("test_sim_api --seed %llu (scenes from %s)\n", seed, scenes_dir);
  kind_test("drop", 0, 20);
  kind_test("cloth_hang", 1, 20);
  health_test();
  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
