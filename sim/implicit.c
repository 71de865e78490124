// The implicit integrator: backward Euler as the minimisation of the
// incremental potential (Martin et al. 2011, "Example-based elastic
// materials"; Gast et al. 2015, "Optimization integrator for large time
// steps"), solved by Newton's method with a backtracking line search,
// each Newton system by matrix-free preconditioned conjugate gradients on
// the projected element Hessians, as in Kim & Eberle's HOBAK (Newton +
// PCG on clamped Hessians). The gradient, the Hessian products and the
// diagonal blocks are the body's (body.h; tets: include/ek/hessian.h,
// triangles: cloth_force.h). ek_scene_implicit (sim.h) states the
// objective, the residual and the knobs.
//
// One step:
//   1. free vertices start at x_n + dt v_n + dt^2 g (x_n if an element is
//      outside the model's domain there); pinned and prescribed vertices
//      sit at their position at t_{n+1} throughout. With an assembled
//      solver ("amg", "direct") the start is x_n + dt v_n + dt^2 a_n
//      instead, a_n = (v_n - v_{n-1}) / dt the last step's acceleration
//      (g on the first step and after ek_sim_set_state): the same
//      backward Euler step to the same newton_tol from a nearer start.
//      Measured (bracket with "amg", busy 2-core Zen 5, 1 thread): 7.87 ->
//      5.43 Newton iterations per step over its 30 steps (6.40 -> 4.90 over
//      10), every step to newton_tol, no backtracks. The matrix-free path
//      keeps g (its trajectories keep their bits);
//   2. Newton: grad Phi and the element eigensystems in one pass; stop if
//      the residual is at most newton_tol after at least one iteration
//      (below: the stopping rule); else solve
//        (M (1 + c dt) / dt^2 + K) dx = -grad Phi
//      over the free vertices by PCG (K: projected to PSD, so the system
//      is SPD), then halve alpha from 1 until the Armijo condition
//      Phi(x + alpha dx) <= Phi(x) + 1e-4 alpha grad.dx holds. A trial
//      point with an element outside the model's domain has Phi = +inf and
//      is never accepted. Near convergence Phi's change falls below its
//      rounding; a trial whose Phi is within that rounding of Phi(x) is
//      accepted when the residual decreases (its gradient comes with the
//      same pass). Clamped models (material.h: where a singular value is
//      clamped, P is not the gradient of psi) take the Armijo test on Phi
//      only when neither x nor the trial point has a clamped singular
//      value (any_clamped), where Phi is the potential of the gradient;
//      from such an x a trial that has one is halved until it has none
//      (the last of the MAX_BACKTRACKS trials excepted); from a clamped x
//      the trial is accepted when the residual decreases, r_t <= (1 -
//      1e-4 alpha) r. The residual alone everywhere (before)
//      crawled: dx solves with the Hessian at F_hat, not the force's
//      Jacobian, so it need not descend the residual; ek-verify --extremes,
//      fixed corotated + clamp, plane crush at nu = 0.49: step 1 took 50
//      iterations at alpha 1/8-1/128, r 4.9 -> 0.24 (0.1-1% per iteration),
//      and step 2 then stalled at r 8.5e3 with a body turned inside out
//      (the residual rose for every alpha in [2.4e-7, 1], while psi's slope
//      along dx was 620x grad.dx). With the test on Phi where it holds,
//      every step converges there (10 of the 40 known failures were such
//      rows; 8 recover, test_sim_implicit 10.). Accepting a clamped trial
//      from an unclamped x on the residual (stable neo-Hookean + clamp, nu
//      = 0.499: step 1 took |dx| = 176 at alpha 1/64 into the clamp, r 4045
//      -> 542, then stalled) left 2 of the 8. From a clamped x where no
//      trial passes the residual test, the largest trial that passed
//      Armijo on Phi (with grad.dx, as above) is taken instead of stopping
//      the step: dx still descends Phi there (Phi's slope along dx, by
//      differences, was 0.36-1.1x grad.dx at every such iteration until
//      Phi's change reached its rounding), while the residual rose for
//      every alpha (its slope along dx > 0: the Hessian at F_hat is not the
//      Jacobian of P(F_hat)). Measured (ek-verify --extremes, neo-Hookean +
//      clamp 0.05 crushed to a point, f64, seed 1): every step stalled at r
//      33-110 after 1-33 iterations (step 0 at iteration 11, r 33.3) until
//      step 22's state turned the body inside out (refused); with the
//      fallback every step runs to newton_tol or max_newton, step 0 ends at
//      r 6.0 and from step 5 on r <= 2.6e-4, one tet left inverted (not
//      restored: where a singular value is clamped P(F_hat) is not the
//      gradient of Phi, so neither merit reaches r = 0 there; Stomakhin et
//      al. 2012, "Energetically consistent invertible elasticity", extend
//      the energy instead). A step whose residual test passes takes the
//      same trials as before;
//   3. v_{n+1} = (x_{n+1} - x_n) / dt; then the ground as in the explicit
//      loop.
// The stopping rule (issue 26). The residual r (ek_scene_implicit) is an
// absolute bound on the remaining position error, relative to the body's
// size. A body that moves less than about newton_tol body sizes in a step
// (a settling body's drift, a near-equilibrium such as stable neo-Hookean
// crushed to a point, where P(F) = O(|F|^2)) starts every step below
// newton_tol, so the start point x~ + dt^2 g was accepted with no
// iteration: its forces never acted (ek-verify --extremes: the point crush
// stayed a point for all 30 steps, r = 7.3e-7 each; the shipped crush
// scenes flew on at v_n for 42-52 of their last steps, r rising linearly
// until an iteration ran). So the start point is accepted only when its
// gradient is exactly 0 (it is then the step's solution, e.g. a body at
// rest with no load); otherwise Newton runs at least one iteration, which
// takes the forces into account, and the test r <= newton_tol applies
// after it. A step that stops above newton_tol is counted (unconverged)
// and its state used, unless that state turns the body inside out (signed
// volume > 0 before, <= 0 after): near incompressibility a clamped model's
// residual line search accepted such a step (V/V0 0.99 -> -177, every tet
// inverted; every later step then stalled at once while the body flew on,
// ending at V/V0 -4.7e6, reported as a finite state). That step fails with
// EK_SIM_EUNCONVERGED and is not applied. A bound on r was not the test: r
// over-estimates the error by up to 1 + (omega dt)^2 (its Hessian bound is
// M / dt^2 only), and small or stiff bodies stopped at r = 2-64 on their
// first crushed step and then recovered (ek-verify --extremes, L = 1e-4).
// Every sum (objective, dot products) runs over fixed chunks in a fixed
// order and every pass is deterministic (hessian.h), so a step has the
// same bits at any thread count.
//
// Across MPI ranks (ek-sim under mpirun, more than one rank; sim/README.md
// "MPI"): each rank owns a contiguous range of the vertices' Morton order
// and the elements whose lowest-placed vertex is in it; its Hessian context holds those
// elements only (body.h hessian_create_part). The state and every vector
// of the loop are replicated: each rank runs this same loop on the whole
// x, with the gradient and the energy summed over the ranks (the same bits
// on every rank, so every rank takes the same Newton and line-search
// decisions), the system matrix assembled into PETSc's parallel matrix
// (rows owned by the vertex ranges) and solved in parallel, dx gathered
// whole on every rank; with "matrix_free", each CG product K p and the
// preconditioner's diagonal blocks are summed over the ranks the same way
// as the gradient, so every rank runs the same CG iterations.
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels/elements/morton.h" // header-only
#include "../kernels/team.h"
#include "implicit_petsc.h"
#include "sim_internal.h"

// Vector work below this many degrees of freedom runs on one thread (about
// 1 ns per entry and pass; see EXPLICIT_PARALLEL_GRAIN).
#define IMPLICIT_PARALLEL_DOFS 30000
// Fixed chunks of the reductions (a multiple of 3 dofs, a vertex, and of
// the 4 partial sums below): the same bits at any thread count.
#define CHUNK 3072
#define ARMIJO_C1 1e-4
#define MAX_BACKTRACKS 40

