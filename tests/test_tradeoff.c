// Invariant: the speed/accuracy map's bookkeeping (bench/tradeoff.c) is
// exact. The Pareto marking on hand-made sets: a point is on the front
// exactly when no other point is at least as good in both time and error
// and strictly better in one, and of exact duplicates only the first is
// (ties in one coordinate, duplicates, zero and infinite errors, NaN, a
// single point, the issue-26 polar pair); the fronts are taken
// per family and thread count, on p99 and on max. The error distribution's
// nearest-rank percentiles, maximum and over-budget count on a shuffled
// 1..n (NaN counted as over budget, sorted last). The writers: a map written
// to HDF5 and JSON reads back with every field equal (HDF5 C API, cJSON);
// an existing file is not overwritten without force; no temporary file is
// left; a point with a missing or too long string is refused.
#include <cjson/cJSON.h>
#include <dirent.h>
#include <hdf5.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "results.h"
#include "tradeoff.h"

#include "test_check.h"

static void front_text(size_t n, const unsigned char *f, char *buf) {
  for (size_t i = 0; i < n; i++)
    buf[i] = f[i] ? '1' : '0';
  buf[n] = 0;
}

// ---- Pareto marking --------------------------------------------------------

static void check_pareto(void) {
  struct {
    const char *name;
    size_t n;
    double time[8], err[8];
    const char *expected;
  } cases[] = {
      // (1,5) (2,3) (3,4) (4,1) (5,1): (3,4) is beaten by (2,3); (5,1) has
      // the same error as (4,1) and is slower: dominated.
      {"staircase", 5, {1, 2, 3, 4, 5}, {5, 3, 4, 1, 1}, "11010"},
      {"single point", 1, {7}, {1e-3}, "1"},
      {"single zero-error point", 1, {7}, {0}, "1"},
      // Exact duplicates: the first of them only (the given order).
      {"duplicates: the first stays", 3, {1, 1, 2}, {2, 2, 3}, "100"},
      {"duplicates after a better point: none", 3, {0.5, 1, 1}, {1, 2, 2}, "100"},
      {"three duplicates, then a faster worse point", 4, {3, 3, 3, 1}, {1, 1, 1, 2}, "1001"},
      // Equal time: the lower error wins; equal error: the lower time wins.
      {"equal time, lower error beats", 2, {1, 1}, {2, 1}, "01"},
      {"equal error, lower time beats", 2, {2, 1}, {1, 1}, "01"},
      // The issue-26 pair: scalar f64 SVD polar 494 ns and warm polar 6.9
      // ns at one error, plus a slower point with a lower error.
      {"equal error: the 494 ns polar off", 3, {494, 6.9, 700}, {1e-15, 1e-15, 1e-16}, "011"},
      // Zero errors (loop references): 0 beats every error > 0 at equal
      // or higher time; two zero-error points: the faster.
      {"zero error beats equal-time error", 2, {5, 5}, {1e-9, 0}, "01"},
      {"two zero errors: the faster", 3, {9, 4, 1}, {0, 0, 1e-3}, "011"},
      {"zero-error duplicates: the first", 2, {4, 4}, {0, 0}, "10"},
      {"NaN never on the front, hides nothing", 4, {1, NAN, 3, 2}, {3, 0, NAN, 5}, "1000"},
      {"NaN duplicates of a point hide nothing", 3, {NAN, 2, 2}, {1, NAN, 1}, "001"},
      {"one point beats all", 4, {1, 2, 3, 4}, {1, 2, 3, 4}, "1000"},
      {"anti-diagonal all on", 4, {1, 2, 3, 4}, {4, 3, 2, 1}, "1111"},
      {"inf error", 3, {1, 2, 3}, {INFINITY, 1, 0.5}, "111"},
      {"inf errors tie: the faster", 3, {2, 1, 3}, {INFINITY, INFINITY, 1}, "011"},
  };
  for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
    unsigned char front[8];
    char got[9];
    ek_tradeoff_pareto(cases[c].n, cases[c].time, cases[c].err, front);
    front_text(cases[c].n, front, got);
    check(cases[c].name, !strcmp(got, cases[c].expected), "front %s, expected %s", got,
          cases[c].expected);
  }
}

// ---- error distributions -------------------------------------------------

