// The speed/accuracy map's points, their error distributions, the Pareto
// fronts and the two writers (bench/tradeoff.h).
//
// HDF5 (one file): the run metadata as attributes of "/" (results.h:
// cpu_model, isas_available, git_revision ... and the suite's own keys);
// "/tradeoff" with attribute "families"; one group per family, nested by
// its '/'-separated name ("/tradeoff/svd3", "/tradeoff/pk1/fixed_corotated"),
// with attribute "family" and a dataset "points": one compound row per
// point with the fields of ek_tradeoff_point plus on_front_p99 and
// on_front_max (strings fixed-length, NUL-padded; NaN where a value does
// not apply).
// JSON: {"suite": "tradeoff", "metadata": {...}, "points": [{...}]}, each
// point with the same fields and its setting also split into "knobs";
// a value that does not apply (NaN) is left out, and a non-finite error
// (an output that was not finite) is written as the string "inf".
#include "tradeoff.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <hdf5.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

// Longest strings a point may carry (the HDF5 columns' widths, NUL included).
#define FAMILY_MAX 64
#define SETTING_MAX 256
#define UNIT_MAX 32
#define METRIC_MAX 128

typedef struct {
  ek_tradeoff_point p;
  char family[FAMILY_MAX], setting[SETTING_MAX], unit[UNIT_MAX], metric[METRIC_MAX];
  unsigned char front_p99, front_max;
} stored_point;

struct ek_tradeoff {
  ek_tradeoff_opts opts;
  stored_point *points;
  size_t n, cap;
  int fronts_done;
  int steps, step, tty;
};

ek_tradeoff *ek_tradeoff_create(const ek_tradeoff_opts *opts) {
  ek_tradeoff *t = calloc(1, sizeof *t);
  if (!t)
    return NULL;
  t->opts = *opts;
  t->tty = isatty(2);
  return t;
}

void ek_tradeoff_free(ek_tradeoff *t) {
  if (!t)
    return;
  free(t->points);
  free(t);
}

const ek_tradeoff_opts *ek_tradeoff_options(const ek_tradeoff *t) { return &t->opts; }

void ek_tradeoff_expect(ek_tradeoff *t, int steps) { t->steps += steps; }

void ek_tradeoff_progress(ek_tradeoff *t, const char *fmt, ...) {
  char msg[256];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  t->step++;
  if (t->tty)
    fprintf(stderr, "\r\033[K[%d/%d] %s ...", t->step, t->steps, msg);
  else
    fprintf(stderr, "[%d/%d] %s\n", t->step, t->steps, msg);
}

size_t ek_tradeoff_count(const ek_tradeoff *t) { return t->n; }

// Copies s into dst (cap bytes) or says which field of which point is too
// long or missing.
static int copy_field(char *dst, size_t cap, const char *s, const char *field,
                      const ek_tradeoff_point *p) {
  if (!s || !*s || strlen(s) >= cap) {
    // Long values are cut in the message (their length is given).
    fprintf(stderr,
            "ek tradeoff: a point of family '%.64s': %s '%.64s%s' is %s (%zu characters; "
            "1..%zu allowed)\n",
            p->family ? p->family : "(null)", field, s ? s : "(null)",
            s && strlen(s) > 64 ? "..." : "", s && *s ? "too long" : "missing", s ? strlen(s) : 0,
            cap - 1);
    return -1;
  }
  memcpy(dst, s, strlen(s) + 1);
  return 0;
}