// The forcing term (linear_solver "amg"; implicit_petsc_forcing): CG's
// relative tolerance per Newton iteration, an inexact Newton method (Dembo,
// Eisenstat & Steihaug 1982) with Eisenstat & Walker's choice 2 (1996,
// "Choosing the forcing terms in an inexact Newton method", SIAM J. Sci.
// Comput. 17(1)): eta_0 = FORCING_MAX, then
//   eta_k = min(FORCING_MAX, max(cg_tol, FORCING_GAMMA (r_k / r_{k-1})^2)),
// r the Newton residual (their safeguard, eta_k >= gamma eta_{k-1}^2 where
// that exceeds 0.1, never acts under this cap). Loose where Newton is far
// from the step's solution, down to the scene's cg_tol as it converges.
// One more safeguard keeps every step to newton_tol: once an iteration
// reduces r by less than FORCING_STALL, the rest of the step solves to
// cg_tol (as without the forcing term): with loose solves a stall feeds
// itself (r_k / r_{k-1} near 1 gives eta near the cap). Measured (busy
// 2-core Zen 5, 1 thread, CPU time; sim/README.md): the bracket's 30 steps
// 84.7 -> 46.5 CG iterations per step (5.43 -> 5.47 Newton iterations),
// CPU 32.6 -> 22.4 s; on 2 MPI ranks 14.9 -> 7.7 CG iterations per Newton
// iteration, wall 46.0 -> 30.7 s. EW's own eta_0 = 0.5 and cap 0.9 left crush_implicit (amg)
// 55 of its 120 steps above newton_tol (main: 19; with 0.1: 14); without
// FORCING_STALL the bracket and twist_implicit crawled at r_k / r_{k-1} ~
// 0.999 up to max_newton.
#define FORCING_MAX 0.1
#define FORCING_GAMMA 0.9
#define FORCING_STALL 0.5
// The assembled solvers' line search, a trial's Phi not resolving the
// step: where the step's predicted decrease -grad.dx is below PHI_FLAT
// |Phi|, the trial is accepted when the residual decreases (like a trial
// within Phi's rounding). Phi's change along dx then disagrees with its
// gradient (cantilever_implicit, E = 1e8, r ~ 1e-5: grad.dx = -7.4e-14
// |Phi|, Phi rising by 4.1e-12 |Phi| alpha for every alpha), so Armijo
// halved alpha to ~2^-9 for 50 iterations at 0.2% each. The matrix-free
// path keeps its test (and bits).
#define PHI_FLAT 1e-10
// The clamped fallback (step 2 above): once a trial has passed Armijo on
// Phi, the residual test gets 6 more halvings, not MAX_BACKTRACKS. Measured
// (quiet Zen 5): crush_implicit 120 steps 1.03 -> 0.76 s (0.45 s before
// the fallback), 3601 -> 585 backtracks, its first 30 steps' bits kept
// (tools/hash_scenes.sh), 11 steps above newton_tol either way;
// ek-verify --extremes' implicit point crushes the same or better (nh+clamp
// f32 30 -> 17 unconverged steps, snh+clamp f64 7 -> 6).
#define FALLBACK_SPAN (1.0 / 64)

typedef struct {
  const sim_body *body;
  void *H;              // the body's Hessian (body.h: hessian_create)
  sim_hessian_info hes; // f32 products, residual merit, split timing
  size_t n3, nchunks;
  int par, block;
  double *is_free; // per dof: 1 free, 0 held (a held vertex, or one with no mass)
  double *minv;    // per dof: is_free / m, the M^-1 norm's weight
  double *mdiag;   // per dof: is_free m (1 + c dt) / dt^2, the system's mass term
  double *x, *xt, *g, *gt, *xtil, *dx, *r, *z, *p, *q, *parts;
  double *parts2; // per chunk: r.z (the preconditioner's pass)
  double *pre;    // nverts x 6: the preconditioner's blocks
  float *p32, *q32;
  // The product in parts (body.h hessian_apply_parts: nparts 0 without
  // it), for the CG's passes on the helper team (kernels/team.h).
  int nparts, apply_par;
  // Assembled solvers (linear_solver "amg", "direct"): K's pattern and
  // values, the system's values, PETSc's solver.
  ek_csr_pattern pat;
  double *kvals, *svals;
  implicit_petsc *ps;
  // Across MPI ranks: diag, per dof, the system's diagonal term each row's
  // owner adds (mdiag, 1 at held dofs).
  // perm: the vertices' Morton order (create_rank_part), PETSc's numbering.
  int mpi;
  double *diag;
  int32_t *perm;
  // Assembled solvers: the last step's acceleration (v_{n+1} - v_n) / dt
  // per dof, and the state epoch it belongs to (the start point uses it
  // only if no ek_sim_set_state came since).
  double *acc;
  int have_acc;
  unsigned long acc_epoch;
  // Clamped models (hes.residual_merit, tets): each element's rest inverse
  // D_m^-1 (row-major 3x3), to tell whether a state has a clamped singular
  // value (any_clamped), i.e. whether the energy is the force's potential
  // there.
  double *dm_inv;
} implicit_data;

static void data_free(implicit_data *d) {
  if (!d)
    return;
  if (d->H)
    d->body->ops->hessian_destroy(d->H);
  double *arrays[] = {d->is_free, d->minv, d->mdiag, d->x, d->xt, d->g,   d->gt,    d->xtil,
                      d->dx,      d->r,    d->z,     d->p, d->q,  d->pre, d->parts, d->parts2};
  for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; i++)
    free(arrays[i]);
  free(d->p32);
  free(d->q32);
  free(d->kvals);
  free(d->svals);
  free(d->diag);
  free(d->perm);
  free(d->acc);
  free(d->dm_inv);
  implicit_petsc_destroy(d->ps);
  free(d);
}

static void implicit_destroy(void *data) { data_free(data); }

// 0 on every rank if rc is 0 on every rank, else EK_EINVAL on every rank
// (a rank whose own rc was 0 says another rank failed): the ranks leave
// creation together, never with one of them waiting in a collective call.
static int agree(ek_sim *s, int rc) {
  double failed = rc != 0;
  char err[256];
  if (implicit_mpi_sum(&failed, 1, err, sizeof err) < 0)
    return rc ? rc : sim_fail(s, "%s", err);
  if (failed > 0 && rc == 0)
    return sim_fail(s, "another MPI rank failed to set up (its message is on its stderr)");
  return rc;
}

// perm[v]: vertex v's place in the Morton order of the rest positions
// (21 bits per axis, interleaved x, y, z from the top), on
// the bounding box's enclosing cube (one scale for all axes, so the first
// cuts fall across the longest extent: a beam is cut along its length).
static int morton_order(const double *X, size_t nv, int32_t *perm) {
  ek_morton_key *k = malloc((nv + 1) * sizeof *k);
  if (!k)
    return -1;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, side = 0;
  for (size_t v = 0; v < nv; v++)
    for (int a = 0; a < 3; a++)
      lo[a] = fmin(lo[a], X[3 * v + a]);
  for (size_t v = 0; v < nv; v++)
    for (int a = 0; a < 3; a++)
      side = fmax(side, X[3 * v + a] - lo[a]);
  const double scale = side > 0 ? 2097151.0 / side : 0; // 2^21 - 1
  for (size_t v = 0; v < nv; v++) {
    uint64_t code = 0;
    for (int a = 0; a < 3; a++)
      code |= ek_morton_spread3((uint64_t)((X[3 * v + a] - lo[a]) * scale)) << (2 - a);
    k[v] = (ek_morton_key){code, (int32_t)v};
  }
  qsort(k, nv, sizeof *k, ek_morton_key_cmp);
  for (size_t i = 0; i < nv; i++)
    perm[k[i].index] = (int32_t)i;
  free(k);
  return 0;
}

