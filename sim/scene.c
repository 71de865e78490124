// Scene files: JSON (cJSON) -> ek_scene, with errors that name the file,
// the key path and the offending value, and unknown keys refused (a typo in
// a scene must not silently fall back to a default). A key twice in one
// object is refused too (cJSON keeps both and lookups find the first, so
// "dt": 1e-4, "dt": -1 would run with 1e-4), and text quoted from the file
// is escaped (text_escape.h).
#include "errbuf.h"
#include "sim_internal.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "text_escape.h"

// ---------------------------------------------------------------- positions
// The scene's text is read once more beside cJSON's tree, to place each
// value and key at its line and column in error messages; on text that
// cJSON refused, the same scan finds where and why it stops being JSON
// (cJSON's own error position is one byte late after a bad key, and only
// the terminating NUL on a truncated file). The scanner follows cJSON
// 1.7's grammar: white space is any byte <= 32, a number is what strtod
// takes of the bytes [0-9+-.eE] after a '-' or digit, literals are
// matched by prefix, nesting stops at 1000 levels. Should scan and tree
// ever disagree, messages go without positions rather than with wrong
// ones.

enum { JSON_NESTING_LIMIT = 1000 }; // cJSON's CJSON_NESTING_LIMIT

typedef struct {
  const char *key;   // opening quote of its key in an object, else NULL
  const char *value; // first byte of the value
} text_pos;

typedef struct {
  const char *p;
  text_pos *pos; // every value, in pre-order (a member's key, then its value)
  size_t n, cap;
  int ok;
  // Where the text stops being JSON: the byte, what was expected there,
  // and for a truncated text the innermost string or container left open.
  const char *err_at, *expected, *open_at, *open_what;
} json_scan;

static void scan_ws(json_scan *k) {
  while (*k->p && (unsigned char)*k->p <= 32) // cJSON's white space
    k->p++;
}

static void scan_fail(json_scan *k, const char *at, const char *expected) {
  if (k->ok) {
    k->ok = 0;
    k->err_at = at;
    k->expected = expected;
  }
}

// Text cut short inside what opened at `at` (the innermost one names it).
static void scan_open(json_scan *k, const char *at, const char *what) {
  if (!k->ok && k->err_at && !*k->err_at && !k->open_at) {
    k->open_at = at;
    k->open_what = what;
  }
}

static int hex4(const char *s) {
  int h = 0;
  for (int i = 0; i < 4; i++) {
    char ch = s[i];
    int d = ch >= '0' && ch <= '9'   ? ch - '0'
            : ch >= 'a' && ch <= 'f' ? ch - 'a' + 10
            : ch >= 'A' && ch <= 'F' ? ch - 'A' + 10
                                     : -1;
    if (d < 0)
      return 0; // as cJSON's parse_hex4: an invalid digit reads as U+0000
    h = h * 16 + d;
  }
  return h;
}

static void scan_string(json_scan *k, const char *expected) {
  const char *open = k->p;
  if (*open != '"') {
    scan_fail(k, open, expected);
    return;
  }
  const char *end = open + 1;
  while (*end && *end != '"')
    end += end[0] == '\\' && end[1] ? 2 : 1;
  if (*end != '"') {
    scan_fail(k, end, "the closing '\"'");
    scan_open(k, open, "string");
    return;
  }
  for (const char *q = open + 1; q < end; q++) {
    if (*q != '\\')
      continue;
    const char *esc = "\"\\/bfnrt";
    if (q[1] && strchr(esc, q[1])) {
      q++;
      continue;
    }
    const char *at = q;
    int ok = 0;
    if (q[1] == 'u' && end - q >= 6) {
      // UTF-16: a lone low surrogate, or a high one without its low
      // half, is refused (cJSON's utf16_literal_to_utf8).
      int first = hex4(q + 2);
      ok = !(first >= 0xDC00 && first <= 0xDFFF);
      if (ok && first >= 0xD800 && first <= 0xDBFF) {
        int second = end - q >= 12 && q[6] == '\\' && q[7] == 'u' ? hex4(q + 8) : 0;
        ok = second >= 0xDC00 && second <= 0xDFFF;
        q += 6;
      }
      q += 5;
    }
    if (!ok) {
      scan_fail(k, at, "a valid escape (\\\" \\\\ \\/ \\b \\f \\n \\r \\t \\uXXXX)");
      return;
    }
  }
  k->p = end + 1;
}

static void scan_value(json_scan *k, const char *key, int depth);

static void scan_container(json_scan *k, int depth) {
  const char *open = k->p;
  const int object = *open == '{';
  const char close = object ? '}' : ']';
  if (depth >= JSON_NESTING_LIMIT) {
    scan_fail(k, open, "at most 1000 levels of nesting");
    return;
  }
  k->p++;
  scan_ws(k);
  if (*k->p == close) {
    k->p++;
    return;
  }
  for (;;) {
    const char *key = NULL;
    if (object) {
      scan_ws(k);
      key = k->p;
      scan_string(k, "a key (a string in double quotes)");
      scan_ws(k);
      if (k->ok && *k->p != ':')
        scan_fail(k, k->p, "':' after the key");
      if (!k->ok)
        break;
      k->p++;
    }
    scan_value(k, key, depth + 1);
    scan_ws(k);
    if (!k->ok)
      break;
    if (*k->p == ',') {
      k->p++;
    } else if (*k->p == close) {
      k->p++;
      return;
    } else {
      scan_fail(k, k->p, object ? "',' or '}'" : "',' or ']'");
      break;
    }
  }
  scan_open(k, open, object ? "object" : "array");
}

static void scan_value(json_scan *k, const char *key, int depth) {
  scan_ws(k);
  if (!k->ok)
    return;
  if (k->n == k->cap) {
    size_t cap = k->cap ? 2 * k->cap : 64;
    text_pos *pos = realloc(k->pos, cap * sizeof *pos);
    if (!pos) {
      k->ok = 0; // no positions, and no syntax verdict (err_at stays NULL)
      return;
    }
    k->pos = pos;
    k->cap = cap;
  }
  k->pos[k->n++] = (text_pos){key, k->p};
  const char *at = k->p;
  if (*at == '"') {
    scan_string(k, "a value");
  } else if (*at == '{' || *at == '[') {
    scan_container(k, depth);
  } else if (*at == '-' || (*at >= '0' && *at <= '9')) {
    // strtod on a copy of the bytes a number may hold ("0x1", "-inf" stop
    // early, as in cJSON), however many.
    size_t len = strspn(at, "0123456789+-eE."), used = 0;
    char small[64], *num = len < sizeof small ? small : malloc(len + 1);
    if (num) {
      memcpy(num, at, len);
      num[len] = '\0';
      char *end;
      strtod(num, &end);
      used = (size_t)(end - num);
      if (num != small)
        free(num);
    } else {
      k->ok = 0; // out of memory: no positions, no syntax verdict
      return;
    }
    if (!used)
      scan_fail(k, at, "a value");
    else
      k->p += used;
  } else {
    static const char *const literals[] = {"null", "false", "true"};
    for (int i = 0; i < 3; i++) {
      size_t len = strlen(literals[i]);
      if (!strncmp(at, literals[i], len)) {
        k->p += len;
        return;
      }
      if (*at && !strncmp(at, literals[i], strlen(at))) { // cut short at the end
        scan_fail(k, at + strlen(at), "the rest of a literal");
        return;
      }
    }
    scan_fail(k, at, "a value");
  }
}

static void line_col(const char *text, const char *at, int *line, int *col) {
  *line = 1;
  *col = 1;
  for (const char *p = text; *p && p < at; ++p) {
    if (*p == '\n') {
      ++*line;
      *col = 1;
    } else {
      ++*col;
    }
  }
}

