// Cloth kernels (seed 003): the 3x2 deformation gradient of a triangle in
// 3D, its polar decomposition from the closed-form eigen-decomposition of
// C = F^T F, the best rotation of a point set (Kabsch), and the velocity
// gradient L = Fdot F^-1 (tets) / Fdot F^+ (triangles) with its rate of
// strain D and spin W.
//
// Layouts (AoS, row-major, one item after the other):
//   x, X   n x 9: the 3 corners x0, x1, x2 of each triangle, xyz each;
//   Dm_inv n x 4: the 2x2 inverse of the rest edges in the triangle's own
//          orthonormal 2D rest frame (below), row-major;
//   F, R   n x 6: 3x2 matrices, row-major (F[2 i + j] = F_ij, i the 3D
//          row, j the 2D column);
//   Uc     n x 4: 2x2 symmetric matrices, row-major;
//   L, D, W n x 9: 3x3 matrices, row-major.
// AoSoA forms (`_aosoa_`, layout of batch.h): the same entries as planes,
// nblocks blocks of EK_LANES_F32 (16) / EK_LANES_F64 (8) items: x and v 9
// planes, Dm_inv 4, F and R 6, Uc 4, L, D, W 9 (as ek_svd3_aosoa_* has 9
// planes for A and 3 for S). Tail lanes padded with zeros (ek_aosoa_pack_*)
// are safe: a zero F gives the R and Uc of a rank-0 F below, zero edges a
// zero L.
//
// The rest frame (ek_tri_rest_f64). With E1 = X1 - X0, E2 = X2 - X0 and
// the unit normal N = E1 x E2 / |E1 x E2|, the frame is t1 = E1 / |E1|,
// t2 = N x t1 (right-handed in the triangle's plane, counter-clockwise
// vertex order), and
//   Dm = [[|E1|, E2.t1], [0, E2.t2]]   (upper triangular, det Dm = 2 A > 0),
// so F = [x1 - x0, x2 - x0] Dm^-1 maps the rest frame's axes to the
// deformed triangle: F = [t1 t2] at rest (C = I), and F is the seed's eq. 2
// with both edge matrices taken in the triangle's own plane instead of
// dropping z (seed 003 eq. 13, "only applied for 2D problem").
//
// Threads: chunks of blocks on the library's helper threads (as many as
// omp_get_max_threads(); the calling thread alone inside an OpenMP parallel
// region); every output has the same bits at any thread count. Every
// kernel is built per ISA x precision and dispatched once per call
// (EK_ISA, or opts->isa in the _ex / element forms).
#ifndef EK_CLOTH_H
#define EK_CLOTH_H

#include <stddef.h>

#include "core.h"
#include "elements.h"

