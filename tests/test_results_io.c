// Invariant: a results set written by ek_bench_core reads back unchanged.
// HDF5 (read with the HDF5 C API): one group per row under /benchmarks
// (nested by the '/'-separated name), sample values bit-exact, row and run
// attributes (flags and passes of the robustness tests included) equal to
// what was recorded. JSON (read with cJSON): Google Benchmark's keys with
// its types (integers written as integers, bool, arrays; the schema is
// listed in bench/results.c), ek's metadata as string custom context, ek's
// row fields as number counters and the label, no null anywhere; five
// aggregates per row (mean, median, stddev, cv, min) equal to the
// statistics; iteration entries (bit-exact) only when samples are asked
// for. Writing onto an existing file without force fails and leaves the old
// file byte-for-byte intact; with force it replaces it; no temporary file is
// ever left behind. A metadata text is kept whole at any length (one of
// LONG_TEXT characters: once cut at 511, and an HDF5 attribute of the old
// object header holds at most 64 KiB).
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

#include "test_check.h"

// ---- the results set under test ------------------------------------------

enum { NROWS = 3 };
static const char *const row_names[NROWS] = {
    "svd3/aosoa/avx2/f32/sweeps:4/threads:1",
    "svd3/aosoa/avx2/f32/sweeps:4/threads:2",
    "svd3/lapack/f64/threads:1",
};
static const int row_samples[NROWS] = {5, 7, 6};
enum { LONG_TEXT = 100000 };
static char long_text[LONG_TEXT + 1]; // "long_text": a..z repeated

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
  for (int i = 0; i < LONG_TEXT; i++)
    long_text[i] = (char)('a' + i % 26);
  ek_results_meta_text(r, "long_text", long_text);
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
    if (i == 1) {
      // A row the robustness tests flagged after a second pass.
      row->flags = EK_ROW_NOISY | EK_ROW_TWIN;
      row->passes = 2;
      row->other_pass_median_ns = 2 * row->stats.median;
    }
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
  char *whole = malloc(LONG_TEXT + 2);
  ok = whole && read_text_attr(f, "long_text", whole, LONG_TEXT + 2) == 0 &&
       !strcmp(whole, long_text);
  check("root text attribute of 100 000 characters whole", ok, "%zu characters read",
        ok ? strlen(whole) : 0);
  free(whole);
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
    char want_flags[64];
    ek_results_flags_text(row->flags, want_flags, sizeof want_flags);
    ok = read_text_attr(g, "flags", text, sizeof text) == 0 && !strcmp(text, want_flags);
    check("attribute flags", ok, "%s: '%s' expected '%s'", row->name, ok ? text : "?", want_flags);
    long long passes = -1;
    ok = read_int_attr(g, "passes", &passes) == 0 && passes == row->passes;
    check("attribute passes", ok, "%s: %lld expected %d", row->name, passes, row->passes);
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
                {"speedup_threads", row->speedup_threads},
                {"other_pass_median_ns", row->other_pass_median_ns}};
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

// Every occurrence of "key": in the text is followed by an integer literal
// (Google Benchmark writes these keys as int64): digits, optional minus,
// then ',' / '}' / whitespace. The doubles are written in scientific
// notation, so an integer key written as a double shows here.
static int key_is_integer_everywhere(const char *text, const char *key, int *count) {
  char pat[80];
  snprintf(pat, sizeof pat, "\"%s\":", key);
  *count = 0;
  for (const char *p = strstr(text, pat); p; p = strstr(p + 1, pat)) {
    const char *v = p + strlen(pat);
    while (*v == ' ' || *v == '\t')
      v++;
    if (*v == '-')
      v++;
    if (*v < '0' || *v > '9')
      return 0;
    while (*v >= '0' && *v <= '9')
      v++;
    if (*v != ',' && *v != '}' && *v != '\n' && *v != '\r' && *v != ' ' && *v != '\t')
      return 0;
    (*count)++;
  }
  return 1;
}

// 1 if no value anywhere under o is null.
static int no_null(const cJSON *o, char *where, size_t cap) {
  if (cJSON_IsNull(o)) {
    snprintf(where, cap, "'%s' is null", o->string ? o->string : "(array element)");
    return 0;
  }
  const cJSON *c;
  cJSON_ArrayForEach(c, o) if (!no_null(c, where, cap)) return 0;
  return 1;
}

// Google Benchmark's keys and their JSON types (bench/results.c has the
// source: google/benchmark src/json_reporter.cc). 'i' integer, 'n' number,
// 's' string, 'b' bool, 'a' array.
typedef struct {
  const char *key;
  char type;
} schema_key;