// This rank's elements and their Hessian context. The vertices are put in
// the Morton order of their rest positions (perm) and rank r owns the
// places [nv r / size, nv (r + 1) / size) of it (PETSc's rows,
// implicit_petsc.h): a Morton cut. A rank owns the elements whose
// lowest-placed vertex it owns, so the element cut follows the row cut and
// a rank's entries fall in its own rows except along the cut.
static int create_rank_part(ek_sim *s, implicit_data *d) {
  const sim_body *b = s->body;
  const int size = implicit_mpi_size(), rank = implicit_mpi_rank();
  if (!b->ops->hessian_create_part)
    return sim_fail(s,
                    "%d MPI ranks: this body (%s) cannot be split across ranks; run on one "
                    "rank",
                    size, b->kind);
  const size_t v0 = s->nv * (size_t)rank / (size_t)size;
  const size_t v1 = s->nv * (size_t)(rank + 1) / (size_t)size;
  size_t *mine = malloc((b->ne + 1) * sizeof *mine), count = 0;
  d->perm = malloc((s->nv + 1) * sizeof *d->perm);
  if (!mine || !d->perm || morton_order(b->X, s->nv, d->perm) < 0) {
    free(mine);
    return agree(s, sim_fail(s, "out of memory"));
  }
  for (size_t e = 0; e < b->ne; e++) {
    const int32_t *t = b->elems + e * (size_t)b->corners;
    int32_t lo = d->perm[t[0]];
    for (int a = 1; a < b->corners; a++)
      lo = d->perm[t[a]] < lo ? d->perm[t[a]] : lo;
    if ((size_t)lo >= v0 && (size_t)lo < v1)
      mine[count++] = e;
  }
  int rc = 0;
  if (count == 0)
    rc = sim_fail(s, "MPI rank %d of %d owns no element (%zu elements): use fewer ranks", rank,
                  size, b->ne);
  else if (!(d->H = b->ops->hessian_create_part(s, &d->hes, mine, count)))
    rc = EK_EINVAL; // the message is in s->error
  free(mine);
  return agree(s, rc);
}

// A failure of implicit_create after create_rank_part: across ranks, every
// rank learns of it at the one agreement before the collective setup.
static int create_failed(ek_sim *s, implicit_data *d, int rc) {
  const int mpi = d->mpi;
  data_free(d);
  return mpi ? agree(s, rc) : rc;
}

// Each tet's D_m^-1 (D_m = [X1 - X0, X2 - X0, X3 - X0]), row-major; NULL
// when out of memory. A degenerate rest tet gets non-finite entries, which
// any_clamped counts as clamped (the residual merit, as before).
static double *rest_inverses(const sim_body *b) {
  double *inv = malloc(9 * b->ne * sizeof(double));
  for (size_t e = 0; inv && e < b->ne; e++) {
    const int32_t *t = b->elems + 4 * e;
    double D[9], *m = inv + 9 * e;
    for (int i = 0; i < 3; i++)
      for (int c = 0; c < 3; c++)
        D[3 * i + c] = b->X[3 * t[c + 1] + i] - b->X[3 * t[0] + i];
    m[0] = D[4] * D[8] - D[5] * D[7], m[1] = D[2] * D[7] - D[1] * D[8];
    m[2] = D[1] * D[5] - D[2] * D[4], m[3] = D[5] * D[6] - D[3] * D[8];
    m[4] = D[0] * D[8] - D[2] * D[6], m[5] = D[2] * D[3] - D[0] * D[5];
    m[6] = D[3] * D[7] - D[4] * D[6], m[7] = D[1] * D[6] - D[0] * D[7];
    m[8] = D[0] * D[4] - D[1] * D[3];
    const double det = D[0] * m[0] + D[1] * m[3] + D[2] * m[6];
    for (int k = 0; k < 9; k++)
      m[k] /= det;
  }
  return inv;
}

// Elements per chunk of any_clamped.
#define CLAMP_CHUNK 1024

typedef struct {
  const implicit_data *d;
  const double *x;
  double c2;
  atomic_int any;
} clamp_job;

// any_clamped over chunk ch's elements (it stops at the first clamped one).
static void clamp_chunk(void *ctx, size_t ch) {
  clamp_job *job = ctx;
  const sim_body *b = job->d->body;
  const double *x = job->x, c2 = job->c2;
  const size_t e1 = (ch + 1) * CLAMP_CHUNK < b->ne ? (ch + 1) * CLAMP_CHUNK : b->ne;
  int any = 0;
  for (size_t e = ch * CLAMP_CHUNK; e < e1 && !any; e++) {
    const int32_t *t = b->elems + 4 * e;
    const double *m = job->d->dm_inv + 9 * e;
    double D[9], F[9], C[6];
    for (int i = 0; i < 3; i++)
      for (int c = 0; c < 3; c++)
        D[3 * i + c] = x[3 * t[c + 1] + i] - x[3 * t[0] + i];
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++)
        F[3 * i + j] = D[3 * i] * m[j] + D[3 * i + 1] * m[3 + j] + D[3 * i + 2] * m[6 + j];
    const double J = F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) +
                     F[2] * (F[3] * F[7] - F[4] * F[6]);
    // C's entries 00, 11, 22, 01, 02, 12.
    static const int ci[6] = {0, 1, 2, 0, 0, 1}, cj[6] = {0, 1, 2, 1, 2, 2};
    for (int k = 0; k < 6; k++)
      C[k] = F[ci[k]] * F[cj[k]] + F[3 + ci[k]] * F[3 + cj[k]] + F[6 + ci[k]] * F[6 + cj[k]];
    const double q = (C[0] + C[1] + C[2]) / 3, p1 = C[3] * C[3] + C[4] * C[4] + C[5] * C[5];
    const double p2 =
        (C[0] - q) * (C[0] - q) + (C[1] - q) * (C[1] - q) + (C[2] - q) * (C[2] - q) + 2 * p1;
    double lmin = q;
    if (p2 > 0) {
      const double p = sqrt(p2 / 6), B0 = (C[0] - q) / p, B1 = (C[1] - q) / p, B2 = (C[2] - q) / p,
                   B3 = C[3] / p, B4 = C[4] / p, B5 = C[5] / p;
      double r =
          0.5 * (B0 * (B1 * B2 - B5 * B5) - B3 * (B3 * B2 - B5 * B4) + B4 * (B3 * B5 - B1 * B4));
      r = r < -1 ? -1 : r > 1 ? 1 : r;
      // The smallest of q + 2 p cos(phi + 2 pi k / 3), phi = acos(r) / 3.
      lmin = q + 2 * p * cos(acos(r) / 3 + 2.0943951023931957);
    }
    any = !(J > 0 && lmin > c2);
  }
  if (any)
    atomic_store_explicit(&job->any, 1, memory_order_relaxed);
}

// 1 if some tet of x has a singular value below the clamp (or is inverted,
// or not finite): there the clamped model's energy is not the potential of
// its force (material.h). The smallest singular value from the smallest
// eigenvalue of C = F^T F in closed form (Smith 1961, CACM 4(4)); near the
// clamp, where this and the kernel's SVD may round apart, psi and P agree
// to first order either way. Elements are independent (an OR): the same
// answer at any thread count and on every MPI rank (x is replicated). In
// chunks of elements on the helper team (kernels/team.h) where d->par.
static int any_clamped(const ek_sim *s, const implicit_data *d, const double *x) {
  clamp_job j = {d, x, s->mat.clamp * s->mat.clamp, 0};
  ek_team_run_if(d->par, (d->body->ne + CLAMP_CHUNK - 1) / CLAMP_CHUNK, clamp_chunk, &j);
  return atomic_load(&j.any);
}