// The scan of a whole text: one value, then only white space.
static void scan_text(json_scan *k, const char *text) {
  *k = (json_scan){.p = text, .ok = 1};
  if (!strncmp(k->p, "\xEF\xBB\xBF", 3)) // a UTF-8 byte order mark, as cJSON skips it
    k->p += 3;
  scan_value(k, NULL, 0);
  scan_ws(k);
  if (k->ok && *k->p)
    scan_fail(k, k->p, "the end of the file after the scene's object");
}

// Text cJSON refused: "FILE:LINE:COL: invalid JSON ..." at the first byte
// that is not JSON, or at the end of a truncated text. cJSON's position
// when the scan finds nothing wrong.
static void syntax_error(const char *name, const char *text, const char *cjson_at, char *err,
                         size_t errlen) {
  json_scan k;
  scan_text(&k, text);
  free(k.pos);
  const char *at = k.err_at ? k.err_at : cjson_at;
  int line, col;
  line_col(text, at, &line, &col);
  if (!err || !errlen)
    return;
  if (!*at) {
    char open[128] = "";
    if (k.open_at) {
      int l, c;
      line_col(text, k.open_at, &l, &c);
      snprintf(open, sizeof open, ": the %s opened at line %d, column %d is not closed",
               k.open_what, l, c);
    }
    snprintf(err, errlen, "%s:%d:%d: invalid JSON: unexpected end of file%s", name, line, col,
             open[0]    ? open
             : k.n <= 1 ? ": the file holds no JSON value"
                        : "");
    return;
  }
  char near[128];
  text_escape(near, sizeof near, at, 20, 1);
  if (k.err_at)
    snprintf(err, errlen, "%s:%d:%d: invalid JSON near \"%s\": expected %s", name, line, col, near,
             k.expected);
  else
    snprintf(err, errlen, "%s:%d:%d: invalid JSON near \"%s\"", name, line, col, near);
}

// ---------------------------------------------------------------- errors

typedef struct {
  const char *name; // file name for messages
  char *err;
  size_t errlen;
  const char *text;    // the scene's text
  const cJSON **nodes; // the tree's items in pre-order, NULL without positions
  const text_pos *pos; // nodes[i]'s place in the text
  size_t npos;
} parse_ctx;

static size_t count_items(const cJSON *v) {
  size_t n = 1;
  for (const cJSON *it = v->child; it; it = it->next)
    n += count_items(it);
  return n;
}

// Pairs the tree's items with the scan's values, in pre-order; 0 when a
// value's first byte does not fit its item's type (scan and tree disagree).
static int pair_items(const cJSON *v, const cJSON **nodes, const text_pos *pos, size_t *i) {
  char first = *pos[*i].value;
  int fits = cJSON_IsObject(v)   ? first == '{'
             : cJSON_IsArray(v)  ? first == '['
             : cJSON_IsString(v) ? first == '"'
             : cJSON_IsNumber(v) ? first == '-' || (first >= '0' && first <= '9')
             : cJSON_IsBool(v)   ? first == 't' || first == 'f'
                                 : first == 'n';
  if (!fits || !pos[*i].key != !v->string)
    return 0;
  nodes[(*i)++] = v;
  for (const cJSON *it = v->child; it; it = it->next)
    if (!pair_items(it, nodes, pos, i))
      return 0;
  return 1;
}

// Positions for c's messages (none when out of memory or in disagreement).
static void find_positions(parse_ctx *c, const cJSON *root, json_scan *k) {
  scan_text(k, c->text);
  size_t i = 0;
  const cJSON **nodes = k->ok && k->n == count_items(root) ? malloc(k->n * sizeof *nodes) : NULL;
  if (nodes && pair_items(root, nodes, k->pos, &i)) {
    c->nodes = nodes;
    c->pos = k->pos;
    c->npos = k->n;
  } else {
    free(nodes);
  }
}

// Where v's value (its key when at_key) starts in the text; NULL unknown.
static const char *node_at(const parse_ctx *c, const cJSON *v, int at_key) {
  for (size_t i = 0; v && i < c->npos; i++)
    if (c->nodes[i] == v)
      return at_key && c->pos[i].key ? c->pos[i].key : c->pos[i].value;
  return NULL;
}

// "FILE:LINE:COL" of v's value (its key when at_key), or "FILE" alone.
static const char *place(const parse_ctx *c, const cJSON *v, int at_key, char *out, size_t n) {
  const char *at = node_at(c, v, at_key);
  if (!at) {
    snprintf(out, n, "%s", c->name);
  } else {
    int line, col;
    line_col(c->text, at, &line, &col);
    snprintf(out, n, "%s:%d:%d", c->name, line, col);
  }
  return out;
}

// v's place for ek_scene_where ({0, 0} unknown).
static ek_scene_pos pos_of(const parse_ctx *c, const cJSON *v) {
  const char *at = node_at(c, v, 0);
  ek_scene_pos p = {0, 0};
  if (at)
    line_col(c->text, at, &p.line, &p.col);
  return p;
}

static const cJSON *item(const cJSON *obj, const char *key) {
  return cJSON_GetObjectItemCaseSensitive(obj, key);
}

// The places of the values that later checks refer to (ek_scene_where), from
// the parsed (and checked) tree.
static void record_positions(const parse_ctx *c, const cJSON *root, ek_scene_where *w) {
  const cJSON *mesh = item(root, "mesh"), *mat = item(root, "material");
  const cJSON *integ = item(root, "integrator");
  const cJSON *m = item(mesh, "file");
  if (!m)
    m = item(mesh, "box");
  if (!m)
    m = item(mesh, "grid");
  w->mesh = pos_of(c, m);
  w->material = pos_of(c, mat);
  w->model = pos_of(c, item(mat, "model"));
  w->isa = pos_of(c, item(root, "isa"));
  const cJSON *list = item(root, "boundary");
  int i = 0;
  for (const cJSON *bc = list ? list->child : NULL; bc && i < EK_SCENE_MAX_BC; bc = bc->next, i++)
    w->region[i] = pos_of(c, item(bc, "region"));
  w->dt = pos_of(c, item(root, "dt"));
  w->integrator = pos_of(c, integ);
  w->solver = pos_of(c, item(integ, "solver"));
  w->elements = pos_of(c, item(integ, "elements"));
  w->substeps = pos_of(c, item(integ, "substeps"));
  w->linear_solver = pos_of(c, item(integ, "linear_solver"));
  w->output_file = pos_of(c, item(item(root, "output"), "file"));
  w->reference_dt = pos_of(c, item(item(root, "advise"), "reference_dt"));
}

// Short text of a JSON value for an error message.
static void value_text(const cJSON *v, char *out, size_t outlen) {
  if (!v) {
    snprintf(out, outlen, "(missing)");
  } else if (cJSON_IsNumber(v)) {
    snprintf(out, outlen, "%.10g", v->valuedouble);
  } else if (cJSON_IsString(v)) {
    char text[256];
    snprintf(out, outlen, "\"%s\"", text_escape(text, sizeof text, v->valuestring, 60, 1));
  } else {
    char *s = cJSON_PrintUnformatted(v), text[256];
    snprintf(out, outlen, "%s", text_escape(text, sizeof text, s ? s : "?", 60, 0));
    cJSON_free(s);
  }
}

static int vbad(parse_ctx *c, const char *path, const cJSON *v, int at_key, const char *fmt,
                va_list ap) {
  char val[300], reason[256], where[EK_SCENE_AT_MAX];
  value_text(v, val, sizeof val);
  vsnprintf(reason, sizeof reason, fmt, ap);
  if (c->err && c->errlen)
    snprintf(c->err, c->errlen, "%s: %s = %s: %s", place(c, v, at_key, where, sizeof where), path,
             val, reason);
  return EK_EINVAL;
}

// "FILE:LINE:COL: <path> = <value>: <reason>" at the value; always returns
// EK_EINVAL.
__attribute__((format(printf, 4, 5))) static int bad(parse_ctx *c, const char *path, const cJSON *v,
                                                     const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  int rc = vbad(c, path, v, 0, fmt, ap);
  va_end(ap);
  return rc;
}

