// ek simulation library (libek_sim, ek::sim). Triangle meshes for cloth: creation, validation,
// loading (Wavefront OBJ, Gmsh 2D triangles) and a generated grid; each holds the cloth element
// layer the force kernels read (cloth_force.h).
//
// Order: vertices and triangles keep the file's order (OBJ: as defined;
// Gmsh: by node tag order of appearance), except that vertices no triangle
// uses are dropped (they would carry no mass).
//
// Validation (files, ek_trimesh_create and the grid alike): finite
// coordinates, indices in range, no repeated vertex in a triangle, and no
// degenerate rest triangle (2 area <= EK_CLOTH_DEGENERATE_REL (longest
// edge)^2, tested in scaled units: the same at any scale), no triangle twice
// (the same three vertices in any order: "duplicate element", both places
// named), and the supported range: what the element layer computes, (2A)^2
// and 2A x (longest edge)^2, must be finite, normal doubles (2A from about
// 1.5e-154 to 1.3e154: edges from about 1e-77 to 1e77 for a well-shaped
// triangle; a triangle of size 1e100 is a valid shape whose squared area no
// double holds). Errors name the file and line (or the triangle index for
// in-memory meshes) and the offending value; a mesh never half-loads.
//
// Formats:
//   OBJ (Wavefront, "Object Files", Appendix B1 of the Advanced Visualizer
//   manual): "v x y z [w]" vertices (or "v x y z r g b", the vertex
//   colours other tools write; w and r g b are dropped, anything else after
//   x y z is refused naming the line and the token), "f i j k ..." faces;
//   an index is "i", "i/t", "i//n" or "i/t/n", 1-based, or negative,
//   relative to the last vertex defined so far (-1 is the latest). Faces with more than 3
//   vertices are triangulated as a fan from their first vertex (exact for
//   convex polygons; a fan triangle of a non-convex polygon that comes out
//   degenerate is refused like any other). Other statements (vt, vn, o, g,
//   s, usemtl, mtllib, l, ...) are ignored.
//   Gmsh .msh, ASCII v2 and v4 (reference manual sec. 10.1): 3-node
//   triangles (element type 2) become triangles; other element types are
//   skipped; a line read holds its fields and nothing more. Counts in
//   headers are checked against the data that follows, never used to size
//   memory before the data arrives.
#ifndef EK_SIM_TRIMESH_H
#define EK_SIM_TRIMESH_H

#include <stddef.h>
#include <stdint.h>

#include <ek/cloth_force.h>
#include <ek/core.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ek_trimesh ek_trimesh;

ek_trimesh *ek_trimesh_create(size_t nverts, const double *X, size_t ntris, const int32_t *tris);
// An .obj or a .msh file (by extension).
ek_trimesh *ek_trimesh_load(const char *path);
// A rectangle of nx x ny cells of lx x ly, each cut into two triangles
// along alternating diagonals, in the plane `plane` = "xy" (z = 0) or "xz"
// (y = 0), corner at the origin; (nx+1)(ny+1) vertices, first axis fastest.
ek_trimesh *ek_trimesh_grid(int nx, int ny, double lx, double ly, const char *plane);
void ek_trimesh_destroy(ek_trimesh *m);

size_t ek_trimesh_nverts(const ek_trimesh *m);
size_t ek_trimesh_ntris(const ek_trimesh *m);
const double *ek_trimesh_rest_positions(const ek_trimesh *m); // nverts x 3
const int32_t *ek_trimesh_tris(const ek_trimesh *m);          // ntris x 3, 0-based
const ek_cloth *ek_trimesh_cloth(const ek_trimesh *m);        // the element layer

#ifdef __cplusplus
}
#endif
#endif
