// Internal layout of ek_tets (include/ek/elements.h), read by the kernel
// drivers (kernels/fvm/fvm.c, ...); owned by kernels/elements/tets.c.
//
// Slot orders: a slot is a position in an order, holding a caller tet
// index or -1 (padding). Padding slots have vertex indices -1, Dm^-1 = 0
// and V0 = 0; kernels compute them with F = I and never write through them.
#ifndef EK_KERNELS_ELEMENTS_TETS_H
#define EK_KERNELS_ELEMENTS_TETS_H

#include <ek/batch.h>
#include <ek/elements.h>
#include <ek/fvm.h> // EK_FVM_PARTS
#include <stddef.h>
#include <stdint.h>

// One slot order packed into AoSoA blocks: f32 nslots / 16 blocks, f64
// nslots / 8 blocks.
//   index planes: idx[(b * 4 + c) * LANES + l]   (corner c, lane l)
//   Dm^-1 planes: dm_inv[(b * 9 + k) * LANES + l] (row-major entry k)
//   V0 plane:     v0[b * LANES + l]
typedef struct {
  size_t nslots;     // a multiple of EK_LANES_F32
  int32_t *slot_tet; // nslots: caller tet index or -1
  int32_t *idx_f32, *idx_f64;
  float *dm_inv_f32, *v0_f32;
  double *dm_inv_f64, *v0_f64;
} ek_tet_blocks;

struct ek_tets {
  // Caller order.
  size_t nverts, ntets;
  int32_t *tets;  // ntets x 4
  double *V0;     // ntets
  double *Dm_inv; // ntets x 9
  double *X;      // nverts x 3 rest positions (shape-matching clusters)

  ek_tet_blocks morton;
  // The coloured order (elements.h). Phase p runs chunks [phase_chunk[p],
  // phase_chunk[p+1]); chunk k holds slots [chunk_slot[k], chunk_slot[k+1])
  // and colour groups [chunk_group[k], chunk_group[k+1]); group g holds
  // slots [group_slot[g], group_slot[g+1]). Every bound is a multiple of
  // EK_LANES_F32, so a block of either precision lies in one group.
  ek_tet_blocks colored;
  int ncolors, nphases;
  size_t nchunks, ngroups;
  size_t *phase_chunk, *chunk_slot, *chunk_group, *group_slot;

  // Caller tet -> its slot in the Morton order (ntets).
  int32_t *morton_slot;

  // Vertex incidence over the Morton order: entries vert_entries[
  // vert_start[v] .. vert_start[v+1]) are slot * 4 + corner, ascending.
  int32_t *vert_start, *vert_entries;

  // The THREAD_BUFFERS scatter's parts (kernels/fvm/scatter.c: EK_FVM_PARTS
  // equal shares of the Morton blocks of f32, [0], or f64, [1]): part p's
  // tets touch vertices [part_vlo[.][p], part_vhi[.][p]) only (empty: lo =
  // hi), so its buffer is zeroed and summed over that range alone (about
  // half the vertices per part on a box mesh).
  size_t part_vlo[2][EK_FVM_PARTS], part_vhi[2][EK_FVM_PARTS];
};

// Per-element state (elements.h): nblocks * planes * LANES values of the
// precision, Morton slot order.
struct ek_tet_state {
  const ek_tets *el;
  int planes, f64;
  void *data;
};

#endif