// The same at v's key (a key that must not be there).
__attribute__((format(printf, 4, 5))) static int bad_key(parse_ctx *c, const char *path,
                                                         const cJSON *v, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  int rc = vbad(c, path, v, 1, fmt, ap);
  va_end(ap);
  return rc;
}

// A required key absent from obj: placed at obj (where it belongs).
static int missing(parse_ctx *c, const cJSON *obj, const char *path) {
  char where[EK_SCENE_AT_MAX];
  if (c->err && c->errlen)
    snprintf(c->err, c->errlen, "%s: %s: missing (required)", place(c, obj, 0, where, sizeof where),
             path);
  return EK_EINVAL;
}

// parent.key; the key is escaped (it may come from the file).
static void join(char *out, size_t outlen, const char *parent, const char *key) {
  char text[160];
  text_escape(text, sizeof text, key, 40, 1);
  if (parent[0])
    snprintf(out, outlen, "%s.%s", parent, text);
  else
    snprintf(out, outlen, "%s", text);
}

// Every key of `obj` must be one of `allowed` (NULL-terminated).
static int check_keys(parse_ctx *c, const cJSON *obj, const char *path,
                      const char *const *allowed) {
  for (const cJSON *it = obj->child; it; it = it->next) {
    int known = 0;
    for (const char *const *a = allowed; *a; ++a)
      known |= strcmp(it->string, *a) == 0;
    if (!known) {
      char p[256], list[256] = "";
      join(p, sizeof p, path, it->string);
      for (const char *const *a = allowed; *a; ++a) {
        strncat(list, *a, sizeof list - strlen(list) - 1);
        if (a[1])
          strncat(list, ", ", sizeof list - strlen(list) - 1);
      }
      return bad_key(c, p, it, "unknown key (allowed: %s)", list);
    }
  }
  return 0;
}

static int want_object(parse_ctx *c, const cJSON *v, const char *path) {
  if (!cJSON_IsObject(v))
    return bad(c, path, v, "must be an object");
  return 0;
}

// ---------------------------------------------------------------- duplicates
// Found in the tree (cJSON's unescaped names; cJSON keeps both and lookups
// find the first), placed by the scan's positions.

typedef struct {
  const cJSON *item;
  size_t index; // its place among its object's members (text order)
} member;

static int cmp_member(const void *x, const void *y) {
  const member *a = x, *b = y;
  int c = strcmp(a->item->string, b->item->string);
  return c ? c : (a->index > b->index) - (a->index < b->index);
}

static int find_duplicates(parse_ctx *c, const cJSON *v, const char *path) {
  if (cJSON_IsArray(v)) {
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
      char p[300];
      snprintf(p, sizeof p, "%s[%d]", path[0] ? path : "(top level)", i);
      int rc = find_duplicates(c, it, p);
      if (rc)
        return rc;
    }
    return 0;
  }
  if (!cJSON_IsObject(v))
    return 0;
  size_t n = 0;
  for (const cJSON *it = v->child; it; it = it->next)
    n++;
  member *m = malloc((n ? n : 1) * sizeof *m);
  if (!m) {
    if (c->err && c->errlen)
      snprintf(c->err, c->errlen, "%s: out of memory checking keys", c->name);
    return EK_ENOMEM;
  }
  size_t i = 0;
  int rc = 0;
  for (const cJSON *it = v->child; it && !rc; it = it->next, ++i) {
    m[i] = (member){it, i};
    char p[300];
    join(p, sizeof p, path, it->string);
    rc = find_duplicates(c, it, p);
  }
  if (!rc) {
    qsort(m, n, sizeof *m, cmp_member);
    // The repeat that comes first in the text.
    const member *first = NULL, *again = NULL;
    for (i = 1; i < n; i++)
      if (strcmp(m[i].item->string, m[i - 1].item->string) == 0 &&
          (!again || m[i].index < again->index)) {
        again = &m[i];
        first = &m[i - 1];
        while (first > m && strcmp((first - 1)->item->string, again->item->string) == 0)
          first--;
      }
    if (again) {
      char p[300], where[EK_SCENE_AT_MAX];
      join(p, sizeof p, path, again->item->string);
      const char *at1 = node_at(c, first->item, 1);
      if (c->err && c->errlen && at1) {
        int l1, c1;
        line_col(c->text, at1, &l1, &c1);
        snprintf(c->err, c->errlen,
                 "%s: duplicate key \"%s\" (first at line %d, column %d): a key may appear once "
                 "per object",
                 place(c, again->item, 1, where, sizeof where), p, l1, c1);
      } else if (c->err && c->errlen) {
        snprintf(c->err, c->errlen, "%s: duplicate key \"%s\": a key may appear once per object",
                 c->name, p);
      }
      rc = EK_EINVAL;
    }
  }
  free(m);
  return rc;
}

// ---------------------------------------------------------------- readers
// Each reader: absent + !required -> 0, *out untouched; absent + required ->
// error; present with the wrong type -> error naming path and value.

static int get_number(parse_ctx *c, const cJSON *obj, const char *parent, const char *key,
                      int required, double *out, const cJSON **node) {
  char p[256];
  join(p, sizeof p, parent, key);
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (node)
    *node = v;
  if (!v)
    return required ? missing(c, obj, p) : 0;
  if (!cJSON_IsNumber(v))
    return bad(c, p, v, "must be a number");
  if (!isfinite(v->valuedouble))
    return bad(c, p, v, "must be finite");
  *out = v->valuedouble;
  return 0;
}

static int get_vec(parse_ctx *c, const cJSON *obj, const char *parent, const char *key,
                   int required, int n, double *out) {
  char p[256];
  join(p, sizeof p, parent, key);
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!v)
    return required ? missing(c, obj, p) : 0;
  if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != n)
    return bad(c, p, v, "must be an array of %d numbers", n);
  int i = 0;
  for (const cJSON *it = v->child; it; it = it->next, ++i) {
    if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble)) {
      char pi[300];
      snprintf(pi, sizeof pi, "%s[%d]", p, i);
      return bad(c, pi, it, "must be a finite number");
    }
    out[i] = it->valuedouble;
  }
  return 0;
}

static int get_string(parse_ctx *c, const cJSON *obj, const char *parent, const char *key,
                      int required, const char **out, const cJSON **node) {
  char p[256];
  join(p, sizeof p, parent, key);
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (node)
    *node = v;
  if (!v)
    return required ? missing(c, obj, p) : 0;
  if (!cJSON_IsString(v) || !v->valuestring[0])
    return bad(c, p, v, "must be a non-empty string");
  *out = v->valuestring;
  return 0;
}

static int get_bool(parse_ctx *c, const cJSON *obj, const char *parent, const char *key, int *out) {
  char p[256];
  join(p, sizeof p, parent, key);
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!v)
    return 0;
  if (!cJSON_IsBool(v))
    return bad(c, p, v, "must be true or false");
  *out = cJSON_IsTrue(v);
  return 0;
}

// A whole number in [lo, hi].
static int get_count(parse_ctx *c, const cJSON *obj, const char *parent, const char *key,
                     int required, long lo, long hi, long *out) {
  double d = 0;
  const cJSON *node = NULL;
  int rc = get_number(c, obj, parent, key, required, &d, &node);
  if (rc || !node)
    return rc;
  char p[256];
  join(p, sizeof p, parent, key);
  if (d != floor(d) || d < (double)lo || d > (double)hi)
    return bad(c, p, node, "must be a whole number in [%ld, %ld]", lo, hi);
  *out = (long)d;
  return 0;
}

// ---------------------------------------------------------------- models

// The names live in the model descriptors (kernels/material/<name>.c): scenes
// take the long names or the short ones.
const char *ek_scene_model_name(ek_model model) {
  return (unsigned)model < EK_MODEL_COUNT ? ek_model_long_name(model) : NULL;
}

int ek_scene_model_from_name(const char *name, ek_model *model) {
  return ek_model_from_name(name, model) == EK_OK ? 0 : -1;
}

