// Invariant: every frame ek_frames_write completed is read back bit for bit
// (rest mesh, positions, per-tet fields, time, step) with the plain HDF5 C
// API; a writer killed with SIGKILL at an arbitrary moment leaves a file that
// opens and holds at least every frame it reported complete, each intact;
// an existing output is never overwritten without force (and is left
// untouched), and force does overwrite it.
#include <ek/sim.h>

#include "cli.h"
#include <errno.h>
#include <hdf5.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static unsigned long long seed = 1;
static int failures = 0;

// Deterministic content of frame k (positions, fields), a function of the
// seed so that the reader can recompute what the writer wrote.
static double value_at(unsigned long long k, unsigned long long i, int which) {
  unsigned long long z = seed * 0x9E3779B97F4A7C15ull + k * 0xBF58476D1CE4E5B9ull +
                         i * 0x94D049BB133111EBull +
                         (unsigned long long)which * 0x2545F4914F6CDD1Dull;
  z ^= z >> 31;
  z *= 0xD6E9F8CC1D2B7A1Bull;
  z ^= z >> 29;
  return (double)(z >> 11) / 9007199254740992.0 * 2.0 - 1.0;
}

static void fill_frame(long k, size_t nv, size_t nt, double *x, double *J, double *smin,
                       double *psi) {
  for (size_t i = 0; i < 3 * nv; ++i)
    x[i] = value_at(k, i, 0);
  for (size_t i = 0; i < nt; ++i) {
    J[i] = value_at(k, i, 1);
    smin[i] = value_at(k, i, 2);
    psi[i] = value_at(k, i, 3);
  }
}

// A small rest mesh: nv vertices, nt tets with in-range indices (the frame
// writer stores the mesh as given; it does not validate geometry).
static void make_mesh(size_t nv, size_t nt, double *X, int32_t *tets) {
  for (size_t i = 0; i < 3 * nv; ++i)
    X[i] = value_at(1000000, i, 4);
  for (size_t e = 0; e < nt; ++e)
    for (int c = 0; c < 4; ++c)
      tets[4 * e + c] = (int32_t)((e + (size_t)c) % nv);
}

static int read_all(hid_t file, const char *name, hid_t type, void *buf) {
  hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
  if (d < 0)
    return -1;
  herr_t rc = H5Dread(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
  H5Dclose(d);
  return rc < 0 ? -1 : 0;
}

static long series_length(hid_t file, const char *name) {
  hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
  if (d < 0)
    return -1;
  hid_t s = H5Dget_space(d);
  hsize_t dims[3] = {0, 0, 0};
  H5Sget_simple_extent_dims(s, dims, NULL);
  H5Sclose(s);
  H5Dclose(d);
  return (long)dims[0];
}

// Read frame k of a series into buf (row of `row` doubles).
static int read_row(hid_t file, const char *name, long k, size_t row, double *buf) {
  hid_t d = H5Dopen2(file, name, H5P_DEFAULT);
  if (d < 0)
    return -1;
  hid_t fs = H5Dget_space(d);
  int rank = H5Sget_simple_extent_ndims(fs);
  hsize_t start[3] = {(hsize_t)k, 0, 0}, count[3] = {1, row, 3};
  if (rank == 2)
    count[1] = row;
  hsize_t mcount[1] = {rank == 3 ? row * 3 : row};
  hid_t ms = H5Screate_simple(1, mcount, NULL);
  herr_t rc = H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, count, NULL);
  if (rc >= 0)
    rc = H5Dread(d, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, buf);
  H5Sclose(ms);
  H5Sclose(fs);
  H5Dclose(d);
  return rc < 0 ? -1 : 0;
}