static void check_distribution(unsigned long long seed) {
  enum { N = 20000 };
  double *err = malloc(N * sizeof *err);
  for (long i = 0; i < N; i++)
    err[i] = (double)(i + 1);
  // Shuffle (Fisher-Yates, LCG from the seed): the order must not matter.
  unsigned long long x = seed * 2862933555777941757ULL + 3037000493ULL;
  for (long i = N - 1; i > 0; i--) {
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    long j = (long)((x >> 33) % (unsigned long long)(i + 1));
    double t = err[i];
    err[i] = err[j], err[j] = t;
  }
  ek_tradeoff_point p = {.budget = 19990.5};
  ek_tradeoff_distribution(err, N, &p);
  // Nearest rank of 1..N: p_q = ceil(q N).
  check("distribution 1..20000",
        p.count == N && p.err_p50 == 10000 && p.err_p99 == 19800 && p.err_p9999 == 19998 &&
            p.err_max == N && p.over_budget == 10,
        "count %ld p50 %g p99 %g p99.99 %g max %g over %ld; expected 20000 10000 19800 19998 "
        "20000 10",
        p.count, p.err_p50, p.err_p99, p.err_p9999, p.err_max, p.over_budget);
  double small[5] = {3, NAN, 1, INFINITY, 2};
  ek_tradeoff_point q = {.budget = 2.5};
  ek_tradeoff_distribution(small, 5, &q);
  check("distribution with NaN and inf",
        q.err_p50 == 3 && isnan(q.err_max) && q.err_p99 != q.err_p99 && q.over_budget == 3,
        "p50 %g max %g over %ld; expected 3, NaN (last), 3 over budget", q.err_p50, q.err_max,
        q.over_budget);
  ek_tradeoff_point e = {.budget = NAN};
  ek_tradeoff_distribution(small, 0, &e);
  check("empty distribution", e.count == 0 && isnan(e.err_max), "count %ld max %g", e.count,
        e.err_max);
  free(err);
}

// ---- writers -----------------------------------------------------------------

enum { NPOINTS = 6 };
typedef struct {
  const char *family, *setting;
  int threads;
  double time, p99, max;
  int front_p99, front_max; // expected
} spec;
// Fronts per family and thread count: svd3 at 1 thread: (10, 1e-3) and
// (20, 1e-6) on both; (30, 1e-5) beaten by (20, 1e-6) on p99 but on the
// max front (its max 1e-7 is the lowest). At 2 threads alone: on both.
static const spec specs[NPOINTS] = {
    {"svd3", "precision=f32;sweeps=1;isa=avx2", 1, 10, 1e-3, 1e-2, 1, 1},
    {"svd3", "precision=f32;sweeps=2;isa=avx2", 1, 20, 1e-6, 1e-5, 1, 1},
    {"svd3", "precision=f32;sweeps=3;isa=avx2", 1, 30, 1e-5, 1e-7, 0, 1},
    {"svd3", "precision=f32;sweeps=3;isa=avx2", 2, 100, 1, 1, 1, 1},
    {"pk1/fixed_corotated", "precision=f64;isa=scalar", 1, 5, 1e-15, 2e-15, 1, 1},
    {"pk1/fixed_corotated", "precision=f32;isa=scalar", 1, 4, 1e-7, INFINITY, 1, 1},
};

static int build(ek_tradeoff *t) {
  for (int i = 0; i < NPOINTS; i++) {
    ek_tradeoff_point p = {
        .family = specs[i].family,
        .setting = specs[i].setting,
        .is_default = i == 1,
        .is_reference = i == 4,
        .time_median = specs[i].time,
        .time_min = specs[i].time * 0.75,
        .time_unit = "ns/matrix",
        .threads = specs[i].threads,
        .error_metric = "worst",
        .count = 1000 + i,
        .err_p50 = specs[i].p99 / 8,
        .err_p99 = specs[i].p99,
        .err_p9999 = specs[i].p99 * 2,
        .err_max = specs[i].max,
        .budget = i < 4 ? 2e-5 : NAN,
        .over_budget = i,
        .energy_drift = i == 5 ? 0.125 : NAN,
    };
    if (ek_tradeoff_add(t, &p))
      return -1;
  }
  return 0;
}

// Same double, NaN equal to NaN.
static int same(double a, double b) { return a == b || (isnan(a) && isnan(b)); }