int ek_tradeoff_add(ek_tradeoff *t, const ek_tradeoff_point *p) {
  if (!t || !p)
    return -1;
  if (t->n == t->cap) {
    size_t cap = t->cap ? 2 * t->cap : 256;
    stored_point *points = realloc(t->points, cap * sizeof *points);
    if (!points) {
      fprintf(stderr, "ek tradeoff: out of memory adding point %zu\n", t->n);
      return -1;
    }
    t->points = points;
    t->cap = cap;
    // The points' strings live in the moved array.
    for (size_t i = 0; i < t->n; i++) {
      stored_point *q = &points[i];
      q->p.family = q->family, q->p.setting = q->setting;
      q->p.time_unit = q->unit, q->p.error_metric = q->metric;
    }
  }
  stored_point *s = &t->points[t->n];
  memset(s, 0, sizeof *s);
  if (copy_field(s->family, sizeof s->family, p->family, "family", p) ||
      copy_field(s->setting, sizeof s->setting, p->setting, "setting", p) ||
      copy_field(s->unit, sizeof s->unit, p->time_unit, "time_unit", p) ||
      copy_field(s->metric, sizeof s->metric, p->error_metric, "error_metric", p))
    return -1;
  // The family becomes a path of HDF5 groups: no empty component.
  if (s->family[0] == '/' || strstr(s->family, "//") || s->family[strlen(s->family) - 1] == '/') {
    fprintf(stderr, "ek tradeoff: point '%s': family has an empty '/' component\n", s->family);
    return -1;
  }
  s->p = *p;
  s->p.family = s->family, s->p.setting = s->setting;
  s->p.time_unit = s->unit, s->p.error_metric = s->metric;
  t->n++;
  t->fronts_done = 0;
  return 0;
}

// ---- error distributions -----------------------------------------------

// Ascending, NaN last (a NaN error is worse than any number).
static int cmp_err(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  if (isnan(x) || isnan(y))
    return isnan(x) - isnan(y);
  return (x > y) - (x < y);
}

// Nearest-rank percentile (the smallest value with at least q of the
// values at or below it) of n sorted values.
static double nearest_rank(const double *sorted, long n, double q) {
  long k = (long)ceil(q * (double)n);
  k = k < 1 ? 1 : k > n ? n : k;
  return sorted[k - 1];
}

void ek_tradeoff_distribution(double *err, long n, ek_tradeoff_point *p) {
  p->count = n;
  p->over_budget = 0;
  if (n <= 0) {
    p->err_p50 = p->err_p99 = p->err_p9999 = p->err_max = NAN;
    return;
  }
  qsort(err, (size_t)n, sizeof *err, cmp_err);
  p->err_p50 = nearest_rank(err, n, 0.5);
  p->err_p99 = nearest_rank(err, n, 0.99);
  p->err_p9999 = nearest_rank(err, n, 0.9999);
  p->err_max = err[n - 1];
  if (!isnan(p->budget))
    for (long i = n - 1; i >= 0 && !(err[i] <= p->budget); i--)
      p->over_budget++;
}

// ---- Pareto fronts -----------------------------------------------------

// Weak dominance (issue 26: with "strictly lower in both", a point whose
// error equals a faster one's stayed on the front; at 2 threads 16 of 28
// svd3 and 7 of 13 rotation front points were dominated, e.g. the scalar
// f64 SVD polar at 494 ns beside the 6.9 ns warm polar at the same error).
void ek_tradeoff_pareto(size_t n, const double *time, const double *err, unsigned char *front) {
  for (size_t i = 0; i < n; i++) {
    front[i] = !isnan(time[i]) && !isnan(err[i]);
    for (size_t j = 0; j < n && front[i]; j++) {
      if (j == i || isnan(time[j]) || isnan(err[j]) || time[j] > time[i] || err[j] > err[i])
        continue;
      // j is at least as good in both: it dominates i when strictly better
      // in one, and an exact tie goes to the first of the two.
      if (time[j] < time[i] || err[j] < err[i] || j < i)
        front[i] = 0;
    }
  }
}

