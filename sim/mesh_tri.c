// Triangle meshes for cloth (include/ek/sim/trimesh.h): validation, the OBJ and
// Gmsh 2D readers and the grid generator. Readers collect everything first,
// grow their arrays as data arrives (a header's count is checked against
// the data, never trusted to size memory), then hand the arrays to one
// builder, so a mesh never half-loads and every error names file:line.
#include <ek/cloth.h>
#include <ek/sim/trimesh.h>

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "errbuf.h"
#include "mesh_build.h"
#include "mesh_read.h"
#include "text_escape.h"

struct ek_trimesh {
  size_t nv, nt;
  size_t dropped, first_dropped; // vertices no triangle used (dropped), the first
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

size_t sim_trimesh_dropped(const ek_trimesh *m, size_t *first) {
  if (m->dropped)
    *first = m->first_dropped;
  return m->dropped;
}
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

// An edge shared by more than two triangles (a non-manifold edge: a
// bending hinge joins exactly two, cloth_force.h): 1 with the edge and the
// first three triangles on it, 0 if there is none, EK_ENOMEM.
typedef struct {
  int32_t a, b;
  size_t t;
} tm_edge;

static int tm_edge_cmp(const void *x, const void *y) {
  const tm_edge *p = x, *q = y;
  if (p->a != q->a)
    return p->a < q->a ? -1 : 1;
  if (p->b != q->b)
    return p->b < q->b ? -1 : 1;
  return p->t < q->t ? -1 : p->t > q->t;
}

static int find_nonmanifold_edge(const int32_t *T, size_t nt, int32_t edge[2], size_t tris[3]) {
  tm_edge *e = malloc((nt > 0 ? 3 * nt : 1) * sizeof *e);
  if (!e)
    return EK_ENOMEM;
  for (size_t t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c) {
      int32_t u = T[3 * t + c], v = T[3 * t + (c + 1) % 3];
      e[3 * t + c] = (tm_edge){u < v ? u : v, u < v ? v : u, t};
    }
  qsort(e, 3 * nt, sizeof *e, tm_edge_cmp);
  int found = 0;
  for (size_t i = 0; !found && i + 2 < 3 * nt; ++i)
    if (e[i].a == e[i + 2].a && e[i].b == e[i + 2].b) {
      edge[0] = e[i].a, edge[1] = e[i].b;
      for (int k = 0; k < 3; ++k)
        tris[k] = e[i + k].t;
      found = 1;
    }
  free(e);
  return found;
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
    // The degeneracy test is the element layer's (ek_tri_degenerate, the
    // one ek_cloth_create applies), called here to name the line. The
    // message and the range check below use the same scaled units: the
    // edges times 2^-e (largest component in [0.5, 1), exact), so they
    // hold at any scale (issue 28: a triangle of size 1e200 was
    // "degenerate: twice the rest area inf <= inf").
    const double *a = X + 3 * (size_t)q[0], *b = X + 3 * (size_t)q[1], *c = X + 3 * (size_t)q[2];
    double e1[3], e2[3], e3[3], n[3], emax = 0;
    for (int k = 0; k < 3; ++k) {
      e1[k] = b[k] - a[k], e2[k] = c[k] - a[k], e3[k] = c[k] - b[k];
      emax = fmax(emax, fmax(fabs(e1[k]), fmax(fabs(e2[k]), fabs(e3[k]))));
    }
    if (!isfinite(emax)) {
      long bs = o ? o->base : 0;
      tm_error(err, errlen,
               "%s: triangle %zu (%ld %ld %ld): an edge vector overflows (beyond the range of a "
               "double; supported: see trimesh.h)",
               at, t, q[0] + bs, q[1] + bs, q[2] + bs);
      goto fail;
    }
    int e = 0;
    frexp(emax, &e);
    for (int k = 0; k < 3; ++k)
      e1[k] = ldexp(e1[k], -e), e2[k] = ldexp(e2[k], -e), e3[k] = ldexp(e3[k], -e);
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double area = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    double l2 = fmax(fmax(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2],
                          e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]),
                     e3[0] * e3[0] + e3[1] * e3[1] + e3[2] * e3[2]);
    char a2[48], lt[48];
    mesh_fmt_scaled(a2, sizeof a2, 2 * area, 2 * e);
    mesh_fmt_scaled(lt, sizeof lt, l2, 2 * e);
    if (ek_tri_degenerate(a, b, c, NULL, NULL)) {
      long bs = o ? o->base : 0;
      char rl[48];
      mesh_fmt_scaled(rl, sizeof rl, EK_TRI_DEGENERATE_REL * l2, 2 * e);
      tm_error(err, errlen,
               "%s: triangle %zu (%ld %ld %ld): twice the rest area %s <= %s (longest "
               "edge^2 %s): degenerate (zero-area) triangle",
               at, t, q[0] + bs, q[1] + bs, q[2] + bs, a2, rl, lt);
      goto fail;
    }
    // The supported range: what the element layer computes in the mesh's
    // units (ek_cloth_create: |n|^2 = (2A)^2 for the area, n x e1 and
    // e2 . (n x e1) for the rest frame, of size up to longest edge^2 x 2A)
    // must be a finite, normal double (trimesh.h). A triangle of size 1e100
    // would otherwise load with an infinite area.
    const double a2sq = ldexp(4 * area * area, 4 * e), a2l2 = ldexp(2 * area * l2, 4 * e);
    if (!isfinite(a2sq) || a2sq < DBL_MIN || !isfinite(a2l2)) {
      long bs = o ? o->base : 0;
      tm_error(err, errlen,
               "%s: triangle %zu (%ld %ld %ld): twice the rest area %s (longest edge^2 %s) is "
               "outside the supported range: (2A)^2 and 2A x longest edge^2 must be finite, "
               "normal doubles (2A from about 1.5e-154 to 1.3e154, edges from about 1e-77 to "
               "1e77 for a well-shaped triangle): rescale the mesh",
               at, t, q[0] + bs, q[1] + bs, q[2] + bs, a2, lt);
      goto fail;
    }
  }
  {
    // The same triangle twice (in any vertex order) doubles its membrane
    // and makes its edges look non-manifold (issue 28: an OBJ listing a
    // face twice loaded).
    size_t first = 0, second = 0;
    int dup = mesh_find_duplicate(T, nt, 3, &first, &second);
    if (dup < 0)
      goto oom;
    if (dup) {
      char at1[1100];
      where(at, sizeof at, o, o ? o->tline : NULL, second, "triangle");
      where(at1, sizeof at1, o, o ? o->tline : NULL, first, "triangle");
      const int32_t *q = T + 3 * second;
      long b = o ? o->base : 0;
      tm_error(err, errlen,
               "%s: duplicate element: triangle (%ld %ld %ld), the same vertices as %s", at,
               q[0] + b, q[1] + b, q[2] + b, at1);
      goto fail;
    }
  }
  {
    // An edge of three or more triangles would get no bending hinge at all
    // (a hinge joins two): refused, not silently left without bending.
    int32_t edge[2];
    size_t tris[3];
    int nm = find_nonmanifold_edge(T, nt, edge, tris);
    if (nm < 0)
      goto oom;
    if (nm) {
      char at1[1100], at2[1100];
      where(at, sizeof at, o, o ? o->tline : NULL, tris[2], "triangle");
      where(at1, sizeof at1, o, o ? o->tline : NULL, tris[0], "triangle");
      where(at2, sizeof at2, o, o ? o->tline : NULL, tris[1], "triangle");
      long b = o ? o->base : 0;
      tm_error(err, errlen,
               "%s: non-manifold edge (%ld %ld): a third triangle on the edge of %s and %s; a "
               "cloth's edges may join at most two triangles (its bending hinges, cloth_force.h)",
               at, edge[0] + b, edge[1] + b, at1, at2);
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
  size_t first_dropped = 0;
  for (size_t i = nv; i-- > 0;)
    if (map[i] < 0)
      first_dropped = i;
  free(map);
  ek_trimesh *m = calloc(1, sizeof *m);
  if (!m)
    goto oom;
  m->dropped = nv - used;
  m->first_dropped = first_dropped;
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

ek_trimesh *ek_trimesh_create_errbuf(size_t nverts, const double *X, size_t ntris,
                                     const int32_t *tris, char *err, size_t errlen) {
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

ek_trimesh *ek_trimesh_grid_errbuf(int nx, int ny, double lx, double ly, const char *plane,
                                   char *err, size_t errlen) {
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
// The line reader, the growable arrays and the Gmsh parser are the
// tetrahedral readers' (mesh_read.h).

static int push_failed(mesh_reader *r) {
  mesh_error(r->err, r->errlen, "%s:%ld: out of memory", r->path, r->lineno);
  return -1;
}

// Builds from the arrays, which give up X and T to tm_build.
static ek_trimesh *build_from(mesh_reader *r, mesh_arrays *a, long base) {
  tm_origin o = {r->path, a->vline, a->tline, base};
  ek_trimesh *m = tm_build(a->nv, a->X, a->nt, a->T, &o, r->err, r->errlen);
  a->X = NULL, a->T = NULL;
  return m;
}

// After a vertex's x y z: nothing, w (the spec's optional weight, for
// rational curves; a polygon's vertex ignores it) or r g b (vertex colours,
// the extension MeshLab and others write), numbers all, read and dropped;
// anything else is refused. 0, or -1 with the error set.
static int obj_vertex_rest(mesh_reader *r) {
  static const char *const read[] = {"x y z", "x y z w", "x y z and 2 more numbers", "x y z r g b"};
  int n = 0;
  for (char *tok; (tok = mesh_rd_token(r)); n++) {
    char *end, text[128];
    errno = 0;
    (void)strtod(tok, &end);
    if (n == 3 || *end || (errno && errno != ERANGE)) {
      mesh_error(r->err, r->errlen,
                 "%s:%ld: unexpected '%s' after the vertex's %s (a v line holds x y z, x y z w "
                 "or x y z r g b)",
                 r->path, r->lineno, text_escape(text, sizeof text, tok, 40, 1), read[n]);
      return -1;
    }
  }
  if (n == 2) {
    mesh_error(r->err, r->errlen,
               "%s:%ld: 5 numbers on a v line (a v line holds x y z, x y z w or x y z r g b)",
               r->path, r->lineno);
    return -1;
  }
  return 0;
}

static ek_trimesh *read_obj(mesh_reader *r, mesh_arrays *a) {
  int rc;
  while ((rc = mesh_rd_line_or_eof(r)) == 0) {
    char *kw = mesh_rd_token(r);
    if (strcmp(kw, "v") == 0) {
      double p[3];
      if (mesh_rd_double(r, "x", &p[0]) || mesh_rd_double(r, "y", &p[1]) ||
          mesh_rd_double(r, "z", &p[2]) || obj_vertex_rest(r))
        return NULL;
      if (mesh_arrays_push_vert(a, p, r->lineno)) {
        push_failed(r);
        return NULL;
      }
    } else if (strcmp(kw, "f") == 0) {
      int32_t first = -1, prev = -1;
      int k = 0;
      for (char *tok; (tok = mesh_rd_token(r)); ++k) {
        // "i", "i/t", "i//n", "i/t/n": the vertex index is before the first '/'.
        char *end, text[128];
        errno = 0;
        long i = strtol(tok, &end, 10);
        if (end == tok || (*end && *end != '/') || errno) {
          mesh_error(r->err, r->errlen, "%s:%ld: bad vertex index '%s' in face", r->path, r->lineno,
                     text_escape(text, sizeof text, tok, 40, 1));
          return NULL;
        }
        // 1-based; negative relative to the vertices defined so far.
        long v = i > 0 ? i - 1 : (long)a->nv + i;
        if (i == 0 || v < 0 || v >= (long)a->nv) {
          mesh_error(r->err, r->errlen,
                     "%s:%ld: vertex index %ld out of range (%zu vertices defined so far; "
                     "indices are 1..%zu or -1..-%zu)",
                     r->path, r->lineno, i, a->nv, a->nv, a->nv);
          return NULL;
        }
        if (k == 0)
          first = (int32_t)v;
        else if (k >= 2) {
          // Fan triangulation from the first vertex.
          int32_t q[3] = {first, prev, (int32_t)v};
          if (mesh_arrays_push_elem(a, q, r->lineno)) {
            push_failed(r);
            return NULL;
          }
        }
        prev = (int32_t)v;
      }
      if (k < 3) {
        mesh_error(r->err, r->errlen, "%s:%ld: face with %d vertices: need at least 3", r->path,
                   r->lineno, k);
        return NULL;
      }
    }
    // Every other statement is ignored (trimesh.h).
  }
  return rc < 0 ? NULL : build_from(r, a, 1);
}

static ek_trimesh *read_msh(mesh_reader *r, mesh_arrays *a) {
  if (mesh_read_gmsh(r, 2, a)) // type 2: the 3-node triangle
    return NULL;
  if (a->nt == 0) {
    mesh_error(r->err, r->errlen, "%s: no 3-node triangles (element type 2)", r->path);
    return NULL;
  }
  return build_from(r, a, 0);
}

ek_trimesh *ek_trimesh_load_errbuf(const char *path, char *err, size_t errlen) {
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
  mesh_reader r;
  if (mesh_rd_open(&r, path, obj, err, errlen)) // '#' starts an OBJ comment
    return NULL;
  mesh_arrays a = {.npe = 3};
  ek_trimesh *m = obj ? read_obj(&r, &a) : read_msh(&r, &a);
  mesh_rd_close(&r);
  mesh_arrays_free(&a);
  return m;
}