static void check_h5(const char *path) {
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  check("HDF5 opens", f >= 0, "%s", path);
  if (f < 0)
    return;
  check("HDF5 metadata attribute", H5Aexists(f, "cpu_model") > 0 && H5Aexists(f, "suite") > 0,
        "cpu_model and suite on /");
  const char *families[2] = {"tradeoff/svd3/points", "tradeoff/pk1/fixed_corotated/points"};
  const int first[2] = {0, 4}, count[2] = {4, 2};
  for (int k = 0; k < 2; k++) {
    hid_t ds = H5Dopen2(f, families[k], H5P_DEFAULT);
    check("HDF5 family dataset", ds >= 0, "%s", families[k]);
    if (ds < 0)
      continue;
    hid_t space = H5Dget_space(ds);
    hssize_t n = H5Sget_simple_extent_npoints(space);
    H5Sclose(space);
    check("HDF5 point count", n == count[k], "%s: %lld, expected %d", families[k], (long long)n,
          count[k]);
    // Read the fields back with a memory type of our own (by name).
    typedef struct {
      char setting[256];
      int threads, on_front_p99, on_front_max, is_default, is_reference;
      double time_median, time_min, err_p99, err_max, budget, energy_drift;
      long long count, over_budget;
    } row;
    hid_t mt = H5Tcreate(H5T_COMPOUND, sizeof(row));
    hid_t s256 = H5Tcopy(H5T_C_S1);
    H5Tset_size(s256, 256);
    H5Tset_cset(s256, H5T_CSET_UTF8);
    H5Tinsert(mt, "setting", HOFFSET(row, setting), s256);
#define INS(name, type) H5Tinsert(mt, #name, HOFFSET(row, name), type)
    INS(threads, H5T_NATIVE_INT);
    INS(on_front_p99, H5T_NATIVE_INT);
    INS(on_front_max, H5T_NATIVE_INT);
    INS(is_default, H5T_NATIVE_INT);
    INS(is_reference, H5T_NATIVE_INT);
    INS(time_median, H5T_NATIVE_DOUBLE);
    INS(time_min, H5T_NATIVE_DOUBLE);
    INS(err_p99, H5T_NATIVE_DOUBLE);
    INS(err_max, H5T_NATIVE_DOUBLE);
    INS(budget, H5T_NATIVE_DOUBLE);
    INS(energy_drift, H5T_NATIVE_DOUBLE);
    INS(count, H5T_NATIVE_LLONG);
    INS(over_budget, H5T_NATIVE_LLONG);
#undef INS
    row rows[4];
    memset(rows, 0, sizeof rows);
    herr_t rc = n == count[k] ? H5Dread(ds, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, rows) : -1;
    check("HDF5 read", rc >= 0, "%s", families[k]);
    for (int i = 0; rc >= 0 && i < count[k]; i++) {
      const spec *s = &specs[first[k] + i];
      int j = first[k] + i;
      int ok = !strcmp(rows[i].setting, s->setting) && rows[i].threads == s->threads &&
               rows[i].time_median == s->time && rows[i].time_min == s->time * 0.75 &&
               rows[i].err_p99 == s->p99 && same(rows[i].err_max, s->max) &&
               rows[i].on_front_p99 == s->front_p99 && rows[i].on_front_max == s->front_max &&
               rows[i].is_default == (j == 1) && rows[i].is_reference == (j == 4) &&
               rows[i].count == 1000 + j && rows[i].over_budget == j &&
               same(rows[i].budget, j < 4 ? 2e-5 : NAN) &&
               same(rows[i].energy_drift, j == 5 ? 0.125 : NAN);
      check("HDF5 point round trip", ok,
            "%s threads %d: time %g err_p99 %g max %g fronts p99 %d max %d (expected %d %d)",
            rows[i].setting, rows[i].threads, rows[i].time_median, rows[i].err_p99, rows[i].err_max,
            rows[i].on_front_p99, rows[i].on_front_max, s->front_p99, s->front_max);
    }
    H5Tclose(s256), H5Tclose(mt), H5Dclose(ds);
  }
  H5Fclose(f);
}

static double number_or_nan(const cJSON *o, const char *key) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
  if (cJSON_IsString(v) && !strcmp(v->valuestring, "inf"))
    return INFINITY;
  return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

static void check_json(const char *path) {
  char *text = slurp(path);
  cJSON *root = text ? cJSON_Parse(text) : NULL;
  free(text);
  check("JSON parses", root != NULL, "%s", path);
  if (!root)
    return;
  const cJSON *suite = cJSON_GetObjectItemCaseSensitive(root, "suite");
  const cJSON *meta = cJSON_GetObjectItemCaseSensitive(root, "metadata");
  const cJSON *points = cJSON_GetObjectItemCaseSensitive(root, "points");
  check("JSON suite and metadata",
        cJSON_IsString(suite) && !strcmp(suite->valuestring, "tradeoff") &&
            cJSON_IsString(cJSON_GetObjectItemCaseSensitive(meta, "git_revision")),
        "suite, metadata.git_revision");
  check("JSON point count", cJSON_GetArraySize(points) == NPOINTS, "%d, expected %d",
        cJSON_GetArraySize(points), NPOINTS);
  for (int i = 0; i < NPOINTS && i < cJSON_GetArraySize(points); i++) {
    const cJSON *p = cJSON_GetArrayItem(points, i);
    const cJSON *knobs = cJSON_GetObjectItemCaseSensitive(p, "knobs");
    const cJSON *isa = cJSON_GetObjectItemCaseSensitive(knobs, "isa");
    int ok =
        !strcmp(cJSON_GetObjectItemCaseSensitive(p, "family")->valuestring, specs[i].family) &&
        number_or_nan(p, "time_median") == specs[i].time &&
        number_or_nan(p, "err_p99") == specs[i].p99 &&
        same(number_or_nan(p, "err_max"), specs[i].max) &&
        cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(p, "on_front_p99")) == specs[i].front_p99 &&
        cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(p, "on_front_max")) == specs[i].front_max &&
        cJSON_IsString(isa) &&
        (i == 5 ? number_or_nan(p, "energy_drift") == 0.125
                : !cJSON_HasObjectItem(p, "energy_drift")) &&
        (i < 4 ? number_or_nan(p, "budget") == 2e-5 : !cJSON_HasObjectItem(p, "budget"));
    check("JSON point round trip", ok, "point %d (%s %s)", i, specs[i].family, specs[i].setting);
  }
  cJSON_Delete(root);
}