// Fronts within each (family, threads) group: a point at 2 threads is not
// held against one at 1 thread (the thread count is the machine's, not an
// accuracy knob). O(n^2) per group; groups hold a few hundred points.
static int mark_fronts(ek_tradeoff *t) {
  if (t->fronts_done)
    return 0;
  size_t *idx = malloc((t->n ? t->n : 1) * sizeof *idx);
  double *time = malloc((t->n ? t->n : 1) * sizeof *time);
  double *err = malloc((t->n ? t->n : 1) * sizeof *err);
  unsigned char *front = malloc(t->n ? t->n : 1);
  unsigned char *done = calloc(t->n ? t->n : 1, 1);
  int rc = 0;
  if (!idx || !time || !err || !front || !done) {
    fprintf(stderr, "ek tradeoff: out of memory marking the fronts\n");
    rc = -1;
  }
  for (size_t i = 0; rc == 0 && i < t->n; i++) {
    if (done[i])
      continue;
    size_t m = 0;
    for (size_t j = i; j < t->n; j++)
      if (!done[j] && t->points[j].p.threads == t->points[i].p.threads &&
          !strcmp(t->points[j].family, t->points[i].family))
        idx[m++] = j, done[j] = 1;
    for (int on_max = 0; on_max < 2; on_max++) {
      for (size_t k = 0; k < m; k++) {
        const ek_tradeoff_point *p = &t->points[idx[k]].p;
        time[k] = p->time_median;
        err[k] = on_max ? p->err_max : p->err_p99;
      }
      ek_tradeoff_pareto(m, time, err, front);
      for (size_t k = 0; k < m; k++) {
        if (on_max)
          t->points[idx[k]].front_max = front[k];
        else
          t->points[idx[k]].front_p99 = front[k];
      }
    }
  }
  free(idx), free(time), free(err), free(front), free(done);
  t->fronts_done = rc == 0;
  return rc;
}

int ek_tradeoff_on_front(ek_tradeoff *t, size_t i, int on_max) {
  if (i >= t->n || mark_fronts(t))
    return 0;
  return on_max ? t->points[i].front_max : t->points[i].front_p99;
}

// ---- HDF5 ----------------------------------------------------------------

// One row of the compound table.
typedef struct {
  char family[FAMILY_MAX], setting[SETTING_MAX];
  int is_default, is_reference, on_front_p99, on_front_max;
  double time_median, time_min;
  char time_unit[UNIT_MAX];
  int threads;
  char error_metric[METRIC_MAX];
  long long count;
  double err_p50, err_p99, err_p9999, err_max, budget;
  long long over_budget;
  double energy_drift;
} h5_row;

static hid_t string_type(size_t size) {
  hid_t s = H5Tcopy(H5T_C_S1);
  H5Tset_size(s, size);
  H5Tset_strpad(s, H5T_STR_NULLPAD);
  H5Tset_cset(s, H5T_CSET_UTF8);
  return s;
}

// The row type in memory (native) or in the file (little-endian, packed).
static hid_t row_type(int file) {
  hid_t t = H5Tcreate(H5T_COMPOUND, sizeof(h5_row));
  hid_t i32 = file ? H5T_STD_I32LE : H5T_NATIVE_INT;
  hid_t i64 = file ? H5T_STD_I64LE : H5T_NATIVE_LLONG;
  hid_t f64 = file ? H5T_IEEE_F64LE : H5T_NATIVE_DOUBLE;
  hid_t s_family = string_type(FAMILY_MAX), s_setting = string_type(SETTING_MAX);
  hid_t s_unit = string_type(UNIT_MAX), s_metric = string_type(METRIC_MAX);
#define FIELD(name, type) H5Tinsert(t, #name, HOFFSET(h5_row, name), type)
  FIELD(family, s_family);
  FIELD(setting, s_setting);
  FIELD(is_default, i32);
  FIELD(is_reference, i32);
  FIELD(on_front_p99, i32);
  FIELD(on_front_max, i32);
  FIELD(time_median, f64);
  FIELD(time_min, f64);
  FIELD(time_unit, s_unit);
  FIELD(threads, i32);
  FIELD(error_metric, s_metric);
  FIELD(count, i64);
  FIELD(err_p50, f64);
  FIELD(err_p99, f64);
  FIELD(err_p9999, f64);
  FIELD(err_max, f64);
  FIELD(budget, f64);
  FIELD(over_budget, i64);
  FIELD(energy_drift, f64);
#undef FIELD
  H5Tclose(s_family), H5Tclose(s_setting), H5Tclose(s_unit), H5Tclose(s_metric);
  if (file)
    H5Tpack(t);
  return t;
}