// Check the mesh and frames [0, nframes) of an open file; returns the number
// of mismatching values (0 when intact).
static long check_file(hid_t file, size_t nv, size_t nt, const double *X, const int32_t *tets,
                       long nframes) {
  long bad = 0;
  double *Xr = malloc(3 * nv * sizeof(double));
  int32_t *Tr = malloc(4 * nt * sizeof(int32_t));
  double *x = malloc(3 * nv * sizeof(double)), *xr = malloc(3 * nv * sizeof(double));
  double *f[3], *fr = malloc(nt * sizeof(double));
  for (int k = 0; k < 3; ++k)
    f[k] = malloc(nt * sizeof(double));
  if (read_all(file, "/mesh/vertices", H5T_NATIVE_DOUBLE, Xr) ||
      read_all(file, "/mesh/tets", H5T_NATIVE_INT32, Tr)) {
    printf("  cannot read /mesh\n");
    bad++;
  } else {
    for (size_t i = 0; i < 3 * nv; ++i)
      if (memcmp(&Xr[i], &X[i], sizeof(double)) != 0) {
        if (bad < 5)
          printf("  /mesh/vertices[%zu]: expected %.17g, read %.17g\n", i, X[i], Xr[i]);
        bad++;
      }
    for (size_t i = 0; i < 4 * nt; ++i)
      if (Tr[i] != tets[i]) {
        if (bad < 5)
          printf("  /mesh/tets[%zu]: expected %d, read %d\n", i, tets[i], Tr[i]);
        bad++;
      }
  }
  double *time = malloc((size_t)(nframes + 1) * sizeof(double));
  int64_t *step = malloc((size_t)(nframes + 1) * sizeof(int64_t));
  for (long k = 0; k < nframes; ++k) {
    fill_frame(k, nv, nt, x, f[0], f[1], f[2]);
    static const char *names[] = {"/frames/J", "/frames/smin", "/frames/energy_density_from_rest"};
    if (read_row(file, "/frames/positions", k, nv, xr)) {
      printf("  frame %ld: cannot read positions\n", k);
      bad++;
      continue;
    }
    for (size_t i = 0; i < 3 * nv; ++i)
      if (memcmp(&x[i], &xr[i], sizeof(double)) != 0) {
        if (bad < 5)
          printf("  frame %ld positions[%zu]: expected %.17g, read %.17g\n", k, i, x[i], xr[i]);
        bad++;
      }
    for (int n = 0; n < 3; ++n) {
      if (read_row(file, names[n], k, nt, fr)) {
        printf("  frame %ld: cannot read %s\n", k, names[n]);
        bad++;
        continue;
      }
      for (size_t i = 0; i < nt; ++i)
        if (memcmp(&f[n][i], &fr[i], sizeof(double)) != 0) {
          if (bad < 5)
            printf("  frame %ld %s[%zu]: expected %.17g, read %.17g\n", k, names[n], i, f[n][i],
                   fr[i]);
          bad++;
        }
    }
  }
  // time and step are read whole (their length may exceed nframes by none:
  // time is written last).
  long tl = series_length(file, "/frames/time");
  if (tl >= nframes && tl <= nframes + 1) {
    double *t = malloc((size_t)(tl + 1) * sizeof(double));
    int64_t *s = malloc((size_t)(tl + 1) * sizeof(int64_t));
    long sl = series_length(file, "/frames/step");
    if (!read_all(file, "/frames/time", H5T_NATIVE_DOUBLE, t) && sl >= tl &&
        !read_all(file, "/frames/step", H5T_NATIVE_INT64, s)) {
      for (long k = 0; k < nframes; ++k)
        if (t[k] != 0.125 * (double)k || s[k] != 10 * k) {
          printf("  frame %ld: time/step expected %.17g/%ld, read %.17g/%lld\n", k,
                 0.125 * (double)k, 10 * k, t[k], (long long)s[k]);
          bad++;
        }
    } else {
      printf("  cannot read /frames/time or /frames/step\n");
      bad++;
    }
    free(t);
    free(s);
  } else {
    printf("  /frames/time has %ld entries, expected %ld\n", tl, nframes);
    bad++;
  }
  free(time);
  free(step);
  free(Xr);
  free(Tr);
  free(x);
  free(xr);
  free(fr);
  for (int k = 0; k < 3; ++k)
    free(f[k]);
  return bad;
}

static void verdict(const char *what, int ok, const char *detail) {
  printf("%-48s %s  %s\n", what, ok ? "PASS" : "FAIL", detail);
  if (!ok)
    failures++;
}

// Writes frames 0..nframes-1 (nframes < 0: forever), reporting each
// completed frame on fd (if >= 0). Returns 0 on success.
static int writer(const char *path, int force, size_t nv, size_t nt, const double *X,
                  const int32_t *tets, long nframes, int fd) {
  char err[512];
  ek_frames *fr = ek_frames_create(path, force, nv, X, nt, tets, err, sizeof err);
  if (!fr) {
    printf("  ek_frames_create: %s\n", err);
    return -1;
  }
  double *x = malloc(3 * nv * sizeof(double)), *J = malloc(nt * sizeof(double));
  double *smin = malloc(nt * sizeof(double)), *psi = malloc(nt * sizeof(double));
  for (long k = 0; nframes < 0 || k < nframes; ++k) {
    fill_frame(k, nv, nt, x, J, smin, psi);
    if (ek_frames_write(fr, 0.125 * (double)k, 10 * k, x, J, smin, psi, err, sizeof err)) {
      printf("  ek_frames_write: %s\n", err);
      return -1;
    }
    if (fd >= 0) {
      char c = 1;
      if (write(fd, &c, 1) != 1)
        return -1;
    }
  }
  free(x);
  free(J);
  free(smin);
  free(psi);
  return ek_frames_close(fr, err, sizeof err);
}

static long count_in_file(const char *path, const char *needle) {
  FILE *f = fopen(path, "r");
  if (!f)
    return -1;
  long n = 0;
  char line[512];
  while (fgets(line, sizeof line, f))
    if (strstr(line, needle))
      n++;
  fclose(f);
  return n;
}

