// Mesh file readers: TetGen .node/.ele and Gmsh .msh (ASCII v2 and v4).
// Every error names the file, the line and the offending value (a token
// beyond what the format and the header's counts put on a line included:
// mesh_rd_end); a reader
// collects everything first and hands it to mesh_build(), so a mesh never
// half-loads. The line reader, the growable arrays and the Gmsh parser are
// shared with the triangle meshes (mesh_read.h: counts in headers are never
// trusted for memory, bytes quoted from a file are escaped).
//
// Formats: TetGen manual 1.5, sec. 5.2.1 (.node) and 5.2.4 (.ele); Gmsh in
// mesh_read.c.
//
// Adding a format: a load_<format>() built from the reader (mesh_rd_*) and
// mesh_arrays that ends in mesh_build(), and a branch in ek_mesh_load_ex.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "errbuf.h"
#include "mesh_build.h"
#include "mesh_read.h"

static int ends_with(const char *s, const char *suffix) {
  size_t n = strlen(s), k = strlen(suffix);
  return n >= k && strcmp(s + n - k, suffix) == 0;
}

// ---- TetGen ---------------------------------------------------------------

static ek_mesh *load_tetgen(const char *base, const ek_mesh_opts *opts, char *err, size_t errlen) {
  size_t blen = strlen(base);
  char *node_path = malloc(blen + 6), *ele_path = malloc(blen + 6);
  mesh_arrays a = {.npe = 4};
  mesh_reader r = {0};
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
  if (mesh_rd_open(&r, node_path, 1, err, errlen))
    goto done;
  long np, dim, nattr, nmark;
  if (mesh_rd_line(&r, "the .node header") || mesh_rd_long(&r, "number of points", &np) ||
      mesh_rd_check_count(&r, np, MESH_MAX_ITEMS, "point") || mesh_rd_count_fits(&r, np, "point") ||
      mesh_rd_long(&r, "dimension", &dim) ||
      mesh_rd_long_or(&r, "number of attributes", 0, &nattr) ||
      mesh_rd_long_or(&r, "number of boundary markers", 0, &nmark) ||
      mesh_rd_end(&r, "the header's point count, dimension, attribute count and marker count"))
    goto done;
  if (dim != 3) {
    mesh_error(err, errlen, "%s:%ld: dimension %ld, expected 3", node_path, r.lineno, dim);
    goto done;
  }
  // Attributes are read and dropped, one token each: a count beyond the
  // line's tokens is a truncated line, whatever its size.
  if (nattr < 0 || nattr > MESH_MAX_ITEMS || (nmark != 0 && nmark != 1)) {
    mesh_error(err, errlen,
               "%s:%ld: %ld attributes and %ld boundary markers per point, expected >= 0 and 0 "
               "or 1",
               node_path, r.lineno, nattr, nmark);
    goto done;
  }
  // A point line holds its index, x y z, then exactly the attributes and
  // the marker the header declares (read and checked as numbers, not kept);
  // anything beyond them is refused.
  char point_what[160];
  snprintf(point_what, sizeof point_what,
           "the point's index, 3 coordinates, %ld attribute%s and %ld boundary marker%s (as the "
           "header declares)",
           nattr, nattr == 1 ? "" : "s", nmark, nmark == 1 ? "" : "s");
  for (long i = 0; i < np; i++) {
    long idx;
    char what[96];
    snprintf(what, sizeof what, "points (%ld of %ld read)", i, np);
    if (mesh_rd_line(&r, what) || mesh_rd_long(&r, "point index", &idx))
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
    double x[3], attr;
    long mark;
    for (int k = 0; k < 3; k++)
      if (mesh_rd_double(&r, "coordinate", &x[k]))
        goto done;
    for (long k = 0; k < nattr; k++)
      if (mesh_rd_double(&r, "attribute", &attr))
        goto done;
    if ((nmark && mesh_rd_long(&r, "boundary marker", &mark)) || mesh_rd_end(&r, point_what))
      goto done;
    if (mesh_arrays_push_vert(&a, x, r.lineno)) {
      mesh_error(err, errlen, "%s:%ld: out of memory at point %ld", node_path, r.lineno, i);
      goto done;
    }
  }
  mesh_rd_close(&r);

  // .ele: "<#tets> <nodes per tet (4 or 10)> <#attributes>", then
  // "<index> n1 .. n4 [n5..n10] [attributes]" per tet; the first four
  // nodes are the corners.
  if (mesh_rd_open(&r, ele_path, 1, err, errlen))
    goto done;
  long ne, npt, eattr;
  if (mesh_rd_line(&r, "the .ele header") || mesh_rd_long(&r, "number of tetrahedra", &ne) ||
      mesh_rd_check_count(&r, ne, MESH_MAX_ITEMS / 4, "tetrahedron") ||
      mesh_rd_count_fits(&r, ne, "tetrahedron") ||
      mesh_rd_long(&r, "nodes per tetrahedron", &npt) ||
      mesh_rd_long_or(&r, "number of attributes", 0, &eattr) ||
      mesh_rd_end(&r, "the header's tetrahedron count, nodes per tetrahedron and attribute count"))
    goto done;
  if (npt != 4 && npt != 10) {
    mesh_error(err, errlen, "%s:%ld: %ld nodes per tetrahedron, expected 4 or 10", ele_path,
               r.lineno, npt);
    goto done;
  }
  if (eattr < 0 || eattr > MESH_MAX_ITEMS) {
    mesh_error(err, errlen, "%s:%ld: %ld attributes per tetrahedron, expected >= 0", ele_path,
               r.lineno, eattr);
    goto done;
  }
  // A tet line: its index, npt nodes (the first four the corners, every one
  // a vertex of the .node file), then exactly the attributes the header
  // declares; anything beyond them is refused.
  char tet_what[160];
  snprintf(tet_what, sizeof tet_what,
           "the tetrahedron's index, %ld nodes and %ld attribute%s (as the header declares)", npt,
           eattr, eattr == 1 ? "" : "s");
  for (long e = 0; e < ne; e++) {
    long idx, v[10];
    double attr;
    char what[96];
    snprintf(what, sizeof what, "tetrahedra (%ld of %ld read)", e, ne);
    if (mesh_rd_line(&r, what) || mesh_rd_long(&r, "tetrahedron index", &idx))
      goto done;
    for (int c = 0; c < npt; c++)
      if (mesh_rd_long(&r, "vertex index", &v[c]))
        goto done;
    for (long k = 0; k < eattr; k++)
      if (mesh_rd_double(&r, "attribute", &attr))
        goto done;
    if (mesh_rd_end(&r, tet_what))
      goto done;
    int32_t t[4];
    for (int c = 0; c < npt; c++) {
      long z = v[c] - base_index;
      if (z < 0 || z >= np) {
        mesh_error(err, errlen, "%s:%ld: tet %ld: vertex index %ld out of range [%ld, %ld]",
                   ele_path, r.lineno, idx, v[c], base_index, base_index + np - 1);
        goto done;
      }
      if (c < 4)
        t[c] = (int32_t)z;
    }
    if (mesh_arrays_push_elem(&a, t, r.lineno)) {
      mesh_error(err, errlen, "%s:%ld: out of memory at tetrahedron %ld", ele_path, r.lineno, e);
      goto done;
    }
  }
  mesh_rd_close(&r);
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
  mesh_rd_close(&r);
  mesh_arrays_free(&a);
  free(node_path);
  free(ele_path);
  return m;
}

