// ek simulation library (libek_sim, ek::sim). Tetrahedral meshes: creation, validation, loading,
// and the precomputed rest-shape data the FVM force kernel reads (Teran et al. 2003, seed 004).
//
// Vertex and tet order: every array the API takes or returns is in the
// caller's order (the order of the file, of ek_mesh_create's arrays, or of
// ek_mesh_box). The element layer reorders tets internally (elements.h:
// Morton order of the centroids, a colouring inside Morton chunks) for
// locality and vectorisation; that order never leaks out.
//
// Validation (the same for files, ek_mesh_create and the box generator):
//   - coordinates must be finite;
//   - vertex indices in range, at least 4 distinct vertices used;
//   - a tet with a repeated vertex, or with 6V <= EK_MESH_DEGENERATE_REL *
//     (longest edge)^3, is degenerate and refused;
//   - no tet twice: two tets with the same four vertices, in any order, are
//     refused as a "duplicate element", both places named;
//   - the supported range: every tet's 6V = det(Dm) must be a finite,
//     normal double, [DBL_MIN, DBL_MAX] ~ [2.2e-308, 1.8e308] (edges from
//     about 1e-102 to 1e102 for a well-shaped tet; a cube of edge 1e120 is
//     a valid shape whose volume, 1e360, no double holds), no edge vector
//     may overflow (coordinates 1e308 and -1e308 in one tet), and every
//     lumped volume must be finite; anything else is refused with the tet,
//     its 6V and "outside the supported range", never loaded with an
//     infinite or NaN volume. The shape tests (degenerate, inverted) are
//     computed in scaled units and do not depend on the mesh's units;
//   - a tet with negative volume (det Dm < 0) is inverted and refused unless
//     fix_orientation is set, in which case its vertices 1 and 2 are swapped
//     (the swap is visible through ek_mesh_tets and counted by
//     ek_mesh_nfixed).
// Errors name the file, the line (or the element index for in-memory
// meshes) and the offending value; a mesh never half-loads: on error the
// functions return NULL and leave the message in ek_last_error (core.h).
// Files: counts in headers are checked against the
// bytes that follow and memory grows only as items arrive; a directory, a
// NUL byte or a read error is reported as such; bytes quoted from a file
// are escaped (\xNN) in messages.
#ifndef EK_SIM_MESH_H
#define EK_SIM_MESH_H

#include <stddef.h>
#include <stdint.h>

#include <ek/core.h>
#include <ek/elements.h>
#include <ek/fvm.h>
#include <ek/material.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ek_mesh ek_mesh;

// Degeneracy threshold: a tet is degenerate when
// 6 |V| <= EK_MESH_DEGENERATE_REL * (longest edge)^3.
#define EK_MESH_DEGENERATE_REL 1e-12

// Accuracy of the precomputed rest data (asserted by tests/test_mesh.c):
//   |Dm Dm^-1 - I|_max <= EK_MESH_TOL * |Dm|_max |Dm^-1|_max (a bound
//   scaled by the condition of Dm, as any inverse's is), and
//   |V0 - det(Dm)/6| <= EK_MESH_TOL * |V0|.
#define EK_MESH_TOL 1e-13

// Options of the loaders and of ek_mesh_create_ex; zero means default.
//   fix_orientation: 0 (default) refuses inverted rest tets; 1 swaps their
//   vertices 1 and 2 so that every rest volume is positive.
typedef struct {
  int fix_orientation;
} ek_mesh_opts;

// X: nverts x 3 rest positions; tets: ntets x 4 vertex indices (0-based).
ek_mesh *ek_mesh_create(size_t nverts, const double *X, size_t ntets, const int32_t *tets);
ek_mesh *ek_mesh_create_ex(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                           const ek_mesh_opts *opts);

// path: a TetGen base name ("bar" -> bar.node + bar.ele), either of the
// .node/.ele files, or a Gmsh .msh file (ASCII v2 or v4; only tetrahedra,
// element type 4, become elements, other element types are skipped).
// TetGen indices are 0- or 1-based as the .node file's first index says.
// Lines are read whole: a TetGen line holds exactly what its header
// declares (a point: index, x y z, the attributes and the boundary marker
// the .node header counts; a tet: index, 4 or 10 nodes, the attributes the
// .ele header counts; attributes and markers are checked as numbers and
// dropped); a Gmsh line it reads (headers, nodes, elements of type 4,
// section marks) holds its fields and nothing more. Any other token is
// refused naming FILE:LINE and the token.
ek_mesh *ek_mesh_load(const char *path);
ek_mesh *ek_mesh_load_ex(const char *path, const ek_mesh_opts *opts);

