// Cloth in the simulation loops (sim.h with a triangle mesh):
//   a. a flat cloth at rest stays at rest (explicit f64 and f32, implicit),
//      with the quadratic bending on;
//   b. a free, stretched cloth without gravity keeps its momentum
//      (explicit, undamped);
//   c. the shipped cloth scenes run finite, the pinned corners stay put and
//      the hanging cloth sags below them;
//   d. the same bits at 1 and 2 threads (above the force's parallel
//      threshold), explicit and implicit;
//   e. frames: /mesh/triangles, the per-triangle fields and an XDMF with a
//      Triangle topology;
//   g. the velocity gradient fields (sim.h, ek_sim_rate_fields) of a rigid
//      spin: D = 0, W = [omega]x, no strain rate, cloth and tets;
//   f. scene errors: a cloth without thickness, a tet model on triangles,
//      "cloth" on a tet mesh, a bad grid plane, XPBD clusters on a cloth.
// The loops: explicit (f32 and f64), implicit and XPBD (double).
#include <ek/sim/sim.h>
#include <hdf5.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "cli.h"
#include "test_tolerances.h"
static int failures = 0;
static char scenes_dir[1024];

static void report(const char *what, double err, double budget) {
  double r = err / budget;
  const char *v = ek_verdict_name(ek_check_verdict(err, budget));
  printf("%-62s err %.3e  budget %.1e  err/budget %.3f  %s\n", what, err, budget, r, v);
  if (!(r <= 1.0))
    failures++;
}

static void check(const char *what, int ok, const char *detail) {
  printf("%-62s %s  %s\n", what, ok ? "PASS" : "FAIL", detail ? detail : "");
  if (!ok)
    failures++;
}

// A flat cloth at rest: max |x - X| / L after the steps, rounding of the
// rest forces (EK_CLOTH_REST_TOL_*) integrated over the run. f64: 1e-12 of
// the size; f32 positions go through float (6e-8 relative): 1e-6.
#define REST_TOL_F64 1e-12
#define REST_TOL_F32 1e-6
// g. A rigid spin's D (and strain rates, and W - [omega]x) relative to
// omega: L = Vs Ds^-1 (Ds^+) from positions and velocities rounded at
// ~1e-16 of |x| ~ 1 m over edges of ~0.2 m, times the condition of Ds
// (< 10 here): ~1e-14; 1e-10 leaves room.
#define RATE_TOL 1e-10

typedef struct {
  ek_scene scene;
  ek_trimesh *mesh;
  ek_sim *sim;
} run;

static int start(run *r, const char *json_or_name, int is_file) {
  char path[1200];
  memset(r, 0, sizeof *r);
  int rc;
  if (is_file) {
    snprintf(path, sizeof path, "%s/%s.json", scenes_dir, json_or_name);
    rc = ek_scene_load(path, &r->scene);
  } else {
    rc = ek_scene_parse(json_or_name, "test.json", ".", &r->scene);
  }
  r->scene.output_file[0] = '\0';
  if (rc == 0 && (r->mesh = ek_scene_trimesh(&r->scene)))
    r->sim = ek_sim_create_cloth(&r->scene, r->mesh);
  if (!r->sim) {
    ek_trimesh_destroy(r->mesh);
    return -1;
  }
  return 0;
}

static void finish(run *r) {
  ek_sim_destroy(r->sim);
  ek_trimesh_destroy(r->mesh);
}

static int steps(run *r, int n) {
  for (int i = 0; i < n; ++i)
    if (ek_sim_step(r->sim) != 0) {
      printf("step %d: %s\n", i, ek_last_error());
      return -1;
    }
  return 0;
}

static int all_finite(const run *r) {
  const double *x = ek_sim_positions(r->sim);
  for (size_t i = 0; i < 3 * ek_trimesh_nverts(r->mesh); ++i)
    if (!isfinite(x[i]))
      return 0;
  return 1;
}

#define CLOTH(grid, extra)                                                                         \
  "{\"mesh\": {\"grid\": [" grid "], \"size\": [1, 1]}, \"material\": {\"model\": \"%s\", "        \
  "\"E\": 1e6, \"nu\": 0.3, \"density\": 400}, \"cloth\": {\"thickness\": 5e-4}, \"precision\": "  \
  "\"%s\", \"dt\": %g, \"steps\": 1" extra "}"