#ifdef __cplusplus
extern "C" {
#endif

// A rest triangle is degenerate, and refused, when
//   2 A = |E1 x E2| <= EK_TRI_DEGENERATE_REL * (longest edge)^2
// (the triangle form of mesh.h's EK_MESH_DEGENERATE_REL for tets).
#define EK_TRI_DEGENERATE_REL 1e-12

// The one degeneracy test of a rest triangle (X0, X1, X2: 3 coordinates
// each), used by ek_tri_rest_f64 and ek_cloth_create: 1 when degenerate
// (or an edge vector is not finite), else 0. The test runs on the edges
// scaled by a power of two (exact), so it decides at any scale as the
// formula above does wherever that is in range. two_area and longest2
// (either may be NULL) receive 2 A and the longest edge squared, for a
// message.
int ek_tri_degenerate(const double X0[3], const double X1[3], const double X2[3], double *two_area,
                      double *longest2);

// Error budgets against the double references (reference/cloth/), max over
// the batch; measured by ek-verify and asserted by tests/test_cloth.c:
//   polar32: relative to sigma1 = the largest singular value of F:
//     |F - R Uc|_max, |R^T R - I|_max, |Uc - Uc_ref|_max and the
//     eigenvalues of Uc against dgesvd's singular values; and
//     |R - R_ref|_max <= tol * sigma1 / sigma2 (the polar factor of a 3x2
//     matrix moves by |dF| / sigma2; none is unique at sigma2 = 0);
//   Kabsch: |R^T R - I|_max, |det R - 1|, the objective
//     sum_k w_k |R p_k - q_k|^2 no larger than the reference's by more than
//     tol * sum_k w_k |p_k| |q_k| (p, q centred); and |R - R_ref|_max <=
//     tol * s1 / (s2 + s3) with s the signed singular values of the
//     covariance (the reflection-fixed rotation is unique when s2 + s3 > 0);
//   tri deformation, velocity gradients: |out - out_ref|_max relative to
//     the cancellation-free size of the products (|Ds| |Dm_inv| for F,
//     |Vs| |Ds^-1| (tets) and |Vs| |Ds^+| (triangles) for L, D, W).
#define EK_CLOTH_TOL_F32 2e-5
#define EK_CLOTH_TOL_F64 1e-12

// Options of the _ex and element forms; zero means default.
//   isa: EK_ISA_AUTO or a forced target; one the CPU lacks gives EK_EISA.
typedef struct {
  ek_isa isa;
} ek_cloth_opts;

// ---- Triangle rest data and deformation gradient --------------------------

// X: n x 9 rest corners; Dm_inv: n x 4 (the rest frame above); area: n
// (may be NULL). A triangle with a non-finite coordinate or 2A <=
// EK_TRI_DEGENERATE_REL (longest edge)^2 (a repeated corner, collinear
// corners, zero area) is refused: EK_EINVAL, a message naming the triangle
// index and the value (ek_last_error), and nothing written.
int ek_tri_rest_f64(size_t n, const double *X, double *Dm_inv, double *area);

// F = [x1 - x0, x2 - x0] Dm_inv, n x 6 (3x2 row-major). Any finite x is
// accepted: degenerate and flipped deformed triangles give their F.
int ek_tri_deformation_f64(size_t n, const double *x, const double *Dm_inv, double *F);
int ek_tri_deformation_f32(size_t n, const float *x, const float *Dm_inv, float *F);
int ek_tri_deformation_ex_f32(size_t n, const float *x, const float *Dm_inv, float *F,
                              const ek_cloth_opts *opts);
int ek_tri_deformation_ex_f64(size_t n, const double *x, const double *Dm_inv, double *F,
                              const ek_cloth_opts *opts);
int ek_tri_deformation_aosoa_f32(size_t nblocks, const float *x, const float *Dm_inv, float *F,
                                 const ek_cloth_opts *opts);
int ek_tri_deformation_aosoa_f64(size_t nblocks, const double *x, const double *Dm_inv, double *F,
                                 const ek_cloth_opts *opts);

// ---- Polar decomposition of a 3x2 F ---------------------------------------
//
// F = R Uc (seed 003 eqs. 14-20) from the closed-form eigen-decomposition of
// the 2x2 symmetric C = F^T F = V diag(lambda1, lambda2) V^T:
//   Uc = V diag(sigma1, sigma2) V^T, sigma = sqrt(lambda) (eq. 20),
//   R  = [u1 u2] V^T, u1 = F v1 / |F v1|, u2 = n x u1,
// with n = f1 x f2 / |f1 x f2| the unit normal of the deformed triangle
// (f1, f2 the columns of F; n follows the vertex order). So R has
// orthonormal columns spanning the deformed plane with r1 x r2 = n, and
// det(V) = +1. sigma1 >= sigma2 >= 0 always: sigma2 = |f1 x f2| / sigma1
// (C's determinant is |f1 x f2|^2, taken from the cross product instead of
// lambda1 lambda2, so it is never -0 or negative: the seed's NaN from a -0
// eigenvalue, its slide 15, cannot occur).
// Orientation: a 3D triangle cannot invert; a triangle "flipped" over (its
// normal reversed) is a rotation of it, which R carries (r1 x r2 follows
// the deformed normal) while Uc stays positive semi-definite. Callers that
// need the fold of a triangle against its neighbours compare normals.
// Rank-deficient F (collinear or coincident deformed corners): R stays
// orthonormal and finite.
//   rank 1 (after F is scaled to a largest entry of 1: |f1 x f2|^2 below
//     the precision's smallest normal number, or n so inaccurate that
//     |n x u1|^2 <= |n|^2 / 2): u2 is the unit vector perpendicular to u1
//     made from the coordinate axis least aligned with u1 (e_k x u1
//     normalised, k = argmin |u1_k|); sigma2 = |f1 x f2| / sigma1 as ever;
//   rank 0 (F = 0): R = [[1, 0], [0, 1], [0, 0]], Uc = 0.
// F is scaled by its largest entry first, so 1e+-30 and subnormal inputs
// neither overflow nor underflow in C. A F with a NaN or infinity gives NaN
// in all of its R and Uc entries and nothing else.
// Uc may be NULL in the AoS forms.
int ek_polar32_f32(size_t n, const float *F, float *R, float *Uc);
int ek_polar32_f64(size_t n, const double *F, double *R, double *Uc);
int ek_polar32_ex_f32(size_t n, const float *F, float *R, float *Uc, const ek_cloth_opts *opts);
int ek_polar32_ex_f64(size_t n, const double *F, double *R, double *Uc, const ek_cloth_opts *opts);
int ek_polar32_aosoa_f32(size_t nblocks, const float *F, float *R, float *Uc,
                         const ek_cloth_opts *opts);
int ek_polar32_aosoa_f64(size_t nblocks, const double *F, double *R, double *Uc,
                         const ek_cloth_opts *opts);

// ---- Kabsch: the best rotation of a point set -----------------------------
//
// For each of nsets point sets (set s = points [offsets[s], offsets[s+1])
// of P and Q, n x 3, weights w or NULL for 1), the rotation R (det +1,
// nsets x 9 row-major) minimising sum_k w_k |R (p_k - pbar) - (q_k - qbar)|^2,
// pbar, qbar the weighted centroids (seed 003 eqs. 21-23). R is the
// rotation closest to M = sum_k w_k (q_k - qbar)(p_k - pbar)^T (= H^T of
// eq. 22), from ek's rotation-variant 3x3 SVD M = U diag(s) V^T with
// det U = det V = +1 and s3 < 0 exactly when det M < 0: R = U V^T, which is
// eq. 21's V diag(1, 1, d) U^T with the reflection fix d = det(V U^T) of
// H's SVD built in (a reflected set gives a rotation, never a reflection).
// The centred points of P and of Q are each scaled by their largest entry
// before the products (R does not depend on either scale), so 1e+-30 sets
// neither overflow nor underflow.
// Degenerate sets: coplanar sets have a unique R; collinear sets (and
// s2 + s3 = 0 in general) have a family of minimisers, R is one of them; a
// set whose P or Q points all coincide (up to the rounding of their
// centroid: centred points within 8 eps of its largest coordinate) or with
// fewer than 2 points gives the identity.
// Refused (EK_EINVAL, message naming the set or point and the value,
// nothing written): NULL arrays with nsets > 0, offsets not non-decreasing,
// a weight that is negative or not finite, a set whose weights sum to 0.
int ek_kabsch_f64(size_t nsets, const size_t *offsets, const double *P, const double *Q,
                  const double *w, double *R);
int ek_kabsch_f32(size_t nsets, const size_t *offsets, const float *P, const float *Q,
                  const float *w, float *R);
int ek_kabsch_ex_f32(size_t nsets, const size_t *offsets, const float *P, const float *Q,
                     const float *w, float *R, const ek_cloth_opts *opts);
int ek_kabsch_ex_f64(size_t nsets, const size_t *offsets, const double *P, const double *Q,
                     const double *w, double *R, const ek_cloth_opts *opts);

// ---- Velocity gradient L = D + W ------------------------------------------
//
// Tets: L = Fdot F^-1 with F = Ds Dm^-1, Fdot = [v1-v0, v2-v0, v3-v0] Dm^-1
// = Vs Dm^-1, D = (L + L^T)/2 (rate of strain), W = (L - L^T)/2 (spin)
// (seed 003 eqs. 28-31). Dm cancels: L = Vs Ds^-1, which is how it is
// computed (no rest data enters, and no rounding from Dm^-1). ntets x 9
// each, caller tet order (ek_mesh_velocity_gradient_*, <ek/sim/mesh.h>, on
// an ek_mesh); any of L, D, W may be NULL. x, v: nverts x 3.
// For a rigid motion v = omega x x + c, L = W = [omega]x (the spin matrix,
// W y = omega x y) and D = 0; for a stretch rate v_i = r_i x_i (no sum),
// D = diag(r) = the logarithmic stretch rates lambda_i' / lambda_i of seed
// eqs. 32-36. A tet collapsed in the current state (det Ds = 0) has no
// velocity gradient: NaN in its L, D, W (inverted tets, det Ds < 0, are
// fine).
int ek_tet_velocity_gradient_f32(const ek_tets *el, const float *x, const float *v, float *L,
                                 float *D, float *W, const ek_cloth_opts *opts);
int ek_tet_velocity_gradient_f64(const ek_tets *el, const double *x, const double *v, double *L,
                                 double *D, double *W, const ek_cloth_opts *opts);

// Triangles (x, v: n x 9 corners and their velocities): L = Fdot F^+ with
// F^+ = (F^T F)^-1 F^T the pseudo-inverse of the 3x2 F; Dm cancels again,
// L = Vs Ds^+ (Ds = [x1-x0, x2-x0], Vs = [v1-v0, v2-v0], 3x2). What it
// means for a surface: with n the deformed unit normal and P = I - n n^T
// the projector onto the triangle's plane,
//   L t = dv/ds along every tangent direction t of the deformed triangle
//       (L Ds = Vs: L maps each current edge to its rate of change), and
//   L n = 0 (a surface says nothing about dv across its thickness):
// L is the surface gradient of the velocity, grad_s v = (grad v) P. Its
// in-plane part P L P holds the membrane rate: P D P = the rate of strain
// in the plane, F^T D F = Cdot / 2 (Cdot = d/dt F^T F), whose two non-zero
// eigenvalues are the principal in-plane strain rates (sigma_i' / sigma_i
// of polar32's stretches when the principal axes do not turn). The rows
// along n, n^T L = grad_s (v.n), are the rate at which the plane tilts:
// they enter D and W through the normal-tangential entries only. So a
// rigid motion v = omega x x + c gives L = [omega]x P (not [omega]x: the
// normal-normal row is lost), P D P = 0 and D = -(a n^T + n a^T)/2,
// a = omega x n (zero when omega is along n: a spin in the plane). A
// uniform in-plane stretch rate r along orthonormal tangents t1, t2 gives
// D = r1 t1 t1^T + r2 t2 t2^T, W = 0.
// Rank-deficient Ds (collinear current corners): Ds^+ is the Moore-Penrose
// pseudo-inverse with singular values sigma2 <= 3 eps sigma1 treated as 0
// (eps of the precision), so L stays finite; Ds = 0 gives L = 0.
int ek_tri_velocity_gradient_f32(size_t n, const float *x, const float *v, float *L, float *D,
                                 float *W, const ek_cloth_opts *opts);
int ek_tri_velocity_gradient_f64(size_t n, const double *x, const double *v, double *L, double *D,
                                 double *W, const ek_cloth_opts *opts);
int ek_tri_velocity_gradient_aosoa_f32(size_t nblocks, const float *x, const float *v, float *L,
                                       float *D, float *W, const ek_cloth_opts *opts);
int ek_tri_velocity_gradient_aosoa_f64(size_t nblocks, const double *x, const double *v, double *L,
                                       double *D, double *W, const ek_cloth_opts *opts);

#ifdef __cplusplus
}
#endif
#endif