// ---------------------------------------------------------------- sections

// Every component of the n-vector obj.key (already read into v) must be > 0.
static int all_positive(parse_ctx *c, const cJSON *obj, const char *objname, const char *key, int n,
                        const double *v) {
  for (int i = 0; i < n; ++i)
    if (!(v[i] > 0)) {
      char p[64];
      snprintf(p, sizeof p, "%s.%s[%d]", objname, key, i);
      return bad(c, p, cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(obj, key), i),
                 "must be > 0");
    }
  return 0;
}

// mesh.key: n whole numbers in [1, max] into cells.
static int get_cells(parse_ctx *c, const cJSON *mesh, const char *key, int n, int max, int *cells) {
  double v[3];
  int rc = get_vec(c, mesh, "mesh", key, 1, n, v);
  for (int i = 0; !rc && i < n; ++i) {
    if (v[i] != floor(v[i]) || v[i] < 1 || v[i] > max) {
      char p[32];
      snprintf(p, sizeof p, "mesh.%s[%d]", key, i);
      return bad(c, p, cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(mesh, key), i),
                 "must be a whole number in [1, %d]", max);
    }
    cells[i] = (int)v[i];
  }
  return rc;
}

// mesh: {"file"} (tets; triangles for .obj or "kind": "triangles"),
// {"box", "size"} (tets) or {"grid", "size", "plane"} (a cloth's triangles).
static int parse_mesh(parse_ctx *c, const cJSON *root, const char *base_dir, ek_scene *s) {
  const cJSON *mesh = cJSON_GetObjectItemCaseSensitive(root, "mesh");
  if (!mesh)
    return missing(c, root, "mesh");
  int rc = want_object(c, mesh, "mesh");
  if (!rc)
    rc = check_keys(c, mesh, "mesh",
                    (const char *const[]){"file", "box", "size", "fix_orientation", "grid", "plane",
                                          "kind", NULL});
  if (rc)
    return rc;
  const char *file = NULL, *kind = NULL, *plane = NULL;
  const cJSON *file_node = NULL, *kind_node = NULL, *plane_node = NULL;
  if ((rc = get_string(c, mesh, "mesh", "file", 0, &file, &file_node)) ||
      (rc = get_string(c, mesh, "mesh", "kind", 0, &kind, &kind_node)) ||
      (rc = get_string(c, mesh, "mesh", "plane", 0, &plane, &plane_node)))
    return rc;
  const cJSON *box = cJSON_GetObjectItemCaseSensitive(mesh, "box");
  const cJSON *grid = cJSON_GetObjectItemCaseSensitive(mesh, "grid");
  if ((rc = get_bool(c, mesh, "mesh", "fix_orientation", &s->fix_orientation)))
    return rc;
  if (!!file + !!box + !!grid > 1)
    return bad(c, grid ? "mesh.grid" : "mesh.box", grid ? grid : box,
               "give either mesh.file, mesh.box or mesh.grid, one of them");
  if (kind && strcmp(kind, "tets") != 0 && strcmp(kind, "triangles") != 0)
    return bad(c, "mesh.kind", kind_node, "must be \"tets\" or \"triangles\"");
  if (kind && !file)
    return bad(c, "mesh.kind", kind_node, "only meaningful with mesh.file");
  if (plane && !grid)
    return bad(c, "mesh.plane", plane_node, "only meaningful with mesh.grid");
  if (file) {
    for (const char *p = file; *p; ++p)
      if ((unsigned char)*p < 0x20 || *p == 0x7f)
        return bad(c, "mesh.file", file_node, "control character in a path");
    if (cJSON_GetObjectItemCaseSensitive(mesh, "size"))
      return bad(c, "mesh.size", cJSON_GetObjectItemCaseSensitive(mesh, "size"),
                 "only meaningful with mesh.box or mesh.grid");
    int n;
    if (file[0] == '/' || !base_dir || !base_dir[0])
      n = snprintf(s->mesh_file, sizeof s->mesh_file, "%s", file);
    else
      n = snprintf(s->mesh_file, sizeof s->mesh_file, "%s/%s", base_dir, file);
    if (n < 0 || (size_t)n >= sizeof s->mesh_file)
      return bad(c, "mesh.file", file_node, "path too long");
    size_t len = strlen(file);
    int obj = len > 4 && strcmp(file + len - 4, ".obj") == 0;
    if (obj && kind && strcmp(kind, "tets") == 0)
      return bad(c, "mesh.kind", kind_node, "an .obj file holds triangles, not tets");
    s->triangles = obj || (kind && strcmp(kind, "triangles") == 0);
    return 0;
  }
  if (grid) {
    if ((rc = get_cells(c, mesh, "grid", 2, 8192, s->grid_cells)) ||
        (rc = get_vec(c, mesh, "mesh", "size", 1, 2, s->grid_size)) ||
        (rc = all_positive(c, mesh, "mesh", "size", 2, s->grid_size)))
      return rc;
    if (plane && strcmp(plane, "xy") != 0 && strcmp(plane, "xz") != 0)
      return bad(c, "mesh.plane", plane_node, "must be \"xy\" or \"xz\"");
    snprintf(s->grid_plane, sizeof s->grid_plane, "%s", plane ? plane : "xy");
    s->triangles = 1;
    return 0;
  }
  if (!box)
    return missing(c, mesh, "mesh.file or mesh.box (or mesh.grid for a cloth)");
  if ((rc = get_cells(c, mesh, "box", 3, 4096, s->box_cells)) ||
      (rc = get_vec(c, mesh, "mesh", "size", 1, 3, s->box_size)))
    return rc;
  return all_positive(c, mesh, "mesh", "size", 3, s->box_size);
}

// cloth: {"thickness" (m, required for a triangle mesh), "bending_stiffness"
// (N m; default the plate's E h^3 / (12 (1 - nu^2)))}. Only a triangle
// mesh takes it, and a triangle mesh takes only the membrane models.
static int parse_cloth(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const cJSON *cl = cJSON_GetObjectItemCaseSensitive(root, "cloth");
  if (!s->triangles) {
    if (cl)
      return bad(c, "cloth", cl, "only meaningful with a triangle mesh");
    return 0;
  }
  if (!ek_model_describe(s->material.model)->has_membrane)
    return bad(c, "material.model",
               cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(root, "material"),
                                                "model"),
               "a triangle mesh (cloth) takes \"stvk\" or \"arap\" membranes only");
  if (!cl)
    return missing(c, root, "cloth (a triangle mesh needs cloth.thickness)");
  int rc = want_object(c, cl, "cloth");
  if (!rc)
    rc = check_keys(c, cl, "cloth", (const char *const[]){"thickness", "bending_stiffness", NULL});
  const cJSON *th = NULL, *kb = NULL;
  if (!rc)
    rc = get_number(c, cl, "cloth", "thickness", 1, &s->thickness, &th);
  if (!rc && !(s->thickness > 0))
    rc = bad(c, "cloth.thickness", th, "must be > 0");
  s->bending_stiffness = NAN;
  if (!rc)
    rc = get_number(c, cl, "cloth", "bending_stiffness", 0, &s->bending_stiffness, &kb);
  if (!rc && kb && !(s->bending_stiffness >= 0))
    rc = bad(c, "cloth.bending_stiffness", kb, "must be >= 0");
  if (!rc && kb && !isfinite(s->bending_stiffness))
    rc = bad(c, "cloth.bending_stiffness", kb, "must be finite");
  // The values per unit area the sheet runs on (sim_core.c: mu h, the
  // plane-stress lambda times h, the mass density times h) must be finite
  // and the mass > 0: named here by the key, not at step 1 by internal
  // values (issue 28: thickness 1e300).
  const double mu = s->material.mu, lam = s->material.lambda, h = s->thickness;
  const double mu_h = mu * h, lam_h = 2 * mu * lam / (lam + 2 * mu) * h, rho_h = s->density * h;
  if (!rc && (!isfinite(mu_h) || !isfinite(lam_h) || !isfinite(rho_h) || !(rho_h > 0)))
    rc = bad(c, "cloth.thickness", th,
             "the sheet's values per unit area are out of range (mu h = %g, plane-stress lambda "
             "h = %g Pa m, density h = %g kg/m^2: each must be finite, the last > 0)",
             mu_h, lam_h, rho_h);
  if (rc || kb)
    return rc;
  // Plate flexural rigidity D = E h^3 / (12 (1 - nu^2)) (Timoshenko and
  // Woinowsky-Krieger, "Theory of plates and shells", sec. 4), with E, nu
  // from mu, lambda when those were given.
  double E = mu * (3 * lam + 2 * mu) / (lam + mu), nu = lam / (2 * (lam + mu));
  s->bending_stiffness = E * s->thickness * s->thickness * s->thickness / (12 * (1 - nu * nu));
  if (!isfinite(s->bending_stiffness))
    return bad(c, "cloth.thickness", th,
               "the bending stiffness E h^3 / (12 (1 - nu^2)) = %g from it is not finite (give "
               "cloth.bending_stiffness, or a smaller thickness)",
               s->bending_stiffness);
  return 0;
}

