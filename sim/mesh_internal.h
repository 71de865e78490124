// Internal layout of ek_mesh, shared by the mesh code (sim/mesh*.c, owner)
// and the FVM driver / simulation (read-only). Not installed.
//
// Two internal tet orders ("slot" orders), each packed into AoSoA blocks:
//  - colored: tets sorted by colour (greedy colouring: tets of one colour
//    share no vertex), Morton order of the centroids within a colour, every
//    colour padded to a multiple of EK_LANES_F32 (16) slots so that any
//    16-lane (f32) or 8-lane (f64) block holds tets of one colour. Used by
//    EK_SCATTER_COLORED (blocks of one colour run in parallel).
//  - morton: Morton order only, padded at the end. Used by the strategies
//    that need no colouring (thread buffers, gather, atomic): consecutive
//    tets share vertices, so gathers and scatters hit the cache; the
//    colour-major order sweeps the whole vertex array once per colour.
// Padding slots have tet index -1, vertex indices -1, Dm^-1 = 0 and V0 = 0,
// and no kernel ever writes through them.
#ifndef EK_SIM_MESH_INTERNAL_H
#define EK_SIM_MESH_INTERNAL_H

#include <ek/batch.h>
#include <ek/mesh.h>
#include <stddef.h>
#include <stdint.h>

// One slot order packed into AoSoA blocks; f32: nslots / 16 blocks, f64:
// nslots / 8 blocks.
// Index planes: block b, corner c, lane l -> idx[(b * 4 + c) * LANES + l].
// Dm^-1 planes: dm_inv[(b * 9 + k) * LANES + l], k row-major entry.
// V0 plane:     v0[b * LANES + l].
typedef struct {
  size_t nslots;     // multiple of EK_LANES_F32
  int32_t *slot_tet; // nslots: caller tet index or -1
  int32_t *idx_f32, *idx_f64;
  float *dm_inv_f32, *v0_f32;
  double *dm_inv_f64, *v0_f64;
} ek_mesh_blocks;

struct ek_mesh {
  // Caller order.
  size_t nverts, ntets;
  double *X;      // nverts x 3
  int32_t *tets;  // ntets x 4 (orientation fixes applied)
  double *V0;     // ntets
  double *Dm_inv; // ntets x 9, row-major
  double *lumped; // nverts, sum of V0/4
  size_t nfixed;
  double min_edge;

  // Internal orders.
  int ncolors;
  size_t *color_slot_start; // ncolors + 1, into colored, multiples of 16
  ek_mesh_blocks colored;
  ek_mesh_blocks morton;

  // Vertex-centric lists over the morton order: entries
  // vert_entries[vert_start[v] .. vert_start[v+1]) are slot * 4 + corner,
  // ascending (the fixed order in which the gather strategy sums them).
  int32_t *vert_start; // nverts + 1
  int32_t *vert_entries;
};

#endif