static int implicit_create(ek_sim *s, void **data) {
  *data = NULL;
  implicit_data *d = calloc(1, sizeof *d);
  if (!d)
    return sim_fail(s, "out of memory");
  const ek_scene *sc = &s->scene;
  d->n3 = 3 * s->nv;
  d->nchunks = (d->n3 + CHUNK - 1) / CHUNK;
  d->par = d->n3 > IMPLICIT_PARALLEL_DOFS;
  d->block = sc->implicit.preconditioner == EK_PRECOND_BLOCK_JACOBI;
  d->body = s->body;
  d->mpi = implicit_mpi_size() > 1;
  if (d->mpi) {
    int rc = create_rank_part(s, d);
    if (rc) {
      data_free(d);
      return rc;
    }
  } else if (!(d->H = s->body->ops->hessian_create(s, &d->hes))) {
    data_free(d);
    return EK_EINVAL; // the message is in s->error
  }
  double **arrays[] = {&d->is_free, &d->minv, &d->mdiag, &d->x, &d->xt, &d->g, &d->gt,
                       &d->xtil,    &d->dx,   &d->r,     &d->z, &d->p,  &d->q};
  int ok = 1;
  for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; i++)
    ok &= (*arrays[i] = calloc(d->n3, sizeof(double))) != NULL;
  ok &= (d->pre = calloc(2 * d->n3, sizeof(double))) != NULL; // 6 per vertex
  ok &= (d->parts = calloc(d->nchunks, sizeof(double))) != NULL;
  ok &= (d->parts2 = calloc(d->nchunks, sizeof(double))) != NULL;
  if (!d->mpi && s->body->ops->hessian_apply_parts)
    d->nparts = s->body->ops->hessian_apply_parts(d->H, &d->apply_par);
  if (d->hes.f32)
    ok &= (d->p32 = calloc(d->n3, sizeof(float))) && (d->q32 = calloc(d->n3, sizeof(float)));
  if (ok && d->hes.residual_merit && s->body->corners == 4)
    ok &= (d->dm_inv = rest_inverses(s->body)) != NULL;
  if (!ok)
    return create_failed(
        s, d, sim_fail(s, "out of memory for the implicit solver's vectors (%zu dofs)", d->n3));
  const ek_linear_solver ls = sc->implicit.linear_solver;
  if (ls != EK_LINSOLVE_MATRIX_FREE) {
    const sim_body_ops *ops = s->body->ops;
    const char *name = ek_linear_solver_name(ls);
    if (!ops->hessian_pattern || !ops->hessian_assemble)
      return create_failed(s, d,
                           sim_fail_at(s, sc->where.linear_solver,
                                       "integrator.linear_solver = \"%s\": this body has no "
                                       "assembled Hessian (tets only); use \"matrix_free\"",
                                       name));
    if (ops->hessian_pattern(d->H, &d->pat) < 0)
      return create_failed(s, d, sim_fail(s, "the Hessian's pattern: %s", ek_last_error()));
    d->acc = calloc(d->n3, sizeof(double));
    d->kvals = malloc((d->pat.nnz + 1) * sizeof(double));
    d->svals = malloc((d->pat.nnz + 1) * sizeof(double));
    if (d->mpi)
      d->diag = malloc(d->n3 * sizeof(double));
    if (!d->kvals || !d->svals || (d->mpi && !d->diag) || !d->acc)
      return create_failed(
          s, d, sim_fail(s, "out of memory for the assembled Hessian (%zu nonzeros)", d->pat.nnz));
    int rc;
    if (d->mpi && (rc = agree(s, 0))) { // every rank is ready for the collective setup
      data_free(d);
      return rc;
    }
    char err[512] = "";
    if (d->mpi)
      d->ps =
          implicit_petsc_create_mpi(ls == EK_LINSOLVE_DIRECT, &d->pat, s->nv, d->perm, s->body->X,
                                    sc->implicit.cg_tol, sc->implicit.max_cg, err, sizeof err);
    else
      d->ps = implicit_petsc_create(ls == EK_LINSOLVE_DIRECT, &d->pat, s->body->X,
                                    sc->implicit.cg_tol, sc->implicit.max_cg, err, sizeof err);
    if (!d->ps) {
      data_free(d);
      return sim_fail_at(s, sc->where.linear_solver, "integrator.linear_solver = \"%s\": %s", name,
                         err);
    }
  }
  *data = d;
  return 0;
}

// ---- Reductions and vector work (fixed chunks) ----

static double sum_parts(const implicit_data *d) {
  double s = 0;
  for (size_t c = 0; c < d->nchunks; c++)
    s += d->parts[c];
  return s;
}

// Chunk c's dofs [*lo, *hi).
static void chunk_range(const implicit_data *d, size_t c, size_t *lo, size_t *hi) {
  *lo = c * CHUNK;
  *hi = *lo + CHUNK < d->n3 ? *lo + CHUNK : d->n3;
}

// A vector pass over the fixed chunks: its vectors and scalars.
typedef struct {
  implicit_data *d;
  const double *a, *b;
  double *out;
  double alpha, beta;
  const ek_sim *s;
} vec_job;

// Runs fn(job, c) for every chunk: on the helper team (kernels/team.h)
// where d->par, the caller never waiting for a thread that has not
// started; a chunk writes the same values whoever runs it.
static void run_chunks(const implicit_data *d, ek_team_fn *fn, vec_job *job) {
  ek_team_run_if(d->par, d->nchunks, fn, job);
}

// A chunk function whose body runs for each dof i of the chunk and adds
// its term to acc_[i & 3]: four independent partial sums (a single one
// would chain every addition's latency), combined in a fixed order into
// d->parts[c].
#define CHUNK_FN(name, ...)                                                                        \
  static void name(void *ctx_, size_t c_) {                                                        \
    const vec_job *j = ctx_;                                                                       \
    implicit_data *d = j->d;                                                                       \
    size_t lo_, hi_;                                                                               \
    chunk_range(d, c_, &lo_, &hi_);                                                                \
    double acc_[4] = {0, 0, 0, 0};                                                                 \
    for (size_t i = lo_; i < hi_; i++) {                                                           \
      __VA_ARGS__                                                                                  \
    }                                                                                              \
    d->parts[c_] = (acc_[0] + acc_[1]) + (acc_[2] + acc_[3]);                                      \
  }

CHUNK_FN(dot_chunk, acc_[i & 3] += j->a[i] * j->b[i];)
CHUNK_FN(norm2_minv_chunk, acc_[i & 3] += d->minv[i] * j->a[i] * j->a[i];)

// a.b over the free dofs (held dofs of a and b are 0 in every use).
static double dot(implicit_data *d, const double *a, const double *b) {
  vec_job j = {.d = d, .a = a, .b = b};
  run_chunks(d, dot_chunk, &j);
  return sum_parts(d);
}

// g^T M^-1 g over the free dofs.
static double norm2_minv(implicit_data *d, const double *g) {
  vec_job j = {.d = d, .a = g};
  run_chunks(d, norm2_minv_chunk, &j);
  return sum_parts(d);
}

// Newton's residual of a gradient (ek_scene_implicit.newton_tol).
static double residual(implicit_data *d, const ek_sim *s, const double *g, double free_mass) {
  double dt = s->scene.dt;
  return dt * dt * sqrt(norm2_minv(d, g) / free_mass) / s->body_size;
}

// Inertia, gravity and damping at x = j->a of the free vertices into
// acc_, their gradient added into j->out (0 at held dofs); alpha 1 / dt^2,
// beta c / dt.
CHUNK_FN(
    inertia_chunk, const double *x = j->a, *xn = j->s->x, *g = j->s->scene.gravity;
    double *gr = j->out; if (d->is_free[i] != 0) {
      const int k = (int)(i % 3);
      const double mi = j->s->mass[i / 3], u = x[i] - d->xtil[i], w = x[i] - xn[i];
      acc_[i & 3] += mi * (0.5 * j->alpha * u * u - g[k] * x[i] + 0.5 * j->beta * w * w);
      gr[i] += mi * (j->alpha * u - g[k] + j->beta * w);
    } else gr[i] = 0;)

// Phi(x) and grad Phi (into gr) from one gradient pass; +inf outside the
// model's domain. Caches the eigensystems for the products at x.
static int objective(ek_sim *s, implicit_data *d, const double *x, double *gr, double *phi) {
  const ek_scene *sc = &s->scene;
  const double dt = sc->dt, c = sc->damping;
  const sim_body_ops *ops = d->body->ops;
  double E, t0 = sim_now();
  if (s->time_phases && d->hes.split_timing) {
    // The pass without the cache, to split off what caching costs.
    int rc = ops->gradient(s, d->H, x, gr, &E, 0);
    if (rc < 0)
      return sim_fail(s, "gradient: %s", ek_last_error());
    double t1 = sim_now();
    s->times.eigensystems -= t1 - t0;
    t0 = t1;
  }
  int rc = ops->gradient(s, d->H, x, gr, &E, 1);
  double t1 = sim_now();
  if (s->time_phases) {
    s->times.eigensystems += t1 - t0;
    s->times.gradient_timed += t1 - t0;
  }
  s->times.gradient += t1 - t0;
  s->times.gradient_passes++;
  if (rc < 0)
    return sim_fail(s, "gradient: %s", ek_last_error());
  if (d->mpi) {
    // This rank's elements' share, summed over the ranks.
    char err[256];
    if (implicit_mpi_sum(gr, d->n3, err, sizeof err) < 0 ||
        implicit_mpi_sum(&E, 1, err, sizeof err) < 0)
      return sim_fail(s, "gradient: %s", err);
    double t2 = sim_now();
    s->times.mpi_sum += t2 - t1;
    t1 = t2;
  }
  // Inertia, gravity and damping of the free vertices, and their gradient.
  vec_job j = {.d = d, .a = x, .out = gr, .alpha = 1 / (dt * dt), .beta = c / dt, .s = s};
  run_chunks(d, inertia_chunk, &j);
  *phi = isfinite(E) ? E + sum_parts(d) : INFINITY;
  s->times.line_search += sim_now() - t1;
  return 0;
}

