// Invariants checked: every good mesh file (TetGen 0- and 1-based, with
// attributes and markers, base name or either file; Gmsh v2 and v4.1 with
// non-tet elements) loads into the same unit cube (8 vertices, 6 positive
// tets, total volume 1); every kind of bad file or in-memory mesh gives
// NULL and an error naming file, line (or element) and value; the precompute
// is right (Dm Dm^-1 = I, V0 = det Dm / 6 > 0, lumped volumes sum to the
// total); the box generator is conforming (every face shared by at most two
// tets, the boundary has exactly the box's triangles) with volume
// lx*ly*lz. The element layer the mesh hands its arrays to (orders,
// colourings, packing) has its own test, tests/test_elements.c.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ek/sim/mesh.h>

#include "check.h"
#include "cli.h"

static int failures = 0;

static void fail(const char *what) {
  printf("FAIL: %s\n", what);
  failures++;
}

// Source-relative paths: __FILE__ is absolute under CMake.
static char data_dir[1024], scene_dir[1100];
static void init_dirs(void) {
  snprintf(data_dir, sizeof data_dir, "%s", __FILE__);
  char *slash = strrchr(data_dir, '/');
  if (slash)
    *slash = 0;
  else
    snprintf(data_dir, sizeof data_dir, ".");
  snprintf(scene_dir, sizeof scene_dir, "%s/../scenes/meshes", data_dir);
  strncat(data_dir, "/data/mesh", sizeof data_dir - strlen(data_dir) - 1);
}

// Dm of a tet from the rest positions, columns X_c - X_0.
static void rest_dm(const ek_mesh *m, size_t t, double Dm[9]) {
  const double *X = ek_mesh_rest_positions(m);
  const int32_t *T = ek_mesh_tets(m) + t * 4;
  for (int c = 0; c < 3; c++)
    for (int r = 0; r < 3; r++)
      Dm[r * 3 + c] = X[T[c + 1] * 3 + r] - X[T[0] * 3 + r];
}

static double maxabs9(const double A[9]) {
  double s = 0;
  for (int k = 0; k < 9; k++)
    s = fmax(s, fabs(A[k]));
  return s;
}

// Compensated (Kahan) summation, so that sums over 1e4+ terms compare at
// the accuracy of the terms, not of a naive running sum.
typedef struct {
  double s, c;
} kahan;
static void kahan_add(kahan *k, double x) {
  double y = x - k->c, t = k->s + y;
  k->c = (t - k->s) - y;
  k->s = t;
}

// Precompute: Dm Dm^-1 = I within the conditioned budget, V0 = det/6 > 0,
// lumped volumes sum to the total volume. Returns the total volume.
static double check_precompute(const char *label, const ek_mesh *m) {
  size_t nt = ek_mesh_ntets(m), nv = ek_mesh_nverts(m);
  double worst_inv = 0, worst_vol = 0;
  kahan total = {0, 0}, lumped = {0, 0};
  int nonpositive = 0;
  for (size_t t = 0; t < nt; t++) {
    double Dm[9], I[9];
    rest_dm(m, t, Dm);
    const double *Dmi = ek_mesh_dm_inv(m) + t * 9;
    ek_mul3(Dm, Dmi, I);
    for (int k = 0; k < 9; k++)
      I[k] -= (k % 4 == 0);
    double e = maxabs9(I) / (maxabs9(Dm) * maxabs9(Dmi));
    worst_inv = fmax(worst_inv, e);
    double V0 = ek_mesh_rest_volumes(m)[t];
    if (!(V0 > 0))
      nonpositive++;
    worst_vol = fmax(worst_vol, fabs(V0 - ek_det3(Dm) / 6) / fabs(V0));
    kahan_add(&total, V0);
  }
  for (size_t v = 0; v < nv; v++)
    kahan_add(&lumped, ek_mesh_lumped_volume(m)[v]);
  char buf[256];
  snprintf(buf, sizeof buf, "%s: Dm Dm^-1 = I", label);
  failures += ek_check_report(buf, worst_inv, EK_MESH_TOL);
  snprintf(buf, sizeof buf, "%s: V0 = det Dm / 6", label);
  failures += ek_check_report(buf, worst_vol, EK_MESH_TOL);
  snprintf(buf, sizeof buf, "%s: sum of lumped volumes = total", label);
  failures += ek_check_report(buf, fabs(lumped.s - total.s) / total.s, EK_MESH_TOL);
  if (nonpositive) {
    printf("%s: %d tets with V0 <= 0\n", label, nonpositive);
    fail("positive rest volumes");
  }
  return total.s;
}

