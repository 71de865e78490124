// frames_gap SCENE A.h5 B.h5 [exact]: the trajectory check of ek-sim across MPI
// ranks (tests/mpi.sh). A and B are frames of SCENE written by two runs
// (one rank, N ranks) of the same steps; the invariant: their last frames'
// positions agree to EK_SIM_MPI_GAP_PER_STEP newton_tol per step run
// (verify/test_tolerances.h says why), in the mass-weighted RMS over the
// body size (lumped tet masses from the files' rest mesh, L its bounding
// box's diagonal). With `exact` the budget is 0: the same bits (one rank
// under mpirun against a plain run). Prints the gap, the budget and the
// verdict; exit 0 on PASS or MARGINAL, 1 on FAIL or a file that cannot be
// read.
#include <ek/sim/scene.h>

#include <hdf5.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_tolerances.h"

// Reads the dataset `name` of file f (n values of `type`); 0 or -1.
static int read_all(hid_t f, const char *name, hid_t type, void *buf, size_t n) {
  hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  if (d < 0)
    return -1;
  hid_t sp = H5Dget_space(d);
  hssize_t have = H5Sget_simple_extent_npoints(sp);
  herr_t rc = have == (hssize_t)n ? H5Dread(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) : -1;
  H5Sclose(sp);
  H5Dclose(d);
  return rc < 0 ? -1 : 0;
}

static hssize_t npoints(hid_t f, const char *name) {
  hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  if (d < 0)
    return -1;
  hid_t sp = H5Dget_space(d);
  hssize_t n = H5Sget_simple_extent_npoints(sp);
  H5Sclose(sp);
  H5Dclose(d);
  return n;
}

typedef struct {
  hid_t f;
  long nframes, last_step;
  size_t nv, nt;
} frames;

static int open_frames(const char *path, frames *fr) {
  fr->f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  if (fr->f < 0)
    return -1;
  hssize_t nv = npoints(fr->f, "/mesh/vertices"), nt = npoints(fr->f, "/mesh/tets");
  hssize_t nf = npoints(fr->f, "/frames/step");
  if (nv <= 0 || nt <= 0 || nf <= 0)
    return -1;
  fr->nv = (size_t)nv / 3;
  fr->nt = (size_t)nt / 4;
  fr->nframes = (long)nf;
  int64_t *steps = malloc((size_t)nf * sizeof *steps);
  int rc = steps ? read_all(fr->f, "/frames/step", H5T_NATIVE_INT64, steps, (size_t)nf) : -1;
  fr->last_step = rc == 0 ? (long)steps[nf - 1] : -1;
  free(steps);
  return rc;
}

int main(int argc, char **argv) {
  const int exact = argc == 5 && strcmp(argv[4], "exact") == 0;
  if (argc != 4 && !exact) {
    fprintf(stderr, "usage: frames_gap SCENE A.h5 B.h5 [exact]\n");
    return 2;
  }
  static ek_scene scene;
  if (ek_scene_load(argv[1], &scene) != 0) {
    fprintf(stderr, "frames_gap: %s: cannot load\n", argv[1]);
    return 1;
  }
  frames a, b;
  if (open_frames(argv[2], &a) < 0 || open_frames(argv[3], &b) < 0) {
    fprintf(stderr, "frames_gap: %s or %s: not a frames file of tets\n", argv[2], argv[3]);
    return 1;
  }
  if (a.nv != b.nv || a.nt != b.nt || a.nframes != b.nframes || a.last_step != b.last_step) {
    fprintf(stderr,
            "frames_gap: the files differ in mesh or frames (%zu/%zu vertices, %ld/%ld "
            "frames, last step %ld/%ld)\n",
            a.nv, b.nv, a.nframes, b.nframes, a.last_step, b.last_step);
    return 1;
  }
  const size_t nv = a.nv, nt = a.nt;
  double *X = malloc(3 * nv * sizeof *X), *xa = malloc(3 * nv * sizeof *xa);
  double *xb = malloc(3 * nv * sizeof *xb), *m = calloc(nv, sizeof *m);
  int32_t *T = malloc(4 * nt * sizeof *T);
  char name[64];
  snprintf(name, sizeof name, "/frames/positions/%06ld", a.nframes - 1);
  if (!X || !xa || !xb || !m || !T ||
      read_all(a.f, "/mesh/vertices", H5T_NATIVE_DOUBLE, X, 3 * nv) < 0 ||
      read_all(a.f, "/mesh/tets", H5T_NATIVE_INT32, T, 4 * nt) < 0 ||
      read_all(a.f, name, H5T_NATIVE_DOUBLE, xa, 3 * nv) < 0 ||
      read_all(b.f, name, H5T_NATIVE_DOUBLE, xb, 3 * nv) < 0) {
    fprintf(stderr, "frames_gap: cannot read the mesh or %s\n", name);
    return 1;
  }
  // Lumped masses (a quarter of each tet's volume; the density cancels).
  for (size_t e = 0; e < nt; e++) {
    const int32_t *t = T + 4 * e;
    double d[3][3];
    for (int i = 0; i < 3; i++)
      for (int k = 0; k < 3; k++)
        d[i][k] = X[3 * t[i + 1] + k] - X[3 * t[0] + k];
    double V = fabs(d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1]) -
                    d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0]) +
                    d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0])) /
               6;
    for (int i = 0; i < 4; i++)
      m[t[i]] += V / 4;
  }
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  double num = 0, den = 0, worst = 0;
  for (size_t v = 0; v < nv; v++) {
    double g2 = 0;
    for (int k = 0; k < 3; k++) {
      lo[k] = fmin(lo[k], X[3 * v + k]);
      hi[k] = fmax(hi[k], X[3 * v + k]);
      const double g = xa[3 * v + k] - xb[3 * v + k];
      g2 += g * g;
    }
    num += m[v] * g2;
    den += m[v];
    worst = fmax(worst, sqrt(g2));
  }
  const double L = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                        (hi[2] - lo[2]) * (hi[2] - lo[2]));
  const double gap = sqrt(num / den) / L;
  const double budget =
      exact ? 0 : EK_SIM_MPI_GAP_PER_STEP * (double)a.last_step * scene.implicit.newton_tol;
  const char *verdict = !(gap <= budget) ? "FAIL" : gap > 0.5 * budget ? "MARGINAL" : "PASS";
  if (exact) {
    // The same bits: every coordinate equal (gap 0 could hide opposite
    // signs of zero only).
    int same = memcmp(xa, xb, 3 * nv * sizeof *xa) == 0;
    printf("%s: %s vs %s, %zu vertices, step %ld: last frame's positions %s\n",
           same ? "PASS" : "FAIL", argv[2], argv[3], nv, a.last_step,
           same ? "bit-identical" : "differ");
    if (!same)
      printf("  mass-weighted RMS gap / body size %.3g, largest vertex gap / body size %.3g\n", gap,
             worst / L);
    return same ? 0 : 1;
  }
  printf("%s: %s vs %s, %zu vertices, step %ld: mass-weighted RMS gap / body size %.3g (largest "
         "vertex gap / body size %.3g), budget %g x %ld steps x newton_tol %g = %.3g, "
         "gap/budget %.3g\n",
         verdict, argv[2], argv[3], nv, a.last_step, gap, worst / L, EK_SIM_MPI_GAP_PER_STEP,
         a.last_step, scene.implicit.newton_tol, budget, gap / budget);
  H5Fclose(a.f);
  H5Fclose(b.f);
  free(X), free(xa), free(xb), free(m), free(T);
  return gap <= budget ? 0 : 1;
}