// A line-search trial: xt = x + alpha dx, its Phi and gradient (gt) and
// the body's eigensystems at xt.
static void trial_chunk(void *ctx, size_t c) {
  const vec_job *j = ctx;
  size_t lo, hi;
  chunk_range(j->d, c, &lo, &hi);
  for (size_t i = lo; i < hi; i++)
    j->out[i] = j->a[i] + j->alpha * j->b[i];
}

static int trial(ek_sim *s, implicit_data *d, const double *x, double alpha, double *phi) {
  const double t0 = sim_now();
  vec_job j = {.d = d, .a = x, .b = d->dx, .out = d->xt, .alpha = alpha};
  run_chunks(d, trial_chunk, &j);
  s->times.line_search += sim_now() - t0;
  return objective(s, d, d->xt, d->gt, phi);
}

// The preconditioner's blocks of chunk c's vertices (build_preconditioner;
// j->out the blocks, alpha (1 + c dt) / dt^2).
static void precondition_build_chunk(void *ctx, size_t c) {
  const vec_job *j = ctx;
  const implicit_data *d = j->d;
  size_t lo, hi;
  chunk_range(d, c, &lo, &hi);
  for (size_t v = lo / 3; v < hi / 3; v++) {
    double *B = j->out + 6 * v, m = j->alpha * j->s->mass[v];
    if (d->is_free[3 * v] == 0) {
      for (int k = 0; k < 6; k++)
        B[k] = 0;
      continue;
    }
    double a00 = B[0] + m, a01 = B[1], a02 = B[2], a11 = B[3] + m, a12 = B[4], a22 = B[5] + m;
    if (!d->block) {
      B[0] = 1 / a00, B[1] = 1 / a11, B[2] = 1 / a22;
      continue;
    }
    // Symmetric inverse by cofactors (the block is SPD: K's blocks are PSD).
    double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22, c02 = a01 * a12 - a02 * a11;
    double det = a00 * c00 + a01 * c01 + a02 * c02;
    B[0] = c00 / det;
    B[1] = c01 / det;
    B[2] = c02 / det;
    B[3] = (a00 * a22 - a02 * a02) / det;
    B[4] = (a01 * a02 - a00 * a12) / det;
    B[5] = (a00 * a11 - a01 * a01) / det;
  }
}

// The preconditioner at the current eigensystems: inverse diagonal or
// inverse 3x3 vertex blocks of M (1 + c dt) / dt^2 + K, 0 at held dofs.
// blocks: 6 values per vertex (the diagonal blocks in, the inverse's 6 or
// the inverse diagonal's 3 out).
static int build_preconditioner(ek_sim *s, implicit_data *d, double *blocks) {
  int rc = d->body->ops->hessian_diagonal(d->H, blocks);
  if (rc < 0)
    return sim_fail(s, "diagonal blocks: %s", ek_last_error());
  if (d->mpi) {
    // This rank's elements' blocks, summed over the ranks (the same bits on
    // every rank, as the gradient).
    char err[256];
    const double t0 = sim_now();
    rc = implicit_mpi_sum(blocks, 2 * d->n3, err, sizeof err);
    s->times.mpi_sum += sim_now() - t0;
    if (rc < 0)
      return sim_fail(s, "diagonal blocks: %s", err);
  }
  const double dt = s->scene.dt;
  vec_job j = {.d = d, .out = blocks, .alpha = (1 + s->scene.damping * dt) / (dt * dt), .s = s};
  run_chunks(d, precondition_build_chunk, &j);
  return 0;
}

// ---- The CG iteration's passes ----
// Each pass runs over the fixed chunks (CHUNK dofs; the product's parts)
// and a chunk's result does not depend on the thread that runs it: the
// same bits at any thread count. At more than one thread the passes run on
// the helper team (kernels/team.h), chunks claimed by whichever thread
// comes first, so no thread waits for one that is not running: with fork/join passes
// (5 regions and a barrier per CG iteration, each needing every thread
// scheduled) a core held by another process cost a scheduler slice per
// pass (sim/README.md, fifteenth round). The update of dx and r and the
// preconditioner run in one pass (z is needed only where CG goes on; the
// last iteration computes it for nothing).

typedef struct {
  implicit_data *d;
  const double *blocks;
  double alpha, beta;
  int rows;          // the product's pass sums the parts' rows first
  atomic_int failed; // a part's product failed (the message is in ek_last_error)
} cg_pass;

// Runs fn over chunks [0, n): on the team (or on this thread alone where
// parallel is 0).
static void run_pass(ek_team_fn *fn, void *ctx, size_t n, int parallel) {
  ek_team_run_if(parallel, n, fn, ctx);
}

// z = P^-1 r over chunk c's vertices; returns their r.z.
static double precondition_chunk(const implicit_data *d, const double *blocks, size_t c) {
  const double *r = d->r;
  double *z = d->z;
  size_t lo, hi, block = d->block;
  chunk_range(d, c, &lo, &hi);
  double acc = 0;
  for (size_t v = lo / 3; v < hi / 3; v++) {
    const double *B = blocks + 6 * v, *rv = r + 3 * v;
    double *zv = z + 3 * v;
    if (block) {
      zv[0] = B[0] * rv[0] + B[1] * rv[1] + B[2] * rv[2];
      zv[1] = B[1] * rv[0] + B[3] * rv[1] + B[4] * rv[2];
      zv[2] = B[2] * rv[0] + B[4] * rv[1] + B[5] * rv[2];
    } else {
      zv[0] = B[0] * rv[0];
      zv[1] = B[1] * rv[1];
      zv[2] = B[2] * rv[2];
    }
    acc += rv[0] * zv[0] + rv[1] * zv[1] + rv[2] * zv[2];
  }
  return acc;
}

static void pass_precondition(void *ctx, size_t c) {
  cg_pass *cp = ctx;
  cp->d->parts2[c] = precondition_chunk(cp->d, cp->blocks, c);
}

// p = z + beta p (p = z for beta 0, the first direction), and its float
// copy for f32 products.
static void pass_direction(void *ctx, size_t c) {
  const cg_pass *cp = ctx;
  implicit_data *d = cp->d;
  const double beta = cp->beta, *z = d->z;
  double *p = d->p;
  float *p32 = d->hes.f32 ? d->p32 : NULL;
  size_t lo, hi;
  chunk_range(d, c, &lo, &hi);
  for (size_t i = lo; i < hi; i++) {
    p[i] = beta == 0 ? z[i] : z[i] + beta * p[i];
    if (p32)
      p32[i] = (float)p[i];
  }
}

// Part c of K p (hessian_apply_part).
static void pass_part(void *ctx, size_t c) {
  cg_pass *cp = ctx;
  implicit_data *d = cp->d;
  if (d->body->ops->hessian_apply_part(d->H, (int)c, d->p, d->p32) < 0)
    atomic_store(&cp->failed, 1);
}

// q = (M (1 + c dt) / dt^2 + K) p at the free dofs (0 at held ones) over
// chunk c, K p's rows summed from the parts first where cp->rows; its p.q.
static void pass_product(void *ctx, size_t c) {
  const cg_pass *cp = ctx;
  implicit_data *d = cp->d;
  const double *w = d->is_free, *md = d->mdiag, *p = d->p;
  const float *q32 = d->q32;
  double *q = d->q, acc_[4] = {0, 0, 0, 0};
  size_t lo, hi;
  chunk_range(d, c, &lo, &hi);
  if (cp->rows)
    d->body->ops->hessian_apply_rows(d->H, lo / 3, hi / 3, q, d->q32);
  if (d->hes.f32)
    for (size_t i = lo; i < hi; i++) {
      q[i] = md[i] * p[i] + w[i] * (double)q32[i];
      acc_[i & 3] += p[i] * q[i];
    }
  else
    for (size_t i = lo; i < hi; i++) {
      q[i] = md[i] * p[i] + w[i] * q[i];
      acc_[i & 3] += p[i] * q[i];
    }
  d->parts[c] = (acc_[0] + acc_[1]) + (acc_[2] + acc_[3]);
}

// dx += alpha p, r -= alpha q and r^T M^-1 r over chunk c, then z = P^-1 r
// and r.z there.
static void pass_update(void *ctx, size_t c) {
  const cg_pass *cp = ctx;
  implicit_data *d = cp->d;
  const double alpha = cp->alpha, *w = d->minv, *p = d->p, *q = d->q;
  double *dx = d->dx, *r = d->r, acc_[4] = {0, 0, 0, 0};
  size_t lo, hi;
  chunk_range(d, c, &lo, &hi);
  for (size_t i = lo; i < hi; i++) {
    dx[i] += alpha * p[i];
    r[i] -= alpha * q[i];
    acc_[i & 3] += w[i] * r[i] * r[i];
  }
  d->parts[c] = (acc_[0] + acc_[1]) + (acc_[2] + acc_[3]);
  d->parts2[c] = precondition_chunk(d, cp->blocks, c);
}

