// Triangle meshes for cloth (include/ek/trimesh.h): validation, the OBJ and
// Gmsh 2D readers and the grid generator. Readers collect everything first,
// grow their arrays as data arrives (a header's count is checked against
// the data, never trusted to size memory), then hand the arrays to one
// builder, so a mesh never half-loads and every error names file:line.
#include <ek/trimesh.h>

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "text_escape.h"

struct ek_trimesh {
  size_t nv, nt;
  double *X;
  int32_t *T;
  ek_cloth *cloth;
};

static void tm_error(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
// Messages quote tokens from the file: every byte that is not printable
// ASCII is shown as \xNN (text_escape.h), never echoed raw.
static void tm_error(char *err, size_t errlen, const char *fmt, ...) {
  if (!err || errlen < 8)
    return;
  char raw[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(raw, sizeof raw, fmt, ap);
  va_end(ap);
  text_escape(err, errlen, raw, sizeof raw, 0);
}

void ek_trimesh_destroy(ek_trimesh *m) {
  if (!m)
    return;
  free(m->X);
  free(m->T);
  ek_cloth_destroy(m->cloth);
  free(m);
}

size_t ek_trimesh_nverts(const ek_trimesh *m) { return m->nv; }
size_t ek_trimesh_ntris(const ek_trimesh *m) { return m->nt; }
const double *ek_trimesh_rest_positions(const ek_trimesh *m) { return m->X; }
const int32_t *ek_trimesh_tris(const ek_trimesh *m) { return m->T; }
const ek_cloth *ek_trimesh_cloth(const ek_trimesh *m) { return m->cloth; }

// Where the arrays came from: file (NULL for memory), per-vertex and
// per-triangle source lines (NULL: report indices), and the index base the
// file uses (so indices are reported as written).
typedef struct {
  const char *file;
  const long *vline, *tline;
  long base;
} tm_origin;

static void where(char *buf, size_t n, const tm_origin *o, const long *lines, size_t i,
                  const char *what) {
  if (o && o->file && lines)
    snprintf(buf, n, "%s:%ld", o->file, lines[i]);
  else if (o && o->file)
    snprintf(buf, n, "%s: %s %zu", o->file, what, i);
  else
    snprintf(buf, n, "%s %zu", what, i);
}

// Validate and build. Takes ownership of X and T (freed on failure too).
static ek_trimesh *tm_build(size_t nv, double *X, size_t nt, int32_t *T, const tm_origin *o,
                            char *err, size_t errlen) {
  char at[1100];
  const char *name = o && o->file ? o->file : "ek_trimesh_create";
  if (nt == 0 || nv < 3) {
    tm_error(err, errlen, "%s: no triangles (%zu vertices, %zu triangles)", name, nv, nt);
    goto fail;
  }
  if (nt > (size_t)INT32_MAX / 4 || nv > (size_t)INT32_MAX / 3) {
    tm_error(err, errlen, "%s: too large (%zu vertices, %zu triangles)", name, nv, nt);
    goto fail;
  }
  for (size_t i = 0; i < 3 * nv; ++i)
    if (!isfinite(X[i])) {
      where(at, sizeof at, o, o ? o->vline : NULL, i / 3, "vertex");
      tm_error(err, errlen, "%s: coordinate %g is not finite", at, X[i]);
      goto fail;
    }
  for (size_t t = 0; t < nt; ++t) {
    const int32_t *q = T + 3 * t;
    where(at, sizeof at, o, o ? o->tline : NULL, t, "triangle");
    for (int c = 0; c < 3; ++c)
      if (q[c] < 0 || (size_t)q[c] >= nv) {
        tm_error(err, errlen, "%s: vertex index %ld out of range [%ld, %ld]", at,
                 (long)q[c] + (o ? o->base : 0), o ? o->base : 0, (long)nv - 1 + (o ? o->base : 0));
        goto fail;
      }
    if (q[0] == q[1] || q[1] == q[2] || q[0] == q[2]) {
      long b = o ? o->base : 0;
      tm_error(err, errlen, "%s: triangle (%ld %ld %ld) repeats a vertex", at, q[0] + b, q[1] + b,
               q[2] + b);
      goto fail;
    }
    // The degeneracy rule of ek_cloth_create, checked here to name the line.
    const double *a = X + 3 * (size_t)q[0], *b = X + 3 * (size_t)q[1], *c = X + 3 * (size_t)q[2];
    double e1[3], e2[3], e3[3], n[3];
    for (int k = 0; k < 3; ++k)
      e1[k] = b[k] - a[k], e2[k] = c[k] - a[k], e3[k] = c[k] - b[k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double area = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    double l2 = fmax(fmax(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2],
                          e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]),
                     e3[0] * e3[0] + e3[1] * e3[1] + e3[2] * e3[2]);
    if (!(2 * area > EK_CLOTH_DEGENERATE_REL * l2)) {
      long bs = o ? o->base : 0;
      tm_error(err, errlen,
               "%s: triangle %zu (%ld %ld %ld): twice the rest area %g <= %g (longest "
               "edge^2 %g): degenerate (zero-area) triangle",
               at, t, q[0] + bs, q[1] + bs, q[2] + bs, 2 * area, EK_CLOTH_DEGENERATE_REL * l2, l2);
      goto fail;
    }
  }
  // Drop vertices no triangle uses (they would carry no mass).
  int32_t *map = malloc(nv * sizeof *map);
  if (!map)
    goto oom;
  for (size_t i = 0; i < nv; ++i)
    map[i] = -1;
  for (size_t i = 0; i < 3 * nt; ++i)
    map[T[i]] = 0;
  size_t used = 0;
  for (size_t i = 0; i < nv; ++i)
    if (map[i] == 0) {
      map[i] = (int32_t)used;
      memmove(X + 3 * used, X + 3 * i, 3 * sizeof(double));
      used++;
    }
  for (size_t i = 0; i < 3 * nt; ++i)
    T[i] = map[T[i]];
  free(map);
  ek_trimesh *m = calloc(1, sizeof *m);
  if (!m)
    goto oom;
  m->nv = used;
  m->nt = nt;
  m->X = X;
  m->T = T;
  m->cloth = ek_cloth_create(used, X, nt, T);
  if (!m->cloth) {
    tm_error(err, errlen, "%s: %s", name, ek_last_error());
    m->X = NULL, m->T = NULL;
    ek_trimesh_destroy(m);
    goto fail;
  }
  return m;
oom:
  tm_error(err, errlen, "%s: out of memory (%zu vertices, %zu triangles)", name, nv, nt);
fail:
  free(X);
  free(T);
  return NULL;
}

ek_trimesh *ek_trimesh_create(size_t nverts, const double *X, size_t ntris, const int32_t *tris,
                              char *err, size_t errlen) {
  if (!X || !tris) {
    tm_error(err, errlen, "ek_trimesh_create: NULL arrays");
    return NULL;
  }
  double *Xc = malloc((nverts ? nverts : 1) * 3 * sizeof(double));
  int32_t *Tc = malloc((ntris ? ntris : 1) * 3 * sizeof(int32_t));
  if (!Xc || !Tc) {
    free(Xc);
    free(Tc);
    tm_error(err, errlen, "ek_trimesh_create: out of memory");
    return NULL;
  }
  memcpy(Xc, X, nverts * 3 * sizeof(double));
  memcpy(Tc, tris, ntris * 3 * sizeof(int32_t));
  return tm_build(nverts, Xc, ntris, Tc, NULL, err, errlen);
}

ek_trimesh *ek_trimesh_grid(int nx, int ny, double lx, double ly, const char *plane, char *err,
                            size_t errlen) {
  int xz = plane && strcmp(plane, "xz") == 0;
  if (plane && !xz && strcmp(plane, "xy") != 0) {
    tm_error(err, errlen, "ek_trimesh_grid: plane \"%s\": must be \"xy\" or \"xz\"", plane);
    return NULL;
  }
  if (nx < 1 || ny < 1 || nx > 8192 || ny > 8192 || !(lx > 0) || !(ly > 0) || !isfinite(lx) ||
      !isfinite(ly)) {
    tm_error(err, errlen,
             "ek_trimesh_grid: %d x %d cells of %g x %g: need 1..8192 cells and finite sizes > 0",
             nx, ny, lx, ly);
    return NULL;
  }
  size_t nv = (size_t)(nx + 1) * (size_t)(ny + 1), nt = 2 * (size_t)nx * (size_t)ny;
  double *X = malloc(3 * nv * sizeof(double));
  int32_t *T = malloc(3 * nt * sizeof(int32_t));
  if (!X || !T) {
    free(X);
    free(T);
    tm_error(err, errlen, "ek_trimesh_grid: out of memory for %zu triangles", nt);
    return NULL;
  }
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      double *p = X + 3 * ((size_t)j * (size_t)(nx + 1) + (size_t)i);
      double u = lx * i / nx, v = ly * j / ny;
      p[0] = u;
      p[1] = xz ? 0 : v;
      p[2] = xz ? v : 0;
    }
  size_t t = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      int32_t a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      // Alternating diagonals: no preferred shear direction.
      int32_t q[6] = {a, b, d, a, d, c}, r[6] = {a, b, c, b, d, c};
      memcpy(T + 3 * t, (i + j) % 2 ? r : q, sizeof q);
      t += 2;
    }
  tm_origin o = {"grid", NULL, NULL, 0};
  return tm_build(nv, X, nt, T, &o, err, errlen);
}

