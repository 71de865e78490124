// Invariant: a results set written by ek_bench_core reads back unchanged.
// HDF5 (read with the HDF5 C API): one group per row under /benchmarks
// (nested by the '/'-separated name), sample values bit-exact, row and run
// attributes equal to what was recorded. JSON (read with cJSON): Google
// Benchmark's schema keys present, one iteration row per sample with
// bit-exact real_time, aggregate rows (mean/median/stddev) equal to the
// statistics. Writing onto an existing file without force fails and leaves
// the old file byte-for-byte intact; with force it replaces it; no
// temporary file is ever left behind.
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
#include "timer.h"

static int failures;

static void check(const char *what, int ok, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void check(const char *what, int ok, const char *fmt, ...) {
  char detail[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(detail, sizeof detail, fmt, ap);
  va_end(ap);
  printf("%-5s %s (%s)\n", ok ? "PASS" : "FAIL", what, detail);
  if (!ok)
    failures++;
}

// ---- the results set under test ------------------------------------------

enum { NROWS = 3 };
static const char *const row_names[NROWS] = {
    "svd3/aosoa/avx2/f32/sweeps:4/threads:1",
    "svd3/aosoa/avx2/f32/sweeps:4/threads:2",
    "svd3/lapack/f64/threads:1",
};
static const int row_samples[NROWS] = {5, 7, 6};

static unsigned long long lcg;
static double next_sample(void) {
  lcg = lcg * 6364136223846793005ULL + 1442695040888963407ULL;
  // Values with full 53-bit mantissas: any rounding on the way shows.
  return 1 + (double)(lcg >> 11) * 0x1p-53 * 100;
}

static int build(ek_results *r, unsigned long long seed) {
  ek_results_init(r);
  ek_results_collect_metadata(r, "test_results_io");
  ek_results_meta_number(r, "seed", (double)seed);
  ek_results_meta_text(r, "note", "written by test_results_io");
  lcg = seed;
  for (int i = 0; i < NROWS; i++) {
    double ns[16], cpu[16];
    for (int s = 0; s < row_samples[i]; s++) {
      ns[s] = next_sample();
      cpu[s] = ns[s] * 0.75;
    }
    ek_timing t = {.overhead_ns = 20.5,
                   .iters = 1000 + i,
                   .items = 4096,
                   .nsamples = row_samples[i],
                   .sample_ns = ns,
                   .sample_cpu_ns = cpu,
                   .stats = ek_stats_of(ns, (size_t)row_samples[i])};
    ek_result_row *row = ek_results_add(r, row_names[i], &t);
    if (!row)
      return -1;
    snprintf(row->family, sizeof row->family, "svd3");
    snprintf(row->isa, sizeof row->isa, "%s", i == 2 ? "lapack" : "avx2");
    snprintf(row->precision, sizeof row->precision, "%s", i == 2 ? "f64" : "f32");
    snprintf(row->knobs, sizeof row->knobs, "%s", i == 2 ? "" : "sweeps=4;rsqrt=exact");
    row->threads = i == 1 ? 2 : 1;
    row->flops_per_item = i == 2 ? 0 : 1102;
    row->bytes_per_item = 120;
    row->peak_gflops = 100;
    row->triad_gbs = 20;
    if (i != 2)
      snprintf(row->baseline, sizeof row->baseline, "%s", row_names[2]);
  }
  ek_results_derive(r);
  return 0;
}

// ---- HDF5 read-back --------------------------------------------------------

static int read_text_attr(hid_t obj, const char *name, char *buf, size_t cap) {
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  if (a < 0)
    return -1;
  hid_t type = H5Aget_type(a);
  size_t size = H5Tget_size(type);
  int rc = -1;
  if (H5Tget_class(type) == H5T_STRING && size < cap) {
    memset(buf, 0, cap);
    rc = H5Aread(a, type, buf) < 0 ? -1 : 0;
  }
  H5Tclose(type);
  H5Aclose(a);
  return rc;
}

static int read_double_attr(hid_t obj, const char *name, double *v) {
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  if (a < 0)
    return -1;
  int rc = H5Aread(a, H5T_NATIVE_DOUBLE, v) < 0 ? -1 : 0;
  H5Aclose(a);
  return rc;
}

static int read_int_attr(hid_t obj, const char *name, long long *v) {
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  if (a < 0)
    return -1;
  int rc = H5Aread(a, H5T_NATIVE_LLONG, v) < 0 ? -1 : 0;
  H5Aclose(a);
  return rc;
}

// Same bits, or both NaN (NaN marks "not applicable").
static int same(double a, double b) { return (isnan(a) && isnan(b)) || memcmp(&a, &b, 8) == 0; }

static void check_h5(const ek_results *r, const char *path) {
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  check("HDF5 file opens", f >= 0, "%s", path);
  if (f < 0)
    return;
  char text[EK_RESULTS_TEXT_MAX];
  const ek_meta *host = ek_results_meta_find(r, "host_name");
  int ok = read_text_attr(f, "host_name", text, sizeof text) == 0 && host &&
           strcmp(text, host->text) == 0;
  check("root attribute host_name", ok, "read '%s', expected '%s'", ok ? text : "?",
        host ? host->text : "?");
  const char *text_keys[] = {"git_revision", "compiler",       "c_flags",       "cpu_model", "date",
                             "build_type",   "isas_available", "omp_proc_bind", "note"};
  for (size_t k = 0; k < sizeof text_keys / sizeof *text_keys; k++) {
    const ek_meta *m = ek_results_meta_find(r, text_keys[k]);
    ok = m && read_text_attr(f, text_keys[k], text, sizeof text) == 0 && !strcmp(text, m->text);
    check("root text attribute", ok, "%s = '%s' (expected '%s')", text_keys[k], ok ? text : "?",
          m ? m->text : "(not recorded)");
  }
  double seed = NAN;
  const ek_meta *ms = ek_results_meta_find(r, "seed");
  ok = read_double_attr(f, "seed", &seed) == 0 && ms && same(seed, ms->number);
  check("root number attribute seed", ok, "read %.17g", seed);

  long long count = -1;
  hid_t bench = H5Gopen2(f, "benchmarks", H5P_DEFAULT);
  ok = bench >= 0 && read_int_attr(bench, "count", &count) == 0 && count == NROWS;
  check("/benchmarks count", ok, "count %lld, expected %d", count, NROWS);
  for (int i = 0; bench >= 0 && i < NROWS; i++) {
    const ek_result_row *row = &r->rows[i];
    hid_t g = H5Gopen2(bench, row->name, H5P_DEFAULT);
    check("row group exists", g >= 0, "/benchmarks/%s", row->name);
    if (g < 0)
      continue;
    // Samples, bit-exact.
    double got[16] = {0};
    hid_t ds = H5Dopen2(g, "samples_ns", H5P_DEFAULT);
    hid_t space = ds >= 0 ? H5Dget_space(ds) : -1;
    hssize_t n = space >= 0 ? H5Sget_simple_extent_npoints(space) : -1;
    ok = n == row->nsamples &&
         H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, got) >= 0 &&
         memcmp(got, row->sample_ns, (size_t)n * sizeof(double)) == 0;
    check("samples_ns bit-exact", ok, "%s: %lld values, first written %.17g read %.17g", row->name,
          (long long)n, row->sample_ns[0], got[0]);
    if (space >= 0)
      H5Sclose(space);
    if (ds >= 0)
      H5Dclose(ds);
    ds = H5Dopen2(g, "samples_cpu_ns", H5P_DEFAULT);
    ok = ds >= 0 && H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, got) >= 0 &&
         memcmp(got, row->sample_cpu_ns, (size_t)row->nsamples * sizeof(double)) == 0;
    check("samples_cpu_ns bit-exact", ok, "%s", row->name);
    if (ds >= 0)
      H5Dclose(ds);
    // Attributes.
    ok = read_text_attr(g, "name", text, sizeof text) == 0 && !strcmp(text, row->name);
    check("attribute name", ok, "'%s'", ok ? text : "?");
    ok = read_text_attr(g, "isa", text, sizeof text) == 0 && !strcmp(text, row->isa);
    check("attribute isa", ok, "'%s' expected '%s'", ok ? text : "?", row->isa);
    ok = read_text_attr(g, "knobs", text, sizeof text) == 0 && !strcmp(text, row->knobs);
    check("attribute knobs", ok, "'%s' expected '%s'", ok ? text : "?", row->knobs);
    if (row->knobs[0]) {
      ok = read_text_attr(g, "knob.sweeps", text, sizeof text) == 0 && !strcmp(text, "4");
      check("attribute knob.sweeps", ok, "'%s' expected '4'", ok ? text : "?");
    }
    long long threads = -1, iters = -1;
    ok = read_int_attr(g, "threads", &threads) == 0 && threads == row->threads &&
         read_int_attr(g, "iters", &iters) == 0 && iters == row->iters;
    check("attributes threads, iters", ok, "threads %lld (%d), iters %lld (%ld)", threads,
          row->threads, iters, row->iters);
    const struct {
      const char *name;
      double expected;
    } nums[] = {{"median_ns", row->stats.median},
                {"mad_ns", row->stats.mad},
                {"cv", row->stats.cv},
                {"min_ns", row->stats.min},
                {"gflops", row->gflops},
                {"peak_fraction", row->peak_fraction},
                {"speedup_vs_baseline", row->speedup_vs_baseline},
                {"speedup_threads", row->speedup_threads}};
    for (size_t k = 0; k < sizeof nums / sizeof *nums; k++) {
      double v = -1;
      ok = read_double_attr(g, nums[k].name, &v) == 0 && same(v, nums[k].expected);
      check("numeric attribute", ok, "%s %s: read %.17g, written %.17g", row->name, nums[k].name, v,
            nums[k].expected);
    }
    H5Gclose(g);
  }
  if (bench >= 0)
    H5Gclose(bench);
  H5Fclose(f);
}

