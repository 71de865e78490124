// Mesh file readers: TetGen .node/.ele and Gmsh .msh (ASCII v2 and v4).
// Every error names the file, the line and the offending value; a reader
// collects everything first and hands it to mesh_build(), so a mesh never
// half-loads.
//
// Formats: TetGen manual 1.5, sec. 5.2.1 (.node) and 5.2.4 (.ele); Gmsh
// reference manual sec. 10.1 ("MSH file format", v4.1) and its legacy v2
// description; v4.0 differs from v4.1 in the block headers only.
//
// Counts in headers are never trusted for memory: arrays grow as items
// arrive (mesh_arrays), and in a regular file a count is checked against
// the bytes left (rd_count_fits), so a header declaring 2e9 vertices is an
// error at its line, not a 96 GB allocation. Bytes quoted from a file are
// escaped (text_escape.h).
//
// Adding a format: a load_<format>() built from the reader (rd_*) and
// mesh_arrays that ends in mesh_build(), and a branch in ek_mesh_load_ex.
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "mesh_build.h"
#include "text_escape.h"

// A line reader with a token cursor and line numbers for messages.
typedef struct {
  FILE *fp;
  const char *path;
  char *line;
  size_t cap;
  long lineno;
  char *cur;      // next token in line
  int comments;   // '#' starts a comment (TetGen)
  long long size; // bytes in the file if it is a regular file, else -1
  char *err;
  size_t errlen;
  int failed;
} reader;

static int rd_open(reader *r, const char *path, int comments, char *err, size_t errlen) {
  memset(r, 0, sizeof *r);
  r->path = path;
  r->comments = comments;
  r->err = err;
  r->errlen = errlen;
  r->fp = fopen(path, "r");
  if (!r->fp) {
    mesh_error(err, errlen, "%s: cannot open: %s", path, strerror(errno));
    return -1;
  }
  // fopen succeeds on a directory; reading it then fails (EISDIR), which
  // would read as a truncated file.
  struct stat st;
  r->size = -1;
  if (fstat(fileno(r->fp), &st) == 0) {
    if (S_ISDIR(st.st_mode)) {
      mesh_error(err, errlen, "%s: is a directory, not a mesh file", path);
      fclose(r->fp);
      r->fp = NULL;
      return -1;
    }
    if (S_ISREG(st.st_mode))
      r->size = (long long)st.st_size;
  }
  return 0;
}

static void rd_close(reader *r) {
  if (r->fp)
    fclose(r->fp);
  free(r->line);
  r->fp = NULL;
  r->line = NULL;
  r->cap = 0;
}

// Next non-empty line (comments stripped). 0 on success, -1 at EOF with
// an error naming `what` was expected.
static int rd_line(reader *r, const char *what) {
  for (;;) {
    errno = 0;
    ssize_t n = getline(&r->line, &r->cap, r->fp);
    if (n < 0) {
      // Reported at the line that is missing (one past the last read).
      if (ferror(r->fp))
        mesh_error(r->err, r->errlen, "%s:%ld: read error while reading %s: %s", r->path,
                   r->lineno + 1, what, strerror(errno));
      else
        mesh_error(r->err, r->errlen, "%s:%ld: truncated file: end of file while reading %s",
                   r->path, r->lineno + 1, what);
      r->failed = 1;
      return -1;
    }
    r->lineno++;
    if (strlen(r->line) != (size_t)n) {
      mesh_error(r->err, r->errlen, "%s:%ld: NUL byte at column %zu: not a text mesh file", r->path,
                 r->lineno, strlen(r->line) + 1);
      r->failed = 1;
      return -1;
    }
    if (r->comments) {
      char *h = strchr(r->line, '#');
      if (h)
        *h = 0;
    }
    char *p = r->line;
    while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')
      p++;
    if (*p) {
      r->cur = p;
      return 0;
    }
  }
}

