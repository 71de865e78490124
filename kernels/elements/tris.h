// Internal layout of the triangle element layer (struct ek_cloth,
// include/ek/cloth_force.h), owned by kernels/elements/tris.c beside the
// tets' (tets.c), with the incidence lists, colouring and AoSoA packing of
// layer.h; read by the cloth force driver (kernels/cloth_force/) and the
// cloth XPBD (kernels/xpbd/cloth_xpbd.c).
#ifndef EK_KERNELS_ELEMENTS_TRIS_H
#define EK_KERNELS_ELEMENTS_TRIS_H

#include <ek/cloth_force.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

struct ek_cloth {
  size_t nv, nt, nh;
  double *X;       // nv x 3
  int32_t *tris;   // nt x 3
  double *dm_inv;  // nt x 4
  double *area;    // nt
  int32_t *hinges; // nh x 4
  double *hinge_k; // nh x 4
  double *lumped;  // nv
  // AoSoA blocks per precision (cloth_force_kernel.h), caller order.
  size_t ntb_f32, ntb_f64, nhb_f32, nhb_f64;
  int32_t *tri_idx_f32, *tri_idx_f64, *hinge_idx_f32, *hinge_idx_f64;
  float *dm_f32, *area_f32, *hk_f32;
  double *dm_f64, *area_f64, *hk_f64;
  // Vertex incidence in element order (layer.h): vertex v's triangle
  // corners are tri_ref[tri_off[v] .. tri_off[v+1]) (3 t + c), its hinge
  // corners hinge_ref[hinge_off[v] ..) (4 h + c).
  size_t *tri_off, *hinge_off;
  size_t *tri_ref, *hinge_ref;
  // Corner buffers of the force call (AoSoA, 9 / 12 planes per block): a
  // cloth serves one force call at a time.
  float *tri_corner_f32, *hinge_corner_f32;
  double *tri_corner_f64, *hinge_corner_f64;
  // The energy call's scratch: f64, the hinge energies (nh); f32, the
  // positions in double (3 nv) then the block sums (one per
  // EK_CLOTH_ENERGY_BLOCK_F32 triangles, then hinges); the triangle
  // energies go in tri_corner_*. f64's flag per chunk (of
  // EK_CLOTH_ENERGY_TRIS triangles, then of EK_CLOTH_ENERGY_CHUNK hinges)
  // once its energies are written.
  double *energy_buf;
  atomic_uchar *energy_ready;
};

// Below this many triangles a force call runs on the calling thread (as
// EK_FVM_PARALLEL_MIN_TETS for tets: a second thread gains too little).
#define EK_CLOTH_PARALLEL_MIN_TRIS 4096
#define EK_CLOTH_ENERGY_CHUNK 256
#define EK_CLOTH_ENERGY_TRIS 256
// The f32 energy's partial sums (cloth_force.h): triangles and hinges in
// blocks of this many (a multiple of EK_LANES_F32). Part of that energy's
// definition: changing it changes its bits.
#define EK_CLOTH_ENERGY_BLOCK_F32 256

// The triangle rest frame (include/ek/cloth.h, ek_tri_rest_f64): Dm^-1
// (2x2 row-major) of the rest edges in the triangle's orthonormal frame
// (t1 along E1 = X1 - X0, t2 = N x t1 in the plane), Dm = [[|E1|, E2.t1],
// [0, E2.t2]]. Returns the area (<= 0 or NaN for a degenerate triangle:
// check ek_tri_degenerate first). E2.t2 = |N| / |E1| (N = E1 x E2) in
// exact arithmetic; EK_TRI_REST_VIA_T2 rounds it as e2 . (N x E1) /
// (|N| |E1|), the element layer's form since it was written, kept so that
// ek_cloth_dm_inv (and every cloth scene frame) keeps its bits, while
// ek_tri_rest_f64 keeps its |N| / |E1| (both are hashed by ek-hash).
enum { EK_TRI_REST_DIRECT = 0, EK_TRI_REST_VIA_T2 = 1 };
double ek_tri_rest_frame(const double *X0, const double *X1, const double *X2, int rounding,
                         double dm_inv[4]);

#endif