static int has_type(const cJSON *v, char type) {
  switch (type) {
  case 'i':
    return cJSON_IsNumber(v) && v->valuedouble == floor(v->valuedouble);
  case 'n':
    return cJSON_IsNumber(v);
  case 's':
    return cJSON_IsString(v);
  case 'b':
    return cJSON_IsBool(v);
  case 'a':
    return cJSON_IsArray(v);
  }
  return 0;
}

static int check_keys(const cJSON *o, const schema_key *keys, size_t n, char *detail, size_t cap) {
  for (size_t k = 0; k < n; k++) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, keys[k].key);
    if (!has_type(v, keys[k].type)) {
      snprintf(detail, cap, "'%s' %s (type %c expected)", keys[k].key,
               v ? "has the wrong type" : "missing", keys[k].type);
      return 0;
    }
  }
  return 1;
}

static double number_of(const cJSON *o, const char *key) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
  return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

static void check_json(const ek_results *r, const char *path, int samples) {
  char *text = slurp(path);
  cJSON *root = text ? cJSON_Parse(text) : NULL;
  check("JSON parses", root != NULL, "%s", path);
  if (!root) {
    free(text);
    return;
  }
  char where[256] = "";
  check("no null value anywhere", no_null(root, where, sizeof where), "%s %s", path, where);
  static const char *const int_keys[] = {
      "num_cpus",    "mhz_per_cpu",  "json_schema_version",       "level",       "size",
      "num_sharing", "family_index", "per_family_instance_index", "repetitions", "repetition_index",
      "threads",     "iterations"};
  for (size_t k = 0; k < sizeof int_keys / sizeof *int_keys; k++) {
    int count = 0;
    int ok = key_is_integer_everywhere(text, int_keys[k], &count);
    check("integer key written as an integer", ok, "%s: '%s' (%d integer occurrences%s)", path,
          int_keys[k], count, ok ? "" : " before one that is not");
  }
  free(text);

  cJSON *ctx = cJSON_GetObjectItemCaseSensitive(root, "context");
  static const schema_key ctx_keys[] = {{"date", 's'},
                                        {"host_name", 's'},
                                        {"executable", 's'},
                                        {"num_cpus", 'i'},
                                        {"mhz_per_cpu", 'i'},
                                        {"cpu_scaling_enabled", 'b'},
                                        {"caches", 'a'},
                                        {"load_avg", 'a'},
                                        {"library_version", 's'},
                                        {"library_build_type", 's'},
                                        {"json_schema_version", 'i'}};
  char detail[512] = "all keys";
  check("context has Google Benchmark's keys and types",
        check_keys(ctx, ctx_keys, sizeof ctx_keys / sizeof *ctx_keys, detail, sizeof detail), "%s",
        detail);
  check("json_schema_version is 1", number_of(ctx, "json_schema_version") == 1, "%g",
        number_of(ctx, "json_schema_version"));
  static const schema_key cache_keys[] = {
      {"type", 's'}, {"level", 'i'}, {"size", 'i'}, {"num_sharing", 'i'}};
  const cJSON *c;
  int caches_ok = 1;
  snprintf(detail, sizeof detail, "%d caches", r->ncaches);
  cJSON_ArrayForEach(c, cJSON_GetObjectItemCaseSensitive(ctx, "caches")) caches_ok &=
      check_keys(c, cache_keys, 4, detail, sizeof detail);
  check("caches have type, level, size, num_sharing", caches_ok, "%s", detail);
  int load_ok = 1;
  cJSON_ArrayForEach(c, cJSON_GetObjectItemCaseSensitive(ctx, "load_avg")) load_ok &=
      cJSON_IsNumber(c);
  check("load_avg is an array of numbers", load_ok, "%d entries",
        cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(ctx, "load_avg")));
  // ek's own metadata: custom context, strings as Google Benchmark writes it.
  int custom_ok = 1;
  snprintf(detail, sizeof detail, "all strings");
  cJSON_ArrayForEach(c, ctx) {
    int gb = 0;
    for (size_t k = 0; k < sizeof ctx_keys / sizeof *ctx_keys; k++)
      gb |= !strcmp(c->string, ctx_keys[k].key);
    if (!gb && !cJSON_IsString(c)) {
      custom_ok = 0;
      snprintf(detail, sizeof detail, "'%s' is not a string", c->string);
    }
  }
  check("custom context values are strings", custom_ok, "%s", detail);
  cJSON *host = cJSON_GetObjectItemCaseSensitive(ctx, "host_name");
  const ek_meta *mh = ek_results_meta_find(r, "host_name");
  check("context host_name equal",
        cJSON_IsString(host) && mh && !strcmp(host->valuestring, mh->text), "'%s'",
        cJSON_IsString(host) ? host->valuestring : "?");
  const char *got_long = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(ctx, "long_text"));
  check("context text of 100 000 characters whole", got_long && !strcmp(got_long, long_text),
        "%zu characters", got_long ? strlen(got_long) : 0);
  const ek_meta *seed = ek_results_meta_find(r, "seed");
  char want_seed[40];
  snprintf(want_seed, sizeof want_seed, "%.17g", seed ? seed->number : NAN);
  const char *got_seed = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(ctx, "seed"));
  check("custom context seed as a string", got_seed && !strcmp(got_seed, want_seed),
        "'%s' expected '%s'", got_seed ? got_seed : "?", want_seed);

  cJSON *list = cJSON_GetObjectItemCaseSensitive(root, "benchmarks");
  int expected = 0;
  for (int i = 0; i < NROWS; i++)
    expected += (samples ? row_samples[i] : 0) + 5;
  check("benchmarks entries = 5 aggregates per row (+ samples with --samples)",
        cJSON_IsArray(list) && cJSON_GetArraySize(list) == expected, "%s: %d entries, expected %d",
        path, cJSON_IsArray(list) ? cJSON_GetArraySize(list) : -1, expected);
  static const schema_key entry_keys[] = {
      {"name", 's'},     {"family_index", 'i'}, {"per_family_instance_index", 'i'},
      {"run_name", 's'}, {"run_type", 's'},     {"repetitions", 'i'},
      {"threads", 'i'},  {"iterations", 'i'},   {"real_time", 'n'},
      {"cpu_time", 'n'}, {"time_unit", 's'}};
  static const schema_key iteration_keys[] = {{"repetition_index", 'i'}};
  static const schema_key aggregate_keys[] = {{"aggregate_name", 's'}, {"aggregate_unit", 's'}};
  int schema_ok = 1, values_ok = 1, aggs_ok = 1, extra_ok = 1, iter_rows = 0, agg_rows = 0;
  char sdetail[512] = "all entries", vdetail[512] = "all entries", adetail[512] = "all entries",
       edetail[512] = "all extra keys numbers, label a string";
  cJSON *o;
  cJSON_ArrayForEach(o, list) {
    schema_ok &=
        check_keys(o, entry_keys, sizeof entry_keys / sizeof *entry_keys, sdetail, sizeof sdetail);
    const char *run_name = cJSON_GetStringValue(cJSON_GetObjectItem(o, "run_name"));
    const char *run_type = cJSON_GetStringValue(cJSON_GetObjectItem(o, "run_type"));
    const ek_result_row *row = run_name ? ek_results_find(r, run_name) : NULL;
    if (!row || !run_type) {
      values_ok = 0;
      snprintf(vdetail, sizeof vdetail, "run_name '%s' is not a written row",
               run_name ? run_name : "?");
      continue;
    }
    // Keys beyond the schema are counters (numbers) or the label.
    cJSON_ArrayForEach(c, o) {
      int known = !strcmp(c->string, "label") || !strcmp(c->string, "repetition_index") ||
                  !strcmp(c->string, "aggregate_name") || !strcmp(c->string, "aggregate_unit");
      for (size_t k = 0; k < sizeof entry_keys / sizeof *entry_keys; k++)
        known |= !strcmp(c->string, entry_keys[k].key);
      if ((!known && !cJSON_IsNumber(c)) || (!strcmp(c->string, "label") && !cJSON_IsString(c))) {
        extra_ok = 0;
        snprintf(edetail, sizeof edetail, "%s: '%s'", row->name, c->string);
      }
    }
    double real = number_of(o, "real_time");
    if (number_of(o, "threads") != row->threads ||
        number_of(o, "iterations") != (double)row->iters * (double)row->items ||
        number_of(o, "repetitions") != row->nsamples) {
      values_ok = 0;
      snprintf(vdetail, sizeof vdetail, "%s: threads %g, iterations %g, repetitions %g", row->name,
               number_of(o, "threads"), number_of(o, "iterations"), number_of(o, "repetitions"));
    }
    if (!strcmp(run_type, "iteration")) {
      iter_rows++;
      schema_ok &= check_keys(o, iteration_keys, 1, sdetail, sizeof sdetail);
      int s = (int)number_of(o, "repetition_index");
      if (s < 0 || s >= row->nsamples || !same(real, row->sample_ns[s]) ||
          !same(number_of(o, "cpu_time"), row->sample_cpu_ns[s])) {
        values_ok = 0;
        snprintf(vdetail, sizeof vdetail, "%s sample %d: JSON %.17g, written %.17g", row->name, s,
                 real, s >= 0 && s < row->nsamples ? row->sample_ns[s] : NAN);
      }
    } else if (!strcmp(run_type, "aggregate")) {
      agg_rows++;
      schema_ok &= check_keys(o, aggregate_keys, 2, sdetail, sizeof sdetail);
      const char *agg = cJSON_GetStringValue(cJSON_GetObjectItem(o, "aggregate_name"));
      double want = !agg                     ? NAN
                    : !strcmp(agg, "mean")   ? row->stats.mean
                    : !strcmp(agg, "median") ? row->stats.median
                    : !strcmp(agg, "stddev") ? row->stats.stddev
                    : !strcmp(agg, "cv")     ? row->stats.cv
                    : !strcmp(agg, "min")    ? row->stats.min
                                             : NAN;
      if (!same(real, want)) {
        aggs_ok = 0;
        snprintf(adetail, sizeof adetail, "%s aggregate %s: JSON %.17g, expected %.17g", row->name,
                 agg ? agg : "?", real, want);
      }
      if (agg && !strcmp(agg, "median")) {
        // ek's fields ride on the median entry: min and median per row,
        // flags, and nothing where a value does not apply.
        int ok =
            same(number_of(o, "min_ns"), row->stats.min) && number_of(o, "passes") == row->passes &&
            number_of(o, "noisy") == ((row->flags & EK_ROW_NOISY) != 0) &&
            cJSON_HasObjectItem(o, "peak_fraction") == isfinite(row->peak_fraction) &&
            cJSON_HasObjectItem(o, "other_pass_median_ns") == isfinite(row->other_pass_median_ns);
        const char *label = cJSON_GetStringValue(cJSON_GetObjectItem(o, "label"));
        ok = ok && label && strstr(label, row->isa) &&
             ((row->flags & EK_ROW_NOISY) != 0) == (strstr(label, "flags noisy") != NULL);
        if (!ok) {
          aggs_ok = 0;
          snprintf(adetail, sizeof adetail,
                   "%s median entry: min_ns %.17g (%.17g), passes %g, "
                   "noisy %g, label '%s'",
                   row->name, number_of(o, "min_ns"), row->stats.min, number_of(o, "passes"),
                   number_of(o, "noisy"), label ? label : "?");
        }
      }
    } else {
      schema_ok = 0;
      snprintf(sdetail, sizeof sdetail, "run_type '%s'", run_type);
    }
  }
  check("every entry has Google Benchmark's keys and types", schema_ok, "%s", sdetail);
  check("extra keys are counters (numbers) or the label", extra_ok, "%s", edetail);
  check(samples ? "iteration entries: times bit-exact" : "no iteration entries without samples",
        values_ok && iter_rows == (samples ? expected - 5 * NROWS : 0), "%s (%d iteration rows)",
        vdetail, iter_rows);
  check("aggregates mean/median/stddev/cv/min equal the statistics",
        aggs_ok && agg_rows == 5 * NROWS, "%s (%d aggregate rows)", adetail, agg_rows);
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
  int rc_json = ek_results_write_json(r, json, 0, 0);
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
  rc_json = ek_results_write_json(r, json, 1, 0);
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
  char h5[256], json[256], json_samples[256];
  snprintf(h5, sizeof h5, "%s/run.h5", dir);
  snprintf(json, sizeof json, "%s/run.json", dir);
  snprintf(json_samples, sizeof json_samples, "%s/run_samples.json", dir);
  ek_results r;
  if (build(&r, seed) != 0) {
    printf("FAIL building the results set\n");
    return 1;
  }
  int rc_h5 = ek_results_write_h5(&r, h5, 0);
  int rc_json = ek_results_write_json(&r, json, 0, 0);
  int rc_samples = ek_results_write_json(&r, json_samples, 0, 1);
  check("HDF5 written", rc_h5 == 0, "rc %d, %s", rc_h5, h5);
  check("JSON written", rc_json == 0, "rc %d, %s", rc_json, json);
  check("JSON with samples written", rc_samples == 0, "rc %d, %s", rc_samples, json_samples);
  if (rc_h5 == 0)
    check_h5(&r, h5);
  if (rc_json == 0)
    check_json(&r, json, 0);
  if (rc_samples == 0)
    check_json(&r, json_samples, 1);
  if (rc_h5 == 0 && rc_json == 0)
    check_overwrite(&r, dir, h5, json);
  ek_results_free(&r);
  unlink(h5);
  unlink(json);
  unlink(json_samples);
  rmdir(dir);
  printf("test_results_io: %s (%d failure%s)\n", failures ? "FAILED" : "passed", failures,
         failures == 1 ? "" : "s");
  return failures ? 1 : 0;
}