static double sum_of(const implicit_data *d, const double *parts) {
  double s = 0;
  for (size_t c = 0; c < d->nchunks; c++)
    s += parts[c];
  return s;
}

// Across MPI ranks: this rank's K p (j->out; in q32 for f32 products) at
// the free dofs, 0 at held ones.
static void free_rows_chunk(void *ctx, size_t c) {
  const vec_job *j = ctx;
  const implicit_data *d = j->d;
  const double *w = d->is_free;
  const float *q32 = d->q32;
  double *q = j->out;
  size_t lo, hi;
  chunk_range(d, c, &lo, &hi);
  for (size_t i = lo; i < hi; i++)
    q[i] = w[i] * (d->hes.f32 ? (double)q32[i] : q[i]);
}

// Then (the sum over the ranks) the mass term, and p.q (p = j->a).
CHUNK_FN(mass_term_chunk, j->out[i] += d->mdiag[i] * j->a[i]; acc_[i & 3] += j->a[i] * j->out[i];)

// q = (M (1 + c dt) / dt^2 + K) p at the free dofs (0 at held ones);
// returns p.q. For f32 products, d->p32 holds p (pass_direction).
static int system_product(ek_sim *s, implicit_data *d, cg_pass *cp, int team, double *pq) {
  double t0 = sim_now();
  const double *p = d->p;
  double *q = d->q;
  int rc;
  if (team) {
    atomic_store(&cp->failed, 0);
    run_pass(pass_part, cp, (size_t)d->nparts, d->apply_par);
    if (atomic_load(&cp->failed))
      return sim_fail(s, "Hessian product: %s", ek_last_error());
    cp->rows = 1;
  } else {
    rc = d->body->ops->hessian_apply(d->H, p, q, d->p32, d->q32);
    if (rc < 0)
      return sim_fail(s, "Hessian product: %s", ek_last_error());
    cp->rows = 0;
  }
  if (d->mpi) {
    // This rank's elements' K p at the free dofs, summed over the ranks
    // (the same bits on every rank: every rank then runs the same CG
    // iterations and stops at the same one), then the mass term.
    vec_job j = {.d = d, .a = p, .out = q};
    run_chunks(d, free_rows_chunk, &j);
    char err[256];
    const double t1 = sim_now();
    rc = implicit_mpi_sum(q, d->n3, err, sizeof err);
    const double t2 = sim_now();
    s->times.mpi_sum += t2 - t1;
    t0 += t2 - t1;
    if (rc < 0)
      return sim_fail(s, "Hessian product: %s", err);
    run_chunks(d, mass_term_chunk, &j);
  } else
    run_pass(pass_product, cp, d->nchunks, d->par || (team && d->apply_par));
  *pq = sum_parts(d);
  s->times.matvec += sim_now() - t0;
  s->times.matvecs++;
  return 0;
}

// The PCG iterations from dx = 0, r = -g, r0 = |r|_{M^-1} (solve); the
// passes on the helper team and the product in parts where team is set.
static int cg(ek_sim *s, implicit_data *d, const double *blocks, int team, double r0, long *iters,
              double *rel) {
  const ek_scene_implicit *im = &s->scene.implicit;
  const double stop = im->cg_tol * r0;
  cg_pass cp = {.d = d, .blocks = blocks};
  double t0 = sim_now();
  run_pass(pass_precondition, &cp, d->nchunks, d->par);
  double rz = sum_of(d, d->parts2);
  run_pass(pass_direction, &cp, d->nchunks, d->par);
  s->times.preconditioner += sim_now() - t0;
  for (long k = 0; k < im->max_cg && r0 > 0; k++) {
    double pq = 0;
    // The stop flag between CG iterations (issue 28: a step of many Newton
    // and CG iterations ignored SIGINT); it reads the flag only.
    int rc = sim_stop_requested(s, "CG iteration", k + 1, im->max_cg);
    if (rc == 0)
      rc = system_product(s, d, &cp, team, &pq);
    if (rc)
      return rc;
    if (!(pq > 0))
      break; // p = 0 to rounding: nothing left to solve
    t0 = sim_now();
    cp.alpha = rz / pq;
    run_pass(pass_update, &cp, d->nchunks, d->par);
    double rn = sqrt(sum_parts(d));
    s->times.cg_iterations++;
    ++*iters;
    *rel = rn / r0;
    if (rn <= stop) {
      s->times.cg_vectors += sim_now() - t0;
      break;
    }
    const double rz_new = sum_of(d, d->parts2);
    cp.beta = rz_new / rz;
    rz = rz_new;
    run_pass(pass_direction, &cp, d->nchunks, d->par);
    s->times.cg_vectors += sim_now() - t0;
  }
  return 0;
}

// PCG for A dx = -g over the free dofs, from dx = 0; *iters and *rel: its
// iterations and final |r|_{M^-1} / |g|_{M^-1}.
static int solve(ek_sim *s, implicit_data *d, const double *blocks, long *iters, double *rel) {
  const double t0 = sim_now();
  double *dx = d->dx, *r = d->r;
  const double *g = d->g;
  for (size_t i = 0; i < d->n3; i++) {
    dx[i] = 0;
    r[i] = -g[i];
  }
  const double r0 = sqrt(norm2_minv(d, r));
  *iters = 0;
  *rel = r0 > 0 ? 1 : 0;
  s->times.cg_vectors += sim_now() - t0;
  // The helper team where some pass runs on more than one thread (not
  // across MPI ranks, whose product sums over the ranks between its passes).
  const int team = !d->mpi && d->nparts && (d->par || d->apply_par) && omp_get_max_threads() > 1;
  return cg(s, d, blocks, team, r0, iters, rel);
}

// The system matrix's rows of chunk c (solve_assembled).
static void system_rows_chunk(void *ctx, size_t ch) {
  const implicit_data *d = ((const vec_job *)ctx)->d;
  const int32_t *rp = d->pat.row_ptr, *col = d->pat.col;
  const double *w = d->is_free, *md = d->mdiag, *kv = d->kvals;
  double *sv = d->svals;
  const int share = d->mpi;
  size_t lo, hi;
  chunk_range(d, ch, &lo, &hi);
  for (size_t r = lo; r < hi; r++) {
    const int fr = w[r] != 0;
    for (int32_t k = rp[r]; k < rp[r + 1]; k++) {
      const int32_t c = col[k];
      double v = fr && w[c] != 0 ? kv[k] : 0;
      if ((size_t)c == r && !share)
        v = fr ? v + md[r] : 1;
      sv[k] = v;
    }
  }
}

// The Newton system by an assembled solver (linear_solver "amg" or
// "direct"): K assembled at the current eigensystems (hessian.h), the
// system matrix M (1 + c dt) / dt^2 + K over the free dofs with held dofs
// as identity rows and columns (their right-hand side is 0: dx stays 0
// there), then PETSc. *iters: the solver's iterations (1 for a
// factorisation), *rel: |r|_2 / |b|_2.
static int solve_assembled(ek_sim *s, implicit_data *d, long *iters, double *rel) {
  double t0 = sim_now();
  int rc = d->body->ops->hessian_assemble(d->H, d->kvals);
  if (rc < 0)
    return sim_fail(s, "Hessian assembly: %s", ek_last_error());
  // Across ranks: this rank's share of K at free rows and columns; the
  // diagonal term is added once, by the row's owner (implicit_petsc.h).
  if (d->mpi)
    for (size_t r = 0; r < d->n3; r++)
      d->diag[r] = d->is_free[r] != 0 ? d->mdiag[r] : 1;
  vec_job j = {.d = d};
  run_chunks(d, system_rows_chunk, &j);
  for (size_t i = 0; i < d->n3; i++)
    d->r[i] = -d->g[i]; // 0 at held dofs (objective)
  s->times.assembly += sim_now() - t0;
  char err[512];
  rc = implicit_petsc_solve(d->ps, d->svals, d->diag, d->r, d->x, d->dx, iters, rel,
                            &s->times.solver_setup, &s->times.solver_solve, err, sizeof err);
  if (rc < 0)
    return sim_fail(s, "%s", err);
  // Held dofs stay put: their rows are identity rows with a zero
  // right-hand side, but an inexact solve leaves dx nonzero there (AMG's
  // aggregates couple them to free dofs). The residual, over free dofs
  // only, never saw it, and step 3 puts held vertices back, but the free
  // ones had converged against the moved clamp. Measured
  // (cantilever_implicit, amg, one step): 4.4e-7 body sizes from the
  // matrix-free path's step at cg_tol 1e-4, 7.9e-4 with CG to 0.1; with
  // dx zeroed there 7.7e-11 at either (test_sim_implicit's amg vs
  // matrix_free gap, 5 steps: 1.25e-4 without this, budget 1e-5).
  for (size_t i = 0; i < d->n3; i++)
    d->dx[i] *= d->is_free[i];
  s->times.cg_iterations += *iters;
  return 0;
}