// Rank and dimensions (up to 2) of a dataset; -1 when it does not open.
static int dims_of(hid_t file, const char *name, hsize_t *dims) {
  hid_t ds = H5Dopen2(file, name, H5P_DEFAULT);
  if (ds < 0)
    return -1;
  hid_t sp = H5Dget_space(ds);
  int rank = H5Sget_simple_extent_ndims(sp);
  hsize_t d[8] = {0};
  if (rank > 0 && rank <= 8)
    H5Sget_simple_extent_dims(sp, d, NULL);
  for (int i = 0; i < rank && i < 2; ++i)
    dims[i] = d[i];
  H5Sclose(sp);
  H5Dclose(ds);
  return rank;
}

int main(int argc, char **argv) {
  const char *scenes = NULL;
  ek_cli_test_args(argc, argv, 1, &scenes); // deterministic: the seed is unused
  snprintf(scenes_dir, sizeof scenes_dir, "%s", __FILE__);
  char *slash = strrchr(scenes_dir, '/');
  if (slash)
    snprintf(slash, sizeof scenes_dir - (size_t)(slash - scenes_dir), "/../scenes");
  if (scenes)
    snprintf(scenes_dir, sizeof scenes_dir, "%s", scenes);
  char err[1024], json[2048], what[200];
  run r;

  // a. at rest, no gravity, no boundary conditions.
  const char *models[] = {"stvk", "arap"};
  for (int mi = 0; mi < 2; ++mi)
    for (int prec = 32; prec <= 64; prec += 32)
      for (int implicit = 0; implicit < 3; ++implicit) {
        // 1 implicit, 2 XPBD: the cloth's paths there are double either way.
        static const char *integ[] = {"explicit", "implicit", "xpbd"};
        if (implicit && prec == 32)
          continue;
        snprintf(json, sizeof json, CLOTH("16, 16", ", \"integrator\": {\"type\": \"%s\"}"),
                 models[mi], prec == 32 ? "f32" : "f64", implicit ? 1e-2 : 2e-4, integ[implicit]);
        snprintf(what, sizeof what, "a. %s f%d %s: flat cloth at rest stays (max |x - X| / L)",
                 models[mi], prec, integ[implicit]);
        if (start(&r, json, 0)) {
          check(what, 0, ek_last_error());
          continue;
        }
        int ok = steps(&r, implicit ? 10 : 200) == 0;
        const double *x = ek_sim_positions(r.sim), *X = ek_trimesh_rest_positions(r.mesh);
        double d = 0;
        for (size_t i = 0; i < 3 * ek_trimesh_nverts(r.mesh); ++i)
          d = fmax(d, fabs(x[i] - X[i]));
        report(what, ok ? d / sqrt(2.0) : INFINITY, prec == 32 ? REST_TOL_F32 : REST_TOL_F64);
        finish(&r);
      }

  // b. momentum: stretched by 10% in x, squeezed in y, moving; undamped,
  // no gravity, f64.
  for (int mi = 0; mi < 2; ++mi) {
    snprintf(json, sizeof json,
             CLOTH("12, 10", ", \"initial\": {\"scale\": [1.1, 0.9, 1], \"velocity\": [0.3, "
                             "-0.2, 0.5]}"),
             models[mi], "f64", 2e-4);
    snprintf(what, sizeof what, "b. %s: momentum kept, 500 free steps", models[mi]);
    if (start(&r, json, 0)) {
      check(what, 0, ek_last_error());
      continue;
    }
    double p0[3], p1[3], mag = 0;
    ek_sim_momentum(r.sim, p0);
    int ok = steps(&r, 500) == 0;
    ek_sim_momentum(r.sim, p1);
    const double *v = ek_sim_velocities(r.sim), *m = ek_sim_masses(r.sim);
    for (size_t i = 0; i < ek_trimesh_nverts(r.mesh); ++i)
      mag += m[i] *
             sqrt(v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
    double dp = sqrt((p1[0] - p0[0]) * (p1[0] - p0[0]) + (p1[1] - p0[1]) * (p1[1] - p0[1]) +
                     (p1[2] - p0[2]) * (p1[2] - p0[2]));
    ek_sim_energies e;
    ek_sim_energy(r.sim, &e);
    report(what, ok ? dp / mag : INFINITY, EK_SIM_MOMENTUM_TOL_F64);
    check("b. ... and the cloth vibrates (elastic energy > 0)", e.elastic > 0, NULL);
    finish(&r);
  }

  // c. shipped scenes.
  const char *shipped[] = {"cloth_hang", "cloth_drop", "cloth_hang_implicit", "cloth_hang_xpbd"};
  const int nsteps[] = {1000, 1000, 10, 6};
  for (int k = 0; k < 4; ++k) {
    snprintf(what, sizeof what, "c. %s: %d steps finite", shipped[k], nsteps[k]);
    if (start(&r, shipped[k], 1)) {
      check(what, 0, ek_last_error());
      continue;
    }
    int ok = steps(&r, nsteps[k]) == 0 && all_finite(&r);
    check(what, ok, NULL);
    const double *x = ek_sim_positions(r.sim);
    size_t nv = ek_trimesh_nverts(r.mesh);
    double zmin = INFINITY, zmax = -INFINITY;
    for (size_t i = 0; i < nv; ++i) {
      zmin = fmin(zmin, x[3 * i + 2]);
      zmax = fmax(zmax, x[3 * i + 2]);
    }
    if (k != 1) {
      // Pinned corners: the grid's last row ends (rest z = 1, x = 0 and 1).
      const double *X = ek_trimesh_rest_positions(r.mesh);
      int pinned_ok = 1, npinned = 0;
      for (size_t i = 0; i < nv; ++i)
        if (X[3 * i + 2] == 1 && (X[3 * i] == 0 || X[3 * i] == 1)) {
          npinned++;
          pinned_ok &= memcmp(x + 3 * i, X + 3 * i, 3 * sizeof(double)) == 0;
        }
      snprintf(err, sizeof err, "lowest z %.4g m after %.3g s", zmin, ek_sim_time(r.sim));
      check("c. ... two corners pinned exactly, the rest sags below them",
            pinned_ok && npinned == 2 && zmax <= 1 + 1e-9 && zmin < -1e-3, err);
    } else {
      snprintf(err, sizeof err, "z in [%.4g, %.4g] m after %.3g s", zmin, zmax, ek_sim_time(r.sim));
      check("c. ... the dropped cloth falls and stays above the ground", zmin >= 0 && zmax < 0.3,
            err);
    }
    if (k == 2) {
      const ek_sim_times *tm = ek_sim_timings(r.sim);
      snprintf(err, sizeof err, "%ld Newton iterations, %ld CG, worst residual %.3g",
               tm->newton_iterations, tm->cg_iterations, tm->worst_residual);
      check("c. ... implicit: every step converged", tm->unconverged_steps == 0, err);
    }
    finish(&r);
  }

  // d. 1 vs 2 threads on 48 x 48 cells = 4608 triangles (above
  // EK_CLOTH_PARALLEL_MIN_TRIS), hanging from two corners, both precisions.
  const char *hang = ", \"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": [0, 1, 0], "
                     "\"max\": [0, 1, 0]}}, {\"type\": \"pin\", \"region\": {\"min\": [1, 1, "
                     "0], \"max\": [1, 1, 0]}}], \"gravity\": [0, -9.81, 0], \"damping\": 1, "
                     "\"integrator\": {\"type\": \"%s\"}";
  for (int mi = 0; mi < 2; ++mi)
    for (int variant = 0; variant < 4; ++variant) {
      const char *prec = variant == 1 ? "f32" : "f64";
      const char *integ = variant == 2 ? "implicit" : variant == 3 ? "xpbd" : "explicit";
      char fmt[1024];
      snprintf(fmt, sizeof fmt, "%s", CLOTH("48, 48", "%s"));
      char tail[512];
      snprintf(tail, sizeof tail, hang, integ);
      snprintf(json, sizeof json, fmt, models[mi], prec, variant >= 2 ? 1e-2 : 1e-4, tail);
      double *x1 = NULL;
      size_t n3 = 0;
      long mism = -1;
      int ok = 1;
      for (int threads = 1; threads <= 3 && ok; ++threads) {
        omp_set_num_threads(threads);
        if (start(&r, json, 0)) {
          ok = 0;
          break;
        }
        n3 = 3 * ek_trimesh_nverts(r.mesh);
        ok = steps(&r, variant >= 2 ? 2 : 50) == 0 && all_finite(&r);
        const double *x = ek_sim_positions(r.sim);
        if (threads == 1) {
          x1 = malloc(n3 * sizeof(double));
          memcpy(x1, x, n3 * sizeof(double));
        } else {
          mism = mism < 0 ? 0 : mism;
          for (size_t i = 0; i < n3; ++i)
            mism += memcmp(x + i, x1 + i, sizeof(double)) != 0;
        }
        finish(&r);
      }
      free(x1);
      snprintf(what, sizeof what, "d. %s %s %s: same bits at 1, 2 and 3 threads", models[mi], prec,
               integ);
      snprintf(err, sizeof err, "%ld of %zu coordinates differ", mism, n3);
      check(what, ok && mism == 0, err);
    }
  omp_set_num_threads(2);

  // e. frames.
  {
    char h5[512], xmf[600];
    snprintf(h5, sizeof h5, "/tmp/ek_test_sim_cloth_%ld.h5", (long)getpid());
    ek_frames_xdmf_path(h5, xmf, sizeof xmf);
    snprintf(json, sizeof json, CLOTH("4, 3", ""), "stvk", "f64", 1e-4);
    int ok = start(&r, json, 0) == 0;
    size_t nt = ok ? ek_trimesh_ntris(r.mesh) : 0, nv = ok ? ek_trimesh_nverts(r.mesh) : 0;
    ek_frames *fr = ok ? ek_frames_create_ex(h5, 1, nv, ek_trimesh_rest_positions(r.mesh), nt, 3,
                                             ek_trimesh_tris(r.mesh))
                       : NULL;
    double J[64], s1[64], s2[64], psi[64];
    for (int f = 0; fr && f < 2; ++f) {
      ok &= ek_sim_cloth_fields(r.sim, J, s1, s2, psi) == 0;
      double D[9 * 64], W[9 * 64], rates[3 * 64], VR[9 * 64];
      ok &= ek_sim_rate_fields(r.sim, D, W, rates) == 0;
      ok &= ek_sim_vertex_rotations(r.sim, VR) == 0;
      const ek_frame_fields ff = {J, s2, psi, s1, D, W, rates, VR};
      ok &= ek_frames_write_fields(fr, ek_sim_time(r.sim), f, ek_sim_positions(r.sim), &ff) == 0;
      ok &= steps(&r, 1) == 0;
    }
    ok &= fr && ek_frames_close(fr) == 0;
    check("e. frames written for a cloth", ok, ok ? NULL : ek_last_error());
    check("e. ... J = 1 and stretches 1 at rest", fabs(J[0] - 1) < 1e-12 && fabs(s1[0] - 1) < 1e-12,
          NULL);
    // sim.h's layout: one dataset per frame and field, /frames/<field>/NNNNNN.
    hid_t file = H5Fopen(h5, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (file >= 0) {
      hsize_t tri[2], t[2], D[2], VR[2], smax[2];
      int rank_tri = dims_of(file, "/mesh/triangles", tri),
          rank_t = dims_of(file, "/frames/time", t);
      int rank_D = dims_of(file, "/frames/D/000001", D);
      int rank_VR = dims_of(file, "/frames/vertex_rotation/000001", VR);
      int rank_smax = dims_of(file, "/frames/smax/000001", smax);
      double s1_read[64];
      hid_t ds = H5Dopen2(file, "/frames/smax/000001", H5P_DEFAULT);
      int read_ok = ds >= 0 && rank_smax == 1 && smax[0] == nt &&
                    H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, s1_read) >= 0;
      if (ds >= 0)
        H5Dclose(ds);
      H5Fclose(file);
      check("e. /mesh/triangles ntris x 3, /frames/time 2 frames",
            rank_tri == 2 && tri[0] == nt && tri[1] == 3 && rank_t == 1 && t[0] == 2, NULL);
      check("e. /frames/D/000001 ntris x 9, /frames/vertex_rotation/000001 nverts x 9",
            rank_D == 2 && D[0] == nt && D[1] == 9 && rank_VR == 2 && VR[0] == nv && VR[1] == 9,
            NULL);
      check("e. /frames/smax/000001 ntris: the larger stretches as written",
            read_ok && memcmp(s1_read, s1, nt * sizeof(double)) == 0, NULL);
    } else {
      check("e. the HDF5 file opens", 0, h5);
    }
    FILE *x = fopen(xmf, "r");
    char buf[8192] = "";
    size_t n = x ? fread(buf, 1, sizeof buf - 1, x) : 0;
    buf[n] = 0;
    if (x)
      fclose(x);
    check("e. XDMF: Triangle topology on /mesh/triangles; smax, D, vertex_rotation attributes",
          strstr(buf, "TopologyType=\"Triangle\"") && strstr(buf, ":/mesh/triangles") &&
              strstr(buf, "Name=\"smax\"") && strstr(buf, "Name=\"D\" AttributeType=\"Tensor\"") &&
              strstr(buf, "Name=\"vertex_rotation\" AttributeType=\"Tensor\" Center=\"Node\""),
          NULL);
    remove(h5);
    remove(xmf);
    if (r.sim)
      finish(&r);
  }

  // f. scene errors.
  {
    ek_scene s;
    int rc = ek_scene_parse("{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": "
                            "{\"model\": \"stvk\", \"E\": 1e6, \"nu\": 0.3, \"density\": 400}, "
                            "\"dt\": 1e-4, \"steps\": 1}",
                            "f1.json", ".", &s);
    check("f. a cloth without cloth.thickness refused", rc != 0 && strstr(ek_last_error(), "cloth"),
          ek_last_error());
    rc = ek_scene_parse("{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": "
                        "{\"model\": \"neo_hookean\", \"E\": 1e6, \"nu\": 0.3, \"density\": 400}, "
                        "\"cloth\": {\"thickness\": 1e-3}, \"dt\": 1e-4, \"steps\": 1}",
                        "f2.json", ".", &s);
    check("f. a tet model on a cloth refused (material.model)",
          rc != 0 && strstr(ek_last_error(), "material.model"), ek_last_error());
    rc = ek_scene_parse("{\"mesh\": {\"box\": [2, 2, 2], \"size\": [1, 1, 1]}, \"material\": "
                        "{\"model\": \"stvk\", \"E\": 1e6, \"nu\": 0.3, \"density\": 400}, "
                        "\"cloth\": {\"thickness\": 1e-3}, \"dt\": 1e-4, \"steps\": 1}",
                        "f3.json", ".", &s);
    check("f. \"cloth\" on a tet mesh refused", rc != 0 && strstr(ek_last_error(), "cloth"),
          ek_last_error());
    rc = ek_scene_parse("{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1], \"plane\": \"yz\"}, "
                        "\"material\": {\"model\": \"stvk\", \"E\": 1e6, \"nu\": 0.3, "
                        "\"density\": 400}, \"cloth\": {\"thickness\": 1e-3}, \"dt\": 1e-4, "
                        "\"steps\": 1}",
                        "f4.json", ".", &s);
    check("f. mesh.plane \"yz\" refused", rc != 0 && strstr(ek_last_error(), "mesh.plane"),
          ek_last_error());
    rc = ek_scene_parse("{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": "
                        "{\"model\": \"stvk\", \"E\": 1e6, \"nu\": 0.3, \"density\": 400}, "
                        "\"cloth\": {\"thickness\": 1e-3}, \"dt\": 1e-4, \"steps\": 1, "
                        "\"integrator\": {\"type\": \"xpbd\", \"elements\": \"clusters\"}}",
                        "f5.json", ".", &s);
    ek_trimesh *tm = rc == 0 ? ek_scene_trimesh(&s) : NULL;
    ek_sim *sim = tm ? ek_sim_create_cloth(&s, tm) : NULL;
    check("f. XPBD clusters on a cloth refused with a message",
          !sim && strstr(ek_last_error(), "xpbd"), ek_last_error());
    ek_sim_destroy(sim);
    ek_trimesh_destroy(tm);
  }

  // g. the velocity gradient of a rigid spin about z (every vertex held by
  // a twist condition, so v = omega x (x - c) exactly): D = 0, W = [omega]x
  // and no strain rate, for a cloth in the xy plane (the spin lies in its
  // plane, so L = [omega]x P = [omega]x) and for a tet box.
  {
    const double omega = 2.0;
    const char *twist = "\"boundary\": [{\"type\": \"twist\", \"region\": {\"min\": [-1, -1, "
                        "-1], \"max\": [2, 2, 2]}, \"axis\": [0, 0, 1], \"center\": [0.5, 0.5, "
                        "0], \"rate\": 2}]";
    for (int tets = 0; tets < 2; ++tets) {
      if (tets)
        snprintf(json, sizeof json,
                 "{\"mesh\": {\"box\": [3, 3, 2], \"size\": [1, 1, 0.5]}, \"material\": "
                 "{\"model\": \"stvk\", \"E\": 1e6, \"nu\": 0.3, \"density\": 400}, %s, "
                 "\"dt\": 1e-4, \"steps\": 1}",
                 twist);
      else
        snprintf(json, sizeof json,
                 "{\"mesh\": {\"grid\": [6, 5], \"size\": [1, 1]}, \"material\": {\"model\": "
                 "\"stvk\", \"E\": 1e6, \"nu\": 0.3, \"density\": 400}, \"cloth\": "
                 "{\"thickness\": 5e-4}, %s, \"dt\": 1e-4, \"steps\": 1}",
                 twist);
      ek_scene sc;
      ek_mesh *tm = NULL;
      ek_trimesh *cm = NULL;
      ek_sim *sim = NULL;
      if (ek_scene_parse(json, "g.json", ".", &sc) == 0) {
        if (tets && (tm = ek_scene_mesh(&sc)))
          sim = ek_sim_create(&sc, tm);
        if (!tets && (cm = ek_scene_trimesh(&sc)))
          sim = ek_sim_create_cloth(&sc, cm);
      }
      snprintf(what, sizeof what, "g. %s, rigid spin: |D|, |W - [omega]x|, |rates| / omega",
               tets ? "tets" : "cloth");
      if (!sim || ek_sim_step(sim) != 0) {
        check(what, 0, ek_last_error());
      } else {
        size_t ne = tets ? ek_mesh_ntets(tm) : ek_trimesh_ntris(cm);
        double *D = malloc(9 * ne * sizeof(double)), *W = malloc(9 * ne * sizeof(double)),
               *rt = malloc(3 * ne * sizeof(double)), e = 0;
        const double Wx[9] = {0, -omega, 0, omega, 0, 0, 0, 0, 0};
        int rc = ek_sim_rate_fields(sim, D, W, rt);
        for (size_t i = 0; rc == 0 && i < ne; ++i) {
          for (int k = 0; k < 9; ++k)
            e = fmax(e, fmax(fabs(D[9 * i + k]), fabs(W[9 * i + k] - Wx[k])));
          for (int k = 0; k < 3; ++k)
            e = fmax(e, fabs(rt[3 * i + k]));
        }
        report(what, rc == 0 ? e / omega : INFINITY, RATE_TOL);
        // The one-ring Kabsch rotations: Rz(omega t) at every vertex.
        size_t nvx = tets ? ek_mesh_nverts(tm) : ek_trimesh_nverts(cm);
        double *VR = malloc(9 * nvx * sizeof(double)), er = 0, th = omega * ek_sim_time(sim);
        const double Rz[9] = {cos(th), -sin(th), 0, sin(th), cos(th), 0, 0, 0, 1};
        rc = ek_sim_vertex_rotations(sim, VR);
        for (size_t i = 0; rc == 0 && i < nvx; ++i)
          for (int k = 0; k < 9; ++k)
            er = fmax(er, fabs(VR[9 * i + k] - Rz[k]));
        snprintf(what, sizeof what, "g. %s, rigid spin: one-ring Kabsch rotations vs Rz(omega t)",
                 tets ? "tets" : "cloth");
        report(what, rc == 0 ? er : INFINITY, RATE_TOL);
        free(VR);
        free(D), free(W), free(rt);
      }
      ek_sim_destroy(sim);
      ek_mesh_destroy(tm);
      ek_trimesh_destroy(cm);
    }
  }

  printf("%s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures != 0;
}