static int parse_initial(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const cJSON *init = cJSON_GetObjectItemCaseSensitive(root, "initial");
  if (!init)
    return 0;
  int rc = want_object(c, init, "initial");
  if (!rc)
    rc = check_keys(c, init, "initial",
                    (const char *const[]){"scale", "translate", "velocity", NULL});
  if (!rc)
    rc = get_vec(c, init, "initial", "scale", 0, 3, s->init_scale);
  if (!rc)
    rc = get_vec(c, init, "initial", "translate", 0, 3, s->init_translate);
  if (!rc)
    rc = get_vec(c, init, "initial", "velocity", 0, 3, s->init_velocity);
  if (rc)
    return rc;
  return all_positive(c, init, "initial", "scale", 3, s->init_scale);
}

static int parse_material(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const cJSON *mat = cJSON_GetObjectItemCaseSensitive(root, "material");
  if (!mat)
    return missing(c, root, "material");
  int rc = want_object(c, mat, "material");
  if (!rc)
    rc = check_keys(
        c, mat, "material",
        (const char *const[]){"model", "E", "nu", "mu", "lambda", "density", "clamp", NULL});
  if (rc)
    return rc;
  const char *model = NULL;
  const cJSON *model_node = NULL;
  if ((rc = get_string(c, mat, "material", "model", 1, &model, &model_node)))
    return rc;
  if (ek_scene_model_from_name(model, &s->material.model) != 0) {
    char list[256] = "";
    for (int i = 0; i < EK_MODEL_COUNT; ++i) {
      strncat(list, ek_model_long_name((ek_model)i), sizeof list - strlen(list) - 1);
      if (i + 1 < EK_MODEL_COUNT)
        strncat(list, ", ", sizeof list - strlen(list) - 1);
    }
    return bad(c, "material.model", model_node, "unknown model (known: %s)", list);
  }
  snprintf(s->model_name, sizeof s->model_name, "%s", model);

  const cJSON *nE = cJSON_GetObjectItemCaseSensitive(mat, "E");
  const cJSON *nnu = cJSON_GetObjectItemCaseSensitive(mat, "nu");
  const cJSON *nmu = cJSON_GetObjectItemCaseSensitive(mat, "mu");
  const cJSON *nlambda = cJSON_GetObjectItemCaseSensitive(mat, "lambda");
  if ((nE || nnu) && (nmu || nlambda))
    return bad(c, nE ? "material.E" : "material.nu", nE ? nE : nnu,
               "give either E and nu, or mu and lambda, not a mix");
  if (nE || nnu) {
    double E = 0, nu = 0;
    if ((rc = get_number(c, mat, "material", "E", 1, &E, NULL)) ||
        (rc = get_number(c, mat, "material", "nu", 1, &nu, NULL)))
      return rc;
    if (!(E > 0))
      return bad(c, "material.E", nE, "Young's modulus must be > 0");
    if (!(nu < 0.5))
      return bad(c, "material.nu", nnu, "Poisson ratio must be < 0.5");
    if (!(nu > -1))
      return bad(c, "material.nu", nnu, "Poisson ratio must be > -1");
    if ((rc = ek_lame_from_young_poisson(E, nu, &s->material.mu, &s->material.lambda)) != 0)
      return bad(c, "material.E", nE, "cannot convert E, nu to Lame parameters: %s",
                 ek_last_error());
    s->young = E;
    s->poisson = nu;
  } else if (nmu || nlambda) {
    if ((rc = get_number(c, mat, "material", "mu", 1, &s->material.mu, NULL)) ||
        (rc = get_number(c, mat, "material", "lambda", 1, &s->material.lambda, NULL)))
      return rc;
    if (!(s->material.mu > 0))
      return bad(c, "material.mu", nmu, "shear modulus must be > 0");
    if (!(s->material.lambda > -2.0 * s->material.mu / 3.0))
      return bad(c, "material.lambda", nlambda, "must be > -2 mu / 3 (positive bulk modulus)");
  } else {
    return missing(c, mat, "material.E and material.nu (or material.mu and material.lambda)");
  }

  const cJSON *node = NULL;
  if ((rc = get_number(c, mat, "material", "density", 1, &s->density, &node)))
    return rc;
  if (!(s->density > 0))
    return bad(c, "material.density", node, "must be > 0");
  s->material.clamp = 0;
  if ((rc = get_number(c, mat, "material", "clamp", 0, &s->material.clamp, &node)))
    return rc;
  if (!(s->material.clamp >= 0 && s->material.clamp < 1))
    return bad(c, "material.clamp", node, "must be in [0, 1) (0 = off)");
  return 0;
}

static int parse_kernels(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const char *str = NULL;
  const cJSON *node = NULL;
  int rc = get_string(c, root, "", "precision", 0, &str, &node);
  if (rc)
    return rc;
  if (str) {
    if (strcmp(str, "f32") == 0)
      s->precision = 32;
    else if (strcmp(str, "f64") == 0)
      s->precision = 64;
    else
      return bad(c, "precision", node, "must be \"f32\" or \"f64\"");
  }
  str = NULL;
  if ((rc = get_string(c, root, "", "isa", 0, &str, &node)))
    return rc;
  if (str) {
    static const char *names[] = {"auto", "scalar", "avx2", "avx512"};
    static const ek_isa isas[] = {EK_ISA_AUTO, EK_ISA_SCALAR, EK_ISA_AVX2, EK_ISA_AVX512};
    int found = 0;
    for (int i = 0; i < 4; ++i)
      if (strcmp(str, names[i]) == 0) {
        s->svd.isa = isas[i];
        found = 1;
      }
    if (!found)
      return bad(c, "isa", node, "must be one of auto, scalar, avx2, avx512");
  }
  str = NULL;
  if ((rc = get_string(c, root, "", "scatter", 0, &str, &node)))
    return rc;
  if (str) {
    static const char *names[] = {"auto", "colored", "thread_buffers", "gather", "atomic"};
    static const ek_scatter kinds[] = {EK_SCATTER_AUTO, EK_SCATTER_COLORED,
                                       EK_SCATTER_THREAD_BUFFERS, EK_SCATTER_GATHER,
                                       EK_SCATTER_ATOMIC};
    int found = 0;
    for (int i = 0; i < 5; ++i)
      if (strcmp(str, names[i]) == 0) {
        s->scatter = kinds[i];
        found = 1;
      }
    if (!found)
      return bad(c, "scatter", node,
                 "must be one of auto, colored, thread_buffers, gather, atomic");
  }
  str = NULL;
  if ((rc = get_string(c, root, "", "polar", 0, &str, &node)))
    return rc;
  if (str) {
    if (strcmp(str, "svd") == 0)
      s->polar = EK_POLAR_SVD;
    else if (strcmp(str, "warm") == 0)
      s->polar = EK_POLAR_WARM;
    else
      return bad(c, "polar", node, "must be \"svd\" or \"warm\"");
  }
  const cJSON *svd = cJSON_GetObjectItemCaseSensitive(root, "svd");
  if (!svd)
    return 0;
  if ((rc = want_object(c, svd, "svd")) ||
      (rc = check_keys(c, svd, "svd", (const char *const[]){"sweeps", "rsqrt", "refine", NULL})))
    return rc;
  long sweeps = 0, refine = -1;
  if ((rc = get_count(c, svd, "svd", "sweeps", 0, 0, EK_SVD3_MAX_SWEEPS, &sweeps)) ||
      (rc = get_count(c, svd, "svd", "refine", 0, 0, EK_SVD3_MAX_REFINE, &refine)))
    return rc;
  s->svd.sweeps = (int)sweeps;
  // In a scene "refine" counts sweeps (0 = none); absent is the default.
  s->svd.refine = refine < 0 ? 0 : refine == 0 ? EK_SVD3_REFINE_NONE : (int)refine;
  str = NULL;
  if ((rc = get_string(c, svd, "svd", "rsqrt", 0, &str, &node)))
    return rc;
  if (str) {
    if (strcmp(str, "default") == 0)
      s->svd.exact_rsqrt = 0;
    else if (strcmp(str, "exact") == 0)
      s->svd.exact_rsqrt = 1;
    else if (strcmp(str, "approximate") == 0)
      s->svd.exact_rsqrt = -1;
    else
      return bad(c, "svd.rsqrt", node, "must be \"default\", \"exact\" or \"approximate\"");
  }
  return 0;
}