// Whether the state x turns the body inside out: its signed measure (tets:
// volume; body.h) > 0 at x_n and <= 0 at x. Asked of unconverged steps only
// (the stopping rule above); the body's measure reads s->x, so x stands in
// for it during the call.
static int turned_inside_out(ek_sim *s, double *x, double *before, double *after) {
  *before = s->body->ops->measure(s);
  double *xn = s->x;
  s->x = x;
  *after = s->body->ops->measure(s);
  s->x = xn;
  return *before > 0 && !(*after > 0);
}

// The objective is not finite at x_n though its force is: name the first
// free vertex whose inertia, gravity and damping term (objective's loop) is
// not (e.g. gravity x mass x position above DBL_MAX), else the elastic
// energy. On this failure only.
static int start_not_finite(ek_sim *s, implicit_data *d, const double *x) {
  const double dt = s->scene.dt, a = 1 / (dt * dt), b = s->scene.damping / dt;
  const double *g = s->scene.gravity;
  for (size_t i = 0; i < s->nv; i++) {
    double term = 0;
    for (int k = 0; k < 3 && d->is_free[3 * i] != 0; k++) {
      const size_t j = 3 * i + (size_t)k;
      const double u = x[j] - d->xtil[j], w = x[j] - s->x[j];
      term += s->mass[i] * (0.5 * a * u * u - g[k] * x[j] + 0.5 * b * w * w);
    }
    if (!isfinite(term))
      return sim_fail(s,
                      "the objective is not finite at the start point: vertex %zu's inertia and "
                      "gravity term is %g (mass %g, position (%g, %g, %g), x_n + dt v_n (%g, %g, "
                      "%g), gravity (%g, %g, %g))",
                      i, term, s->mass[i], x[3 * i], x[3 * i + 1], x[3 * i + 2], d->xtil[3 * i],
                      d->xtil[3 * i + 1], d->xtil[3 * i + 2], g[0], g[1], g[2]);
  }
  return sim_fail(s, "the objective is not finite at the start point: the elastic energy is not "
                     "(its force is finite)");
}