// A box [0,lx] x [0,ly] x [0,lz] of nx*ny*nz cubes, each split into 6 tets
// around its main diagonal (Kuhn / Freudenthal split, so faces of
// neighbouring cubes match). (nx+1)(ny+1)(nz+1) vertices, x fastest;
// 6 nx ny nz tets, all positive. nx, ny, nz >= 1, lengths > 0 and finite.
ek_mesh *ek_mesh_box(int nx, int ny, int nz, double lx, double ly, double lz);

void ek_mesh_destroy(ek_mesh *m);

// The mesh's element layer (elements.h): the orders and blocks the kernels
// read. Owned by the mesh.
const ek_tets *ek_mesh_elements(const ek_mesh *m);

// Accessors (caller order). Pointers stay valid until ek_mesh_destroy.
size_t ek_mesh_nverts(const ek_mesh *m);
size_t ek_mesh_ntets(const ek_mesh *m);
const double *ek_mesh_rest_positions(const ek_mesh *m); // nverts x 3
const int32_t *ek_mesh_tets(const ek_mesh *m);          // ntets x 4 (after fixes)
const double *ek_mesh_rest_volumes(const ek_mesh *m);   // ntets, V0 = det(Dm) / 6 > 0
const double *ek_mesh_dm_inv(const ek_mesh *m);         // ntets x 9, row-major Dm^-1
// Per vertex: sum of V0/4 over its tets (lumped mass = density * this).
const double *ek_mesh_lumped_volume(const ek_mesh *m);
// Tet colours of the element layer's coloured order (ek_tets_ncolors) and
// tets whose orientation was fixed.
int ek_mesh_ncolors(const ek_mesh *m);
size_t ek_mesh_nfixed(const ek_mesh *m);
// Shortest edge of the rest mesh (for a CFL time-step estimate).
double ek_mesh_min_edge(const ek_mesh *m);

// ---- FVM forces, energy and deformation gradients on a mesh (fvm.h) ----
// The fvm.h element-layer forms (ek_fvm_tet_*) on ek_mesh_elements(m).
// f = -dE/dx for E = sum_e V0_e Psi(F_e); x, f: nverts x 3.
// 0 on success, < 0 on error (invalid material, NULL pointer, R missing for
// corotated linear, unavailable ISA); f untouched on error. Elements outside
// the model's domain (neo-Hookean with J <= 0 and no clamp) give NaN forces
// at their vertices, as ek_pk1_* gives NaN stress.
int ek_mesh_fvm_forces_f32(const ek_mesh *m, const ek_material *mat, const float *x, float *f);
int ek_mesh_fvm_forces_f64(const ek_mesh *m, const ek_material *mat, const double *x, double *f);
int ek_mesh_fvm_forces_ex_f32(const ek_mesh *m, const ek_material *mat, const float *x, float *f,
                              const ek_fvm_opts *opts);
int ek_mesh_fvm_forces_ex_f64(const ek_mesh *m, const ek_material *mat, const double *x, double *f,
                              const ek_fvm_opts *opts);

// E = sum_e V0_e Psi(F_e), summed in a fixed order. R as in ek_fvm_opts
// (ntets x 9, caller order; only corotated linear reads it, NULL
// otherwise). NaN on an invalid argument (message in ek_last_error); +inf
// when an element is outside the model's domain.
double ek_mesh_fvm_energy_f64(const ek_mesh *m, const ek_material *mat, const double *x);
double ek_mesh_fvm_energy_ex_f64(const ek_mesh *m, const ek_material *mat, const double *x,
                                 const double *R);

// Per-tet deformation gradients F = Ds Dm^-1 (ntets x 9, row-major, caller
// tet order), e.g. to refresh corotated-linear rotations with ek_polar3_*.
int ek_mesh_deformation_gradients_f64(const ek_mesh *m, const double *x, double *F);

// ---- Velocity gradient on a mesh (cloth.h) ----
// L = Fdot F^-1, D, W per tet (ntets x 9 each, caller tet order; any may
// be NULL): cloth.h's ek_tet_velocity_gradient_* on ek_mesh_elements(m).
int ek_mesh_velocity_gradient_f64(const ek_mesh *m, const double *x, const double *v, double *L,
                                  double *D, double *W);
int ek_mesh_velocity_gradient_f32(const ek_mesh *m, const float *x, const float *v, float *L,
                                  float *D, float *W);

#ifdef __cplusplus
}
#endif
#endif