// ---- JSON read-back ----------------------------------------------------------

static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f)
    return NULL;
  fseek(f, 0, SEEK_END);
  long len = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *buf = malloc((size_t)len + 1);
  if (buf && fread(buf, 1, (size_t)len, f) == (size_t)len)
    buf[len] = 0;
  else {
    free(buf);
    buf = NULL;
  }
  fclose(f);
  return buf;
}

static void check_json(const ek_results *r, const char *path) {
  char *text = slurp(path);
  cJSON *root = text ? cJSON_Parse(text) : NULL;
  free(text);
  check("JSON parses", root != NULL, "%s", path);
  if (!root)
    return;
  cJSON *ctx = cJSON_GetObjectItemCaseSensitive(root, "context");
  const char *ctx_keys[] = {"date",         "host_name",
                            "executable",   "num_cpus",
                            "mhz_per_cpu",  "cpu_scaling_enabled",
                            "caches",       "library_build_type",
                            "git_revision", "compiler",
                            "c_flags",      "isas_available"};
  for (size_t k = 0; k < sizeof ctx_keys / sizeof *ctx_keys; k++)
    check("context key present", cJSON_HasObjectItem(ctx, ctx_keys[k]), "%s", ctx_keys[k]);
  cJSON *host = cJSON_GetObjectItemCaseSensitive(ctx, "host_name");
  const ek_meta *mh = ek_results_meta_find(r, "host_name");
  check("context host_name equal",
        cJSON_IsString(host) && mh && !strcmp(host->valuestring, mh->text), "'%s'",
        cJSON_IsString(host) ? host->valuestring : "?");
  check("context cpu_scaling_enabled is a bool",
        cJSON_IsBool(cJSON_GetObjectItemCaseSensitive(ctx, "cpu_scaling_enabled")), "type");

  cJSON *list = cJSON_GetObjectItemCaseSensitive(root, "benchmarks");
  int expected = 0;
  for (int i = 0; i < NROWS; i++)
    expected += row_samples[i] + 3;
  check("benchmarks entries = samples + 3 aggregates per row",
        cJSON_IsArray(list) && cJSON_GetArraySize(list) == expected, "%d entries, expected %d",
        cJSON_IsArray(list) ? cJSON_GetArraySize(list) : -1, expected);
  const char *keys[] = {"name",       "run_name",  "run_type", "repetitions", "threads",
                        "iterations", "real_time", "cpu_time", "time_unit",   "items_per_second"};
  int schema_ok = 1, values_ok = 1, aggs_ok = 1, iter_rows = 0;
  char detail[512] = "all entries", vdetail[512] = "all entries", adetail[512] = "all entries";
  cJSON *o;
  cJSON_ArrayForEach(o, list) {
    for (size_t k = 0; k < sizeof keys / sizeof *keys; k++)
      if (!cJSON_HasObjectItem(o, keys[k])) {
        schema_ok = 0;
        snprintf(detail, sizeof detail, "an entry lacks '%s'", keys[k]);
      }
    const char *run_name = cJSON_GetStringValue(cJSON_GetObjectItem(o, "run_name"));
    const char *run_type = cJSON_GetStringValue(cJSON_GetObjectItem(o, "run_type"));
    const ek_result_row *row = run_name ? ek_results_find(r, run_name) : NULL;
    if (!row || !run_type) {
      values_ok = 0;
      snprintf(vdetail, sizeof vdetail, "run_name '%s' is not a written row",
               run_name ? run_name : "?");
      continue;
    }
    double real = cJSON_GetNumberValue(cJSON_GetObjectItem(o, "real_time"));
    double threads = cJSON_GetNumberValue(cJSON_GetObjectItem(o, "threads"));
    if (threads != row->threads) {
      values_ok = 0;
      snprintf(vdetail, sizeof vdetail, "%s: threads %g, written %d", row->name, threads,
               row->threads);
    }
    if (!strcmp(run_type, "iteration")) {
      iter_rows++;
      int s = (int)cJSON_GetNumberValue(cJSON_GetObjectItem(o, "repetition_index"));
      if (s < 0 || s >= row->nsamples || !same(real, row->sample_ns[s])) {
        values_ok = 0;
        snprintf(vdetail, sizeof vdetail, "%s sample %d: JSON %.17g, written %.17g", row->name, s,
                 real, s >= 0 && s < row->nsamples ? row->sample_ns[s] : NAN);
      }
    } else if (!strcmp(run_type, "aggregate")) {
      const char *agg = cJSON_GetStringValue(cJSON_GetObjectItem(o, "aggregate_name"));
      double want = !agg                     ? NAN
                    : !strcmp(agg, "mean")   ? row->stats.mean
                    : !strcmp(agg, "median") ? row->stats.median
                    : !strcmp(agg, "stddev") ? row->stats.stddev
                                             : NAN;
      if (!same(real, want)) {
        aggs_ok = 0;
        snprintf(adetail, sizeof adetail, "%s aggregate %s: JSON %.17g, expected %.17g", row->name,
                 agg ? agg : "?", real, want);
      }
    } else {
      schema_ok = 0;
      snprintf(detail, sizeof detail, "run_type '%s'", run_type);
    }
  }
  check("every entry has the Google Benchmark keys", schema_ok, "%s", detail);
  check("iteration rows: real_time bit-exact, threads equal", values_ok, "%s (%d rows)", vdetail,
        iter_rows);
  check("aggregate rows equal the statistics", aggs_ok, "%s", adetail);
  cJSON_Delete(root);
}