// ------------------------------------------------------------------ readers

typedef struct {
  FILE *fp;
  const char *path;
  char *line;
  size_t cap;
  long lineno;
  char *err;
  size_t errlen;
  // growing arrays
  double *X;
  long *vline;
  size_t nv, vcap;
  int32_t *T;
  long *tline;
  size_t nt, tcap;
} tm_reader;

static int rd_getline(tm_reader *r) {
  ssize_t n = getline(&r->line, &r->cap, r->fp);
  if (n < 0)
    return -1;
  r->lineno++;
  return 0;
}

// Room for one more item: `items` (item_bytes each) and their line numbers
// grow together, doubling from 1024.
static int grow(tm_reader *r, void *items_p, size_t item_bytes, long **lines, size_t *cap) {
  void **items = items_p;
  size_t c = *cap ? 2 * *cap : 1024;
  void *a = realloc(*items, c * item_bytes);
  if (a)
    *items = a;
  long *l = realloc(*lines, c * sizeof(long));
  if (l)
    *lines = l;
  if (!a || !l) {
    tm_error(r->err, r->errlen, "%s:%ld: out of memory", r->path, r->lineno);
    return -1;
  }
  *cap = c;
  return 0;
}

static int push_vertex(tm_reader *r, const double p[3]) {
  void *X = r->X;
  int rc = r->nv == r->vcap ? grow(r, &X, 3 * sizeof(double), &r->vline, &r->vcap) : 0;
  r->X = X; // moved by realloc even when the line numbers' realloc failed
  if (rc)
    return -1;
  memcpy(r->X + 3 * r->nv, p, 3 * sizeof(double));
  r->vline[r->nv++] = r->lineno;
  return 0;
}

