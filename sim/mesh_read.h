// Internal: what the mesh file readers share (sim/mesh_read.c): a line
// reader whose errors name file:line and quote bad bytes escaped, growable
// arrays that take what a file holds (never what its header promises), and
// the Gmsh .msh parser (ASCII v2 and v4), parameterised by the element type
// it keeps: 4-node tetrahedra for sim/mesh_io.c, 3-node triangles for
// sim/mesh_tri.c.
#ifndef EK_SIM_MESH_READ_H
#define EK_SIM_MESH_READ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

// A line reader with a token cursor and line numbers for messages.
typedef struct {
  FILE *fp;
  const char *path;
  char *line;
  size_t cap;
  long lineno;
  char *cur;      // next token in line
  int comments;   // '#' starts a comment (TetGen, OBJ)
  long long size; // bytes in the file if it is a regular file, else -1
  char *err;
  size_t errlen;
  int failed;
} mesh_reader;

// Largest item count a header may declare.
#define MESH_MAX_ITEMS 2000000000L

int mesh_rd_open(mesh_reader *r, const char *path, int comments, char *err, size_t errlen);
void mesh_rd_close(mesh_reader *r);
// Next non-empty line (comments stripped): 0, or -1 at end of file with an
// error naming `what` was expected (or on a read error / NUL byte).
int mesh_rd_line(mesh_reader *r, const char *what);
// The same, but the end of the file is 1 and no error (formats without a
// count or an end marker: OBJ).
int mesh_rd_line_or_eof(mesh_reader *r);
// Next whitespace-separated token of the current line, NULL if none.
char *mesh_rd_token(mesh_reader *r);
// Tokens that must be there; errors name `what`, the line and the value.
int mesh_rd_long(mesh_reader *r, const char *what, long *out);
int mesh_rd_double(mesh_reader *r, const char *what, double *out);
// A token that may be absent at the end of the line (*out = absent then).
int mesh_rd_long_or(mesh_reader *r, const char *what, long absent, long *out);
// The line must hold nothing more than what was read: 0, or -1 with an
// error quoting the first token left and saying what the line holds
// ("unexpected '9' after <what>"). A reader calls it on every line it
// reads whole: a token beyond what the format (and its header's counts)
// puts there is a corrupt line, never silently dropped.
int mesh_rd_end(mesh_reader *r, const char *what);
// A count in [0, max], and one that fits the bytes left in the file.
int mesh_rd_check_count(mesh_reader *r, long n, long max, const char *what);
int mesh_rd_count_fits(mesh_reader *r, long n, const char *what);

// Growable vertex and element arrays with the line each item came from;
// npe nodes per element (set before the first push).
typedef struct {
  int npe;
  double *X;
  long *vline;
  size_t nv, vcap;
  int32_t *T;
  long *tline;
  size_t nt, tcap;
} mesh_arrays;

int mesh_arrays_push_vert(mesh_arrays *a, const double x[3], long line);
int mesh_arrays_push_elem(mesh_arrays *a, const int32_t *v, long line);
void mesh_arrays_free(mesh_arrays *a);

// Reads a whole Gmsh ASCII file (v2 or v4) from r: every node into a
// (a->npe must be set), and the elements of Gmsh type elem_type (4: 4-node
// tetrahedron, 2: 3-node triangle; a->npe nodes each) mapped to vertex
// indices; lines of other element types are checked (as many integer node
// tags as the type has) and skipped, and a type Gmsh does not define is an
// error. 0, or -1 with the error set.
int mesh_read_gmsh(mesh_reader *r, long elem_type, mesh_arrays *a);

#endif