// Next whitespace-separated token of the current line, NULL if none.
static char *rd_token(reader *r) {
  char *p = r->cur;
  while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')
    p++;
  if (!*p)
    return NULL;
  char *start = p;
  while (*p && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\n')
    p++;
  if (*p)
    *p++ = 0;
  r->cur = p;
  return start;
}

// The next token of the line, or NULL (error recorded) if the line ended.
static char *rd_need_token(reader *r, const char *what) {
  char *tok = rd_token(r);
  if (!tok) {
    mesh_error(r->err, r->errlen, "%s:%ld: truncated line: missing %s", r->path, r->lineno, what);
    r->failed = 1;
  }
  return tok;
}

static int rd_bad_number(reader *r, const char *tok, const char *what) {
  char text[128];
  mesh_error(r->err, r->errlen, "%s:%ld: bad number '%s' for %s", r->path, r->lineno,
             text_escape(text, sizeof text, tok, 40, 1), what);
  r->failed = 1;
  return -1;
}

static int rd_long(reader *r, const char *what, long *out) {
  char *tok = rd_need_token(r, what), *end;
  if (!tok)
    return -1;
  errno = 0;
  long v = strtol(tok, &end, 10);
  if (*end || errno)
    return rd_bad_number(r, tok, what);
  *out = v;
  return 0;
}

static int rd_double(reader *r, const char *what, double *out) {
  char *tok = rd_need_token(r, what), *end;
  if (!tok)
    return -1;
  errno = 0;
  double v = strtod(tok, &end);
  if (*end || (errno && errno != ERANGE))
    return rd_bad_number(r, tok, what);
  // NaN / inf are parsed by strtod; they are reported by mesh_build with
  // this line number.
  *out = v;
  return 0;
}

static int check_count(reader *r, long n, long max, const char *what) {
  if (n < 0 || n > max) {
    mesh_error(r->err, r->errlen, "%s:%ld: bad %s count %ld", r->path, r->lineno, what, n);
    r->failed = 1;
    return -1;
  }
  return 0;
}

// A count against the bytes left in a regular file: every item takes at
// least one line, and a line at least 2 bytes (a character and a newline),
// so a larger count cannot be right whatever the format. Checked before
// anything is read, so a header that lies by orders of magnitude (2e9
// vertices in a few bytes) is reported at its own line; a merely truncated
// file reads on to its end and is reported there, with the count read.
static int rd_count_fits(reader *r, long n, const char *what) {
  if (r->size < 0 || n <= 0)
    return 0;
  long long at = (long long)ftello(r->fp), left = r->size - (at > 0 ? at : 0);
  if ((long long)n > (left + 1) / 2) {
    mesh_error(r->err, r->errlen,
               "%s:%ld: header declares %ld %ss, but only %lld bytes follow (a line each, 2 "
               "bytes or more): corrupt header or truncated file",
               r->path, r->lineno, n, what, left);
    r->failed = 1;
    return -1;
  }
  return 0;
}

// Growable arrays for the readers: they take what the file holds, never
// what its header promises.
typedef struct {
  double *X;
  long *vline;
  size_t nv, vcap;
  int32_t *T;
  long *tline;
  size_t nt, tcap;
} mesh_arrays;

// *p resized to cap elements of elem bytes (cap * elem checked).
static int resize(void **p, size_t cap, size_t elem) {
  if (cap > SIZE_MAX / elem)
    return -1;
  void *q = realloc(*p, cap * elem);
  if (!q)
    return -1;
  *p = q;
  return 0;
}

static size_t next_cap(size_t cap) { return cap ? cap * 2 : 1024; }

static void arrays_free(mesh_arrays *a) {
  free(a->X);
  free(a->vline);
  free(a->T);
  free(a->tline);
}

static int arrays_push_vert(mesh_arrays *a, const double x[3], long line) {
  if (a->nv == a->vcap) {
    size_t cap = next_cap(a->vcap);
    if (resize((void **)&a->X, cap, 3 * sizeof(double)) ||
        resize((void **)&a->vline, cap, sizeof(long)))
      return -1;
    a->vcap = cap;
  }
  memcpy(a->X + a->nv * 3, x, 3 * sizeof(double));
  a->vline[a->nv++] = line;
  return 0;
}

static int arrays_push_tet(mesh_arrays *a, const int32_t v[4], long line) {
  if (a->nt == a->tcap) {
    size_t cap = next_cap(a->tcap);
    if (resize((void **)&a->T, cap, 4 * sizeof(int32_t)) ||
        resize((void **)&a->tline, cap, sizeof(long)))
      return -1;
    a->tcap = cap;
  }
  memcpy(a->T + a->nt * 4, v, 4 * sizeof(int32_t));
  a->tline[a->nt++] = line;
  return 0;
}

static int ends_with(const char *s, const char *suffix) {
  size_t n = strlen(s), k = strlen(suffix);
  return n >= k && strcmp(s + n - k, suffix) == 0;
}

// ---- TetGen ---------------------------------------------------------------

#define MAX_ITEMS 2000000000L

static ek_mesh *load_tetgen(const char *base, const ek_mesh_opts *opts, char *err, size_t errlen) {
  size_t blen = strlen(base);
  char *node_path = malloc(blen + 6), *ele_path = malloc(blen + 6);
  mesh_arrays a = {0};
  reader r = {0};
  ek_mesh *m = NULL;
  long base_index = 0;
  if (!node_path || !ele_path) {
    mesh_error(err, errlen, "%s: out of memory", base);
    goto done;
  }
  snprintf(node_path, blen + 6, "%s.node", base);
  snprintf(ele_path, blen + 6, "%s.ele", base);

  // .node: "<#points> <dim> <#attributes> <#markers>", then
  // "<index> x y z [attributes] [marker]" per point.
  if (rd_open(&r, node_path, 1, err, errlen))
    goto done;
  long np, dim;
  if (rd_line(&r, "the .node header") || rd_long(&r, "number of points", &np) ||
      check_count(&r, np, MAX_ITEMS, "point") || rd_count_fits(&r, np, "point") ||
      rd_long(&r, "dimension", &dim))
    goto done;
  if (dim != 3) {
    mesh_error(err, errlen, "%s:%ld: dimension %ld, expected 3", node_path, r.lineno, dim);
    goto done;
  }
  // Attribute and marker counts (optional) are not needed: the rest of
  // each point line is ignored.
  for (long i = 0; i < np; i++) {
    long idx;
    char what[96];
    snprintf(what, sizeof what, "points (%ld of %ld read)", i, np);
    if (rd_line(&r, what) || rd_long(&r, "point index", &idx))
      goto done;
    if (i == 0) {
      if (idx != 0 && idx != 1) {
        mesh_error(err, errlen, "%s:%ld: first point index %ld, expected 0 or 1", node_path,
                   r.lineno, idx);
        goto done;
      }
      base_index = idx;
    } else if (idx != base_index + i) {
      mesh_error(err, errlen, "%s:%ld: point index %ld, expected %ld (consecutive)", node_path,
                 r.lineno, idx, base_index + i);
      goto done;
    }
    double x[3];
    for (int k = 0; k < 3; k++)
      if (rd_double(&r, "coordinate", &x[k]))
        goto done;
    if (arrays_push_vert(&a, x, r.lineno)) {
      mesh_error(err, errlen, "%s:%ld: out of memory at point %ld", node_path, r.lineno, i);
      goto done;
    }
  }
  rd_close(&r);

  // .ele: "<#tets> <nodes per tet (4 or 10)> <#attributes>", then
  // "<index> n1 .. n4 [n5..n10] [attributes]" per tet; the first four
  // nodes are the corners.
  if (rd_open(&r, ele_path, 1, err, errlen))
    goto done;
  long ne, npt;
  if (rd_line(&r, "the .ele header") || rd_long(&r, "number of tetrahedra", &ne) ||
      check_count(&r, ne, MAX_ITEMS / 4, "tetrahedron") || rd_count_fits(&r, ne, "tetrahedron") ||
      rd_long(&r, "nodes per tetrahedron", &npt))
    goto done;
  if (npt != 4 && npt != 10) {
    mesh_error(err, errlen, "%s:%ld: %ld nodes per tetrahedron, expected 4 or 10", ele_path,
               r.lineno, npt);
    goto done;
  }
  for (long e = 0; e < ne; e++) {
    long idx, v[4];
    char what[96];
    snprintf(what, sizeof what, "tetrahedra (%ld of %ld read)", e, ne);
    if (rd_line(&r, what) || rd_long(&r, "tetrahedron index", &idx))
      goto done;
    for (int c = 0; c < 4; c++)
      if (rd_long(&r, "vertex index", &v[c]))
        goto done;
    int32_t t[4];
    for (int c = 0; c < 4; c++) {
      long z = v[c] - base_index;
      if (z < 0 || z >= np) {
        mesh_error(err, errlen, "%s:%ld: tet %ld: vertex index %ld out of range [%ld, %ld]",
                   ele_path, r.lineno, idx, v[c], base_index, base_index + np - 1);
        goto done;
      }
      t[c] = (int32_t)z;
    }
    if (arrays_push_tet(&a, t, r.lineno)) {
      mesh_error(err, errlen, "%s:%ld: out of memory at tetrahedron %ld", ele_path, r.lineno, e);
      goto done;
    }
  }
  rd_close(&r);
  memset(&r, 0, sizeof r);
  {
    // Vertex errors name the .node file, tet errors the .ele file: build
    // with the .ele origin and re-check coordinates here first.
    for (size_t i = 0; i < a.nv; i++)
      for (int k = 0; k < 3; k++)
        if (!isfinite(a.X[i * 3 + k])) {
          mesh_error(err, errlen, "%s:%ld: vertex %ld: coordinate %c = %g is not finite", node_path,
                     a.vline[i], (long)i + base_index, "xyz"[k], a.X[i * 3 + k]);
          goto done;
        }
    mesh_origin o = {.file = ele_path,
                     .vert_file = node_path,
                     .vert_line = a.vline,
                     .tet_line = a.tline,
                     .index_base = base_index};
    m = mesh_build(a.nv, a.X, a.nt, a.T, opts, &o, err, errlen);
  }
done:
  rd_close(&r);
  arrays_free(&a);
  free(node_path);
  free(ele_path);
  return m;
}

// ---- Gmsh -----------------------------------------------------------------

typedef struct {
  long tag;
  int32_t index;
} tag_index;

static int cmp_tag(const void *x, const void *y) {
  long a = ((const tag_index *)x)->tag, b = ((const tag_index *)y)->tag;
  return (a > b) - (a < b);
}

// Node tags in file order, grown as nodes arrive.
typedef struct {
  tag_index *v;
  size_t n, cap;
} tag_map;

static int map_push(tag_map *m, long tag) {
  if (m->n == m->cap) {
    size_t cap = next_cap(m->cap);
    if (resize((void **)&m->v, cap, sizeof *m->v))
      return -1;
    m->cap = cap;
  }
  m->v[m->n] = (tag_index){tag, (int32_t)m->n};
  m->n++;
  return 0;
}

static int32_t find_tag(const tag_index *map, size_t n, long tag) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    size_t mid = (lo + hi) / 2;
    if (map[mid].tag < tag)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < n && map[lo].tag == tag ? map[lo].index : -1;
}

