// Mesh file reading shared by the tetrahedral (mesh_io.c) and triangle
// (mesh_tri.c) readers: the line reader, the growable arrays and the Gmsh
// parser (sim/mesh_read.h).
//
// Formats: Gmsh reference manual sec. 10.1 ("MSH file format", v4.1) and
// its legacy v2 description; v4.0 differs from v4.1 in the block headers
// only.
//
// Counts in headers are never trusted for memory: arrays grow as items
// arrive (mesh_arrays), and in a regular file a count is checked against
// the bytes left (mesh_rd_count_fits), so a header declaring 2e9 vertices
// is an error at its line, not a 96 GB allocation. Bytes quoted from a file
// are escaped (text_escape.h).
#include "mesh_read.h"

#include <errno.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "mesh_build.h"
#include "text_escape.h"

int mesh_rd_open(mesh_reader *r, const char *path, int comments, char *err, size_t errlen) {
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

void mesh_rd_close(mesh_reader *r) {
  if (r->fp)
    fclose(r->fp);
  free(r->line);
  r->fp = NULL;
  r->line = NULL;
  r->cap = 0;
}

// Next non-empty line (comments stripped): 0, 1 at the end of the file
// when eof_ok, else -1 there with an error naming `what` was expected.
static int next_line(mesh_reader *r, const char *what, int eof_ok) {
  for (;;) {
    errno = 0;
    ssize_t n = getline(&r->line, &r->cap, r->fp);
    if (n < 0 && eof_ok && !ferror(r->fp))
      return 1;
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

int mesh_rd_line(mesh_reader *r, const char *what) { return next_line(r, what, 0); }

int mesh_rd_line_or_eof(mesh_reader *r) { return next_line(r, "a line", 1); }

// Next whitespace-separated token of the current line, NULL if none.
char *mesh_rd_token(mesh_reader *r) {
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
static char *need_token(mesh_reader *r, const char *what) {
  char *tok = mesh_rd_token(r);
  if (!tok) {
    mesh_error(r->err, r->errlen, "%s:%ld: truncated line: missing %s", r->path, r->lineno, what);
    r->failed = 1;
  }
  return tok;
}

static int bad_number(mesh_reader *r, const char *tok, const char *what) {
  char text[128];
  mesh_error(r->err, r->errlen, "%s:%ld: bad number '%s' for %s", r->path, r->lineno,
             text_escape(text, sizeof text, tok, 40, 1), what);
  r->failed = 1;
  return -1;
}

static int parse_long(mesh_reader *r, const char *tok, const char *what, long *out) {
  char *end;
  errno = 0;
  long v = strtol(tok, &end, 10);
  if (*end || errno)
    return bad_number(r, tok, what);
  *out = v;
  return 0;
}

int mesh_rd_long(mesh_reader *r, const char *what, long *out) {
  char *tok = need_token(r, what);
  return tok ? parse_long(r, tok, what, out) : -1;
}

int mesh_rd_long_or(mesh_reader *r, const char *what, long absent, long *out) {
  char *tok = mesh_rd_token(r);
  if (!tok) {
    *out = absent;
    return 0;
  }
  return parse_long(r, tok, what, out);
}

int mesh_rd_end(mesh_reader *r, const char *what) {
  char *tok = mesh_rd_token(r), text[128];
  if (!tok)
    return 0;
  mesh_error(r->err, r->errlen, "%s:%ld: unexpected '%s' after %s", r->path, r->lineno,
             text_escape(text, sizeof text, tok, 40, 1), what);
  r->failed = 1;
  return -1;
}

int mesh_rd_double(mesh_reader *r, const char *what, double *out) {
  char *tok = need_token(r, what), *end;
  if (!tok)
    return -1;
  errno = 0;
  double v = strtod(tok, &end);
  if (*end || (errno && errno != ERANGE))
    return bad_number(r, tok, what);
  // NaN / inf are parsed by strtod; they are reported by mesh_build with
  // this line number.
  *out = v;
  return 0;
}

int mesh_rd_check_count(mesh_reader *r, long n, long max, const char *what) {
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
int mesh_rd_count_fits(mesh_reader *r, long n, const char *what) {
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

void mesh_arrays_free(mesh_arrays *a) {
  free(a->X);
  free(a->vline);
  free(a->T);
  free(a->tline);
  a->X = NULL, a->vline = NULL, a->T = NULL, a->tline = NULL;
}

int mesh_arrays_push_vert(mesh_arrays *a, const double x[3], long line) {
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

int mesh_arrays_push_elem(mesh_arrays *a, const int32_t *v, long line) {
  if (a->nt == a->tcap) {
    size_t cap = next_cap(a->tcap);
    if (resize((void **)&a->T, cap, (size_t)a->npe * sizeof(int32_t)) ||
        resize((void **)&a->tline, cap, sizeof(long)))
      return -1;
    a->tcap = cap;
  }
  memcpy(a->T + a->nt * (size_t)a->npe, v, (size_t)a->npe * sizeof(int32_t));
  a->tline[a->nt++] = line;
  return 0;
}

// ---- Gmsh ------------------------------------------------------------------

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

// The a->npe node tags of element `tag` on the current line (Gmsh v2 and v4
// alike), mapped to vertex indices and appended to a.
static int read_elem_nodes(mesh_reader *r, const tag_index *map, size_t nnodes, long tag,
                           mesh_arrays *a) {
  int32_t t[4];
  for (int c = 0; c < a->npe; c++) {
    long node;
    if (mesh_rd_long(r, "node tag", &node))
      return -1;
    t[c] = find_tag(map, nnodes, node);
    if (t[c] < 0) {
      mesh_error(r->err, r->errlen, "%s:%ld: element %ld: node tag %ld out of range (no such node)",
                 r->path, r->lineno, tag, node);
      return -1;
    }
  }
  char what[96];
  snprintf(what, sizeof what, "element %ld's tag and %d nodes", tag, a->npe);
  if (mesh_rd_end(r, what))
    return -1;
  if (mesh_arrays_push_elem(a, t, r->lineno)) {
    mesh_error(r->err, r->errlen, "%s:%ld: out of memory at element %ld", r->path, r->lineno, tag);
    return -1;
  }
  return 0;
}

// Nodes per element of each Gmsh element type (the elm-type / elementType
// of MSH 2.2 and 4.x): the Gmsh reference manual's list (types 1-31, 92,
// 93: "2-node line", ..., "125-node fourth order hexahedron") and the rest
// of src/common/GmshDefines.h (MSH_LIN_2 = 1 ... MSH_TRIH_4 = 140; the
// count is the name's suffix, 1 for the MSH_*_1 types, and Gmsh's own
// MElement::getInfoMSH for the XFEM sub-elements 133-136). 0: no fixed
// count (34, 35: polygon, polyhedron) or not a type Gmsh reads or writes
// (138, 139: the "mini" elements, and the unassigned 67-70, 76-78).
static const short gmsh_nodes[] = {
    0,                                                       // 0
    2,   3,    4,   4,   8,  6,  5,  3,  6,   9,   10,  27,  // 1-12
    18,  14,   1,   8,   20, 15, 13, 9,  10,  12,  15,  15,  // 13-24
    21,  4,    5,   6,   20, 35, 56, 22, 28,  0,   0,   16,  // 25-36
    25,  36,   12,  16,  20, 28, 36, 45, 55,  66,  49,  64,  // 37-48
    81,  100,  121, 18,  21, 24, 27, 30, 24,  28,  32,  36,  // 49-60
    40,  7,    8,   9,   10, 11, 0,  0,  0,   0,   84,  120, // 61-72
    165, 220,  286, 0,   0,  0,  34, 40, 46,  52,  58,  1,   // 73-84
    1,   1,    1,   1,   1,  40, 75, 64, 125, 216, 343, 512, // 85-96
    729, 1000, 32,  44,  56, 68, 80, 92, 104, 126, 196, 288, // 97-108
    405, 550,  24,  33,  42, 51, 60, 69, 78,  30,  55,  91,  // 109-120
    140, 204,  285, 385, 21, 29, 37, 45, 53,  61,  69,  1,   // 121-132
    1,   2,    3,   4,   16, 0,  0,  4,                      // 133-140
};

// Nodes of Gmsh element type `type`, or 0 (with the error at the current
// line) for a type that has no fixed count or that Gmsh does not define.
static int gmsh_type_nodes(mesh_reader *r, long type, long kept) {
  const long ntypes = (long)(sizeof gmsh_nodes / sizeof gmsh_nodes[0]);
  const int n = type > 0 && type < ntypes ? gmsh_nodes[type] : 0;
  if (n == 0) {
    mesh_error(r->err, r->errlen,
               "%s:%ld: element type %ld: %s (this reader keeps type %ld and skips Gmsh's other "
               "types of a fixed node count)",
               r->path, r->lineno, type,
               type == 34 || type == 35 ? "a polygon or polyhedron, no fixed node count"
                                        : "not a Gmsh element type",
               kept);
    r->failed = 1;
  }
  return n;
}

// The node tags of element `tag` of a type the reader does not keep, n of
// them: checked to be n integers and nothing more, then dropped (a line of
// the wrong length is a corrupt line, as for a kept type).
static int skip_elem_nodes(mesh_reader *r, long tag, long type, int n) {
  int found = 0;
  for (char *tok; (tok = mesh_rd_token(r)) != NULL; found++) {
    long node;
    if (found < n && parse_long(r, tok, "node tag", &node))
      return -1;
  }
  if (found == n)
    return 0;
  mesh_error(r->err, r->errlen,
             "%s:%ld: element %ld has %d node tag%s; its type, %ld, has %d node%s (Gmsh element "
             "types)",
             r->path, r->lineno, tag, found, found == 1 ? "" : "s", type, n, n == 1 ? "" : "s");
  r->failed = 1;
  return -1;
}

// Skip to the line "$name" (sections we do not read are skipped).
static int find_section(mesh_reader *r, const char *name) {
  char what[64];
  snprintf(what, sizeof what, "section %s", name);
  for (;;) {
    if (mesh_rd_line(r, what))
      return -1;
    char *tok = mesh_rd_token(r);
    if (tok && strcmp(tok, name) == 0)
      return mesh_rd_end(r, name);
  }
}

static int expect_end(mesh_reader *r, const char *name) {
  if (mesh_rd_line(r, name))
    return -1;
  char *tok = mesh_rd_token(r), text[128];
  if (!tok || strcmp(tok, name) != 0) {
    mesh_error(r->err, r->errlen, "%s:%ld: expected %s, found '%s'", r->path, r->lineno, name,
               text_escape(text, sizeof text, tok ? tok : "", 40, 1));
    r->failed = 1;
    return -1;
  }
  return mesh_rd_end(r, name);
}

// n lines "tag x y z" (Gmsh v2 and v4.0 nodes): 0, 1 on a parse error
// (reported), 2 out of memory.
static int read_tagged_nodes(mesh_reader *r, long n, tag_map *map, mesh_arrays *a) {
  for (long i = 0; i < n; i++) {
    long tag;
    double x[3];
    if (mesh_rd_line(r, "nodes") || mesh_rd_long(r, "node tag", &tag))
      return 1;
    for (int k = 0; k < 3; k++)
      if (mesh_rd_double(r, "coordinate", &x[k]))
        return 1;
    if (mesh_rd_end(r, "the node's tag and 3 coordinates"))
      return 1;
    if (map_push(map, tag) || mesh_arrays_push_vert(a, x, r->lineno))
      return 2;
  }
  return 0;
}

int mesh_read_gmsh(mesh_reader *r, long elem_type, mesh_arrays *a) {
  const char *path = r->path;
  char *err = r->err;
  size_t errlen = r->errlen;
  tag_map map = {0};
  int rc = -1;

  // $MeshFormat: "version file-type data-size"; file-type 0 = ASCII.
  double version;
  long ftype, dsize;
  if (find_section(r, "$MeshFormat") || mesh_rd_line(r, "the mesh format line") ||
      mesh_rd_double(r, "format version", &version) || mesh_rd_long(r, "file type", &ftype) ||
      mesh_rd_long(r, "data size", &dsize) ||
      mesh_rd_end(r, "the format's version, file type and data size"))
    goto done;
  int v4 = version >= 4.0 && version < 5.0, v41 = version >= 4.05;
  if (!(version >= 2.0 && version < 3.0) && !v4) {
    mesh_error(err, errlen, "%s:%ld: MSH version %g not supported (only 2.x and 4.x ASCII)", path,
               r->lineno, version);
    goto done;
  }
  if (ftype != 0) {
    mesh_error(err, errlen, "%s:%ld: binary MSH (file type %ld) not supported, only ASCII", path,
               r->lineno, ftype);
    goto done;
  }
  if (expect_end(r, "$EndMeshFormat") || find_section(r, "$Nodes"))
    goto done;

  long nnodes = 0;
  int rc_nodes;
  double x[3];
  if (!v4) {
    // v2: "n", then "tag x y z" per node.
    if (mesh_rd_line(r, "node count") || mesh_rd_long(r, "node count", &nnodes) ||
        mesh_rd_end(r, "the node count") ||
        mesh_rd_check_count(r, nnodes, MESH_MAX_ITEMS, "node") ||
        mesh_rd_count_fits(r, nnodes, "node"))
      goto done;
    if ((rc_nodes = read_tagged_nodes(r, nnodes, &map, a)) == 1)
      goto done;
    if (rc_nodes)
      goto oom;
  } else {
    // v4.1: "numBlocks numNodes minTag maxTag"; per block
    // "entityDim entityTag parametric n", n tag lines, n coordinate lines.
    // v4.0: "numBlocks numNodes"; per block "entityTag entityDim
    // parametric n", then n lines "tag x y z".
    long nblocks, tag_lo, tag_hi;
    if (mesh_rd_line(r, "node header") || mesh_rd_long(r, "node block count", &nblocks) ||
        mesh_rd_long(r, "node count", &nnodes) ||
        (v41 && (mesh_rd_long(r, "minimum node tag", &tag_lo) ||
                 mesh_rd_long(r, "maximum node tag", &tag_hi))) ||
        mesh_rd_end(r, v41 ? "the node header's block count, node count and tag range"
                           : "the node header's block count and node count") ||
        mesh_rd_check_count(r, nnodes, MESH_MAX_ITEMS, "node") ||
        mesh_rd_check_count(r, nblocks, MESH_MAX_ITEMS, "node block") ||
        mesh_rd_count_fits(r, nnodes, "node") || mesh_rd_count_fits(r, nblocks, "node block"))
      goto done;
    long filled = 0;
    for (long b = 0; b < nblocks; b++) {
      long e1, e2, param, n;
      if (mesh_rd_line(r, "node block header") || mesh_rd_long(r, "entity", &e1) ||
          mesh_rd_long(r, "entity", &e2) || mesh_rd_long(r, "parametric flag", &param) ||
          mesh_rd_long(r, "block node count", &n) ||
          mesh_rd_end(r, "the node block header's 4 numbers"))
        goto done;
      if (n < 0 || n > nnodes - filled) {
        mesh_error(err, errlen, "%s:%ld: node block of %ld nodes exceeds the %ld declared", path,
                   r->lineno, n, nnodes);
        goto done;
      }
      if (param) {
        mesh_error(err, errlen, "%s:%ld: parametric nodes not supported", path, r->lineno);
        goto done;
      }
      if (v41) {
        for (long i = 0; i < n; i++) {
          long tag;
          if (mesh_rd_line(r, "node tags") || mesh_rd_long(r, "node tag", &tag) ||
              mesh_rd_end(r, "the node tag"))
            goto done;
          if (map_push(&map, tag))
            goto oom;
        }
        for (long i = 0; i < n; i++) {
          if (mesh_rd_line(r, "node coordinates"))
            goto done;
          for (int k = 0; k < 3; k++)
            if (mesh_rd_double(r, "coordinate", &x[k]))
              goto done;
          if (mesh_rd_end(r, "the node's 3 coordinates"))
            goto done;
          if (mesh_arrays_push_vert(a, x, r->lineno))
            goto oom;
        }
      } else {
        if ((rc_nodes = read_tagged_nodes(r, n, &map, a)) == 1)
          goto done;
        if (rc_nodes)
          goto oom;
      }
      filled += n;
    }
    if (filled != nnodes) {
      mesh_error(err, errlen, "%s:%ld: %ld nodes in blocks, %ld declared", path, r->lineno, filled,
                 nnodes);
      goto done;
    }
  }
  if (expect_end(r, "$EndNodes"))
    goto done;
  if (map.n) // no nodes: map.v is NULL, which qsort must not be given
    qsort(map.v, map.n, sizeof *map.v, cmp_tag);
  for (size_t i = 1; i < map.n; i++)
    if (map.v[i].tag == map.v[i - 1].tag) {
      mesh_error(err, errlen, "%s:%ld: node tag %ld appears twice", path, a->vline[map.v[i].index],
                 map.v[i].tag);
      goto done;
    }
  if (find_section(r, "$Elements"))
    goto done;

  // Element node lists: only elem_type is kept; every line must hold as
  // many nodes as its type has (gmsh_nodes), and a type Gmsh does not
  // define is an error, never skipped.
  if (!v4) {
    // v2: "n", then "tag type ntags tags... nodes..." per element.
    long ne;
    if (mesh_rd_line(r, "element count") || mesh_rd_long(r, "element count", &ne) ||
        mesh_rd_end(r, "the element count") ||
        mesh_rd_check_count(r, ne, MESH_MAX_ITEMS, "element") ||
        mesh_rd_count_fits(r, ne, "element"))
      goto done;
    for (long e = 0; e < ne; e++) {
      long tag, type, ntags, dummy;
      if (mesh_rd_line(r, "elements") || mesh_rd_long(r, "element tag", &tag) ||
          mesh_rd_long(r, "element type", &type) || mesh_rd_long(r, "tag count", &ntags))
        goto done;
      const int nodes = gmsh_type_nodes(r, type, elem_type);
      if (!nodes)
        goto done;
      if (ntags < 0 || ntags > 64) {
        mesh_error(err, errlen, "%s:%ld: bad tag count %ld", path, r->lineno, ntags);
        goto done;
      }
      for (long k = 0; k < ntags; k++)
        if (mesh_rd_long(r, "element tag value", &dummy))
          goto done;
      if (type != elem_type ? skip_elem_nodes(r, tag, type, nodes)
                            : read_elem_nodes(r, map.v, map.n, tag, a))
        goto done;
    }
  } else {
    // v4.1: "numBlocks numElements minTag maxTag"; per block "entityDim
    // entityTag type n" (v4.0: "entityTag entityDim type n"), then n lines
    // "tag node...".
    long nblocks, ne, tag_lo, tag_hi;
    if (mesh_rd_line(r, "element header") || mesh_rd_long(r, "element block count", &nblocks) ||
        mesh_rd_long(r, "element count", &ne) ||
        (v41 && (mesh_rd_long(r, "minimum element tag", &tag_lo) ||
                 mesh_rd_long(r, "maximum element tag", &tag_hi))) ||
        mesh_rd_end(r, v41 ? "the element header's block count, element count and tag range"
                           : "the element header's block count and element count") ||
        mesh_rd_check_count(r, ne, MESH_MAX_ITEMS, "element") ||
        mesh_rd_check_count(r, nblocks, MESH_MAX_ITEMS, "element block") ||
        mesh_rd_count_fits(r, ne, "element") || mesh_rd_count_fits(r, nblocks, "element block"))
      goto done;
    // The blocks must add up to the header's count, as the node blocks do
    // (issue 28: blocks of 6 elements under a header of 3 were accepted).
    long filled = 0;
    for (long b = 0; b < nblocks; b++) {
      long e1, e2, type, n;
      if (mesh_rd_line(r, "element block header") || mesh_rd_long(r, "entity", &e1) ||
          mesh_rd_long(r, "entity", &e2) || mesh_rd_long(r, "element type", &type) ||
          mesh_rd_long(r, "block element count", &n) ||
          mesh_rd_end(r, "the element block header's 4 numbers") ||
          mesh_rd_check_count(r, n, ne, "block element"))
        goto done;
      const int nodes = gmsh_type_nodes(r, type, elem_type);
      if (!nodes)
        goto done;
      if (n > ne - filled) {
        mesh_error(err, errlen,
                   "%s:%ld: element block of %ld elements exceeds the %ld declared (%ld in "
                   "earlier blocks)",
                   path, r->lineno, n, ne, filled);
        goto done;
      }
      filled += n;
      for (long i = 0; i < n; i++) {
        long tag;
        if (mesh_rd_line(r, "elements") || mesh_rd_long(r, "element tag", &tag))
          goto done;
        if (type != elem_type ? skip_elem_nodes(r, tag, type, nodes)
                              : read_elem_nodes(r, map.v, map.n, tag, a))
          goto done;
      }
    }
    if (filled != ne) {
      mesh_error(err, errlen, "%s:%ld: %ld elements in blocks, %ld declared", path, r->lineno,
                 filled, ne);
      goto done;
    }
  }
  if (expect_end(r, "$EndElements"))
    goto done;
  rc = 0;
  goto done;
oom:
  mesh_error(err, errlen, "%s:%ld: out of memory at node %zu", path, r->lineno, map.n);
done:
  free(map.v);
  return rc;
}