static void check_cube_file(const char *path) {
  ek_mesh *m = ek_mesh_load(path);
  if (!m) {
    printf("load %s: %s\n", path, ek_last_error());
    fail("good file loads");
    return;
  }
  if (ek_mesh_nverts(m) != 8 || ek_mesh_ntets(m) != 6) {
    printf("%s: %zu vertices, %zu tets; expected 8 and 6\n", path, ek_mesh_nverts(m),
           ek_mesh_ntets(m));
    fail("cube size");
  }
  double vol = check_precompute(path, m);
  failures += ek_check_report("  unit cube volume", fabs(vol - 1), EK_MESH_TOL);
  ek_mesh_destroy(m);
}

// A bad input: NULL, and each expected piece in the message.
static void expect_error(const char *label, ek_mesh *m, const char *err, const char *want1,
                         const char *want2, const char *want3) {
  const char *want[3] = {want1, want2, want3};
  int ok = m == NULL;
  for (int k = 0; k < 3; k++)
    if (want[k] && !strstr(err, want[k]))
      ok = 0;
  printf("%s: %s\n  message: %s\n", label, ok ? "PASS" : "FAIL", err);
  if (!ok) {
    printf("  expected NULL and a message containing '%s' '%s' '%s'\n", want1, want2 ? want2 : "",
           want3 ? want3 : "");
    failures++;
  }
  ek_mesh_destroy(m);
}

static void bad_file(const char *name, const ek_mesh_opts *opts, const char *want1,
                     const char *want2, const char *want3) {
  char path[1200];
  snprintf(path, sizeof path, "%s/%s", data_dir, name);
  ek_mesh *m = ek_mesh_load_ex(path, opts);
  expect_error(name, m, ek_last_error(), want1, want2, want3);
}

// Faces of the box mesh: each shared by at most two tets, and the boundary
// (faces of one tet) is exactly 2 triangles per boundary square.
static int cmp_face(const void *a, const void *b) {
  const int32_t *x = a, *y = b;
  for (int k = 0; k < 3; k++)
    if (x[k] != y[k])
      return x[k] < y[k] ? -1 : 1;
  return 0;
}