static int attr_text(hid_t obj, const char *name, const char *value) {
  hid_t type = string_type(strlen(value) ? strlen(value) : 1);
  H5Tset_strpad(type, H5T_STR_NULLTERM);
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  int rc = attr < 0 || H5Awrite(attr, type, value) < 0 ? -1 : 0;
  if (attr >= 0)
    H5Aclose(attr);
  H5Sclose(space), H5Tclose(type);
  return rc;
}

static void fill_row(h5_row *r, const stored_point *s) {
  memset(r, 0, sizeof *r);
  const ek_tradeoff_point *p = &s->p;
  memcpy(r->family, s->family, sizeof r->family);
  memcpy(r->setting, s->setting, sizeof r->setting);
  memcpy(r->time_unit, s->unit, sizeof r->time_unit);
  memcpy(r->error_metric, s->metric, sizeof r->error_metric);
  r->is_default = p->is_default != 0, r->is_reference = p->is_reference != 0;
  r->on_front_p99 = s->front_p99, r->on_front_max = s->front_max;
  r->time_median = p->time_median, r->time_min = p->time_min;
  r->threads = p->threads;
  r->count = p->count;
  r->err_p50 = p->err_p50, r->err_p99 = p->err_p99, r->err_p9999 = p->err_p9999;
  r->err_max = p->err_max, r->budget = p->budget;
  r->over_budget = p->over_budget;
  r->energy_drift = p->energy_drift;
}

