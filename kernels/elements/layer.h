// Internal: the element-layer primitives every element kind shares (tets,
// kernels/elements/tets.c; triangles and hinges, tris.c; XPBD's constraint
// blocks and clusters, kernels/xpbd/xpbd.c; the cloth XPBD colouring,
// kernels/xpbd/cloth_xpbd.c): the vertex incidence lists, the greedy
// colouring and the AoSoA packing. Integer and setup work, built once at
// baseline ISA (kernels/CMakeLists.txt, the ek library's own sources).
//
// Each is a plain function of arrays, so an element kind (a tet, a
// triangle, a hinge, a shape-matching cluster) is only a list of vertex
// indices per element: the orders (Morton, coloured) are the caller's.
#ifndef EK_KERNELS_ELEMENTS_LAYER_H
#define EK_KERNELS_ELEMENTS_LAYER_H

#include <stddef.h>
#include <stdint.h>

// Vertex incidence (CSR) of a sequence of vertex indices vert[0 .. n)
// (negative entries are padding and skipped): for each vertex v the
// positions i with vert[i] == v, ascending, in
// entries[start[v] .. start[v+1]); start has nv + 1 entries. Both arrays
// are malloc'ed here (free them). A counting sort: O(n + nv). A caller
// that needs another encoding of an entry (slot * 4 + corner, a plane
// offset) maps the position, which keeps the ascending order.
// 0, or -1 when out of memory (nothing allocated).
int ek_layer_incidence(size_t nv, size_t n, const int32_t *vert, size_t **start, size_t **entries);

// Greedy colouring: elements e = 0 .. n-1, each taking the smallest colour
// no earlier element sharing a vertex with it has (per-vertex bit sets of
// the colours used so far, as many 64-bit words as the worst case needs,
// so any valence is coloured). Element e's vertices are
// vert[e * nc .. e * nc + nc) (estart NULL), or vert[estart[e] ..
// estart[e+1]) (estart non-NULL, nc ignored): an element with no vertex
// gets colour -1. `chunk` > 0: elements [k chunk, (k+1) chunk) are
// coloured as independent graphs (the chunks of tets' coloured order:
// elements of different chunks never conflict here; the caller colours the
// chunks themselves). The colouring depends on the element order only,
// never on threads.
// Returns the number of colours (the largest over chunks), or -1 when out
// of memory.
int ek_layer_color(size_t nv, size_t n, size_t chunk, int nc, const size_t *estart,
                   const int32_t *vert, int32_t *color);

// AoSoA planes of one slot order (slot_elem[s]: the element in slot s, or
// -1 for padding), blocks of L lanes, plane k of block b at
// [(b * planes + k) * L + l]:
//   index planes: vert[e * planes + k] (-1 in padding slots);
//   value planes: val[e * planes + k], rounded to float (f64 == 0) or kept
//   in double (f64 == 1); padding slots get pad[k] (pad NULL: 0).
// nslots must be a multiple of L; out holds nslots * planes values.
void ek_layer_pack_index(size_t nslots, const int32_t *slot_elem, int planes, const int32_t *vert,
                         size_t L, int32_t *out);
void ek_layer_pack_values(size_t nslots, const int32_t *slot_elem, int planes, const double *val,
                          const double *pad, size_t L, int f64, void *out);

#endif