int main(int argc, char **argv) {
  seed = ek_cli_test_args(argc, argv, seed, NULL);
  printf("test_frames --seed %llu\n", seed);
  char dir[] = "/tmp/ek_test_frames_XXXXXX";
  if (!mkdtemp(dir)) {
    perror("mkdtemp");
    return 1;
  }
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
  // Small mesh for the round trip; a larger one for the kill test so that
  // a frame takes long enough for the kill to land inside a write.
  size_t nv = 37, nt = 53;
  double *X = malloc(3 * 20000 * sizeof(double));
  int32_t *tets = malloc(4 * 60000 * sizeof(int32_t));
  make_mesh(nv, nt, X, tets);
  char path[256], xdmf[300], detail[1024];

  // 1. Round trip.
  snprintf(path, sizeof path, "%s/roundtrip.h5", dir);
  long nframes = 7;
  int ok = writer(path, 0, nv, nt, X, tets, nframes, -1) == 0;
  long bad = -1;
  if (ok) {
    hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    ok = f >= 0;
    if (ok) {
      bad = check_file(f, nv, nt, X, tets, nframes);
      ok = bad == 0 && series_length(f, "/frames/time") == nframes;
      H5Fclose(f);
    }
  }
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  long grids = count_in_file(xdmf, "<Time Value=");
  snprintf(detail, sizeof detail, "%ld frames, %ld mismatches, xdmf lists %ld", nframes, bad,
           grids);
  verdict("round trip (write, close, read back)", ok && grids == nframes, detail);

  // 2. Refuse to overwrite; the existing file stays intact.
  struct stat before, after;
  stat(path, &before);
  char err[512];
  ek_frames *fr = ek_frames_create(path, 0, nv, X, nt, tets, err, sizeof err);
  stat(path, &after);
  ok = fr == NULL && strstr(err, path) && strstr(err, "refusing to overwrite") &&
       before.st_size == after.st_size && before.st_mtime == after.st_mtime;
  snprintf(detail, sizeof detail, "message: %s", err);
  verdict("existing file refused without force", ok, detail);
  if (fr)
    ek_frames_close(fr, NULL, 0);
  // The XDMF alone existing also blocks.
  snprintf(path, sizeof path, "%s/only_xdmf.h5", dir);
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  FILE *fx = fopen(xdmf, "w");
  if (fx)
    fclose(fx);
  fr = ek_frames_create(path, 0, nv, X, nt, tets, err, sizeof err);
  struct stat st;
  ok = fr == NULL && strstr(err, xdmf) && stat(path, &st) != 0;
  snprintf(detail, sizeof detail, "message: %s", err);
  verdict("existing XDMF refused, no HDF5 created", ok, detail);
  if (fr)
    ek_frames_close(fr, NULL, 0);
  // force overwrites.
  snprintf(path, sizeof path, "%s/roundtrip.h5", dir);
  ok = writer(path, 1, nv, nt, X, tets, 3, -1) == 0;
  if (ok) {
    hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    ok = f >= 0 && series_length(f, "/frames/time") == 3 && check_file(f, nv, nt, X, tets, 3) == 0;
    if (f >= 0)
      H5Fclose(f);
  }
  verdict("force overwrites (3 frames now)", ok, "");

  // 3. Killed writer: the child writes frames forever and reports each
  // completed one through a pipe; the parent kills it with SIGKILL after a
  // seed-dependent number of frames, at once (so usually inside a write).
  nv = 20000;
  nt = 60000;
  make_mesh(nv, nt, X, tets);
  snprintf(path, sizeof path, "%s/killed.h5", dir);
  int pipefd[2];
  if (pipe(pipefd) != 0) {
    perror("pipe");
    return 1;
  }
  long wait_frames = 3 + (long)(seed % 5);
  fflush(stdout);
  pid_t pid = fork();
  if (pid == 0) {
    close(pipefd[0]);
    _exit(writer(path, 0, nv, nt, X, tets, -1, pipefd[1]) == 0 ? 0 : 3);
  }
  close(pipefd[1]);
  long reported = 0;
  char c;
  while (reported < wait_frames && read(pipefd[0], &c, 1) == 1)
    reported++;
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  // Frames reported after our count but before the kill are complete too.
  while (read(pipefd[0], &c, 1) == 1)
    reported++;
  close(pipefd[0]);
  int killed = WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_libver_bounds(fapl, H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, fapl);
  H5Pclose(fapl);
  long stored = -1;
  bad = -1;
  if (f >= 0) {
    stored = series_length(f, "/frames/time");
    bad = stored >= reported ? check_file(f, nv, nt, X, tets, stored) : -1;
    H5Fclose(f);
  }
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  grids = count_in_file(xdmf, "<Time Value=");
  ok = killed && f >= 0 && stored >= reported && bad == 0 &&
       (grids == stored || grids == stored - 1);
  snprintf(detail, sizeof detail,
           "killed=%d after %ld reported frames; file holds %ld, %ld mismatches, xdmf %ld", killed,
           reported, stored, bad, grids);
  verdict("SIGKILLed writer leaves completed frames", ok, detail);

  free(X);
  free(tets);
  // Clean up the temporary directory.
  const char *names[] = {"roundtrip.h5", "roundtrip.xmf", "only_xdmf.xmf",
                         "killed.h5",    "killed.xmf",    "killed.xmf.tmp"};
  for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i) {
    snprintf(path, sizeof path, "%s/%s", dir, names[i]);
    remove(path);
  }
  rmdir(dir);
  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