// 1 if a "*.tmp.*" file is in dir.
static int temp_left(const char *dir) {
  DIR *d = opendir(dir);
  int found = 0;
  for (struct dirent *e; d && (e = readdir(d));)
    found |= strstr(e->d_name, ".tmp.") != NULL;
  if (d)
    closedir(d);
  return found;
}

static void check_writers(void) {
  char dir[] = "/tmp/ek_tradeoff_XXXXXX";
  if (!mkdtemp(dir)) {
    check("mkdtemp", 0, "%s", dir);
    return;
  }
  char h5[256], json[256];
  snprintf(h5, sizeof h5, "%s/map.h5", dir);
  snprintf(json, sizeof json, "%s/map.json", dir);
  ek_tradeoff_opts o = {.seed = 1, .n = 10};
  ek_tradeoff *t = ek_tradeoff_create(&o);
  ek_results meta;
  ek_results_init(&meta);
  ek_results_collect_metadata(&meta, "test_tradeoff");
  ek_results_meta_text(&meta, "suite", "tradeoff");
  check("points added", t && build(t) == 0 && ek_tradeoff_count(t) == NPOINTS, "%zu points",
        t ? ek_tradeoff_count(t) : 0);
  for (int i = 0; t && i < NPOINTS; i++)
    check("front per family and threads",
          ek_tradeoff_on_front(t, (size_t)i, 0) == specs[i].front_p99 &&
              ek_tradeoff_on_front(t, (size_t)i, 1) == specs[i].front_max,
          "point %d: p99 %d max %d, expected %d %d", i, ek_tradeoff_on_front(t, (size_t)i, 0),
          ek_tradeoff_on_front(t, (size_t)i, 1), specs[i].front_p99, specs[i].front_max);
  int w = ek_tradeoff_write_h5(t, &meta, h5, 0) | ek_tradeoff_write_json(t, &meta, json, 0);
  check("written", w == 0, "%s, %s", h5, json);
  check_h5(h5);
  check_json(json);
  printf("(the next two refusals print their messages)\n");
  check("existing HDF5 not overwritten", ek_tradeoff_write_h5(t, &meta, h5, 0) < 0, "%s", h5);
  check("existing JSON not overwritten", ek_tradeoff_write_json(t, &meta, json, 0) < 0, "%s", json);
  check("overwritten with force",
        ek_tradeoff_write_h5(t, &meta, h5, 1) == 0 &&
            ek_tradeoff_write_json(t, &meta, json, 1) == 0,
        "force");
  check("no temporary file left", !temp_left(dir), "%s", dir);
  char long_setting[400];
  memset(long_setting, 'k', sizeof long_setting - 1);
  long_setting[sizeof long_setting - 1] = 0;
  ek_tradeoff_point bad = {
      .family = "svd3", .setting = long_setting, .time_unit = "ns", .error_metric = "e"};
  printf("(the next three refusals print their messages)\n");
  check("too long setting refused", ek_tradeoff_add(t, &bad) < 0, "%zu characters",
        strlen(long_setting));
  bad.setting = "ok", bad.family = NULL;
  check("missing family refused", ek_tradeoff_add(t, &bad) < 0, "family NULL");
  bad.family = "pk1//x";
  check("empty family component refused", ek_tradeoff_add(t, &bad) < 0, "pk1//x");
  check("refused points not added", ek_tradeoff_count(t) == NPOINTS, "%zu", ek_tradeoff_count(t));
  ek_results_free(&meta);
  ek_tradeoff_free(t);
  unlink(h5), unlink(json), rmdir(dir);
}

int main(int argc, char **argv) {
  unsigned long long seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_tradeoff: seed %llu (exact: no tolerance)\n", seed);
  check_pareto();
  check_distribution(seed);
  check_writers();
  printf("test_tradeoff: %s\n", failures ? "FAIL" : "PASS");
  return failures ? 1 : 0;
}