// ---- row names ---------------------------------------------------------------

// Row names become nested HDF5 group paths: anything that would escape
// /benchmarks or create an empty / "." / ".." component is refused.
static void check_names(void) {
  const char *good[] = {"svd3/aosoa/avx2/f32/sweeps:4/threads:1", "a", "a/b.c/d-e_f:1"};
  const char *bad[] = {"",          "/svd3/x",  "svd3//x",  "svd3/x/",
                       "svd3/../x", "svd3/./x", "svd3/a b", "svd3/\x01"};
  for (size_t i = 0; i < sizeof good / sizeof *good; i++)
    check("valid row name accepted", ek_results_valid_name(good[i]) == 1, "'%s'", good[i]);
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
    check("invalid row name refused", ek_results_valid_name(bad[i]) == 0, "'%s'", bad[i]);
  char longname[EK_RESULTS_NAME_MAX + 1];
  memset(longname, 'a', EK_RESULTS_NAME_MAX);
  longname[EK_RESULTS_NAME_MAX] = 0;
  check("over-long row name refused", ek_results_valid_name(longname) == 0, "%d characters",
        EK_RESULTS_NAME_MAX);
  ek_results r;
  ek_results_init(&r);
  double ns[1] = {1};
  ek_timing t = {.items = 1, .iters = 1, .nsamples = 1, .sample_ns = ns};
  check("ek_results_add refuses '/escape'",
        ek_results_add(&r, "/escape", &t) == NULL && r.nrows == 0, "%zu rows", r.nrows);
  ek_results_free(&r);
}