static int implicit_step(ek_sim *s, void *data) {
  implicit_data *d = data;
  const ek_scene *sc = &s->scene;
  const double dt = sc->dt, t_next = s->t + dt;
  const double *g = sc->gravity;
  double *x = d->x;
  double free_mass = 0;
  if (d->body->ops->hessian_begin_step) {
    int rc = d->body->ops->hessian_begin_step(s, d->H);
    if (rc)
      return rc;
  }

  // 1. Held vertices at t_{n+1}; free ones start at x_n + dt v_n + dt^2 g
  // (assembled solvers: dt^2 a_n, above).
  double t0 = sim_now();
  const double am = (1 + sc->damping * dt) / (dt * dt);
  const int predict = d->acc && d->have_acc && d->acc_epoch == s->state_epoch;
  for (size_t i = 0; i < s->nv; i++) {
    const ek_scene_bc *bc = sim_bc_at(s, i, t_next);
    double vdummy[3];
    int is_free = !bc && s->inv_mass[i] > 0;
    for (int k = 0; k < 3; k++) {
      d->is_free[3 * i + k] = is_free;
      d->minv[3 * i + k] = is_free ? s->inv_mass[i] : 0;
      d->mdiag[3 * i + k] = is_free ? am * s->mass[i] : 0;
      d->xtil[3 * i + k] = s->x[3 * i + k] + dt * s->v[3 * i + k];
      const double a = predict ? d->acc[3 * i + k] : g[k];
      x[3 * i + k] = is_free ? d->xtil[3 * i + k] + dt * dt * a : s->x[3 * i + k];
    }
    if (bc)
      sim_bc_state(bc, s->x0 + 3 * i, t_next, x + 3 * i, vdummy);
    if (is_free)
      free_mass += s->mass[i];
  }
  s->times.line_search += sim_now() - t0;
  double phi;
  int rc = objective(s, d, x, d->g, &phi);
  if (rc)
    return rc;
  if (!isfinite(phi)) {
    for (size_t i = 0; i < d->n3; i++)
      if (d->is_free[i] != 0)
        x[i] = s->x[i];
    if ((rc = objective(s, d, x, d->g, &phi)))
      return rc;
    if (!isfinite(phi)) {
      // Even x_n with the held vertices moved leaves the domain: the
      // force check names the inverted tets.
      if ((rc = sim_forces(s, x)) || (rc = sim_check_forces(s, x)))
        return rc;
      return start_not_finite(s, d, x);
    }
  }

  // 2. Newton.
  double res = free_mass > 0 ? residual(d, s, d->g, free_mass) : 0;
  memset(&s->newton, 0, sizeof s->newton);
  s->newton.residual[0] = res;
  s->newton.phi[0] = phi;
  long it = 0;
  int stalled = 0;
  // Whether x has a clamped singular value (clamped models, line search).
  int x_clamped = d->dm_inv ? any_clamped(s, d, x) : 1;
  double *blocks = d->pre;
  // The forcing term's history (FORCING_MAX): the last residual and
  // tolerance; tight: cg_tol for the rest of the step.
  const int forcing = d->ps && implicit_petsc_forcing(d->ps);
  double res_prev = res, eta = sc->implicit.cg_tol;
  int tight = !forcing;
  // At least one iteration unless grad Phi is exactly 0 (the stopping rule
  // above).
  while ((res > sc->implicit.newton_tol || (it == 0 && res > 0)) && it < sc->implicit.max_newton &&
         free_mass > 0) {
    if ((rc = sim_stop_requested(s, "Newton iteration", it + 1, sc->implicit.max_newton)))
      return rc;
    long cg_its;
    double cg_rel;
    if (d->ps) {
      if (forcing) {
        if (it > 0 && res > FORCING_STALL * res_prev)
          tight = 1;
        eta = FORCING_MAX;
        if (tight) {
          eta = sc->implicit.cg_tol;
        } else if (it > 0) {
          const double q = res / res_prev;
          eta = fmin(FORCING_MAX, fmax(sc->implicit.cg_tol, FORCING_GAMMA * q * q));
        }
        implicit_petsc_set_rtol(d->ps, eta);
      }
      if ((rc = solve_assembled(s, d, &cg_its, &cg_rel)))
        return rc;
    } else {
      t0 = sim_now();
      const double summed = s->times.mpi_sum; // the ranks' sum is its own phase
      if ((rc = build_preconditioner(s, d, blocks)))
        return rc;
      s->times.preconditioner += sim_now() - t0 - (s->times.mpi_sum - summed);
      if ((rc = solve(s, d, blocks, &cg_its, &cg_rel)))
        return rc;
    }
    if (it < EK_SIM_NEWTON_TRACE) {
      s->newton.cg_iterations[it] = cg_its;
      s->newton.cg_relative[it] = cg_rel;
    }
    // An iteration the stopping rule forces (the start residual is already
    // at most newton_tol) tries the full step only: its step is below
    // newton_tol body sizes, where Phi is quadratic to rounding, so a full
    // step that neither decreases Phi nor the residual means the start
    // point is the solution to rounding (a body at rest); backtracking
    // there cost up to 40 gradient passes per step.
    const int forced = it == 0 && res <= sc->implicit.newton_tol;
    it++;
    // Line search on Phi along dx.
    t0 = sim_now();
    const double slope = dot(d, d->g, d->dx);
    double alpha = 1, phi_t = INFINITY, res_t = INFINITY;
    int accepted = 0, trial_clamped = 1;
    // From a clamped x: the first (largest) alpha whose trial passed Armijo
    // on Phi but not the residual test (the fallback, above).
    double alpha_phi = 0;
    s->times.line_search += sim_now() - t0;
    for (int bt = 0; bt < (forced ? 1 : MAX_BACKTRACKS); bt++) {
      if ((rc = sim_stop_requested(s, "line-search trial", bt + 1, MAX_BACKTRACKS)))
        return rc;
      res_t = INFINITY; // computed below only when a test needs it
      if ((rc = trial(s, d, x, alpha, &phi_t)))
        return rc;
      // Clamped models: Phi is the potential of the gradient on a segment
      // whose ends have no clamped singular value (their psi and P are the
      // model's there, material.h): Armijo on Phi as for any model. From
      // such an x, a trial with a clamped singular value is shortened
      // (where the test on Phi means nothing) until it has none; only the
      // last trial may enter the clamp, on the residual. From a clamped x,
      // the residual.
      int use_residual = d->hes.residual_merit;
      if (use_residual && d->dm_inv && isfinite(phi_t)) {
        trial_clamped = any_clamped(s, d, d->xt);
        use_residual = x_clamped || trial_clamped;
        if (!x_clamped && trial_clamped && bt + 1 < MAX_BACKTRACKS) {
          alpha *= 0.5;
          s->times.backtracks++;
          continue;
        }
      }
      if (isfinite(phi_t) && use_residual) {
        res_t = residual(d, s, d->gt, free_mass);
        accepted = res_t <= (1 - ARMIJO_C1 * alpha) * res;
        if (!accepted && x_clamped && alpha_phi == 0 && phi_t <= phi + ARMIJO_C1 * alpha * slope)
          alpha_phi = alpha;
      } else if (isfinite(phi_t)) {
        if (phi_t <= phi + ARMIJO_C1 * alpha * slope) {
          accepted = 1;
        } else if (phi_t - phi <= 1e-14 * fabs(phi) + 1e-300 ||
                   (d->ps && -slope <= PHI_FLAT * fabs(phi))) {
          // Within Phi's rounding, or (assembled solvers) a predicted
          // decrease Phi cannot resolve (PHI_FLAT): accept if the residual
          // decreases.
          res_t = residual(d, s, d->gt, free_mass);
          accepted = res_t < res;
        }
      }
      if (accepted)
        break;
      alpha *= 0.5;
      s->times.backtracks++;
      if (alpha_phi > 0 && alpha < alpha_phi * FALLBACK_SPAN)
        break;
    }
    if (!accepted && alpha_phi > 0) {
      // No trial decreased the residual from a clamped x: the fallback
      // trial, evaluated again (its gradient and eigensystems, so the state
      // and the next Hessian are its own).
      alpha = alpha_phi;
      if ((rc = trial(s, d, x, alpha, &phi_t)))
        return rc;
      trial_clamped = any_clamped(s, d, d->xt);
      res_t = residual(d, s, d->gt, free_mass);
      accepted = isfinite(phi_t);
    }
    if (!accepted) {
      stalled = 1;
      // The eigensystems now belong to the last trial; the state stays at
      // x (its gradient is in d->g).
      break;
    }
    x_clamped = trial_clamped;
    double *tmp = x;
    x = d->xt;
    d->xt = tmp;
    d->x = x;
    tmp = d->g;
    d->g = d->gt;
    d->gt = tmp;
    phi = phi_t;
    res_prev = res;
    res = res_t < INFINITY ? res_t : residual(d, s, d->g, free_mass);
    if (it <= EK_SIM_NEWTON_TRACE) {
      s->newton.alpha[it - 1] = alpha;
      s->newton.residual[it] = res;
      s->newton.phi[it] = phi;
      s->newton.iterations = (int)it;
    }
  }
  s->times.newton_iterations += it;
  s->times.last_residual = res;
  if (res > s->times.worst_residual)
    s->times.worst_residual = res;
  double v_before, v_after;
  if (res > sc->implicit.newton_tol && turned_inside_out(s, x, &v_before, &v_after)) {
    // The first inverted element of the state refused, for the message
    // (one pass, on this failure only).
    size_t first = 0;
    double first_J = NAN;
    const size_t inverted = s->body->ops->inverted_count(s, x, &first, &first_J);
    sim_fail(s,
             "Newton did not converge (residual %.3g > newton_tol %g after %ld iterations: %s) "
             "and its state turns the body inside out (signed volume %.4g -> %.4g; %zu of %zu "
             "%s inverted, first: %zu, J = %.3g); not applied",
             res, sc->implicit.newton_tol, it,
             stalled ? "the line search found no decrease" : "max_newton", v_before, v_after,
             inverted, s->nt, s->body->kind, first, first_J);
    return EK_SIM_EUNCONVERGED;
  }
  if (res > sc->implicit.newton_tol) {
    s->times.unconverged_steps++;
    if (s->times.unconverged_steps == 1)
      sim_warn(s,
               "%s: step %ld (t = %g s to %g s): Newton stopped at residual %.3g > newton_tol %g "
               "after %ld iterations (%s); counted in the summary",
               sc->path, s->n + 1, s->t, t_next, res, sc->implicit.newton_tol, it,
               stalled ? "the line search found no decrease" : "max_newton");
  }

  // 3. Velocities, held vertices' velocities, the ground.
  t0 = sim_now();
  for (size_t i = 0; i < s->nv; i++) {
    const ek_scene_bc *bc = sim_bc_at(s, i, t_next);
    double *xn = s->x_next + 3 * i, *vn = s->v_next + 3 * i;
    if (bc) {
      sim_bc_state(bc, s->x0 + 3 * i, t_next, xn, vn);
      continue;
    }
    for (int k = 0; k < 3; k++) {
      if (s->inv_mass[i] > 0) {
        xn[k] = x[3 * i + k];
        vn[k] = (xn[k] - s->x[3 * i + k]) / dt;
      } else { // no mass, no tet: moves on as in the explicit loop
        vn[k] = s->v[3 * i + k];
        xn[k] = s->x[3 * i + k] + dt * vn[k];
      }
    }
    sim_ground_contact(s, xn, vn);
  }
  if (d->acc) {
    for (size_t i = 0; i < d->n3; i++)
      d->acc[i] = (s->v_next[i] - s->v[i]) / dt;
    d->acc_epoch = s->state_epoch;
    d->have_acc = 1;
  }
  s->times.integration += sim_now() - t0;
  return 0;
}

static int implicit_explain(const ek_scene *s, FILE *out, int number) {
  const ek_scene_implicit *im = &s->implicit;
  fprintf(out,
          "  %d. backward Euler: minimise 1/(2 dt^2)|x - x~|_M^2 + E(x) - x.Mg + c/(2 dt)|x - "
          "x_n|_M^2 by Newton (newton_tol %g, max_newton %ld)\n",
          number, im->newton_tol, im->max_newton);
  if (im->linear_solver == EK_LINSOLVE_MATRIX_FREE)
    fprintf(
        out,
        "       per Newton iteration: gradient + the element data the Hessian reuses (one pass, "
        "double; what it takes per element: passes above); "
        "%s-preconditioned CG (cg_tol %g, max_cg %ld) with matrix-free products on the "
        "projected element Hessians in %s; backtracking line search (Armijo)\n",
        im->preconditioner == EK_PRECOND_JACOBI ? "Jacobi" : "block-Jacobi", im->cg_tol, im->max_cg,
        s->precision == 32 ? "f32" : "f64");
  else
    fprintf(
        out,
        "       per Newton iteration: gradient + the element data the Hessian reuses (one pass, "
        "double; what it takes per element: passes above); "
        "the projected element Hessians (%s) assembled into a CSR matrix, then %s; "
        "backtracking line search (Armijo)\n",
        s->precision == 32 ? "f32" : "f64",
        im->linear_solver == EK_LINSOLVE_AMG
            ? "PETSc CG + GAMG with the rigid-body near-null space (linear_solver amg)"
            : "PETSc sparse Cholesky (linear_solver direct)");
  fprintf(out, "       v = (x_{n+1} - x_n) / dt; the ground after the solve\n");
  return number + 1;
}

const sim_integrator sim_integrator_implicit = {
    .name = "implicit",
    .description = "backward Euler by Newton + matrix-free PCG on the projected element "
                   "Hessians (hessian.h): stable at any dt, damps high frequencies",
    .explain = implicit_explain,
    .create = implicit_create,
    .destroy = implicit_destroy,
    .step = implicit_step,
};