// ---- Gmsh -----------------------------------------------------------------

static ek_mesh *load_gmsh(const char *path, const ek_mesh_opts *opts, char *err, size_t errlen) {
  mesh_reader r;
  mesh_arrays a = {.npe = 4};
  ek_mesh *m = NULL;
  if (mesh_rd_open(&r, path, 0, err, errlen))
    return NULL;
  if (mesh_read_gmsh(&r, 4, &a) == 0) { // type 4: the 4-node tetrahedron
    if (a.nt == 0) {
      mesh_error(err, errlen, "%s: no tetrahedra (element type 4) in the file", path);
    } else {
      mesh_origin o = {.file = path, .vert_line = a.vline, .tet_line = a.tline, .index_base = 0};
      m = mesh_build(a.nv, a.X, a.nt, a.T, opts, &o, err, errlen);
    }
  }
  mesh_rd_close(&r);
  mesh_arrays_free(&a);
  return m;
}

// Whether BASE.node exists (BASE a TetGen base name).
static int tetgen_node_exists(const char *base) {
  size_t n = strlen(base);
  char *node = malloc(n + 6);
  if (!node)
    return 1; // let load_tetgen report it
  snprintf(node, n + 6, "%s.node", base);
  struct stat st;
  int found = stat(node, &st) == 0;
  free(node);
  return found;
}

ek_mesh *ek_mesh_load_ex_errbuf(const char *path, const ek_mesh_opts *opts, char *err,
                                size_t errlen) {
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
  else if (stat(path, &st) == 0 && !tetgen_node_exists(path)) {
    // An existing file of another format (x.vtk) read as a TetGen base
    // name was reported as "x.vtk.node: cannot open", a file never named.
    mesh_error(err, errlen,
               "%s: not a mesh format ek reads (give a .msh file, a TetGen .node or .ele "
               "file, or a TetGen base name)",
               path);
    free(base);
    return NULL;
  }
  ek_mesh *m = load_tetgen(base, opts, err, errlen);
  free(base);
  return m;
}

ek_mesh *ek_mesh_load_errbuf(const char *path, char *err, size_t errlen) {
  return ek_mesh_load_ex_errbuf(path, NULL, err, errlen);
}
