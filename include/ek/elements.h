// The element layer: tetrahedra packed into the AoSoA blocks every
// mesh-based kernel reads (FVM forces; the implicit, XPBD and cloth loops
// build on the same blocks), built from plain arrays. No files, no
// validation beyond what memory safety needs: sim/ (ek_mesh_load,
// ek_mesh_create) validates meshes and hands the result here.
//
// What a tet set holds (all computed once, from the rest shape):
//   - caller-order rest data: Dm^-1 (Dm = [X1-X0, X2-X0, X3-X0], Teran et
//     al. 2003 sec. 4; seed 004) and the rest volume V0 = det(Dm) / 6;
//   - two element orders, each packed into AoSoA blocks of EK_LANES_F32 (16)
//     or EK_LANES_F64 (8) tets: planes of the 4 vertex indices, the 9
//     entries of Dm^-1 and V0, in float and in double:
//       morton:  Morton order of the tet centroids (consecutive tets share
//                vertices, so gathers and scatters hit the cache);
//       colored: the Morton order cut into chunks; inside a chunk the tets
//                are greedily coloured (tets of one colour share no vertex,
//                each colour padded to a whole f32 block), and the chunks
//                themselves are coloured (chunks of one chunk colour share
//                no vertex). A coloured sweep runs chunk colour by chunk
//                colour, threads splitting its chunks, and inside a chunk
//                colour by colour: it walks each chunk's vertices, which
//                stay in cache, not the whole vertex array once per colour;
//   - vertex-incidence lists over the Morton order (vertex -> its (slot,
//     corner) entries, ascending).
// Every order and colouring depends on the mesh alone, never on the thread
// count, so kernels that sum in these orders give the same bits on any
// number of threads.
// Triangles (ek_cloth, cloth_force.h) are built by the same layer
// (kernels/elements/tris.c beside tets.c), with the same incidence lists,
// greedy colouring and AoSoA packing (kernels/elements/layer.h).
#ifndef EK_ELEMENTS_H
#define EK_ELEMENTS_H

#include <stddef.h>
#include <stdint.h>

#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ek_tets ek_tets;

// X: nverts x 3 rest positions; tets: ntets x 4 vertex indices (0-based),
// every tet with a positive rest volume. Refused (NULL, message in
// ek_last_error) on: a NULL array, ntets == 0, more than 2^31 - 1
// vertices or tet corners, an index out of range, a non-finite coordinate,
// a tet with det(Dm) <= 0 (it names the tet and the value), or no memory.
ek_tets *ek_tets_create(size_t nverts, const double *X, size_t ntets, const int32_t *tets);
void ek_tets_destroy(ek_tets *el);

// Accessors (caller order). Pointers stay valid until ek_tets_destroy.
size_t ek_tets_nverts(const ek_tets *el);
size_t ek_tets_count(const ek_tets *el);
const int32_t *ek_tets_vertices(const ek_tets *el);    // ntets x 4
const double *ek_tets_rest_volumes(const ek_tets *el); // ntets, V0 = det(Dm) / 6 > 0
const double *ek_tets_dm_inv(const ek_tets *el);       // ntets x 9, row-major Dm^-1
// The coloured order: tet colours (the most any chunk needs), chunk
// colours (the parallel phases of a coloured sweep), chunks, and its slot
// count (tets plus padding).
int ek_tets_ncolors(const ek_tets *el);
int ek_tets_nphases(const ek_tets *el);
size_t ek_tets_nchunks(const ek_tets *el);
size_t ek_tets_colored_slots(const ek_tets *el);

// Per-element state a loop keeps between passes, stored with the element
// blocks: `planes` values per tet in the Morton order's AoSoA layout (block
// b, plane k, lane l at [(b * planes + k) * LANES + l], LANES = 16 for f32,
// 8 for f64). Corotated linear's rotation R^n is 9 planes, refreshed once a
// step and read by every force evaluation of the step
// (ek_fvm_opts.R_state); an implicit loop keeps the material eigensystem of
// its gradient pass this way for its Hessian products.
typedef struct ek_tet_state ek_tet_state;

// planes 1..81; f64 0 (float) or 1 (double). NULL, message in
// ek_last_error, on a bad argument or no memory. The state starts as the
// identity (9 planes) or zero (other plane counts) in every slot.
ek_tet_state *ek_tet_state_create(const ek_tets *el, int planes, int f64);
void ek_tet_state_destroy(ek_tet_state *st);
int ek_tet_state_planes(const ek_tet_state *st);
// Caller order <-> state: values is ntets x planes (per tet, row-major),
// rounded to the state's precision on set. Padding slots keep their
// identity / zero. EK_OK or EK_EINVAL (NULL argument).
int ek_tet_state_set_f64(ek_tet_state *st, const double *values);
int ek_tet_state_get_f64(const ek_tet_state *st, double *values);

#ifdef __cplusplus
}
#endif
#endif
