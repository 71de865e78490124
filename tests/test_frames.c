// Invariant: every frame ek_frames_write completed is read back bit for bit
// (rest mesh, positions, per-tet fields, time, step) with the plain HDF5 C
// API in read-only mode; a writer killed with SIGKILL at an arbitrary moment
// leaves a file that opens that way (no h5clear, no SWMR) and holds at least
// every frame it reported complete, each intact, and an XDMF that lists
// them (at most the last one missing) and ends with its closing tags; the
// XDMF is committed by swapping names with a scratch copy one frame behind
// (two files in turn, no new file per frame, no scratch left after close)
// and names the HDF5 file XML-escaped; a name the XDMF cannot hold is refused;
// an existing output is never overwritten without force (and is left
// untouched), force does overwrite it, and scratch files a killed run left
// do not block a new one (nor are written into: they are replaced).
#include <ek/sim/sim.h>

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

// Read frame k of a field (/frames/<name>/<k, 6 digits>) into buf, which
// holds `count` doubles; fails unless the dataset has exactly that many.
static int read_row(hid_t file, const char *name, long k, size_t count, double *buf) {
  char path[128];
  snprintf(path, sizeof path, "%s/%06ld", name, k);
  hid_t d = H5Dopen2(file, path, H5P_DEFAULT);
  if (d < 0)
    return -1;
  hid_t fs = H5Dget_space(d);
  hssize_t n = H5Sget_simple_extent_npoints(fs);
  H5Sclose(fs);
  herr_t rc =
      n == (hssize_t)count ? H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) : -1;
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
    if (read_row(file, "/frames/positions", k, 3 * nv, xr)) {
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

// A string attribute of the object at `obj` (variable or fixed length),
// copied into buf; "" when missing.
static void attr_text(hid_t file, const char *obj, const char *name, char *buf, size_t len) {
  buf[0] = '\0';
  hid_t a = H5Aopen_by_name(file, obj, name, H5P_DEFAULT, H5P_DEFAULT);
  if (a < 0)
    return;
  hid_t ftype = H5Aget_type(a);
  if (H5Tget_class(ftype) == H5T_STRING && H5Tis_variable_str(ftype) > 0) {
    hid_t mtype = H5Tcopy(H5T_C_S1);
    H5Tset_size(mtype, H5T_VARIABLE);
    H5Tset_cset(mtype, H5Tget_cset(ftype));
    char *v = NULL;
    if (H5Aread(a, mtype, &v) >= 0 && v) {
      snprintf(buf, len, "%s", v);
      H5free_memory(v);
    }
    H5Tclose(mtype);
  }
  H5Tclose(ftype);
  H5Aclose(a);
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
  ek_frames *fr = ek_frames_create(path, force, nv, X, nt, tets);
  if (!fr) {
    printf("  ek_frames_create: %s\n", ek_last_error());
    return -1;
  }
  double *x = malloc(3 * nv * sizeof(double)), *J = malloc(nt * sizeof(double));
  double *smin = malloc(nt * sizeof(double)), *psi = malloc(nt * sizeof(double));
  for (long k = 0; nframes < 0 || k < nframes; ++k) {
    fill_frame(k, nv, nt, x, J, smin, psi);
    if (ek_frames_write(fr, 0.125 * (double)k, 10 * k, x, J, smin, psi)) {
      printf("  ek_frames_write: %s\n", ek_last_error());
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
  return ek_frames_close(fr);
}

static long count_in_file(const char *path, const char *needle) {
  FILE *f = fopen(path, "r");
  if (!f)
    return -1;
  long n = 0;
  char line[4096];
  while (fgets(line, sizeof line, f))
    if (strstr(line, needle))
      n++;
  fclose(f);
  return n;
}

// The whole file as a string (malloc'ed), or NULL.
static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f)
    return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *s = n >= 0 ? malloc((size_t)n + 1) : NULL;
  if (s && fread(s, 1, (size_t)n, f) != (size_t)n) {
    free(s);
    s = NULL;
  }
  if (s)
    s[n] = '\0';
  fclose(f);
  return s;
}

// The XDMF ends with the collection's closing tags (it is whole).
static int xdmf_closed(const char *path) {
  char *s = slurp(path);
  static const char tail[] = "  </Grid>\n </Domain>\n</Xdmf>\n";
  size_t n = s ? strlen(s) : 0;
  int ok = n >= sizeof tail - 1 && strcmp(s + n - (sizeof tail - 1), tail) == 0;
  free(s);
  return ok;
}

// Frames in the file at path opened read-only with default properties (no
// SWMR, no h5clear): the length of /frames/time, or -1 if it does not open.
static long frames_in(const char *path, hid_t *file_out) {
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0)
    return -1;
  long n = series_length(f, "/frames/time");
  if (file_out)
    *file_out = f;
  else
    H5Fclose(f);
  return n;
}