// The 4 node tags of tetrahedron `tag` on the current line (Gmsh v2 and v4
// alike), mapped to vertex indices and appended to a.
static int read_tet_nodes(reader *r, const tag_index *map, size_t nnodes, long tag,
                          mesh_arrays *a) {
  int32_t t[4];
  for (int c = 0; c < 4; c++) {
    long node;
    if (rd_long(r, "node tag", &node))
      return -1;
    t[c] = find_tag(map, nnodes, node);
    if (t[c] < 0) {
      mesh_error(r->err, r->errlen, "%s:%ld: element %ld: node tag %ld out of range (no such node)",
                 r->path, r->lineno, tag, node);
      return -1;
    }
  }
  if (arrays_push_tet(a, t, r->lineno)) {
    mesh_error(r->err, r->errlen, "%s:%ld: out of memory at element %ld", r->path, r->lineno, tag);
    return -1;
  }
  return 0;
}

// Skip to the line "$name" (sections we do not read are skipped).
static int find_section(reader *r, const char *name) {
  char what[64];
  snprintf(what, sizeof what, "section %s", name);
  for (;;) {
    if (rd_line(r, what))
      return -1;
    char *tok = rd_token(r);
    if (tok && strcmp(tok, name) == 0)
      return 0;
  }
}

static int expect_end(reader *r, const char *name) {
  if (rd_line(r, name))
    return -1;
  char *tok = rd_token(r), text[128];
  if (!tok || strcmp(tok, name) != 0) {
    mesh_error(r->err, r->errlen, "%s:%ld: expected %s, found '%s'", r->path, r->lineno, name,
               text_escape(text, sizeof text, tok ? tok : "", 40, 1));
    r->failed = 1;
    return -1;
  }
  return 0;
}

