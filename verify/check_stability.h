// ek_check's stability verdicts (ek-verify --extremes): plain functions of
// a state (positions, the rest mesh), so tests can hand them made-up states
// and see each verdict fail. Nothing here runs a simulation.
//
// The three verdicts of a stability scene (Irving et al. 2004, "Invertible
// finite elements for robust simulation of large deformation": a body
// crushed to a plane or a point and released must come back; Smith et al.
// 2018, "Stable neo-Hookean flesh simulation": a mesh at rest must stay at
// rest):
//   finite     every coordinate finite and within EK_STAB_BLOWUP_FACTOR
//              body sizes of the rest shape's centre (an explicit loop past
//              its stable step grows geometrically long before it
//              overflows: this catches it early);
//   restoring  crush scenes: no inverted tet and the shape error (below)
//              at most EK_STAB_SHAPE_TOL; rest scenes: the largest vertex
//              displacement at most EK_STAB_REST_TOL_F32 / _F64;
//   volume     |V / V0 - 1| <= EK_SIM_VOLUME_TOL (sim.h, 1%).
#ifndef EK_CHECK_STABILITY_H
#define EK_CHECK_STABILITY_H

#include "test_tolerances.h"
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

// A coordinate farther than this many body sizes (the rest bounding-box
// diagonal) from the rest shape's centre counts as diverged.
#define EK_STAB_BLOWUP_FACTOR 1e3
// Crush scenes: the shape error (ek_stab_shape_error) at the end, relative
// to the body size. The same 1% as the volume (EK_SIM_VOLUME_TOL).
#define EK_STAB_SHAPE_TOL 1e-2
// Rest scenes: max_i |x_i - X_i| / body size after the steps. A force at
// rest is rounding: in f64 about 1e-16 of the stress scale per evaluation,
// in f32 about 6e-8 (float F of float x); the bounds are about 1e6 (f64)
// and 170 (f32) unit roundoffs, so a model whose P(I) is not 0 (a rest
// state that is not an equilibrium, Smith et al. 2018: a strain of 1e-3
// moves the body by 1e-3 of its size) misses them by orders of magnitude.
#define EK_STAB_REST_TOL_F64 1e-10
#define EK_STAB_REST_TOL_F32 1e-5

// 1 if all n values are finite and every point (n / 3 of them) lies within
// EK_STAB_BLOWUP_FACTOR * size of center; 0 otherwise.
int ek_stab_finite(size_t n, const double *x, const double center[3], double size);

// Signed volume of the tets (nt x 4 vertex indices) at positions x: the sum
// of det[x1 - x0, x2 - x0, x3 - x0] / 6.
double ek_stab_volume(size_t nt, const int32_t *tets, const double *x);
// Tets with signed volume <= 0 at x.
size_t ek_stab_inverted(size_t nt, const int32_t *tets, const double *x);
// 1 if |V / V0 - 1| <= tol (and both are finite, V0 > 0).
int ek_stab_volume_recovered(double V, double V0, double tol);

// The shape error of x against the rest positions X (nv points), weights w
// (masses; NULL for 1): the best rigid motion (Kabsch, cloth.h: a rotation,
// never a reflection, so a body that came back mirrored is not restored)
// taking X onto x, then max_i |R (X_i - Xbar) + xbar - x_i| / size. NaN if
// x is not finite or the fit fails.
double ek_stab_shape_error(size_t nv, const double *X, const double *x, const double *w,
                           double size);

// Largest |x_i - X_i| over the nv points, divided by size.
double ek_stab_max_displacement(size_t nv, const double *X, const double *x, double size);

// The rest-scene bound for a precision (32 or 64).
double ek_stab_rest_tol(int precision);

#ifdef __cplusplus
}
#endif
#endif