// Kills a child writer with SIGKILL once it reported `wait_frames` frames
// (0: at once), then checks the file it left. Returns 1 when it holds
// every reported frame intact, or, when the kill came before the first
// commit, when no file is there and a new writer is not blocked.
static int kill_test(const char *path, long wait_frames, size_t nv, size_t nt, const double *X,
                     const int32_t *tets, char *detail, size_t detail_len) {
  int pipefd[2];
  if (pipe(pipefd) != 0) {
    perror("pipe");
    return 0;
  }
  fflush(stdout);
  pid_t pid = fork();
  if (pid == 0) {
    close(pipefd[0]);
    _exit(writer(path, 1, nv, nt, X, tets, -1, pipefd[1]) == 0 ? 0 : 3);
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
  hid_t f = -1;
  long stored = frames_in(path, &f), bad = -1;
  if (f >= 0) {
    bad = stored >= reported ? check_file(f, nv, nt, X, tets, stored) : -1;
    H5Fclose(f);
  }
  char xdmf[300];
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  long grids = count_in_file(xdmf, "<Grid Name=\"frame_");
  int xdmf_ok = grids < 0 || ((grids == stored || grids == stored - 1) && xdmf_closed(xdmf));
  int ok;
  if (stored < 0 && reported == 0) {
    // Killed before the first commit: nothing at path, and a new writer
    // (without force) is not blocked by what the kill left.
    struct stat st;
    ok = killed && stat(path, &st) != 0 && writer(path, 0, nv, nt, X, tets, 1, -1) == 0 &&
         frames_in(path, NULL) == 1;
    snprintf(detail, detail_len, "killed=%d before any frame: no file; a new run %s", killed,
             ok ? "writes 1 frame" : "FAILED");
  } else {
    ok = killed && stored >= reported && bad == 0 && xdmf_ok;
    snprintf(detail, detail_len,
             "killed=%d after %ld reported frames; file holds %ld, %ld mismatches, xdmf lists "
             "%ld%s",
             killed, reported, stored, bad, grids, xdmf_ok ? "" : " (not closed)");
  }
  return ok;
}

// Remove every file in dir, then dir.
static void remove_dir(const char *dir) {
  char cmd[512];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0)
    printf("  could not remove %s\n", dir);
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
  char path[512], xdmf[600], detail[1024];

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
  long grids = count_in_file(xdmf, "<Grid Name=\"frame_");
  char scratch[600];
  snprintf(scratch, sizeof scratch, "%s.scratch", path);
  struct stat st;
  int scratch_left = stat(scratch, &st) == 0;
  snprintf(detail, sizeof detail, "%ld frames, %ld mismatches, xdmf lists %ld%s%s", nframes, bad,
           grids, xdmf_closed(xdmf) ? "" : ", xdmf not closed",
           scratch_left ? ", scratch file left" : "");
  verdict("round trip (write, close, read back)",
          ok && grids == nframes && xdmf_closed(xdmf) && !scratch_left, detail);

  // 1c. The same run through the atomic swap's fallback (hard link +
  // renames, for file systems without RENAME_EXCHANGE; sim/frames.c),
  // forced by EK_FRAMES_TEST_NO_EXCHANGE: the same frames, the same XDMF
  // text (same base name, in a subfolder), no scratch or link name left.
  {
    char sub[400], xdmf2[700], swap[700];
    snprintf(sub, sizeof sub, "%s/fallback", dir);
    mkdir(sub, 0700);
    snprintf(path, sizeof path, "%s/roundtrip.h5", sub);
    setenv("EK_FRAMES_TEST_NO_EXCHANGE", "1", 1);
    ok = writer(path, 0, nv, nt, X, tets, nframes, -1) == 0;
    unsetenv("EK_FRAMES_TEST_NO_EXCHANGE");
    hid_t f = ok ? H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT) : -1;
    bad = f >= 0 ? check_file(f, nv, nt, X, tets, nframes) : -1;
    long n = f >= 0 ? series_length(f, "/frames/time") : -1;
    if (f >= 0)
      H5Fclose(f);
    ek_frames_xdmf_path(path, xdmf2, sizeof xdmf2);
    char *a = slurp(xdmf), *b = slurp(xdmf2);
    int same = a && b && strcmp(a, b) == 0;
    free(a);
    free(b);
    snprintf(scratch, sizeof scratch, "%s.scratch", path);
    snprintf(swap, sizeof swap, "%s.swap", path);
    int left = stat(scratch, &st) == 0 || stat(swap, &st) == 0;
    snprintf(detail, sizeof detail, "%ld frames, %ld mismatches, XDMF %s the round trip's%s", n,
             bad, same ? "identical to" : "differs from",
             left ? ", scratch or link name left" : "");
    verdict("round trip through the hard-link fallback",
            ok && bad == 0 && n == nframes && same && !left, detail);
  }

  // 1b. Attributes (docs/outputs.md): units and a description on every
  // field group and mesh dataset at creation, the run's on the root from
  // ek_frames_set_info, which is refused once a frame is written.
  {
    char v[256];
    snprintf(path, sizeof path, "%s/attrs.h5", dir);
    ek_frames *fr = ek_frames_create(path, 0, nv, X, nt, tets);
    const ek_frames_info info = {.program = "test_frames",
                                 .scene = "scenes/none.json",
                                 .model = "stvk",
                                 .precision = "f64",
                                 .integrator = "explicit",
                                 .git_revision = "0123abc"};
    // A reader holding the file open (HDF5 locks it) while the attributes
    // go in, as ek-sim's readers may (test_frames_sim polls the file).
    hid_t held = fr ? H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT) : -1;
    int set = fr && ek_frames_set_info(fr, &info) == 0;
    if (!set)
      printf("  ek_frames_set_info: %s\n", ek_last_error());
    double *x = malloc(3 * nv * sizeof(double)), *J = malloc(nt * sizeof(double));
    double *sm = malloc(nt * sizeof(double)), *ps = malloc(nt * sizeof(double));
    fill_frame(0, nv, nt, x, J, sm, ps);
    int wrote = fr && ek_frames_write(fr, 0.0, 0, x, J, sm, ps) == 0;
    int late = fr ? ek_frames_set_info(fr, &info) : 0;
    if (held >= 0)
      H5Fclose(held);
    if (fr)
      ek_frames_close(fr);
    free(x);
    free(J);
    free(sm);
    free(ps);
    hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    const char *want[][3] = {
        {"/", "scene", "scenes/none.json"}, {"/", "model", "stvk"},
        {"/", "precision", "f64"},          {"/", "integrator", "explicit"},
        {"/", "git_revision", "0123abc"},   {"/", "program", "test_frames"},
        {"/", "element", "tetrahedron"},    {"/mesh/vertices", "units", "m"},
        {"/frames/time", "units", "s"},     {"/frames/positions", "units", "m"},
        {"/frames/J", "units", "1"},        {"/frames/energy_density_from_rest", "units", "J/m^3"},
        {"/frames/D", "units", "1/s"},      {"/frames/vertex_rotation", "units", "1"}};
    int nwant = (int)(sizeof want / sizeof *want), good = 0, described = 0;
    const char *first_bad = "";
    char got_bad[320] = "";
    for (int i = 0; f >= 0 && i < nwant; ++i) {
      attr_text(f, want[i][0], want[i][1], v, sizeof v);
      if (strcmp(v, want[i][2]) == 0)
        good++;
      else if (!first_bad[0]) {
        first_bad = want[i][1];
        snprintf(got_bad, sizeof got_bad, "%s %s = '%s'", want[i][0], want[i][1], v);
      }
    }
    const char *groups[] = {"/frames/J",
                            "/frames/smin",
                            "/frames/energy_density_from_rest",
                            "/frames/D",
                            "/frames/W",
                            "/frames/strain_rates",
                            "/frames/vertex_rotation",
                            "/frames/positions"};
    for (int i = 0; f >= 0 && i < 8; ++i) {
      attr_text(f, groups[i], "description", v, sizeof v);
      described += v[0] != '\0';
    }
    attr_text(f, "/", "ek_version", v, sizeof v);
    if (f >= 0)
      H5Fclose(f);
    snprintf(detail, sizeof detail,
             "set %d (file held open by a reader), frame %d, %d of %d attributes as written%s%s, "
             "%d of 8 fields described, "
             "ek_version '%s', set after a frame: %d",
             set, wrote, good, nwant, first_bad[0] ? "; first wrong: " : "", got_bad, described, v,
             late);
    verdict("attributes: units, descriptions, the run's info",
            set && wrote && good == nwant && described == 8 && v[0] && late == EK_EINVAL, detail);
  }

  // 2. The XDMF is never written in place: each frame goes into a scratch
  // copy one frame behind, which then swaps names with it (sim/frames.c).
  // After every frame the XDMF is whole and lists every frame, the scratch
  // copy is whole and lists one fewer, the two files take turns at the
  // XDMF's name (the inode after frame k is the one after frame k - 2: no
  // new file per frame), and close removes the scratch copy.
  {
    snprintf(path, sizeof path, "%s/append.h5", dir);
    ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
    char sxmf[700];
    snprintf(sxmf, sizeof sxmf, "%s.scratch", xdmf);
    ek_frames *fr = ek_frames_create(path, 0, nv, X, nt, tets);
    double *x = malloc(3 * nv * sizeof(double)), *J = malloc(nt * sizeof(double));
    double *sm = malloc(nt * sizeof(double)), *ps = malloc(nt * sizeof(double));
    ino_t ino[2] = {0, 0};
    long whole = 0, n = 12, listed = 0, behind = 0, turns = 0;
    int wrote = fr != NULL;
    for (long k = 0; fr && k < n; ++k) {
      fill_frame(k, nv, nt, x, J, sm, ps);
      if (ek_frames_write(fr, 0.125 * (double)k, 10 * k, x, J, sm, ps) != 0) {
        printf("  ek_frames_write: %s\n", ek_last_error());
        wrote = 0;
        break;
      }
      listed = count_in_file(xdmf, "<Grid Name=\"frame_");
      whole += xdmf_closed(xdmf) && listed == k + 1;
      behind += xdmf_closed(sxmf) && count_in_file(sxmf, "<Grid Name=\"frame_") == k;
      if (stat(xdmf, &st) == 0) {
        turns += k < 2 ? st.st_ino != ino[(k + 1) % 2] : st.st_ino == ino[k % 2];
        ino[k % 2] = st.st_ino;
      }
    }
    if (fr)
      ek_frames_close(fr);
    int scratch_left = stat(sxmf, &st) == 0;
    free(x);
    free(J);
    free(sm);
    free(ps);
    snprintf(detail, sizeof detail,
             "%ld frames: whole and listing all after %ld, scratch one behind after %ld, two "
             "files in turn after %ld, lists %ld%s",
             n, whole, behind, turns, listed, scratch_left ? ", scratch XDMF left" : "");
    verdict("XDMF swapped with a scratch copy, whole after each frame",
            wrote && whole == n && behind == n && turns == n && listed == n && !scratch_left,
            detail);
  }

  // 2b. A reader that holds the file open across frames (HDF5 locks it)
  // neither blocks the writer nor sees its file change.
  {
    snprintf(path, sizeof path, "%s/held.h5", dir);
    ek_frames *fw = ek_frames_create(path, 0, nv, X, nt, tets);
    double *x = malloc(3 * nv * sizeof(double)), *J = malloc(nt * sizeof(double));
    double *sm = malloc(nt * sizeof(double)), *ps = malloc(nt * sizeof(double));
    long n = 8, written = 0, held_frames = -1, held_bad = -1;
    hid_t held = -1;
    for (long k = 0; fw && k < n; ++k) {
      if (k == 2)
        held = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
      fill_frame(k, nv, nt, x, J, sm, ps);
      if (ek_frames_write(fw, 0.125 * (double)k, 10 * k, x, J, sm, ps) != 0) {
        printf("  ek_frames_write: %s\n", ek_last_error());
        break;
      }
      written++;
    }
    if (fw)
      ek_frames_close(fw);
    if (held >= 0) {
      held_frames = series_length(held, "/frames/time");
      held_bad = check_file(held, nv, nt, X, tets, 2);
      H5Fclose(held);
    }
    hid_t f = -1;
    long stored = frames_in(path, &f), bad2 = -1;
    if (f >= 0) {
      bad2 = check_file(f, nv, nt, X, tets, n);
      H5Fclose(f);
    }
    free(x);
    free(J);
    free(sm);
    free(ps);
    snprintf(detail, sizeof detail,
             "wrote %ld of %ld; the held file: %ld frames, %ld mismatches; the file now: %ld "
             "frames, %ld mismatches",
             written, n, held_frames, held_bad, stored, bad2);
    verdict("a reader holding the file open does not block",
            written == n && held_frames == 2 && held_bad == 0 && stored == n && bad2 == 0, detail);
  }

  // 3. Refuse to overwrite; the existing file stays intact.
  snprintf(path, sizeof path, "%s/roundtrip.h5", dir);
  struct stat before, after;
  stat(path, &before);
  ek_frames *fr = ek_frames_create(path, 0, nv, X, nt, tets);
  stat(path, &after);
  ok = fr == NULL && strstr(ek_last_error(), path) &&
       strstr(ek_last_error(), "refusing to overwrite") && before.st_size == after.st_size &&
       before.st_mtime == after.st_mtime;
  snprintf(detail, sizeof detail, "message: %s", ek_last_error());
  verdict("existing file refused without force", ok, detail);
  if (fr)
    ek_frames_close(fr);
  // The XDMF alone existing also blocks.
  snprintf(path, sizeof path, "%s/only_xdmf.h5", dir);
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  FILE *fx = fopen(xdmf, "w");
  if (fx)
    fclose(fx);
  fr = ek_frames_create(path, 0, nv, X, nt, tets);
  ok = fr == NULL && strstr(ek_last_error(), xdmf) && stat(path, &st) != 0;
  snprintf(detail, sizeof detail, "message: %s", ek_last_error());
  verdict("existing XDMF refused, no HDF5 created", ok, detail);
  if (fr)
    ek_frames_close(fr);
  // force overwrites.
  snprintf(path, sizeof path, "%s/roundtrip.h5", dir);
  ok = writer(path, 1, nv, nt, X, tets, 3, -1) == 0;
  if (ok) {
    hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    ok = f >= 0 && series_length(f, "/frames/time") == 3 && check_file(f, nv, nt, X, tets, 3) == 0;
    if (f >= 0)
      H5Fclose(f);
  }
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  grids = count_in_file(xdmf, "<Grid Name=\"frame_");
  snprintf(detail, sizeof detail, "xdmf lists %ld", grids);
  verdict("force overwrites (3 frames now)", ok && grids == 3, detail);

  // 4. Scratch files a killed run left (here 48 bytes of junk for the
  // HDF5 file, and for the XDMF a hard link to another file, which must
  // stay as it was: the scratch name is replaced, never written into) do
  // not block a new run without force, and are gone after it.
  snprintf(path, sizeof path, "%s/stale.h5", dir);
  snprintf(scratch, sizeof scratch, "%s.scratch", path);
  fx = fopen(scratch, "wb");
  if (fx) {
    fwrite("\x89HDF\r\n\x1a\n0123456789abcdef0123456789abcdef0123456789", 1, 48, fx);
    fclose(fx);
  }
  char other[600], xscratch[700];
  snprintf(other, sizeof other, "%s/other.txt", dir);
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  snprintf(xscratch, sizeof xscratch, "%s.scratch", xdmf);
  fx = fopen(other, "wb");
  if (fx) {
    fputs("not ek's\n", fx);
    fclose(fx);
  }
  int linked = link(other, xscratch) == 0;
  ok = writer(path, 0, nv, nt, X, tets, 2, -1) == 0;
  hid_t f = -1;
  long stored = frames_in(path, &f);
  if (f >= 0) {
    ok = ok && check_file(f, nv, nt, X, tets, 2) == 0;
    H5Fclose(f);
  }
  char *kept = slurp(other);
  int other_same = kept && strcmp(kept, "not ek's\n") == 0;
  free(kept);
  grids = count_in_file(xdmf, "<Grid Name=\"frame_");
  int left = stat(scratch, &st) == 0 || stat(xscratch, &st) == 0;
  snprintf(detail, sizeof detail,
           "file holds %ld frames, xdmf lists %ld%s; scratch files %s; linked file %s", stored,
           grids, xdmf_closed(xdmf) ? "" : " (not closed)", left ? "left" : "removed",
           other_same ? "unchanged" : "CHANGED");
  verdict("stale scratch files do not block a new run",
          ok && linked && stored == 2 && grids == 2 && xdmf_closed(xdmf) && !left && other_same,
          detail);

  // 4b. The XDMF's scratch name is renamed over at every frame: a
  // directory there is refused before any file is made.
  {
    snprintf(path, sizeof path, "%s/xs.h5", dir);
    ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
    snprintf(xscratch, sizeof xscratch, "%s.scratch", xdmf);
    int made = mkdir(xscratch, 0700) == 0;
    fr = ek_frames_create(path, 1, nv, X, nt, tets);
    ok = made && !fr && strstr(ek_last_error(), ".xmf.scratch: is a directory") &&
         stat(path, &st) != 0 && stat(xdmf, &st) != 0;
    snprintf(detail, sizeof detail, "message: %s", fr ? "(none: created)" : ek_last_error());
    verdict("XDMF scratch name a directory: refused (force)", ok, detail);
    if (fr)
      ek_frames_close(fr);
    rmdir(xscratch);
  }

  // 5. The XDMF names the file XML-escaped; names it cannot hold are
  // refused before any file is made (and their bytes are not echoed).
  snprintf(path, sizeof path, "%s/R&D<1>'\".h5", dir);
  ok = writer(path, 0, nv, nt, X, tets, 2, -1) == 0;
  ek_frames_xdmf_path(path, xdmf, sizeof xdmf);
  char *text = slurp(xdmf);
  long escaped = count_in_file(xdmf, "R&amp;D&lt;1&gt;&apos;&quot;.h5:/");
  // Per frame: the topology, the geometry, the positions again, J, smin,
  // psi, D, W, strain_rates and vertex_rotation.
  ok = ok && text && !strstr(text, "R&D") && escaped == 2 * 10;
  snprintf(detail, sizeof detail, "%ld escaped references (expected 20)%s", escaped,
           text && strstr(text, "R&D") ? ", raw name found" : "");
  verdict("file name XML-escaped in the XDMF", ok, detail);
  free(text);
  static const struct {
    const char *name, *expect;
  } refused[] = {{"a:b.h5", "colon"},
                 {"ctl\001.h5", "0x01"},
                 {"bad\377.h5", "not UTF-8"},
                 {" lead.h5", "blank"}};
  for (size_t i = 0; i < sizeof refused / sizeof refused[0]; ++i) {
    snprintf(path, sizeof path, "%s/%s", dir, refused[i].name);
    fr = ek_frames_create(path, 0, nv, X, nt, tets);
    int raw = strchr(ek_last_error(), '\001') || strchr(ek_last_error(), '\377');
    ok = fr == NULL && strstr(ek_last_error(), refused[i].expect) && !raw && stat(path, &st) != 0;
    snprintf(detail, sizeof detail, "message: %s", raw ? "(holds the raw bytes)" : ek_last_error());
    char what[64];
    snprintf(what, sizeof what, "name refused (%s)", refused[i].expect);
    verdict(what, ok, detail);
    if (fr)
      ek_frames_close(fr);
  }
  snprintf(path, sizeof path, "%s/d\303\251formation.h5", dir);
  ok = writer(path, 0, nv, nt, X, tets, 1, -1) == 0 && frames_in(path, NULL) == 1;
  verdict("UTF-8 name accepted", ok, "");

  // 6. Killed writer: the child writes frames forever and reports each
  // completed one through a pipe; the parent kills it with SIGKILL at once
  // (before or inside the first commit), after one frame, and after a
  // seed-dependent number of frames (usually inside a write).
  nv = 20000;
  nt = 60000;
  make_mesh(nv, nt, X, tets);
  const long waits[] = {0, 1, 3 + (long)(seed % 5)};
  for (size_t i = 0; i < sizeof waits / sizeof waits[0]; ++i) {
    snprintf(path, sizeof path, "%s/killed%zu.h5", dir, i);
    ok = kill_test(path, waits[i], nv, nt, X, tets, detail, sizeof detail);
    char what[80];
    snprintf(what, sizeof what, "SIGKILLed writer (after %ld frames)", waits[i]);
    verdict(what, ok, detail);
  }
  // The same at a seed-dependent frame through the hard-link fallback: a
  // kill between its link and its renames must leave the committed files too.
  snprintf(path, sizeof path, "%s/killed_fallback.h5", dir);
  setenv("EK_FRAMES_TEST_NO_EXCHANGE", "1", 1);
  ok = kill_test(path, waits[2], nv, nt, X, tets, detail, sizeof detail);
  // and a new run (force) over what the kill left writes whole files.
  int rerun = writer(path, 1, nv, nt, X, tets, 2, -1) == 0 && frames_in(path, NULL) == 2;
  unsetenv("EK_FRAMES_TEST_NO_EXCHANGE");
  snprintf(detail + strlen(detail), sizeof detail - strlen(detail), "; a new run %s",
           rerun ? "writes 2 frames" : "FAILED");
  verdict("SIGKILLed writer, hard-link fallback", ok && rerun, detail);

  free(X);
  free(tets);
  remove_dir(dir);
  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