// ---- overwrite rules ---------------------------------------------------------

static int same_file_bytes(const char *path, const char *expected) {
  char *now = slurp(path);
  int same_bytes = now && expected && strcmp(now, expected) == 0;
  free(now);
  return same_bytes;
}

static int no_temp_left(const char *dir) {
  DIR *d = opendir(dir);
  if (!d)
    return 0;
  int clean = 1;
  struct dirent *e;
  while ((e = readdir(d)))
    if (strstr(e->d_name, ".tmp."))
      clean = 0;
  closedir(d);
  return clean;
}

static void check_overwrite(ek_results *r, const char *dir, const char *h5, const char *json) {
  // The JSON file's bytes stand for "the old file": compare them exactly.
  char *old_json = slurp(json);
  char *old_h5 = slurp(h5); // HDF5 may contain NULs: compare sizes and bytes below
  FILE *f = fopen(h5, "rb");
  long h5_size = -1;
  if (f) {
    fseek(f, 0, SEEK_END);
    h5_size = ftell(f);
    fclose(f);
  }
  // Change the set so a wrong overwrite would show.
  ek_results_meta_text(r, "note", "second write");
  int rc_h5 = ek_results_write_h5(r, h5, 0);
  int rc_json = ek_results_write_json(r, json, 0);
  check("write onto an existing HDF5 without force fails", rc_h5 < 0, "rc %d", rc_h5);
  check("write onto an existing JSON without force fails", rc_json < 0, "rc %d", rc_json);
  check("old JSON left byte-for-byte intact", same_file_bytes(json, old_json), "%s", json);
  f = fopen(h5, "rb");
  int h5_same = 0;
  if (f && old_h5) {
    char *now = malloc((size_t)h5_size + 1);
    fseek(f, 0, SEEK_END);
    h5_same = now && ftell(f) == h5_size;
    fseek(f, 0, SEEK_SET);
    h5_same = h5_same && fread(now, 1, (size_t)h5_size, f) == (size_t)h5_size &&
              memcmp(now, old_h5, (size_t)h5_size) == 0;
    free(now);
  }
  if (f)
    fclose(f);
  check("old HDF5 left byte-for-byte intact", h5_same, "%s, %ld bytes", h5, h5_size);
  check("no temporary file left after the refusals", no_temp_left(dir), "%s", dir);
  rc_json = ek_results_write_json(r, json, 1);
  char *new_json = slurp(json);
  check("write with force replaces the file",
        rc_json == 0 && new_json && strstr(new_json, "second write") != NULL, "rc %d", rc_json);
  free(new_json);
  rc_h5 = ek_results_write_h5(r, h5, 1);
  hid_t hf = H5Fopen(h5, H5F_ACC_RDONLY, H5P_DEFAULT);
  char note[64] = "";
  if (hf >= 0) {
    read_text_attr(hf, "note", note, sizeof note);
    H5Fclose(hf);
  }
  check("HDF5 write with force replaces the file", rc_h5 == 0 && !strcmp(note, "second write"),
        "rc %d, note '%s'", rc_h5, note);
  check("no temporary file left after the forced writes", no_temp_left(dir), "%s", dir);
  free(old_json);
  free(old_h5);
}

