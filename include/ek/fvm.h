// Finite-volume elastic forces on tetrahedral meshes (Teran et al. 2003,
// "Finite volume methods for the simulation of skeletal muscle", sec. 4;
// seed 004). Per tet e with rest edge matrix Dm = [X1-X0, X2-X0, X3-X0]:
//   Ds = [x1-x0, x2-x0, x3-x0],  F = Ds Dm^-1,
//   H = [h1 h2 h3] = -V0 P(F) Dm^-T,
//   f1 += h1, f2 += h2, f3 += h3, f0 += -(h1 + h2 + h3),
// which is f = -dE/dx for E = sum_e V0_e Psi(F_e).
//
// x and f are nverts x 3 in the caller's vertex order; f is overwritten,
// never accumulated. Forces are bitwise identical for any thread count
// with every scatter strategy except EK_SCATTER_ATOMIC.
#ifndef EK_FVM_H
#define EK_FVM_H

#include <stddef.h>

#include "core.h"
#include "elements.h"
#include "material.h"

#ifdef __cplusplus
extern "C" {
#endif

// Error budgets of the force kernels against the double reference:
//   max_i |f_i - f_ref_i| / max_i s_i,
// where s_i = sum over the contributions to component i of their absolute
// values (the cancellation-free size of the sum; forces at rest are 0 and a
// plain relative error would be meaningless there). Inherits the stress
// budget (EK_PK1_TOL_*) and valid where that one is.
#define EK_FVM_TOL_F32 1e-4
#define EK_FVM_TOL_F64 1e-10

// How per-tet forces are summed into vertices.
//   COLORED: the element layer's coloured order (elements.h): Morton chunks
//     coloured so that chunks of one colour share no vertex; threads split
//     each chunk colour's chunks and add straight into f.
//   THREAD_BUFFERS: the blocks are cut into EK_FVM_PARTS fixed parts, each
//     with its own force buffer; threads take parts, then the buffers are
//     summed in part order (fixed parts, so any thread count gives the
//     same bits).
//   GATHER: tet corner forces are written to a scratch array, then each
//     vertex sums its (tet, corner) list in a fixed order.
//   ATOMIC: the baseline: one parallel loop adding with atomics; the
//     summation order depends on the schedule, so the bits may change from
//     run to run (non-deterministic).
//   AUTO: THREAD_BUFFERS, the fastest or within a few percent of the fastest
//     in ek-bench on the 2-core Zen 3 and Zen 4 machines at 1e4..1e6 tets.
typedef enum {
  EK_SCATTER_AUTO = 0,
  EK_SCATTER_COLORED,
  EK_SCATTER_THREAD_BUFFERS,
  EK_SCATTER_GATHER,
  EK_SCATTER_ATOMIC,
  EK_SCATTER_COUNT
} ek_scatter;

// What AUTO means (see above).
#define EK_SCATTER_DEFAULT EK_SCATTER_THREAD_BUFFERS

#define EK_FVM_PARTS 4

// Meshes with fewer tets than these run each force evaluation on the
// calling thread alone: below some 30 us of work, waking a second thread
// saves too little to be sure of a gain on a shared machine (and on a
// loaded one the woken thread may wait for its core). Measured on the
// 2-core Zen 4 machine with libgomp's default wait policy, median of 201 x
// 20 calls, 1 / 2 threads: stable neo-Hookean f32 at 1296 tets 21.0 / 16.4
// us, at 3072 tets 47.5 / 34.7 us, at 6000 tets 91.3 / 60.4 us; fixed
// corotated f64 (SVD) at 384 tets 31.2 / 20.6 us. (With
// OMP_WAIT_POLICY=passive a wake-up cost 60-90 us there.)
#define EK_FVM_PARALLEL_MIN_TETS 4096
#define EK_FVM_PARALLEL_MIN_TETS_SVD 512

// Name of a strategy ("auto", "colored", "thread_buffers", "gather",
// "atomic"); "invalid" for others.
const char *ek_scatter_name(ek_scatter s);

// Seconds spent per phase when ek_fvm_opts.phase_times is set. The phases
// then run as separate passes over the mesh with their results stored in
// between (F; SVD/polar; P; H and scatter), which is slower than the fused
// kernel used otherwise: the split says where time goes, the fused total is
// the kernel's real cost. svd is 0 for models that need none. P is the
// material's own stress evaluation and includes the SVD it needs.
typedef struct {
  double deformation_gradient;
  double svd;
  double pk1;
  double scatter;
} ek_fvm_phase_times;

// Options; zero means default.
//   scatter: strategy (AUTO = THREAD_BUFFERS).
//   isa: EK_ISA_AUTO or a forced target (one the CPU lacks gives EK_EISA).
//   svd_sweeps, svd_exact_rsqrt, svd_refine: as in ek_svd3_opts (used by models that
//     take an SVD: fixed corotated, ARAP, clamped models).
//   R: ntets x 9 row-major rotations in caller tet order; read only for
//     the model that takes a rotation input, corotated linear (required
//     there, seed 000, unless R_state).
//   R_state: the same rotations as per-element state of these elements
//     (elements.h: 9 planes, in the call's precision); when set, the force
//     reads it instead of R (a plane load per block in the Morton order
//     instead of a per-lane gather of caller-order doubles). The per-tet
//     psi output still reads R.
//   polar_state: fixed corotated and ARAP without clamp take R = polar(F)
//     from the warm-started polar (polar.h) seeded with these per-element
//     rotations (a 9-plane state of these elements in the call's precision,
//     elements.h) and write the new rotations back, so the next call starts
//     from them; P = 2 mu (F - R) + lambda (J - 1) J F^-T needs no SVD.
//     Start the state at the SVD polar of the first F (or the identity at
//     rest). Other models and a clamp > 0 ignore it (the SVD as before);
//     with phase_times the call runs fused all the same (the split's
//     passes take the SVD), its time in phase_times->pk1.
//   polar_iterations: iterations of the warm polar, 0 = default
//     (polar.h; 1..EK_POLAR_WARM_MAX_ITERATIONS, else EK_EINVAL).
//   J, sigma_min, psi: optional per-tet outputs (ntets each, caller tet
//     order): det F, the smallest signed singular value of F, and the
//     energy density Psi(F) (per unit rest volume). Computed in double from
//     x by a separate pass (they feed output frames, not the force).
//   phase_times: when non-NULL, run the phases separately and report them.
typedef struct {
  ek_scatter scatter;
  ek_isa isa;
  int svd_sweeps;
  int svd_exact_rsqrt;
  int svd_refine;
  const double *R;
  const ek_tet_state *R_state;
  ek_tet_state *polar_state;
  int polar_iterations;
  double *J;
  double *sigma_min;
  double *psi;
  ek_fvm_phase_times *phase_times;
} ek_fvm_opts;

// f = -dE/dx for E = sum_e V0_e Psi(F_e) on an element layer (elements.h:
// ek_tets_create from plain arrays, or an ek_mesh's, <ek/sim/mesh.h>);
// x, f: nverts x 3. 0 on success, < 0 on error (invalid material, NULL
// pointer, R missing for corotated linear, unavailable ISA); f untouched on
// error. Elements outside the model's domain (neo-Hookean with J <= 0 and
// no clamp) give NaN forces at their vertices, as ek_pk1_* gives NaN stress.
int ek_fvm_tet_forces_ex_f32(const ek_tets *el, const ek_material *mat, const float *x, float *f,
                             const ek_fvm_opts *opts);
int ek_fvm_tet_forces_ex_f64(const ek_tets *el, const ek_material *mat, const double *x, double *f,
                             const ek_fvm_opts *opts);
// E = sum_e V0_e Psi(F_e), summed in a fixed order. R as in ek_fvm_opts
// (ntets x 9, caller order; only corotated linear reads it, NULL
// otherwise). NaN on an invalid argument (message in ek_last_error); +inf
// when an element is outside the model's domain.
double ek_fvm_tet_energy_f64(const ek_tets *el, const ek_material *mat, const double *x,
                             const double *R);
// Per-tet deformation gradients F = Ds Dm^-1 (ntets x 9, row-major, caller
// tet order), e.g. to refresh corotated-linear rotations with ek_polar3_*.
int ek_fvm_tet_deformation_gradients_f64(const ek_tets *el, const double *x, double *F);

#ifdef __cplusplus
}
#endif
#endif
