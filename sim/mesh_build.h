// Internal: the one place meshes are validated and built (mesh.c), used by
// the in-memory constructors, the box generator and the file readers, and
// the layout of ek_mesh: what a validated mesh adds to its element layer.
#ifndef EK_SIM_MESH_BUILD_H
#define EK_SIM_MESH_BUILD_H

#include <ek/elements.h>
#include <ek/sim/mesh.h>
#include <stddef.h>
#include <stdint.h>

struct ek_mesh {
  double *X;      // nverts x 3, caller order
  double *lumped; // nverts, sum of V0/4
  size_t nfixed;
  double min_edge;
  ek_tets *el; // caller-order tets (orientation fixes applied), V0, Dm^-1, orders, blocks
};

// Where the arrays came from, so errors can name file and line. vert_line
// and tet_line (nverts / ntets entries) may be NULL; index_base is the
// file's first index (0 or 1) so indices are reported as the file has them.
// vert_file names the file of vert_line when the vertices come from another
// file than the tets (TetGen .node beside .ele); NULL means `file`.
typedef struct {
  const char *file;
  const char *vert_file;
  const long *vert_line;
  const long *tet_line;
  long index_base;
} mesh_origin;

ek_mesh *mesh_build(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                    const ek_mesh_opts *opts, const mesh_origin *origin, char *err, size_t errlen);
// Two of the n elements (nodes = 3 or 4 vertex indices each) with the same
// vertex set, in any order: returns 1 with *first < *second their indices
// (of all such pairs, the one whose second element comes first), 0 if every
// element is distinct, -1 when out of memory. O(n log n).
int mesh_find_duplicate(const int32_t *elems, size_t n, int nodes, size_t *first, size_t *second);
// m * 2^e2 as text (%.6g), also where that value is beyond the range of a
// double (a rest frame measured in scaled units).
void mesh_fmt_scaled(char *buf, size_t len, double m, int e2);
void mesh_error(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

#endif