static int parse_region(parse_ctx *c, const cJSON *bc, const char *path, ek_scene_bc *b) {
  char p[256];
  join(p, sizeof p, path, "region");
  const cJSON *region = cJSON_GetObjectItemCaseSensitive(bc, "region");
  if (!region)
    return missing(c, bc, p);
  int rc = want_object(c, region, p);
  if (!rc)
    rc = check_keys(c, region, p, (const char *const[]){"min", "max", NULL});
  if (!rc)
    rc = get_vec(c, region, p, "min", 1, 3, b->box_min);
  if (!rc)
    rc = get_vec(c, region, p, "max", 1, 3, b->box_max);
  if (rc)
    return rc;
  for (int i = 0; i < 3; ++i)
    if (b->box_min[i] > b->box_max[i]) {
      char pi[300];
      snprintf(pi, sizeof pi, "%s.max[%d]", p, i);
      return bad(c, pi, cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(region, "max"), i),
                 "must be >= %s.min[%d] = %g", p, i, b->box_min[i]);
    }
  return 0;
}

static int parse_boundary(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const cJSON *list = cJSON_GetObjectItemCaseSensitive(root, "boundary");
  if (!list)
    return 0;
  if (!cJSON_IsArray(list))
    return bad(c, "boundary", list, "must be an array of boundary conditions");
  int n = cJSON_GetArraySize(list);
  if (n > EK_SCENE_MAX_BC)
    return bad(c, "boundary", list, "at most %d boundary conditions", EK_SCENE_MAX_BC);
  int i = 0;
  for (const cJSON *bc = list->child; bc; bc = bc->next, ++i) {
    char path[64];
    snprintf(path, sizeof path, "boundary[%d]", i);
    ek_scene_bc *b = &s->bc[i];
    memset(b, 0, sizeof *b);
    b->until = INFINITY;
    int rc = want_object(c, bc, path);
    if (rc)
      return rc;
    const char *type = NULL;
    const cJSON *type_node = NULL;
    if ((rc = get_string(c, bc, path, "type", 1, &type, &type_node)))
      return rc;
    char p[128];
    snprintf(p, sizeof p, "%s.type", path);
    if (strcmp(type, "pin") == 0) {
      b->kind = EK_BC_PIN;
      rc = check_keys(c, bc, path, (const char *const[]){"type", "region", NULL});
    } else if (strcmp(type, "twist") == 0) {
      b->kind = EK_BC_TWIST;
      rc = check_keys(c, bc, path,
                      (const char *const[]){"type", "region", "axis", "center", "rate", "until",
                                            "release", NULL});
      if (!rc)
        rc = get_vec(c, bc, path, "axis", 1, 3, b->axis);
      if (!rc)
        rc = get_vec(c, bc, path, "center", 1, 3, b->center);
      if (!rc)
        rc = get_number(c, bc, path, "rate", 1, &b->rate, NULL);
      if (!rc) {
        double len =
            sqrt(b->axis[0] * b->axis[0] + b->axis[1] * b->axis[1] + b->axis[2] * b->axis[2]);
        snprintf(p, sizeof p, "%s.axis", path);
        if (!(len > 0))
          return bad(c, p, cJSON_GetObjectItemCaseSensitive(bc, "axis"), "must be non-zero");
        for (int k = 0; k < 3; ++k)
          b->axis[k] /= len;
      }
    } else if (strcmp(type, "stretch") == 0) {
      b->kind = EK_BC_STRETCH;
      rc =
          check_keys(c, bc, path,
                     (const char *const[]){"type", "region", "velocity", "until", "release", NULL});
      if (!rc)
        rc = get_vec(c, bc, path, "velocity", 1, 3, b->velocity);
    } else {
      return bad(c, p, type_node, "must be \"pin\", \"twist\" or \"stretch\"");
    }
    if (rc)
      return rc;
    if (b->kind != EK_BC_PIN) {
      const cJSON *node = NULL;
      if ((rc = get_number(c, bc, path, "until", 0, &b->until, &node)))
        return rc;
      snprintf(p, sizeof p, "%s.until", path);
      if (node && !(b->until > 0))
        return bad(c, p, node, "must be > 0 (seconds)");
      if ((rc = get_bool(c, bc, path, "release", &b->release)))
        return rc;
      snprintf(p, sizeof p, "%s.release", path);
      if (b->release && !node)
        return bad(c, p, cJSON_GetObjectItemCaseSensitive(bc, "release"),
                   "needs %s.until (when to release)", path);
    }
    if ((rc = parse_region(c, bc, path, b)))
      return rc;
  }
  s->nbc = n;
  return 0;
}

static int parse_loads(parse_ctx *c, const cJSON *root, ek_scene *s) {
  int rc = get_vec(c, root, "", "gravity", 0, 3, s->gravity);
  if (rc)
    return rc;
  const cJSON *ground = cJSON_GetObjectItemCaseSensitive(root, "ground");
  if (ground) {
    if ((rc = want_object(c, ground, "ground")) ||
        (rc = check_keys(c, ground, "ground", (const char *const[]){"height", NULL})) ||
        (rc = get_number(c, ground, "ground", "height", 1, &s->ground_height, NULL)))
      return rc;
    s->has_ground = 1;
  }
  const cJSON *node = NULL;
  if ((rc = get_number(c, root, "", "damping", 0, &s->damping, &node)))
    return rc;
  if (!(s->damping >= 0))
    return bad(c, "damping", node, "must be >= 0 (1/s)");
  if ((rc = get_number(c, root, "", "dt", 1, &s->dt, &node)))
    return rc;
  if (!(s->dt > 0))
    return bad(c, "dt", node, "must be > 0 (seconds)");
  if ((rc = get_count(c, root, "", "steps", 1, 0, 1000000000L, &s->steps)))
    return rc;
  const cJSON *out = cJSON_GetObjectItemCaseSensitive(root, "output");
  if (out) {
    const char *file = NULL;
    const cJSON *file_node = NULL;
    if ((rc = want_object(c, out, "output")) ||
        (rc = check_keys(c, out, "output", (const char *const[]){"file", "every", NULL})) ||
        (rc = get_string(c, out, "output", "file", 1, &file, &file_node)) ||
        (rc = get_count(c, out, "output", "every", 0, 1, 1000000000L, &s->output_every)))
      return rc;
    if (strlen(file) >= sizeof s->output_file)
      return bad(c, "output.file", file_node, "path too long");
    snprintf(s->output_file, sizeof s->output_file, "%s", file);
  }
  return 0;
}