static ek_mesh *load_gmsh(const char *path, const ek_mesh_opts *opts, char *err, size_t errlen) {
  reader r;
  mesh_arrays a = {0};
  tag_map map = {0};
  ek_mesh *m = NULL;
  if (rd_open(&r, path, 0, err, errlen))
    return NULL;

  // $MeshFormat: "version file-type data-size"; file-type 0 = ASCII.
  double version;
  long ftype, dsize;
  if (find_section(&r, "$MeshFormat") || rd_line(&r, "the mesh format line") ||
      rd_double(&r, "format version", &version) || rd_long(&r, "file type", &ftype) ||
      rd_long(&r, "data size", &dsize))
    goto done;
  int v4 = version >= 4.0 && version < 5.0, v41 = version >= 4.05;
  if (!(version >= 2.0 && version < 3.0) && !v4) {
    mesh_error(err, errlen, "%s:%ld: MSH version %g not supported (only 2.x and 4.x ASCII)", path,
               r.lineno, version);
    goto done;
  }
  if (ftype != 0) {
    mesh_error(err, errlen, "%s:%ld: binary MSH (file type %ld) not supported, only ASCII", path,
               r.lineno, ftype);
    goto done;
  }
  if (expect_end(&r, "$EndMeshFormat") || find_section(&r, "$Nodes"))
    goto done;

  long nnodes = 0;
  double x[3];
  if (!v4) {
    // v2: "n", then "tag x y z" per node.
    if (rd_line(&r, "node count") || rd_long(&r, "node count", &nnodes) ||
        check_count(&r, nnodes, MAX_ITEMS, "node") || rd_count_fits(&r, nnodes, "node"))
      goto done;
    for (long i = 0; i < nnodes; i++) {
      long tag;
      if (rd_line(&r, "nodes") || rd_long(&r, "node tag", &tag))
        goto done;
      for (int k = 0; k < 3; k++)
        if (rd_double(&r, "coordinate", &x[k]))
          goto done;
      if (map_push(&map, tag) || arrays_push_vert(&a, x, r.lineno))
        goto oom;
    }
  } else {
    // v4.1: "numBlocks numNodes minTag maxTag"; per block
    // "entityDim entityTag parametric n", n tag lines, n coordinate lines.
    // v4.0: "numBlocks numNodes"; per block "entityTag entityDim
    // parametric n", then n lines "tag x y z".
    long nblocks;
    if (rd_line(&r, "node header") || rd_long(&r, "node block count", &nblocks) ||
        rd_long(&r, "node count", &nnodes) || check_count(&r, nnodes, MAX_ITEMS, "node") ||
        check_count(&r, nblocks, MAX_ITEMS, "node block") || rd_count_fits(&r, nnodes, "node") ||
        rd_count_fits(&r, nblocks, "node block"))
      goto done;
    long filled = 0;
    for (long b = 0; b < nblocks; b++) {
      long e1, e2, param, n;
      if (rd_line(&r, "node block header") || rd_long(&r, "entity", &e1) ||
          rd_long(&r, "entity", &e2) || rd_long(&r, "parametric flag", &param) ||
          rd_long(&r, "block node count", &n))
        goto done;
      if (n < 0 || n > nnodes - filled) {
        mesh_error(err, errlen, "%s:%ld: node block of %ld nodes exceeds the %ld declared", path,
                   r.lineno, n, nnodes);
        goto done;
      }
      if (param) {
        mesh_error(err, errlen, "%s:%ld: parametric nodes not supported", path, r.lineno);
        goto done;
      }
      if (v41) {
        for (long i = 0; i < n; i++) {
          long tag;
          if (rd_line(&r, "node tags") || rd_long(&r, "node tag", &tag))
            goto done;
          if (map_push(&map, tag))
            goto oom;
        }
        for (long i = 0; i < n; i++) {
          if (rd_line(&r, "node coordinates"))
            goto done;
          for (int k = 0; k < 3; k++)
            if (rd_double(&r, "coordinate", &x[k]))
              goto done;
          if (arrays_push_vert(&a, x, r.lineno))
            goto oom;
        }
      } else {
        for (long i = 0; i < n; i++) {
          long tag;
          if (rd_line(&r, "nodes") || rd_long(&r, "node tag", &tag))
            goto done;
          for (int k = 0; k < 3; k++)
            if (rd_double(&r, "coordinate", &x[k]))
              goto done;
          if (map_push(&map, tag) || arrays_push_vert(&a, x, r.lineno))
            goto oom;
        }
      }
      filled += n;
    }
    if (filled != nnodes) {
      mesh_error(err, errlen, "%s:%ld: %ld nodes in blocks, %ld declared", path, r.lineno, filled,
                 nnodes);
      goto done;
    }
  }
  if (expect_end(&r, "$EndNodes"))
    goto done;
  if (map.n) // no nodes: map.v is NULL, which qsort must not be given
    qsort(map.v, map.n, sizeof *map.v, cmp_tag);
  for (size_t i = 1; i < map.n; i++)
    if (map.v[i].tag == map.v[i - 1].tag) {
      mesh_error(err, errlen, "%s:%ld: node tag %ld appears twice", path, a.vline[map.v[i].index],
                 map.v[i].tag);
      goto done;
    }
  if (find_section(&r, "$Elements"))
    goto done;

  // Element node lists: type 4 is the 4-node tetrahedron; node counts of
  // the other types are needed only to check a line's length, so they are
  // skipped by ignoring the rest of the line.
  if (!v4) {
    // v2: "n", then "tag type ntags tags... nodes..." per element.
    long ne;
    if (rd_line(&r, "element count") || rd_long(&r, "element count", &ne) ||
        check_count(&r, ne, MAX_ITEMS, "element") || rd_count_fits(&r, ne, "element"))
      goto done;
    for (long e = 0; e < ne; e++) {
      long tag, type, ntags, dummy;
      if (rd_line(&r, "elements") || rd_long(&r, "element tag", &tag) ||
          rd_long(&r, "element type", &type) || rd_long(&r, "tag count", &ntags))
        goto done;
      if (type != 4)
        continue;
      if (ntags < 0 || ntags > 64) {
        mesh_error(err, errlen, "%s:%ld: bad tag count %ld", path, r.lineno, ntags);
        goto done;
      }
      for (long k = 0; k < ntags; k++)
        if (rd_long(&r, "element tag value", &dummy))
          goto done;
      if (read_tet_nodes(&r, map.v, map.n, tag, &a))
        goto done;
    }
  } else {
    // v4.1: "numBlocks numElements minTag maxTag"; per block "entityDim
    // entityTag type n" (v4.0: "entityTag entityDim type n"), then n lines
    // "tag node...".
    long nblocks, ne;
    if (rd_line(&r, "element header") || rd_long(&r, "element block count", &nblocks) ||
        rd_long(&r, "element count", &ne) || check_count(&r, ne, MAX_ITEMS, "element") ||
        check_count(&r, nblocks, MAX_ITEMS, "element block") || rd_count_fits(&r, ne, "element") ||
        rd_count_fits(&r, nblocks, "element block"))
      goto done;
    for (long b = 0; b < nblocks; b++) {
      long e1, e2, type, n;
      if (rd_line(&r, "element block header") || rd_long(&r, "entity", &e1) ||
          rd_long(&r, "entity", &e2) || rd_long(&r, "element type", &type) ||
          rd_long(&r, "block element count", &n) || check_count(&r, n, ne, "block element"))
        goto done;
      for (long i = 0; i < n; i++) {
        long tag;
        if (rd_line(&r, "elements") || rd_long(&r, "element tag", &tag))
          goto done;
        if (type != 4)
          continue;
        if (read_tet_nodes(&r, map.v, map.n, tag, &a))
          goto done;
      }
    }
  }
  if (expect_end(&r, "$EndElements"))
    goto done;
  if (a.nt == 0) {
    mesh_error(err, errlen, "%s: no tetrahedra (element type 4) in the file", path);
    goto done;
  }
  {
    mesh_origin o = {.file = path, .vert_line = a.vline, .tet_line = a.tline, .index_base = 0};
    m = mesh_build(a.nv, a.X, a.nt, a.T, opts, &o, err, errlen);
  }
  goto done;
oom:
  mesh_error(err, errlen, "%s:%ld: out of memory at node %zu", path, r.lineno, map.n);
done:
  rd_close(&r);
  free(map.v);
  arrays_free(&a);
  return m;
}

ek_mesh *ek_mesh_load_ex(const char *path, const ek_mesh_opts *opts, char *err, size_t errlen) {
  if (!path) {
    mesh_error(err, errlen, "ek_mesh_load: NULL path");
    return NULL;
  }
  struct stat st;
  if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
    mesh_error(err, errlen,
               "%s: is a directory, not a mesh file (give a .msh file, a TetGen .node or .ele "
               "file, or a TetGen base name)",
               path);
    return NULL;
  }
  if (ends_with(path, ".msh"))
    return load_gmsh(path, opts, err, errlen);
  size_t n = strlen(path);
  char *base = malloc(n + 1);
  if (!base) {
    mesh_error(err, errlen, "%s: out of memory", path);
    return NULL;
  }
  memcpy(base, path, n + 1);
  if (ends_with(base, ".node"))
    base[n - 5] = 0;
  else if (ends_with(base, ".ele"))
    base[n - 4] = 0;
  ek_mesh *m = load_tetgen(base, opts, err, errlen);
  free(base);
  return m;
}

ek_mesh *ek_mesh_load(const char *path, char *err, size_t errlen) {
  return ek_mesh_load_ex(path, NULL, err, errlen);
}
