// Internal: the cloth element layer (struct ek_cloth, built by
// cloth_layer.c, read by the force driver cloth_force.c).
#ifndef EK_CLOTH_LAYER_H
#define EK_CLOTH_LAYER_H

#include <ek/cloth_force.h>
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
  // Vertex incidence in element order: vertex v's triangle corners are
  // tri_ref[tri_off[v] .. tri_off[v+1]) (3 t + c), its hinge corners
  // hinge_ref[hinge_off[v] ..) (4 h + c).
  size_t *tri_off, *hinge_off;
  int32_t *tri_ref, *hinge_ref;
  // Corner buffers of the force call (AoSoA, 9 / 12 planes per block): a
  // cloth serves one force call at a time.
  float *tri_corner_f32, *hinge_corner_f32;
  double *tri_corner_f64, *hinge_corner_f64;
};

// Below this many triangles a force call runs on the calling thread (as
// EK_FVM_PARALLEL_MIN_TETS for tets: a second thread gains too little).
#define EK_CLOTH_PARALLEL_MIN_TRIS 4096

// Rest frame of one triangle: Dm^-1 (2x2 row-major) of the rest edges in
// the triangle's orthonormal frame (t1 along X1 - X0, t2 in the plane),
// and the area. Returns the area (<= 0 or NaN for a degenerate triangle).
double ek_cloth_rest_frame(const double *X0, const double *X1, const double *X2, double dm_inv[4]);

#endif