static int push_tri(tm_reader *r, const int32_t q[3]) {
  void *T = r->T;
  int rc = r->nt == r->tcap ? grow(r, &T, 3 * sizeof(int32_t), &r->tline, &r->tcap) : 0;
  r->T = T;
  if (rc)
    return -1;
  memcpy(r->T + 3 * r->nt, q, 3 * sizeof(int32_t));
  r->tline[r->nt++] = r->lineno;
  return 0;
}

static void rd_free(tm_reader *r) {
  if (r->fp)
    fclose(r->fp);
  free(r->line);
  free(r->X);
  free(r->vline);
  free(r->T);
  free(r->tline);
}

static char *next_tok(char **cur) {
  char *p = *cur;
  while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')
    p++;
  if (!*p)
    return NULL;
  char *s = p;
  while (*p && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\n')
    p++;
  if (*p)
    *p++ = 0;
  *cur = p;
  return s;
}

static int parse_double(tm_reader *r, char **cur, const char *what, double *out) {
  char *tok = next_tok(cur), *end;
  if (!tok) {
    tm_error(r->err, r->errlen, "%s:%ld: truncated line: missing %s", r->path, r->lineno, what);
    return -1;
  }
  errno = 0;
  *out = strtod(tok, &end);
  if (*end || (errno && errno != ERANGE)) {
    tm_error(r->err, r->errlen, "%s:%ld: bad number '%s' for %s", r->path, r->lineno, tok, what);
    return -1;
  }
  return 0;
}

static int parse_long(tm_reader *r, char **cur, const char *what, long *out) {
  char *tok = next_tok(cur), *end;
  if (!tok) {
    tm_error(r->err, r->errlen, "%s:%ld: truncated line: missing %s", r->path, r->lineno, what);
    return -1;
  }
  errno = 0;
  *out = strtol(tok, &end, 10);
  if (*end || errno) {
    tm_error(r->err, r->errlen, "%s:%ld: bad number '%s' for %s", r->path, r->lineno, tok, what);
    return -1;
  }
  return 0;
}

static ek_trimesh *read_obj(tm_reader *r) {
  while (rd_getline(r) == 0) {
    char *h = strchr(r->line, '#');
    if (h)
      *h = 0;
    char *cur = r->line, *kw = next_tok(&cur);
    if (!kw)
      continue;
    if (strcmp(kw, "v") == 0) {
      double p[3];
      if (parse_double(r, &cur, "x", &p[0]) || parse_double(r, &cur, "y", &p[1]) ||
          parse_double(r, &cur, "z", &p[2]) || push_vertex(r, p))
        return NULL;
    } else if (strcmp(kw, "f") == 0) {
      int32_t first = -1, prev = -1;
      int k = 0;
      for (char *tok; (tok = next_tok(&cur)); ++k) {
        // "i", "i/t", "i//n", "i/t/n": the vertex index is before the first '/'.
        char *end;
        errno = 0;
        long i = strtol(tok, &end, 10);
        if (end == tok || (*end && *end != '/') || errno) {
          tm_error(r->err, r->errlen, "%s:%ld: bad vertex index '%s' in face", r->path, r->lineno,
                   tok);
          return NULL;
        }
        // 1-based; negative relative to the vertices defined so far.
        long v = i > 0 ? i - 1 : (long)r->nv + i;
        if (i == 0 || v < 0 || v >= (long)r->nv) {
          tm_error(r->err, r->errlen,
                   "%s:%ld: vertex index %ld out of range (%zu vertices defined so far; indices "
                   "are 1..%zu or -1..-%zu)",
                   r->path, r->lineno, i, r->nv, r->nv, r->nv);
          return NULL;
        }
        if (k == 0)
          first = (int32_t)v;
        else if (k >= 2) {
          // Fan triangulation from the first vertex.
          int32_t q[3] = {first, prev, (int32_t)v};
          if (push_tri(r, q))
            return NULL;
        }
        prev = (int32_t)v;
      }
      if (k < 3) {
        tm_error(r->err, r->errlen, "%s:%ld: face with %d vertices: need at least 3", r->path,
                 r->lineno, k);
        return NULL;
      }
    }
    // Every other statement is ignored (trimesh.h).
  }
  tm_origin o = {r->path, r->vline, r->tline, 1};
  ek_trimesh *m = tm_build(r->nv, r->X, r->nt, r->T, &o, r->err, r->errlen);
  r->X = NULL, r->T = NULL;
  return m;
}

// Node tags -> index: sorted (tag, index) pairs and binary search.
typedef struct {
  long tag;
  int32_t idx;
} tag_pair;
static int tag_cmp(const void *a, const void *b) {
  long x = ((const tag_pair *)a)->tag, y = ((const tag_pair *)b)->tag;
  return (x > y) - (x < y);
}

static int expect_line(tm_reader *r, const char *what) {
  do {
    if (rd_getline(r)) {
      tm_error(r->err, r->errlen, "%s:%ld: truncated file: end of file while reading %s", r->path,
               r->lineno + 1, what);
      return -1;
    }
  } while (strspn(r->line, " \t\r\n") == strlen(r->line));
  return 0;
}

static ek_trimesh *read_msh(tm_reader *r) {
  double version = 0;
  tag_pair *tags = NULL;
  size_t ntags = 0, tcap = 0;
  long *node_tags = NULL; // v4 block: the tags before their coordinates
  ek_trimesh *m = NULL;
  int have_nodes = 0, have_elems = 0;
  // Triangles read with node tags; mapped once nodes are sorted.
  while (rd_getline(r) == 0) {
    char *cur = r->line, *kw = next_tok(&cur);
    if (!kw)
      continue;
    if (strcmp(kw, "$MeshFormat") == 0) {
      if (expect_line(r, "the mesh format"))
        goto done;
      cur = r->line;
      long ftype;
      if (parse_double(r, &cur, "version", &version) || parse_long(r, &cur, "file type", &ftype))
        goto done;
      if (ftype != 0) {
        tm_error(r->err, r->errlen, "%s:%ld: file type %ld: only ASCII (0) is read", r->path,
                 r->lineno, ftype);
        goto done;
      }
      if (!(version >= 2 && version < 3) && !(version >= 4 && version < 5)) {
        tm_error(r->err, r->errlen, "%s:%ld: version %g: only 2.x and 4.x are read", r->path,
                 r->lineno, version);
        goto done;
      }
    } else if (strcmp(kw, "$Nodes") == 0) {
      if (version == 0) {
        tm_error(r->err, r->errlen, "%s:%ld: $Nodes before $MeshFormat", r->path, r->lineno);
        goto done;
      }
      if (expect_line(r, "the node count"))
        goto done;
      cur = r->line;
      long nblocks = 1, nnodes;
      if (version >= 4 && parse_long(r, &cur, "number of entity blocks", &nblocks))
        goto done;
      if (parse_long(r, &cur, "number of nodes", &nnodes))
        goto done;
      if (nnodes < 0 || nblocks < 0) {
        tm_error(r->err, r->errlen, "%s:%ld: negative count %ld", r->path, r->lineno,
                 nnodes < 0 ? nnodes : nblocks);
        goto done;
      }
      long seen = 0;
      for (long b = 0; b < nblocks; ++b) {
        long in_block = nnodes;
        if (version >= 4) {
          long dim, ent, param;
          if (expect_line(r, "a node block header"))
            goto done;
          cur = r->line;
          if (parse_long(r, &cur, "entity dimension", &dim) ||
              parse_long(r, &cur, "entity tag", &ent) ||
              parse_long(r, &cur, "parametric flag", &param) ||
              parse_long(r, &cur, "nodes in block", &in_block))
            goto done;
          if (param != 0) {
            tm_error(r->err, r->errlen, "%s:%ld: parametric nodes (%ld) are not read", r->path,
                     r->lineno, param);
            goto done;
          }
          if (in_block < 0 || in_block > nnodes - seen) {
            tm_error(r->err, r->errlen, "%s:%ld: %ld nodes in block: more than the %ld declared",
                     r->path, r->lineno, in_block, nnodes);
            goto done;
          }
        }
        // v4: tags first, then coordinates; grown as they arrive.
        size_t ncap = 0;
        for (long i = 0; i < in_block; ++i) {
          long tag;
          double p[3];
          if (expect_line(r, "a node"))
            goto done;
          cur = r->line;
          if (parse_long(r, &cur, "node tag", &tag))
            goto done;
          if (version < 4) {
            if (parse_double(r, &cur, "x", &p[0]) || parse_double(r, &cur, "y", &p[1]) ||
                parse_double(r, &cur, "z", &p[2]) || push_vertex(r, p))
              goto done;
          } else {
            if ((size_t)i == ncap) {
              ncap = ncap ? 2 * ncap : 256;
              long *nt = realloc(node_tags, ncap * sizeof(long));
              if (!nt) {
                tm_error(r->err, r->errlen, "%s:%ld: out of memory", r->path, r->lineno);
                goto done;
              }
              node_tags = nt;
            }
            node_tags[i] = tag;
            continue;
          }
          if (ntags == tcap) {
            tcap = tcap ? 2 * tcap : 1024;
            tag_pair *t = realloc(tags, tcap * sizeof *t);
            if (!t) {
              tm_error(r->err, r->errlen, "%s:%ld: out of memory", r->path, r->lineno);
              goto done;
            }
            tags = t;
          }
          tags[ntags++] = (tag_pair){tag, (int32_t)(r->nv - 1)};
        }
        if (version >= 4)
          for (long i = 0; i < in_block; ++i) {
            double p[3];
            if (expect_line(r, "node coordinates"))
              goto done;
            cur = r->line;
            if (parse_double(r, &cur, "x", &p[0]) || parse_double(r, &cur, "y", &p[1]) ||
                parse_double(r, &cur, "z", &p[2]) || push_vertex(r, p))
              goto done;
            if (ntags == tcap) {
              tcap = tcap ? 2 * tcap : 1024;
              tag_pair *t = realloc(tags, tcap * sizeof *t);
              if (!t) {
                tm_error(r->err, r->errlen, "%s:%ld: out of memory", r->path, r->lineno);
                goto done;
              }
              tags = t;
            }
            tags[ntags++] = (tag_pair){node_tags[i], (int32_t)(r->nv - 1)};
          }
        seen += in_block;
      }
      if (seen != nnodes) {
        tm_error(r->err, r->errlen, "%s:%ld: %ld nodes read, %ld declared", r->path, r->lineno,
                 seen, nnodes);
        goto done;
      }
      if (ntags) // no nodes: tags is NULL, which qsort must not be given
        qsort(tags, ntags, sizeof *tags, tag_cmp);
      for (size_t i = 1; i < ntags; ++i)
        if (tags[i].tag == tags[i - 1].tag) {
          tm_error(r->err, r->errlen, "%s:%ld: node tag %ld defined twice", r->path,
                   r->vline[tags[i].idx > tags[i - 1].idx ? tags[i].idx : tags[i - 1].idx],
                   tags[i].tag);
          goto done;
        }
      have_nodes = 1;
    } else if (strcmp(kw, "$Elements") == 0) {
      if (!have_nodes) {
        tm_error(r->err, r->errlen, "%s:%ld: $Elements before $Nodes", r->path, r->lineno);
        goto done;
      }
      if (expect_line(r, "the element count"))
        goto done;
      cur = r->line;
      long nblocks = 1, nelem;
      if (version >= 4 && parse_long(r, &cur, "number of entity blocks", &nblocks))
        goto done;
      if (parse_long(r, &cur, "number of elements", &nelem))
        goto done;
      if (nelem < 0 || nblocks < 0) {
        tm_error(r->err, r->errlen, "%s:%ld: negative count %ld", r->path, r->lineno,
                 nelem < 0 ? nelem : nblocks);
        goto done;
      }
      long seen = 0;
      for (long b = 0; b < nblocks; ++b) {
        long in_block = nelem, type = -1;
        if (version >= 4) {
          long dim, ent;
          if (expect_line(r, "an element block header"))
            goto done;
          cur = r->line;
          if (parse_long(r, &cur, "entity dimension", &dim) ||
              parse_long(r, &cur, "entity tag", &ent) ||
              parse_long(r, &cur, "element type", &type) ||
              parse_long(r, &cur, "elements in block", &in_block))
            goto done;
          if (in_block < 0 || in_block > nelem - seen) {
            tm_error(r->err, r->errlen, "%s:%ld: %ld elements in block: more than the %ld declared",
                     r->path, r->lineno, in_block, nelem);
            goto done;
          }
        }
        for (long i = 0; i < in_block; ++i) {
          long tag, ty = type, ntg = 0, dummy;
          if (expect_line(r, "an element"))
            goto done;
          cur = r->line;
          if (parse_long(r, &cur, "element tag", &tag))
            goto done;
          if (version < 4) {
            if (parse_long(r, &cur, "element type", &ty) ||
                parse_long(r, &cur, "number of tags", &ntg))
              goto done;
            if (ntg < 0 || ntg > 64) {
              tm_error(r->err, r->errlen, "%s:%ld: number of tags %ld out of range [0, 64]",
                       r->path, r->lineno, ntg);
              goto done;
            }
            for (long k = 0; k < ntg; ++k)
              if (parse_long(r, &cur, "element tag value", &dummy))
                goto done;
          }
          if (ty != 2)
            continue; // not a 3-node triangle: skipped
          int32_t q[3];
          for (int c = 0; c < 3; ++c) {
            long nt;
            if (parse_long(r, &cur, "triangle node", &nt))
              goto done;
            tag_pair key = {nt, 0};
            tag_pair *hit = ntags ? bsearch(&key, tags, ntags, sizeof *tags, tag_cmp) : NULL;
            if (!hit) {
              tm_error(r->err, r->errlen, "%s:%ld: node %ld of element %ld is not defined", r->path,
                       r->lineno, nt, tag);
              goto done;
            }
            q[c] = hit->idx;
          }
          if (push_tri(r, q))
            goto done;
        }
        seen += in_block;
      }
      if (seen != nelem) {
        tm_error(r->err, r->errlen, "%s:%ld: %ld elements read, %ld declared", r->path, r->lineno,
                 seen, nelem);
        goto done;
      }
      have_elems = 1;
    }
  }
  if (!have_elems) {
    tm_error(r->err, r->errlen, "%s:%ld: truncated file: no $Elements section", r->path,
             r->lineno + 1);
    goto done;
  }
  if (r->nt == 0) {
    tm_error(r->err, r->errlen, "%s: no 3-node triangles (element type 2)", r->path);
    goto done;
  }
  {
    tm_origin o = {r->path, r->vline, r->tline, 0};
    m = tm_build(r->nv, r->X, r->nt, r->T, &o, r->err, r->errlen);
    r->X = NULL, r->T = NULL;
  }
done:
  free(tags);
  free(node_tags);
  return m;
}

ek_trimesh *ek_trimesh_load(const char *path, char *err, size_t errlen) {
  if (err && errlen)
    err[0] = 0;
  if (!path) {
    tm_error(err, errlen, "ek_trimesh_load: NULL path");
    return NULL;
  }
  size_t n = strlen(path);
  int obj = n > 4 && strcmp(path + n - 4, ".obj") == 0;
  int msh = n > 4 && strcmp(path + n - 4, ".msh") == 0;
  if (!obj && !msh) {
    tm_error(err, errlen, "%s: unknown triangle mesh format (expected .obj or .msh)", path);
    return NULL;
  }
  tm_reader r;
  memset(&r, 0, sizeof r);
  r.path = path;
  r.err = err;
  r.errlen = errlen;
  r.fp = fopen(path, "r");
  if (!r.fp) {
    tm_error(err, errlen, "%s: cannot open: %s", path, strerror(errno));
    return NULL;
  }
  ek_trimesh *m = obj ? read_obj(&r) : read_msh(&r);
  rd_free(&r);
  return m;
}