// The points of one family as /tradeoff/<family>/points.
static int write_family_h5(hid_t top, const ek_tradeoff *t, const char *family) {
  size_t m = 0;
  for (size_t i = 0; i < t->n; i++)
    m += !strcmp(t->points[i].family, family);
  h5_row *rows = malloc(m * sizeof *rows);
  if (!rows)
    return -1;
  m = 0;
  for (size_t i = 0; i < t->n; i++)
    if (!strcmp(t->points[i].family, family))
      fill_row(&rows[m++], &t->points[i]);
  hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  hid_t g = H5Gcreate2(top, family, lcpl, H5P_DEFAULT, H5P_DEFAULT);
  H5Pclose(lcpl);
  int rc = g < 0 ? -1 : attr_text(g, "family", family);
  if (g >= 0) {
    hsize_t dims[1] = {m};
    hid_t space = H5Screate_simple(1, dims, NULL);
    hid_t ftype = row_type(1), mtype = row_type(0);
    hid_t ds = H5Dcreate2(g, "points", ftype, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    rc |= ds < 0 || H5Dwrite(ds, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, rows) < 0 ? -1 : 0;
    if (ds >= 0)
      H5Dclose(ds);
    H5Tclose(ftype), H5Tclose(mtype), H5Sclose(space), H5Gclose(g);
  }
  free(rows);
  if (rc)
    fprintf(stderr, "ek tradeoff: writing family '%s' failed\n", family);
  return rc;
}

// 1 if point i is the first of its family.
static int first_of_family(const ek_tradeoff *t, size_t i) {
  for (size_t j = 0; j < i; j++)
    if (!strcmp(t->points[j].family, t->points[i].family))
      return 0;
  return 1;
}

// /tradeoff: one group per family, and the family names.
static int write_tradeoff_h5(long long file, const void *ctx) {
  const ek_tradeoff *t = ctx;
  hid_t f = (hid_t)file;
  int rc = 0;
  hid_t top = H5Gcreate2(f, "tradeoff", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (top < 0) {
    rc = -1;
  } else {
    // "families": the family names, ';'-separated, in order of appearance.
    size_t len = 1;
    for (size_t i = 0; i < t->n; i++)
      len += first_of_family(t, i) ? strlen(t->points[i].family) + 1 : 0;
    char *families = calloc(len, 1);
    rc |= !families;
    for (size_t i = 0; families && i < t->n && rc == 0; i++)
      if (first_of_family(t, i)) {
        if (families[0])
          strcat(families, ";");
        strcat(families, t->points[i].family);
        rc |= write_family_h5(top, t, t->points[i].family);
      }
    if (families)
      rc |= attr_text(top, "families", families);
    free(families);
    H5Gclose(top);
  }
  return rc;
}

int ek_tradeoff_write_h5(ek_tradeoff *t, const ek_results *meta, const char *path, int force) {
  if (mark_fronts(t))
    return -1;
  return ek_results_write_h5_with("ek tradeoff", path, force, meta, write_tradeoff_h5, t);
}

// ---- JSON ----------------------------------------------------------------

static void add_number(cJSON *o, const char *key, double v) {
  if (isnan(v))
    return; // does not apply
  if (isinf(v)) {
    cJSON_AddStringToObject(o, key, v > 0 ? "inf" : "-inf");
    return;
  }
  char buf[40];
  snprintf(buf, sizeof buf, "%.17g", v);
  cJSON_AddRawToObject(o, key, buf);
}

static cJSON *point_json(const stored_point *s) {
  const ek_tradeoff_point *p = &s->p;
  cJSON *o = cJSON_CreateObject();
  cJSON_AddStringToObject(o, "family", s->family);
  cJSON_AddStringToObject(o, "setting", s->setting);
  cJSON *knobs = cJSON_AddObjectToObject(o, "knobs");
  char setting[SETTING_MAX], *save = NULL;
  memcpy(setting, s->setting, sizeof setting);
  for (char *kv = strtok_r(setting, ";", &save); kv; kv = strtok_r(NULL, ";", &save)) {
    char *eq = strchr(kv, '=');
    if (eq)
      *eq = 0;
    cJSON_AddStringToObject(knobs, kv, eq ? eq + 1 : "");
  }
  cJSON_AddBoolToObject(o, "is_default", p->is_default);
  cJSON_AddBoolToObject(o, "is_reference", p->is_reference);
  cJSON_AddBoolToObject(o, "on_front_p99", s->front_p99);
  cJSON_AddBoolToObject(o, "on_front_max", s->front_max);
  add_number(o, "time_median", p->time_median);
  add_number(o, "time_min", p->time_min);
  cJSON_AddStringToObject(o, "time_unit", s->unit);
  add_number(o, "threads", p->threads);
  cJSON_AddStringToObject(o, "error_metric", s->metric);
  add_number(o, "count", (double)p->count);
  add_number(o, "err_p50", p->err_p50);
  add_number(o, "err_p99", p->err_p99);
  add_number(o, "err_p9999", p->err_p9999);
  add_number(o, "err_max", p->err_max);
  add_number(o, "budget", p->budget);
  add_number(o, "over_budget", (double)p->over_budget);
  add_number(o, "energy_drift", p->energy_drift);
  return o;
}

int ek_tradeoff_write_json(ek_tradeoff *t, const ek_results *meta, const char *path, int force) {
  if (!force && ek_results_file_exists(path)) {
    fprintf(stderr, "ek tradeoff: '%s' exists; not overwritten (use --force)\n", path);
    return -1;
  }
  if (mark_fronts(t))
    return -1;
  cJSON *root = cJSON_CreateObject();
  cJSON_AddStringToObject(root, "suite", "tradeoff");
  cJSON *m = cJSON_AddObjectToObject(root, "metadata");
  for (size_t i = 0; i < meta->nmeta; i++) {
    const ek_meta *e = &meta->meta[i];
    if (e->kind == EK_META_TEXT)
      cJSON_AddStringToObject(m, e->key, e->text);
    else if (e->kind == EK_META_BOOL)
      cJSON_AddBoolToObject(m, e->key, e->number != 0);
    else
      add_number(m, e->key, e->number);
  }
  cJSON *list = cJSON_AddArrayToObject(root, "points");
  for (size_t i = 0; i < t->n; i++)
    cJSON_AddItemToArray(list, point_json(&t->points[i]));
  char *text = cJSON_Print(root);
  cJSON_Delete(root);
  if (!text) {
    fprintf(stderr, "ek tradeoff: out of memory building JSON for '%s'\n", path);
    return -1;
  }
  return ek_results_write_text("ek tradeoff", path, text, force);
}
