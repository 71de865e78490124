// Scalar double-precision reference of the XPBD constraint solver of
// include/ek/xpbd.h (the Hookean constraint of seed 001 on tets and
// shape-matching clusters; Macklin, Mueller, Chentanez 2016): plain AoS
// arrays, constraint data recomputed from the rest mesh itself (so it can
// catch errors in the library's precompute), StVK written out in F, one
// constraint at a time, no colouring, no blocks. Depends on libc and libm
// only.
#ifndef EK_XPBD_REF_H
#define EK_XPBD_REF_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

// Lame parameters, Young's modulus E (StVK's constraint's scale) and the
// constraint: snh 0 seed 001's Hookean (StVK) one, 1 the stable
// neo-Hookean pair of Macklin & Mueller 2021 (include/ek/xpbd.h; E unused).
typedef struct {
  double mu, lambda, young;
  int snh;
} ek_xpbd_ref_material;

// A set of "linear-F elements": constraint j has K_j = start[j+1] -
// start[j] members members[start[j] ..] (member 0 first) and vectors
// b_1..b_{K-1} at b + 3 (start[j] - j) (3 each), with
//   F_j = sum_{k>=1} (x_k - x_0) b_k^T,
// and the volume V[j] (alpha_j = 1 / (V_j E)).
typedef struct {
  size_t n, nverts;
  int32_t *start;   // n + 1
  int32_t *members; // start[n]
  double *b;        // 3 (start[n] - n)
  double *V;        // n
} ek_xpbd_ref_set;

// Q of a cluster counts as singular when det Q <= this times (tr Q / 3)^3
// (its smallest eigenvalue some 1e-10 of the others: coplanar members).
#define EK_XPBD_REF_Q_SINGULAR 1e-10

// Tets: members the 4 corners, b_k row k of Dm^-1 (Dm = [X1-X0, X2-X0,
// X3-X0]; F = Ds Dm^-1, Teran et al. 2003 sec. 4), V = det(Dm) / 6.
// 0, or -1 (nothing allocated) on no memory or a singular Dm.
int ek_xpbd_ref_tets(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                     ek_xpbd_ref_set *s);
// Clusters (shape matching, seed 001; Mueller et al. 2005): one per vertex
// j, members j and the vertices sharing a tet with it (ascending), masses
// mass (nverts). 0, or -1 (nothing allocated) on no memory or a singular
// Q (*bad_vertex, may be NULL, receives the vertex).
int ek_xpbd_ref_clusters(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                         const double *mass, ek_xpbd_ref_set *s, size_t *bad_vertex);
void ek_xpbd_ref_free(ek_xpbd_ref_set *s);

// F of one element (K members, b_1..b_{K-1}) at positions x (nverts x 3).
void ek_xpbd_ref_F(int K, const int32_t *members, const double *b, const double *x, double F[9]);
// StVK W(F) = mu e:e + lambda/2 tr(e)^2, e = (F^T F - I)/2, and
// P = F S, S = 2 mu e + lambda tr(e) I (P may be NULL).
double ek_xpbd_ref_stvk(const ek_xpbd_ref_material *m, const double F[9], double P[9]);
// C = sqrt(2 W(F) / E) of one element; when C > cmin (and grad != NULL)
// grad (K x 3) receives grad_k C = P b_k / (E C), grad_0 = -sum, else it is
// left untouched.
double ek_xpbd_ref_eval(const ek_xpbd_ref_material *m, int K, const int32_t *members,
                        const double *b, const double *x, double cmin, double *grad);

// Stable neo-Hookean pair of one element (m->snh; xpbd.h):
//   C_D = sqrt(I_C - log(1 + I_C)), C_H = det F - a, a = 1 + 3 mu / (4 lambda),
// C_D returned, C_H in *ch. gD, gH (K x 3, may be NULL) receive grad_k C_D
// = I_C / ((1 + I_C) C_D) F b_k and grad_k C_H = cof F b_k (member 0's
// -sum); gD is 0 where C_D <= cmin (F ~ 0: 0/0).
double ek_xpbd_ref_snh_eval(const ek_xpbd_ref_material *m, int K, const int32_t *members,
                            const double *b, const double *x, double cmin, double *gD, double *gH,
                            double *ch);
// The pair's energy density C_D^2 mu / 2 + C_H^2 lambda / 2 at F (equals
// ek's stable neo-Hookean psi + 3 mu / 2).
double ek_xpbd_ref_snh_energy(const ek_xpbd_ref_material *m, const double F[9]);
// The coupled 2x2 solve of one element (Macklin & Mueller 2021; xpbd.h):
// A_XY = sum_k wk_k gX_k . gY_k, kD = V mu h^2, kH = V lambda h^2,
//   [kD A_DD + 1, kD A_DH; kH A_DH, kH A_HH + 1] dl = -[kD C_D + lD; kH C_H + lH].
void ek_xpbd_ref_snh_solve(double add, double adh, double ahh, double kD, double kH, double cd,
                           double ch, double lD, double lH, double dl[2]);

// One Gauss-Seidel sweep: constraints order[0 .. norder-1] (NULL: 0 ..
// n-1) projected one at a time (Macklin 2016 eqs. 17, 18), x and lambda
// updated in place; w: inverse masses (nverts, 0 = pinned); h the substep.
// m->snh: lambda holds 2 n multipliers (lambda_D of constraint j at 2 j,
// lambda_H at 2 j + 1), here and in the Jacobi sweep and the residual.
void ek_xpbd_ref_gauss_seidel(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m,
                              const double *w, double h, double cmin, size_t norder,
                              const int32_t *order, double *x, double *lambda);
// One Jacobi sweep: every constraint from the same x, vertex i's weight
// counted n_i times in the denominators (n_i the constraints containing
// i), the corrections summed per vertex in constraint order, then added.
void ek_xpbd_ref_jacobi(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m, const double *w,
                        double h, double cmin, double *x, double *lambda);
// max_j |C_j(x) + alpha~_j lambda_j| over the constraints with C_j > cmin
// (0 if none); *cmax (may be NULL) receives max_j C_j over all of them.
double ek_xpbd_ref_residual(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m, double h,
                            double cmin, const double *x, const double *lambda, double *cmax);

#ifdef __cplusplus
}
#endif
#endif