static void check_box(int nx, int ny, int nz, double lx, double ly, double lz) {
  char label[128];
  snprintf(label, sizeof label, "box %dx%dx%d (%g x %g x %g)", nx, ny, nz, lx, ly, lz);
  ek_mesh *m = ek_mesh_box(nx, ny, nz, lx, ly, lz);
  if (!m) {
    printf("%s: %s\n", label, ek_last_error());
    fail("box generator");
    return;
  }
  size_t nt = ek_mesh_ntets(m);
  if (nt != (size_t)6 * nx * ny * nz ||
      ek_mesh_nverts(m) != (size_t)(nx + 1) * (ny + 1) * (nz + 1)) {
    printf("%s: %zu tets %zu vertices\n", label, nt, ek_mesh_nverts(m));
    fail("box counts");
  }
  double vol = check_precompute(label, m);
  failures += ek_check_report("  box volume = lx ly lz", fabs(vol - lx * ly * lz) / (lx * ly * lz),
                              EK_MESH_TOL);
  int32_t *faces = malloc(nt * 4 * 3 * sizeof(int32_t));
  const int32_t *T = ek_mesh_tets(m);
  for (size_t t = 0; t < nt; t++)
    for (int skip = 0; skip < 4; skip++) {
      int32_t *f = faces + (t * 4 + skip) * 3, k = 0;
      for (int j = 0; j < 4; j++)
        if (j != skip)
          f[k++] = T[t * 4 + j];
      // sort the three
      for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++)
          if (f[b] < f[a]) {
            int32_t tmp = f[a];
            f[a] = f[b];
            f[b] = tmp;
          }
    }
  qsort(faces, nt * 4, 3 * sizeof(int32_t), cmp_face);
  size_t boundary = 0, over = 0;
  for (size_t i = 0; i < nt * 4;) {
    size_t j = i;
    while (j < nt * 4 && cmp_face(faces + i * 3, faces + j * 3) == 0)
      j++;
    if (j - i == 1)
      boundary++;
    if (j - i > 2)
      over++;
    i = j;
  }
  free(faces);
  size_t want = 4 * ((size_t)nx * ny + (size_t)ny * nz + (size_t)nx * nz);
  printf("%s: %zu boundary triangles (expected %zu), %zu faces in > 2 tets: %s\n", label, boundary,
         want, over, boundary == want && over == 0 ? "PASS" : "FAIL");
  if (boundary != want || over)
    failures++;
  ek_mesh_destroy(m);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 4, NULL);
  printf("test_mesh: seed %llu\n", (unsigned long long)seed);
  init_dirs();
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  char path[1200];

  // Good files.
  snprintf(path, sizeof path, "%s/cube", scene_dir);
  check_cube_file(path);
  snprintf(path, sizeof path, "%s/cube.node", scene_dir);
  check_cube_file(path);
  snprintf(path, sizeof path, "%s/cube.ele", scene_dir);
  check_cube_file(path);
  snprintf(path, sizeof path, "%s/cube0", data_dir);
  check_cube_file(path);
  snprintf(path, sizeof path, "%s/cube_v2.msh", scene_dir);
  check_cube_file(path);
  snprintf(path, sizeof path, "%s/cube_v4.msh", scene_dir);
  check_cube_file(path);

  // Bad files: each its error, naming file, line and value.
  bad_file("missing.node", NULL, "missing.node", "cannot open", NULL);
  bad_file("truncated", NULL, "truncated.node:7", "truncated file", "5 of 8");
  bad_file("badnum", NULL, "badnum.node:6", "bad number '1x'", NULL);
  bad_file("range", NULL, "range.ele:4", "vertex index 8 out of range", NULL);
  bad_file("nan", NULL, "nan.node:8", "coordinate x = nan", NULL);
  bad_file("repeat", NULL, "repeat.ele:3", "vertex 1 appears twice", NULL);
  bad_file("flat", NULL, "flat.ele:3", "degenerate", "6V = 0");
  bad_file("inverted", NULL, "inverted.ele:4", "inverted", "-0.16666");
  bad_file("few", NULL, "few.ele", "only 3 distinct vertices", NULL);
  bad_file("badtag.msh", NULL, "badtag.msh:19", "node tag 999 out of range", NULL);
  bad_file("truncated.msh", NULL, "truncated.msh", "truncated file", NULL);
  bad_file("binary.msh", NULL, "binary.msh:2", "binary", NULL);

  // Inverted with fix_orientation: loads, one fix, all volumes positive.
  {
    ek_mesh_opts fix = {.fix_orientation = 1};
    snprintf(path, sizeof path, "%s/inverted", data_dir);
    ek_mesh *m = ek_mesh_load_ex(path, &fix);
    if (!m) {
      printf("inverted + fix_orientation: %s\n", ek_last_error());
      fail("fix_orientation loads");
    } else {
      printf("inverted + fix_orientation: %zu fixed\n", ek_mesh_nfixed(m));
      if (ek_mesh_nfixed(m) != 1)
        fail("one tet fixed");
      check_precompute("inverted fixed", m);
      ek_mesh_destroy(m);
    }
  }

  // In-memory meshes: same checks, element index in the message.
  {
    double X[5 * 3] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    int32_t good[8] = {0, 1, 2, 3, 1, 2, 3, 4};
    // Second tet (1,2,3,4): det[X2-X1, X3-X1, X4-X1] = 2 > 0.
    ek_mesh *m = ek_mesh_create(5, X, 2, good);
    if (!m) {
      printf("ek_mesh_create good: %s\n", ek_last_error());
      fail("in-memory good mesh");
    } else {
      check_precompute("in-memory", m);
      ek_mesh_destroy(m);
    }
    int32_t range[8] = {0, 1, 2, 3, 1, 2, 3, 7};
    m = ek_mesh_create(5, X, 2, range);
    expect_error("create: index out of range", m, ek_last_error(), "tet 1", "vertex index 7", NULL);
    int32_t rep[8] = {0, 1, 2, 3, 1, 2, 2, 4};
    m = ek_mesh_create(5, X, 2, rep);
    expect_error("create: repeated vertex", m, ek_last_error(), "tet 1", "vertex 2 appears twice",
                 NULL);
    int32_t inv[8] = {0, 1, 2, 3, 0, 2, 1, 3};
    m = ek_mesh_create(5, X, 2, inv);
    expect_error("create: inverted", m, ek_last_error(), "tet 1", "inverted", NULL);
    double Xflat[5 * 3] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 0};
    int32_t flat[8] = {0, 1, 2, 3, 0, 1, 4, 2};
    m = ek_mesh_create(5, Xflat, 2, flat);
    expect_error("create: degenerate", m, ek_last_error(), "tet 1", "degenerate", NULL);
    double Xnan[5 * 3] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, NAN, 1};
    m = ek_mesh_create(5, Xnan, 2, good);
    expect_error("create: NaN coordinate", m, ek_last_error(), "vertex 4", "y = nan", NULL);
    int32_t few[4] = {0, 1, 1, 1};
    m = ek_mesh_create(5, X, 1, few);
    expect_error("create: fewer than 4 vertices", m, ek_last_error(), "only 2 distinct", NULL,
                 NULL);
    m = ek_mesh_box(0, 2, 2, 1, 1, 1);
    expect_error("box: zero cells", m, ek_last_error(), "ek_mesh_box", "0 x 2 x 2", NULL);
  }

  // Box generator at seeded random sizes, and a colouring check on a
  // random (Morton-scrambled) vertex numbering through ek_mesh_create.
  for (int rep = 0; rep < 3; rep++) {
    int nx = 1 + (int)(ek_rng_uniform(&rng) * 7), ny = 1 + (int)(ek_rng_uniform(&rng) * 7),
        nz = 1 + (int)(ek_rng_uniform(&rng) * 7);
    check_box(nx, ny, nz, 0.5 + ek_rng_uniform(&rng), 0.5 + ek_rng_uniform(&rng),
              0.5 + ek_rng_uniform(&rng));
  }
  check_box(20, 20, 20, 1, 1, 1);
  {
    // Randomly jittered box (interior vertices moved by up to 20% of a
    // cell), vertices renumbered at random: still valid and well laid out.
    int n = 6;
    ek_mesh *b = ek_mesh_box(n, n, n, 1, 1, 1);
    size_t nv = ek_mesh_nverts(b), nt = ek_mesh_ntets(b);
    double *X = malloc(nv * 3 * sizeof(double));
    int32_t *T = malloc(nt * 4 * sizeof(int32_t)), *perm = malloc(nv * sizeof(int32_t));
    for (size_t v = 0; v < nv; v++)
      perm[v] = (int32_t)v;
    for (size_t v = nv - 1; v > 0; v--) {
      size_t j = (size_t)(ek_rng_uniform(&rng) * (double)(v + 1));
      int32_t tmp = perm[v];
      perm[v] = perm[j];
      perm[j] = tmp;
    }
    for (size_t v = 0; v < nv; v++)
      for (int k = 0; k < 3; k++) {
        double x = ek_mesh_rest_positions(b)[v * 3 + k];
        int interior = x > 1e-9 && x < 1 - 1e-9;
        X[perm[v] * 3 + k] = x + (interior ? 0.2 / n * (2 * ek_rng_uniform(&rng) - 1) : 0);
      }
    for (size_t i = 0; i < nt * 4; i++)
      T[i] = perm[ek_mesh_tets(b)[i]];
    ek_mesh *m = ek_mesh_create(nv, X, nt, T);
    if (!m) {
      printf("jittered box: %s\n", ek_last_error());
      fail("jittered box");
    } else {
      double vol = check_precompute("jittered renumbered box", m);
      failures += ek_check_report("  jittered box volume", fabs(vol - 1), EK_MESH_TOL);
      ek_mesh_destroy(m);
    }
    ek_mesh_destroy(b);
    free(X);
    free(T);
    free(perm);
  }

  printf("test_mesh: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