// What the run may end in without failing (ek_scene: allow_inverted,
// allow_nonfinite; ek-sim's exit status, sim/cli.h).
static int parse_allow(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const cJSON *allow = cJSON_GetObjectItemCaseSensitive(root, "allow");
  if (!allow)
    return 0;
  int rc;
  if ((rc = want_object(c, allow, "allow")) ||
      (rc = check_keys(c, allow, "allow", (const char *const[]){"inverted", "nonfinite", NULL})) ||
      (rc = get_bool(c, allow, "allow", "inverted", &s->allow_inverted)) ||
      (rc = get_bool(c, allow, "allow", "nonfinite", &s->allow_nonfinite)))
    return rc;
  return 0;
}

// "advise": {"reference_dt": s}: the step of the explicit f64 run that
// ek-sim --advise may trust as its converged reference (sim/advise.h).
static int parse_advise(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const cJSON *adv = cJSON_GetObjectItemCaseSensitive(root, "advise");
  if (!adv)
    return 0;
  const cJSON *node = NULL;
  int rc;
  if ((rc = want_object(c, adv, "advise")) ||
      (rc = check_keys(c, adv, "advise", (const char *const[]){"reference_dt", NULL})) ||
      (rc = get_number(c, adv, "advise", "reference_dt", 1, &s->advise_reference_dt, &node)))
    return rc;
  if (!(s->advise_reference_dt > 0))
    return bad(c, "advise.reference_dt", node, "must be > 0");
  return 0;
}

// XPBD's keys (ek_scene_xpbd).
static int parse_xpbd(parse_ctx *c, const cJSON *integ, ek_scene_xpbd *x) {
  const char *solver = NULL, *elements = NULL;
  const cJSON *node = NULL;
  int rc;
  if ((rc = check_keys(
           c, integ, "integrator",
           (const char *const[]){"type", "iterations", "substeps", "solver", "elements", NULL})) ||
      (rc = get_count(c, integ, "integrator", "iterations", 0, 1, 100000, &x->iterations)) ||
      (rc = get_count(c, integ, "integrator", "substeps", 0, 1, 100000, &x->substeps)) ||
      (rc = get_string(c, integ, "integrator", "solver", 0, &solver, &node)))
    return rc;
  if (solver && strcmp(solver, "gauss_seidel") == 0)
    x->solver = EK_XPBD_GAUSS_SEIDEL;
  else if (solver && strcmp(solver, "jacobi") == 0)
    x->solver = EK_XPBD_JACOBI;
  else if (solver)
    return bad(c, "integrator.solver", node, "unknown solver (known: gauss_seidel, jacobi)");
  if ((rc = get_string(c, integ, "integrator", "elements", 0, &elements, &node)))
    return rc;
  if (elements && strcmp(elements, "tets") == 0)
    x->elements = EK_XPBD_TETS;
  else if (elements && strcmp(elements, "clusters") == 0)
    x->elements = EK_XPBD_CLUSTERS;
  else if (elements)
    return bad(c, "integrator.elements", node, "unknown elements (known: tets, clusters)");
  return 0;
}

// "integrator": {"type": NAME, ...}, optional (default explicit). The type
// comes first: the keys an integrator takes besides it depend on which one
// it is (explicit takes none; implicit: ek_scene_implicit).
static int parse_integrator(parse_ctx *c, const cJSON *root, ek_scene *s) {
  const cJSON *integ = cJSON_GetObjectItemCaseSensitive(root, "integrator");
  if (!integ)
    return 0;
  const char *type = NULL;
  const cJSON *node = NULL;
  int rc = want_object(c, integ, "integrator");
  if (!rc)
    rc = get_string(c, integ, "integrator", "type", 1, &type, &node);
  if (rc)
    return rc;
  int found = -1;
  for (int i = 0; i < EK_INTEGRATOR_COUNT; ++i)
    if (strcmp(type, sim_integrators[i]->name) == 0)
      found = i;
  if (found < 0) {
    char list[256] = "";
    for (int i = 0; i < EK_INTEGRATOR_COUNT; ++i) {
      strncat(list, sim_integrators[i]->name, sizeof list - strlen(list) - 1);
      if (i + 1 < EK_INTEGRATOR_COUNT)
        strncat(list, ", ", sizeof list - strlen(list) - 1);
    }
    return bad(c, "integrator.type", node, "unknown integrator (known: %s)", list);
  }
  s->integrator = (ek_integrator_type)found;
  if (s->integrator == EK_INTEGRATOR_XPBD)
    return parse_xpbd(c, integ, &s->xpbd);
  if (s->integrator != EK_INTEGRATOR_IMPLICIT)
    return check_keys(c, integ, "integrator", (const char *const[]){"type", NULL});
  ek_scene_implicit *im = &s->implicit;
  const char *pc = NULL;
  if ((rc = check_keys(c, integ, "integrator",
                       (const char *const[]){"type", "newton_tol", "max_newton", "cg_tol", "max_cg",
                                             "preconditioner", "projection", "linear_solver",
                                             NULL})) ||
      (rc = get_number(c, integ, "integrator", "newton_tol", 0, &im->newton_tol, &node)))
    return rc;
  if (!(im->newton_tol > 0))
    return bad(c, "integrator.newton_tol", node, "must be > 0");
  if ((rc = get_number(c, integ, "integrator", "cg_tol", 0, &im->cg_tol, &node)))
    return rc;
  if (!(im->cg_tol > 0 && im->cg_tol < 1))
    return bad(c, "integrator.cg_tol", node, "must be in (0, 1)");
  if ((rc = get_count(c, integ, "integrator", "max_newton", 0, 1, 100000, &im->max_newton)) ||
      (rc = get_count(c, integ, "integrator", "max_cg", 0, 1, 1000000, &im->max_cg)) ||
      (rc = get_string(c, integ, "integrator", "preconditioner", 0, &pc, &node)))
    return rc;
  if (pc && strcmp(pc, "jacobi") == 0)
    im->preconditioner = EK_PRECOND_JACOBI;
  else if (pc && strcmp(pc, "block_jacobi") == 0)
    im->preconditioner = EK_PRECOND_BLOCK_JACOBI;
  else if (pc)
    return bad(c, "integrator.preconditioner", node,
               "unknown preconditioner (known: jacobi, block_jacobi)");
  const char *pr = NULL;
  if ((rc = get_string(c, integ, "integrator", "projection", 0, &pr, &node)))
    return rc;
  if (pr && strcmp(pr, "clamp") == 0)
    im->projection = EK_PROJECT_CLAMP;
  else if (pr && strcmp(pr, "abs") == 0)
    im->projection = EK_PROJECT_ABS;
  else if (pr)
    return bad(c, "integrator.projection", node, "unknown projection (known: clamp, abs)");
  const char *ls = NULL;
  if ((rc = get_string(c, integ, "integrator", "linear_solver", 0, &ls, &node)))
    return rc;
  int found_ls = -1;
  for (int k = 0; ls && k < EK_LINSOLVE_COUNT; k++)
    if (strcmp(ls, ek_linear_solver_name((ek_linear_solver)k)) == 0)
      found_ls = k;
  if (ls && found_ls < 0)
    return bad(c, "integrator.linear_solver", node,
               "unknown linear solver (known: matrix_free, amg, direct)");
  if (ls)
    im->linear_solver = (ek_linear_solver)found_ls;
  return 0;
}

// ---------------------------------------------------------------- entry