int main(int argc, char **argv) {
  unsigned long long seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_results_io: seed %llu (exact round trips: no tolerance)\n", seed);
  check_names();
  char dir[] = "/tmp/ek_results_io_XXXXXX";
  if (!mkdtemp(dir)) {
    perror("test_results_io: mkdtemp");
    return 1;
  }
  char h5[256], json[256];
  snprintf(h5, sizeof h5, "%s/run.h5", dir);
  snprintf(json, sizeof json, "%s/run.json", dir);
  ek_results r;
  if (build(&r, seed) != 0) {
    printf("FAIL building the results set\n");
    return 1;
  }
  int rc_h5 = ek_results_write_h5(&r, h5, 0);
  int rc_json = ek_results_write_json(&r, json, 0);
  check("HDF5 written", rc_h5 == 0, "rc %d, %s", rc_h5, h5);
  check("JSON written", rc_json == 0, "rc %d, %s", rc_json, json);
  if (rc_h5 == 0)
    check_h5(&r, h5);
  if (rc_json == 0)
    check_json(&r, json);
  if (rc_h5 == 0 && rc_json == 0)
    check_overwrite(&r, dir, h5, json);
  ek_results_free(&r);
  unlink(h5);
  unlink(json);
  rmdir(dir);
  printf("test_results_io: %s (%d failure%s)\n", failures ? "FAILED" : "passed", failures,
         failures == 1 ? "" : "s");
  return failures ? 1 : 0;
}