static void scene_defaults(ek_scene *s) {
  memset(s, 0, sizeof *s);
  for (int i = 0; i < 3; ++i)
    s->init_scale[i] = 1;
  s->precision = 64;
  s->scatter = EK_SCATTER_AUTO;
  s->svd.isa = EK_ISA_AUTO;
  s->integrator = EK_INTEGRATOR_EXPLICIT;
  s->implicit = (ek_scene_implicit){.newton_tol = 1e-6,
                                    .max_newton = 50,
                                    .cg_tol = 1e-4,
                                    .max_cg = 1000,
                                    .preconditioner = EK_PRECOND_BLOCK_JACOBI};
  s->xpbd = (ek_scene_xpbd){.iterations = 5, .substeps = 20};
  s->young = NAN;
  s->poisson = NAN;
  s->output_every = 1;
}

int ek_scene_parse_errbuf(const char *text, const char *name, const char *base_dir, ek_scene *scene,
                          char *err, size_t errlen) {
  parse_ctx c = {name ? name : "(scene)", err, errlen, text, NULL, NULL, 0};
  if (err && errlen)
    err[0] = '\0';
  if (!text || !scene) {
    if (err && errlen)
      snprintf(err, errlen, "%s: no scene text", c.name);
    return EK_EINVAL;
  }
  const char *end = NULL;
  cJSON *root = cJSON_ParseWithOpts(text, &end, 1);
  if (!root) {
    const char *at = cJSON_GetErrorPtr();
    syntax_error(c.name, text, at ? at : end ? end : text, err, errlen);
    return EK_EINVAL;
  }
  json_scan k;
  find_positions(&c, root, &k);
  ek_scene s;
  scene_defaults(&s);
  snprintf(s.path, sizeof s.path, "%s", c.name);
  int rc = 0;
  if (!cJSON_IsObject(root))
    rc = bad(&c, "(top level)", root, "a scene must be a JSON object");
  if (!rc)
    rc = find_duplicates(&c, root, "");
  if (!rc)
    rc = check_keys(&c, root, "",
                    (const char *const[]){
                        "description", "mesh",   "initial", "material",   "precision", "isa",
                        "scatter",     "svd",    "polar",   "boundary",   "gravity",   "ground",
                        "damping",     "dt",     "steps",   "integrator", "output",    "cloth",
                        "allow",       "advise", NULL});
  if (!rc) {
    const cJSON *d = cJSON_GetObjectItemCaseSensitive(root, "description");
    if (d && !cJSON_IsString(d))
      rc = bad(&c, "description", d, "must be a string");
  }
  if (!rc)
    rc = parse_mesh(&c, root, base_dir, &s);
  if (!rc)
    rc = parse_initial(&c, root, &s);
  if (!rc)
    rc = parse_material(&c, root, &s);
  if (!rc)
    rc = parse_cloth(&c, root, &s);
  if (!rc)
    rc = parse_kernels(&c, root, &s);
  if (!rc)
    rc = parse_boundary(&c, root, &s);
  if (!rc)
    rc = parse_loads(&c, root, &s);
  if (!rc)
    rc = parse_integrator(&c, root, &s);
  if (!rc)
    rc = parse_allow(&c, root, &s);
  if (!rc)
    rc = parse_advise(&c, root, &s);
  if (!rc)
    record_positions(&c, root, &s.where);
  cJSON_Delete(root);
  free(k.pos);
  free(c.nodes);
  if (rc)
    return rc;
  *scene = s;
  return 0;
}

int ek_scene_load_errbuf(const char *path, ek_scene *scene, char *err, size_t errlen) {
  if (err && errlen)
    err[0] = '\0';
  if (!path) {
    if (err && errlen)
      snprintf(err, errlen, "(null): no scene path");
    return EK_EINVAL;
  }
  FILE *f = fopen(path, "rb");
  if (!f) {
    if (err && errlen)
      snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
    return EK_EIO;
  }
  struct stat st;
  if (fstat(fileno(f), &st) == 0 && S_ISDIR(st.st_mode)) {
    if (err && errlen)
      snprintf(err, errlen, "%s: is a directory, not a scene file", path);
    fclose(f);
    return EK_EIO;
  }
  // Scenes are small; 1 MiB is far beyond any hand-written one.
  enum { MAX_SCENE = 1 << 20 };
  char *text = malloc(MAX_SCENE + 1);
  if (!text) {
    fclose(f);
    return EK_ENOMEM;
  }
  size_t n = fread(text, 1, MAX_SCENE + 1, f);
  int read_error = ferror(f);
  fclose(f);
  if (read_error || n > MAX_SCENE) {
    if (err && errlen)
      snprintf(err, errlen, "%s: %s", path,
               read_error ? "read error" : "larger than 1 MiB, not a scene file");
    free(text);
    return EK_EIO;
  }
  text[n] = '\0';
  if (strlen(text) != n) {
    // cJSON would stop at the NUL and take what precedes it as the scene.
    int line = 1;
    for (const char *p = text; *p; ++p)
      line += *p == '\n';
    if (err && errlen)
      snprintf(err, errlen, "%s:%d: NUL byte at offset %zu: not a JSON text file", path, line,
               strlen(text));
    free(text);
    return EK_EIO;
  }
  // Mesh files are resolved relative to the scene's directory.
  char dir[EK_SCENE_PATH_MAX];
  snprintf(dir, sizeof dir, "%s", path);
  char *slash = strrchr(dir, '/');
  if (slash)
    *slash = '\0';
  else
    snprintf(dir, sizeof dir, ".");
  int rc = ek_scene_parse_errbuf(text, path, dir, scene, err, errlen);
  free(text);
  return rc;
}

const char *ek_scene_at(const ek_scene *s, ek_scene_pos pos, char *buf, size_t len) {
  if (!buf || !len)
    return buf;
  if (pos.line > 0)
    snprintf(buf, len, "%s:%d:%d", s->path, pos.line, pos.col);
  else
    snprintf(buf, len, "%s", s->path);
  return buf;
}

// A mesh file that does not load: its reader's message (FILE:LINE of the
// mesh file) after the scene's place of mesh.file.
static void mesh_file_error(const ek_scene *s, char *err, size_t errlen) {
  if (!err || !errlen)
    return;
  char where[EK_SCENE_AT_MAX], why[EK_ERRBUF_LEN];
  snprintf(why, sizeof why, "%s", err);
  snprintf(err, errlen, "%s: mesh.file: %s", ek_scene_at(s, s->where.mesh, where, sizeof where),
           why);
}

ek_mesh *ek_scene_mesh_errbuf(const ek_scene *s, char *err, size_t errlen) {
  if (s->triangles) {
    if (err && errlen)
      snprintf(err, errlen, "%s: the mesh is a triangle mesh (cloth): use ek_scene_trimesh",
               s->path);
    return NULL;
  }
  if (s->mesh_file[0]) {
    ek_mesh_opts opts = {0};
    opts.fix_orientation = s->fix_orientation;
    ek_mesh *m = ek_mesh_load_ex_errbuf(s->mesh_file, &opts, err, errlen);
    if (!m)
      mesh_file_error(s, err, errlen);
    return m;
  }
  return ek_mesh_box_errbuf(s->box_cells[0], s->box_cells[1], s->box_cells[2], s->box_size[0],
                            s->box_size[1], s->box_size[2], err, errlen);
}

ek_trimesh *ek_scene_trimesh_errbuf(const ek_scene *s, char *err, size_t errlen) {
  if (!s->triangles) {
    if (err && errlen)
      snprintf(err, errlen, "%s: the mesh is a tet mesh: use ek_scene_mesh", s->path);
    return NULL;
  }
  if (s->mesh_file[0]) {
    ek_trimesh *m = ek_trimesh_load_errbuf(s->mesh_file, err, errlen);
    if (!m)
      mesh_file_error(s, err, errlen);
    return m;
  }
  return ek_trimesh_grid_errbuf(s->grid_cells[0], s->grid_cells[1], s->grid_size[0],
                                s->grid_size[1], s->grid_plane, err, errlen);
}

const char *ek_linear_solver_name(ek_linear_solver s) {
  static const char *const names[EK_LINSOLVE_COUNT] = {"matrix_free", "amg", "direct"};
  return (unsigned)s < EK_LINSOLVE_COUNT ? names[s] : "invalid";
}
