// The implicit loop's assembled linear solvers on PETSc (implicit_petsc.h):
//   amg:    KSPCG + PCGAMG (smoothed aggregation; Adams et al. 2004, "Ultra-
//           scalable implicit finite element analyses in solid mechanics
//           with over a half a billion degrees of freedom") with the six
//           rigid-body modes as the near-null space (MatNullSpaceCreate-
//           RigidBody), as PETSc's elasticity examples (ksp ex56) set it,
//           those of the current positions at each rebuild
//           (PCSetCoordinates; AMG_REBUILD_EXCESS: when);
//   direct: KSPPREONLY + PCCHOLESKY by CHOLMOD (supernodal; Chen et al.
//           2008), else MUMPS, else PETSc's own.
// One sequential AIJ matrix with block size 3, created once from ek's CSR
// pattern (hessian.h); each solve copies the values in and sets the solver
// up again (the factorisation) or keeps it (AMG, by the rule below). PETSc is initialised on first
// use without its signal handlers (ek-sim's SIGINT handling stays) and with errors returned, not
// printed; PETSC_OPTIONS in the environment still reaches KSPSetFromOptions.
//
// Across MPI ranks (ek-sim under mpirun; sim/README.md "MPI"): an MPIAIJ
// matrix with block size 3 in the vertices' Morton order (implicit.c),
// rows owned by contiguous ranges of it, its pattern the union of the ranks' shares given once
// as COO entries (MatSetPreallocationCOO); each rank's elements' entries and the owner's diagonal
// go in with MatSetValuesCOO, which sums them (rows of other ranks included) in a fixed order;
// the same KSP and PC on PETSC_COMM_WORLD
// (the direct solver by MUMPS, the one parallel Cholesky of Debian's PETSc); the solution is
// gathered whole on every rank (VecScatterCreateToAll). AMG with at least SBAIJ_MIN_NNZ values
// per rank: CG and the finest smoother multiply by an MPISBAIJ copy of A's upper block triangle,
// as one process does by SBAIJ (setup_mpisbaij); GAMG builds from A.
#include "implicit_petsc.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_internal.h"

#ifndef EK_HAVE_PETSC

implicit_petsc *implicit_petsc_create(int direct, const ek_csr_pattern *pattern, const double *X,
                                      double rtol, long max_its, char *err, size_t errlen) {
  (void)pattern, (void)X, (void)rtol, (void)max_its;
  (void)direct;
  snprintf(err, errlen,
           "needs PETSc, and this build has none (install petsc-dev, e.g. apt-get install "
           "petsc-dev, and configure again; or use \"matrix_free\")");
  return NULL;
}
implicit_petsc *implicit_petsc_create_mpi(int direct, const ek_csr_pattern *local, size_t nv,
                                          const int32_t *perm, const double *X, double rtol,
                                          long max_its, char *err, size_t errlen) {
  (void)direct, (void)local, (void)nv, (void)perm, (void)X;
  (void)rtol;
  (void)max_its;
  snprintf(err, errlen, "built without PETSc");
  return NULL;
}
void implicit_petsc_destroy(implicit_petsc *p) { (void)p; }
void implicit_petsc_set_rtol(implicit_petsc *p, double rtol) { (void)p, (void)rtol; }
int implicit_petsc_forcing(const implicit_petsc *p) {
  (void)p;
  return 0;
}
int implicit_petsc_solve(implicit_petsc *p, const double *values, const double *diag,
                         const double *b, const double *pos, double *x, long *its, double *rel,
                         double *t_setup, double *t_solve, char *err, size_t errlen) {
  (void)p, (void)values, (void)diag, (void)b, (void)pos, (void)x, (void)its, (void)rel;
  (void)t_setup;
  (void)t_solve;
  snprintf(err, errlen, "built without PETSc");
  return -1;
}
// Without PETSc there is no MPI: ek-sim under mpirun runs N independent
// copies, so it refuses to start (each would write the same frames).
int implicit_mpi_start(char *err, size_t errlen) {
  const char *n = getenv("OMPI_COMM_WORLD_SIZE"), *m = getenv("PMI_SIZE");
  if ((n && strtol(n, NULL, 10) > 1) || (m && strtol(m, NULL, 10) > 1)) {
    snprintf(err, errlen,
             "launched by mpirun, but this build has no PETSc and so no MPI (install "
             "petsc-dev and configure again, or run without mpirun)");
    return -1;
  }
  return 0;
}
void implicit_mpi_finish(int rc) { (void)rc; }
int implicit_mpi_rank(void) { return 0; }
int implicit_mpi_size(void) { return 1; }
int implicit_mpi_sum(double *v, size_t n, char *err, size_t errlen) {
  (void)v, (void)n, (void)err, (void)errlen;
  return 0;
}
int ek_linear_solver_available(ek_linear_solver s) { return s == EK_LINSOLVE_MATRIX_FREE; }

#else
#include <petscksp.h>

// The rebuild rule's budget, in CG iterations: a rebuild costs about as
// much as 60-70 of the bracket's CG iterations (1 thread), so keeping the
// hierarchy while the iterations it adds stay below that bounds what a
// stale hierarchy costs by what a rebuild would (the ski-rental rule).
// Measured (bracket, 30 steps, busy 2-core Zen 5, CPU time; sim/README.md):
// the earlier rule (keep while a solve takes at most 2x + 5 the iterations
// after the last setup, then recompute) let CG climb from 9 to 40
// iterations per solve: PCGAMG reuses its prolongators by default
// (PCGAMGSetReuseInterpolation), so its "rebuilds" recomputed only the
// Galerkin products, the base for the 2x then grew with every one. Now
// every rebuild is a whole new hierarchy.
// Sixth round, with the cheaper Galerkin products ("rap", setup_solver):
// still flat around 60 (bracket, 10 steps, busy, CPU time, two rounds:
// 30: 15.1 CG iterations per Newton iteration, 13.54 / 13.48 s; 60: 15.4,
// 13.17 / 12.83 s; 100: 16.8, 13.85 / 13.92 s).
#define AMG_REBUILD_EXCESS 60

struct implicit_petsc {
  Mat A;
  // AMG: A's upper block triangle as SBAIJ (block size 3), the operator CG
  // and the finest level's smoother and residual multiply by (half A's
  // bytes); NULL: A alone. One process: sv[i] is the CSR value of S's i-th
  // stored value. Across ranks (MPISBAIJ): sv[i] is the place of S's i-th
  // value among this rank's values of A (those of A's diagonal part, adnnz
  // of them, first, then those of its off-diagonal part): first the sdn
  // values of S's diagonal block (its own array's order), written there
  // directly, then those of the blocks beyond this rank's columns, sbi /
  // sbj their block rows (global block columns), given to PETSc through
  // sbuf (MatSetValuesBlocked's order: block row by block row, row-major).
  Mat S;
  PetscInt *sv, snnz;
  PetscInt *sbi, *sbj, adnnz, sdn;
  PetscScalar *sbuf;
  KSP ksp;
  Vec b, x, r;
  PetscInt n, nnz;
  int direct;
  // AMG: the hierarchy is kept across solves until the iterations they
  // took beyond what the solve after its rebuild would have taken for
  // their tolerance add up to excess_max (excess: that sum so far). That
  // solve's rate: fresh_rate iterations per decade of its rtol (the
  // tolerance varies from solve to solve: implicit_petsc_set_rtol); 0:
  // none yet. rtol, atol, dtol, max_its: the next solve's; forcing:
  // implicit_petsc_forcing.
  double fresh_rate, excess, rtol;
  PetscReal atol, dtol;
  PetscInt excess_max, max_its;
  int forcing;
  // Across ranks: this rank's rows [rstart, rend) (PETSc's numbering),
  // PETSc's row of each of the body's rows (newrow) and the body's row of
  // each owned row (oldrow), the values in the order of the COO pattern
  // given to PETSc (cv: its share's nnz, then the owned rows' diagonals),
  // and the gather of x onto every rank.
  int mpi;
  PetscInt rstart, rend;
  PetscInt *newrow, *oldrow;
  PetscScalar *cv;
  Vec xall;
  VecScatter gather;
};

// The session (implicit_mpi_start): started here, its size and rank.
static int mpi_started, mpi_size = 1, mpi_rank;
// implicit_mpi_sum's buffer: every rank's values (mpi_size x cap).
static double *sum_buf;
static size_t sum_cap;

int ek_linear_solver_available(ek_linear_solver s) { return (unsigned)s < EK_LINSOLVE_COUNT; }

// A PETSc call: on error, its message into err and return -1.
#define PCHK(call)                                                                                 \
  do {                                                                                             \
    PetscErrorCode ierr_ = (call);                                                                 \
    if (ierr_) {                                                                                   \
      const char *text_ = NULL;                                                                    \
      PetscErrorMessage(ierr_, &text_, NULL);                                                      \
      snprintf(err, errlen, "PETSc: %s failed: %s (error %d)", #call, text_ ? text_ : "?",         \
               (int)ierr_);                                                                        \
      return -1;                                                                                   \
    }                                                                                              \
  } while (0)

// OpenBLAS's own threading (Debian's openblas-pthread: a thread per core),
// set where the library is loaded; a weak reference, so a build on another
// BLAS links and runs without it.
extern void openblas_set_num_threads(int) __attribute__((weak));

static int petsc_start(char *err, size_t errlen) {
  PetscBool up = PETSC_FALSE;
  PetscInitialized(&up);
  if (up)
    return 0;
  // The BLAS under CHOLMOD's supernodal factorisation (and PETSc's LAPACK
  // calls) on one thread, as the rest of PETSc's solve: OpenBLAS's threads
  // spin beside ek's and wait for one another, so on a busy core the direct
  // solve ran 2-12x slower, at 1 ek thread too (cantilever_implicit with
  // "direct", 2 busy loops: 324-2130 ms per step against 156-180;
  // sim/README.md, sixteenth round). OPENBLAS_NUM_THREADS, where set, stays.
  if (openblas_set_num_threads && !getenv("OPENBLAS_NUM_THREADS"))
    openblas_set_num_threads(1);
  PCHK(PetscOptionsSetValue(NULL, "-no_signal_handler", NULL));
  PCHK(PetscInitializeNoArguments());
  PCHK(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  return 0;
}

// ---- The MPI session ----

// Started by an MPI launcher (even with one process: Open MPI's mpirun
// then wants MPI_Init and MPI_Finalize from a process that uses MPI).
static int launched(void) {
  return getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMI_SIZE") || getenv("PMIX_RANK");
}

int implicit_mpi_start(char *err, size_t errlen) {
  if (!launched())
    return 0; // a plain run: PETSc starts on first use, as without MPI
  if (petsc_start(err, errlen) < 0)
    return -1;
  mpi_started = 1;
  PCHK(MPI_Comm_size(PETSC_COMM_WORLD, &mpi_size));
  PCHK(MPI_Comm_rank(PETSC_COMM_WORLD, &mpi_rank));
  return 0;
}

void implicit_mpi_finish(int rc) {
  if (!mpi_started) {
    // A plain run that used PETSc: finalise it too, so that diagnostics
    // asked for in PETSC_OPTIONS (-log_view, -ksp_view, ...) print at exit
    // (PetscFinalize prints them; sim/README.md "Assembled solvers").
    PetscBool up = PETSC_FALSE;
    PetscInitialized(&up);
    if (up) {
      fflush(stdout);
      PetscFinalize();
    }
    return;
  }
  fflush(stdout);
  fflush(stderr);
  if (rc != 0 && mpi_size > 1)
    MPI_Abort(PETSC_COMM_WORLD, rc);
  free(sum_buf);
  sum_buf = NULL;
  sum_cap = 0;
  PetscFinalize();
  mpi_started = 0;
}

int implicit_mpi_rank(void) { return mpi_rank; }
int implicit_mpi_size(void) { return mpi_size; }

int implicit_mpi_sum(double *v, size_t n, char *err, size_t errlen) {
  if (mpi_size == 1)
    return 0;
  if (n > (size_t)PETSC_MPI_INT_MAX) {
    snprintf(err, errlen, "MPI: %zu values in one reduction", n);
    return -1;
  }
  // MPI_Allreduce does not promise the same bits on every rank (MPI 4.0
  // sec. 6.9.1 only advises it); every rank summing all the ranks' values
  // in rank order does. One collective (MPI_Allgather), where a reduction
  // on rank 0 and its broadcast (until the ninth round) took two: with
  // "matrix_free" a sum runs per CG iteration, and each collective waits
  // for the ranks to meet. Measured (cantilever_implicit, matrix_free, 6
  // steps, 2 ranks, --mca mpi_yield_when_idle 1, busy 2-core Zen 4, load
  // 6.4-6.6, 3 interleaved rounds): step-time medians 8228, 3552, 2669 ms
  // -> 3065, 3184, 1745 ms. It receives mpi_size x n values per rank (the
  // reduction about 2 n): meant for the few ranks of a replicated state.
  if (n > sum_cap) {
    free(sum_buf);
    sum_cap = 0;
    if (!(sum_buf = malloc(n * (size_t)mpi_size * sizeof *sum_buf))) {
      snprintf(err, errlen, "MPI: out of memory for a sum of %d x %zu values", mpi_size, n);
      return -1;
    }
    sum_cap = n;
  }
  PCHK(MPI_Allgather(v, (int)n, MPI_DOUBLE, sum_buf, (int)n, MPI_DOUBLE, PETSC_COMM_WORLD));
  for (size_t i = 0; i < n; i++) {
    double t = sum_buf[i];
    for (int r = 1; r < mpi_size; r++)
      t += sum_buf[(size_t)r * n + i];
    v[i] = t;
  }
  return 0;
}

// ---- The solver ----

// KSP and PC on A (created, block size 3, values not yet set): AMG-CG with
// the rigid-body modes of X, or the direct solver.
static int setup_solver(implicit_petsc *p, const double *X, double rtol, long max_its, char *err,
                        size_t errlen) {
  PCHK(MatSetOption(p->A, MAT_SYMMETRIC, PETSC_TRUE));
  PCHK(MatSetOption(p->A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  PCHK(MatSetOption(p->A, MAT_SPD, PETSC_TRUE));
  PCHK(MatSetOption(p->A, MAT_SPD_ETERNAL, PETSC_TRUE));
  PCHK(MatCreateVecs(p->A, &p->x, &p->b));
  PCHK(VecDuplicate(p->b, &p->r));
  MPI_Comm comm = p->mpi ? PETSC_COMM_WORLD : PETSC_COMM_SELF;
  PCHK(KSPCreate(comm, &p->ksp));
  PC pc;
  PCHK(KSPGetPC(p->ksp, &pc));
  if (p->direct) {
    PCHK(KSPSetType(p->ksp, KSPPREONLY));
    PCHK(PCSetType(pc, PCCHOLESKY));
    if (p->mpi) {
#if defined(PETSC_HAVE_MUMPS)
      PCHK(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
#else
      snprintf(err, errlen, "linear_solver \"direct\" across MPI ranks needs PETSc with MUMPS");
      return -1;
#endif
    } else {
#if defined(PETSC_HAVE_SUITESPARSE)
      PCHK(PCFactorSetMatSolverType(pc, MATSOLVERCHOLMOD));
#elif defined(PETSC_HAVE_MUMPS)
      PCHK(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
#endif
    }
  } else {
    // The rigid-body modes of X (translations and the three rotations),
    // this rank's rows of them.
    Vec coords;
    MatNullSpace nsp;
    PCHK(VecDuplicate(p->b, &coords));
    PCHK(VecSetBlockSize(coords, 3));
    PetscScalar *c;
    PCHK(VecGetArray(coords, &c));
    for (PetscInt i = 0; i < p->rend - p->rstart; i++)
      c[i] = X[p->oldrow ? p->oldrow[i] : i];
    PCHK(VecRestoreArray(coords, &c));
    PCHK(MatNullSpaceCreateRigidBody(coords, &nsp));
    PCHK(MatSetNearNullSpace(p->A, nsp));
    PCHK(MatNullSpaceDestroy(&nsp));
    PCHK(VecDestroy(&coords));
    PCHK(KSPSetType(p->ksp, KSPCG));
    PCHK(PCSetType(pc, PCGAMG));
    // Smoothing by two Chebyshev-Jacobi iterations per level (PETSc's
    // GAMG default smoother; its eigenvalue bounds come from the setup and
    // stay with the hierarchy when it is kept for the next Newton
    // matrices: implicit_petsc_solve), a coarse problem of up to 1000
    // equations. Measured (busy 2-core Zen 5, 1 thread, CPU time,
    // interleaved): against one Richardson-Jacobi sweep of scale 0.5 (the
    // earlier choice), the cantilever 10.5 CG iterations per Newton
    // iteration instead of 18.4, 5.10 Newton iterations per step instead of
    // 5.00, ~10% less CPU time (0.94-0.95 s against 1.04-1.06 s for 30
    // steps); the bracket 10.8 instead of 18.2, ~4% less; twist_implicit
    // 11.6 instead of 18.8, ~8% less. One Chebyshev iteration: 16.4 on the
    // cantilever, ~7% less. Richardson scale 0.7 failed on the bracket;
    // SOR's setup failed on it (DIVERGED_PC_FAILED). An earlier session
    // saw Chebyshev's kept bounds go stale (the cantilever 29 Newton
    // iterations per step); with two iterations and this reuse rule these
    // runs saw 5.10, every step to newton_tol. PETSC_OPTIONS still wins.
    // Sixth round (bracket, 5 steps unless said, 1 thread, busy 2-core Zen
    // 5, CPU time of whole runs; the default: 4.40 Newton iterations per
    // step, 13.8 CG iterations per Newton iteration, 6.4-7.1 s), not kept:
    // -pc_gamg_agg_nsmooths 0 (27.3 CG iterations, 7.26 s: the cheap setup
    // does not pay); -mg_levels_ksp_max_it 3 (11.6, 7.28 s); -pc_gamg_
    // threshold 0 (14.0, 7.04 s); -pc_gamg_square_graph 0 (10 steps: 13.3
    // CG iterations, 37.9 s against 13.2); Chebyshev targets
    // -mg_levels_ksp_chebyshev_esteig 0,0.05,0,1.1 (13.6, same time) and
    // 0,0.2,0,1.1 (15.0, slower); -pc_gamg_esteig_ksp_max_it 5 and
    // -mg_levels_pc_type pbjacobi (the first solve fails: DIVERGED_
    // INDEFINITE_PC, DIVERGED_PC_FAILED); -matptap_via hypre (indefinite).
    // A looser CG tolerance (scene cg_tol 1e-3): the bracket 10.6 CG
    // iterations at the same 4.40 Newton iterations, 18% less CPU, but
    // twist_implicit 12.9 Newton iterations per step and 12 of its 60
    // steps above newton_tol (4.55 and 1 at 1e-4), so no fixed looser
    // tolerance. Seventh round: implicit.c's forcing term (with held dofs'
    // dx zeroed and its stall safeguard) varies it per Newton iteration.
    static const char *const defaults[][2] = {{"-mg_levels_ksp_type", "chebyshev"},
                                              {"-mg_levels_pc_type", "jacobi"},
                                              {"-mg_levels_ksp_max_it", "2"},
                                              {"-pc_gamg_coarse_eq_limit", "1000"}};
    for (size_t i = 0; i < sizeof defaults / sizeof defaults[0]; i++) {
      PetscBool set = PETSC_FALSE;
      PCHK(PetscOptionsHasName(NULL, NULL, defaults[i][0], &set));
      if (!set)
        PCHK(PetscOptionsSetValue(NULL, defaults[i][0], defaults[i][1]));
    }
    // One process: the Galerkin products P^T A P by forming P^T first
    // ("rap") instead of the default's sparse axpys ("scalable"); the same
    // coarse matrices up to rounding. Measured (bracket, 5 steps, 2
    // rebuilds, busy 2-core Zen 5, 1 thread, 3 interleaved pairs): GAMG's
    // PtAP 1.5-3.5 -> 0.8-2.2 s of wall time, CPU time of the whole run
    // 6.69 / 6.99 / 7.10 -> 5.93 / 6.30 / 6.36 s, CG and Newton iterations
    // unchanged; 10 steps, two rounds: 14.29 / 14.41 -> 13.24 / 12.78 s,
    // setup 543 / 537 -> 318 / 280 ms per step (wall). Across ranks the
    // MPIAIJ product has no "rap"; its others
    // ("nonscalable", "allatonce", "allatonce_merged", "backend") were no
    // faster than the default, allatonce 9x slower (2 ranks, 2 steps).
    PetscBool set = PETSC_FALSE;
    PCHK(PetscOptionsHasName(NULL, NULL, "-matptap_via", &set));
    if (!set && !p->mpi)
      PCHK(PetscOptionsSetValue(NULL, "-matptap_via", "rap"));
    // A rebuild is a whole new hierarchy (AMG_REBUILD_EXCESS says why).
    PCHK(PCGAMGSetReuseInterpolation(pc, PETSC_FALSE));
    p->excess_max = AMG_REBUILD_EXCESS;
    PCHK(PetscOptionsGetInt(NULL, NULL, "-ek_amg_rebuild_excess", &p->excess_max, NULL));
    PCHK(KSPSetNormType(p->ksp, KSP_NORM_UNPRECONDITIONED));
    PCHK(KSPSetTolerances(p->ksp, rtol, 1e-300, PETSC_DEFAULT, (PetscInt)max_its));
    PetscBool forcing = PETSC_TRUE;
    PCHK(PetscOptionsGetBool(NULL, NULL, "-ek_newton_forcing", &forcing, NULL));
    p->forcing = forcing == PETSC_TRUE;
  }
  PCHK(KSPSetFromOptions(p->ksp));
  // The tolerances each solve sets again (implicit_petsc_solve): those
  // after PETSC_OPTIONS, which win; a -ksp_rtol there also fixes CG's
  // tolerance for every solve (no forcing term).
  PetscReal r;
  PetscInt m;
  PetscBool fixed = PETSC_FALSE;
  PCHK(KSPGetTolerances(p->ksp, &r, &p->atol, &p->dtol, &m));
  PCHK(PetscOptionsHasName(NULL, NULL, "-ksp_rtol", &fixed));
  p->rtol = p->direct ? rtol : (double)r;
  p->max_its = p->direct ? (PetscInt)max_its : m;
  if (fixed)
    p->forcing = 0;
  return 0;
}

// The size from which S pays: AIJ's values at least 8 MiB. Measured (busy
// 2-core Zen 5, 1 thread, PETSc 3.18): the bracket (3.5 M nonzeros, A ~
// 40 MB, beyond the caches) solves ~25% faster with S, CG's iterations
// unchanged; the cantilever (~0.4 M, within L2/L3) ~5% slower: there the
// multiply is not bound by memory and SBAIJ's scattered transpose half
// costs more than the bytes it saves. Across ranks the same threshold
// applies to each rank's values (setup_mpisbaij). Measured (bracket, 10
// steps, 2 ranks, --threads 1, busy 2-core Zen 5 at load 4-5, two
// interleaved rounds; the same 4.90 Newton and 14.9 CG iterations): the
// MPISBAIJ operator against MPIAIJ, user CPU 18.4 / 20.2 -> 14.8 / 16.4 s,
// rank 0's solve 3.09 / 3.11 -> 2.09 / 2.62 s per step (wall, load-bound);
// filling its values takes 4-17 ms per solve (busy, wall, the wait for
// the other rank in the assembly included; its diagonal block in place),
// 11-20 ms all through MatSetValuesBlocked.
#define SBAIJ_MIN_NNZ ((size_t)1 << 20)

// S (struct implicit_petsc) from the pattern: its blocks (i, j >= i) and
// the map sv from its values (each block column-major: PETSc's BAIJ
// layout) to the CSR's. A pattern of other than dense 3x3 blocks
// (hessian.h promises them) leaves S unset.
static int setup_sbaij(implicit_petsc *p, const ek_csr_pattern *pat, char *err, size_t errlen) {
  const size_t nb = pat->nrows / 3;
  const int32_t *rp = pat->row_ptr, *col = pat->col;
  if (pat->nrows % 3 || pat->nnz % 9)
    return 0;
  PetscInt *bi = malloc((nb + 1) * sizeof *bi), *bj = malloc((pat->nnz / 9 + 1) * sizeof *bj);
  PetscInt *sv = malloc((pat->nnz + 1) * sizeof *sv);
  if (!bi || !bj || !sv) {
    free(bi), free(bj), free(sv);
    snprintf(err, errlen, "out of memory for the symmetric matrix pattern");
    return -1;
  }
  int dense = 1;
  size_t nbz = 0, ns = 0;
  bi[0] = 0;
  for (size_t i = 0; dense && i < nb; i++) {
    const int32_t k0 = rp[3 * i], len = rp[3 * i + 1] - k0;
    dense = len % 3 == 0 && rp[3 * i + 2] - rp[3 * i + 1] == len &&
            rp[3 * i + 3] - rp[3 * i + 2] == len;
    size_t b0 = nbz;
    for (int32_t k = 0; dense && k < len; k += 3) {
      const int32_t c = col[k0 + k];
      for (int r = 0; dense && r < 3; r++)
        for (int q = 0; q < 3; q++)
          dense = dense && col[rp[3 * i + r] + k + q] == c + q;
      dense = dense && c % 3 == 0;
      if (dense && (size_t)c / 3 >= i)
        bj[nbz++] = c / 3;
    }
    if (!dense)
      break;
    bi[i + 1] = (PetscInt)nbz;
    // Values of the blocks (i, j >= i): column-major within a block.
    for (size_t b = b0; b < nbz; b++)
      for (int q = 0; q < 3; q++)
        for (int r = 0; r < 3; r++) {
          const int32_t row = (int32_t)(3 * i) + r, k1 = rp[row];
          // The block's first column in row `row` (rows share columns).
          int32_t k = k1;
          while (col[k] != 3 * bj[b])
            k++;
          sv[ns++] = k + q;
        }
  }
  PetscErrorCode e = 0;
  if (dense) {
    e = MatCreate(PETSC_COMM_SELF, &p->S);
    if (!e)
      e = MatSetSizes(p->S, p->n, p->n, p->n, p->n);
    if (!e)
      e = MatSetType(p->S, MATSEQSBAIJ);
    if (!e)
      e = MatSeqSBAIJSetPreallocationCSR(p->S, 3, bi, bj, NULL);
  }
  free(bi), free(bj);
  if (!dense || e) {
    free(sv);
    MatDestroy(&p->S);
  } else {
    p->sv = sv;
    p->snnz = (PetscInt)ns;
  }
  PCHK(e);
  return 0;
}

static int setup(implicit_petsc *p, const ek_csr_pattern *pat, const double *X, double rtol,
                 long max_its, char *err, size_t errlen) {
  PetscInt *ia = malloc((pat->nrows + 1) * sizeof(PetscInt));
  PetscInt *ja = malloc((pat->nnz + 1) * sizeof(PetscInt));
  if (!ia || !ja) {
    free(ia), free(ja);
    snprintf(err, errlen, "out of memory for the matrix pattern");
    return -1;
  }
  for (size_t i = 0; i <= pat->nrows; i++)
    ia[i] = pat->row_ptr[i];
  for (size_t k = 0; k < pat->nnz; k++)
    ja[k] = pat->col[k];
  p->n = (PetscInt)pat->nrows;
  p->nnz = (PetscInt)pat->nnz;
  p->rstart = 0;
  p->rend = p->n;
  PetscErrorCode e = MatCreate(PETSC_COMM_SELF, &p->A);
  if (!e)
    e = MatSetSizes(p->A, p->n, p->n, p->n, p->n);
  if (!e)
    e = MatSetBlockSize(p->A, 3);
  if (!e)
    e = MatSetType(p->A, MATSEQAIJ);
  if (!e)
    e = MatSeqAIJSetPreallocationCSR(p->A, ia, ja, NULL);
  free(ia), free(ja);
  PCHK(e);
  PCHK(MatSetOption(p->A, MAT_NEW_NONZERO_LOCATION_ERR, PETSC_TRUE));
  // -ek_sbaij_min_nnz N (PETSC_OPTIONS) moves the threshold: tests/mpi.sh
  // runs the small scenes with S (0) against their plain runs.
  PetscInt min_nnz = (PetscInt)SBAIJ_MIN_NNZ;
  PCHK(PetscOptionsGetInt(NULL, NULL, "-ek_sbaij_min_nnz", &min_nnz, NULL));
  if (!p->direct && (PetscInt)pat->nnz >= min_nnz && setup_sbaij(p, pat, err, errlen) < 0)
    return -1;
  return setup_solver(p, X, rtol, max_its, err, errlen);
}

implicit_petsc *implicit_petsc_create(int direct, const ek_csr_pattern *pattern, const double *X,
                                      double rtol, long max_its, char *err, size_t errlen) {
  if (pattern->nnz > (size_t)PETSC_MAX_INT) {
    snprintf(err, errlen, "%zu nonzeros: more than this PETSc's indices hold", pattern->nnz);
    return NULL;
  }
  if (petsc_start(err, errlen) < 0)
    return NULL;
  implicit_petsc *p = calloc(1, sizeof *p);
  if (!p) {
    snprintf(err, errlen, "out of memory");
    return NULL;
  }
  p->direct = direct;
  if (setup(p, pattern, X, rtol, max_its, err, errlen) < 0) {
    implicit_petsc_destroy(p);
    return NULL;
  }
  return p;
}

// S's maps (struct implicit_petsc) from its block rows bi / bj (global
// block columns, sorted) and sv (block row by block row, row-major): the
// blocks within this rank's columns go to S's diagonal block (SeqSBAIJ:
// the same blocks in the same order, each column-major) when its pattern
// is that (checked; else every block goes through MatSetValuesBlocked:
// SBAIJ_MIN_NNZ has the figures). Takes bi,
// bj and sv.
static int split_mpisbaij(implicit_petsc *p, PetscInt nb, PetscInt *bi, PetscInt *bj, PetscInt *sv,
                          char *err, size_t errlen) {
  const PetscInt rb0 = p->rstart / 3, rb1 = p->rend / 3;
  Mat Sd;
  const PetscInt *ia = NULL, *ja = NULL;
  PetscInt nr = 0;
  PetscBool done = PETSC_FALSE;
  PCHK(MatGetDiagonalBlock(p->S, &Sd));
  PCHK(MatGetRowIJ(Sd, 0, PETSC_FALSE, PETSC_TRUE, &nr, &ia, &ja, &done));
  int same = done && nr == nb;
  for (PetscInt i = 0; same && i < nb; i++) {
    PetscInt k = bi[i], m = ia[i];
    for (; k < bi[i + 1] && bj[k] < rb1; k++, m++)
      same = same && m < ia[i + 1] && ja[m] == bj[k] - rb0;
    same = same && m == ia[i + 1];
  }
  if (done)
    PCHK(MatRestoreRowIJ(Sd, 0, PETSC_FALSE, PETSC_TRUE, &nr, &ia, &ja, &done));
  PetscInt *v = malloc(((size_t)p->snnz + 1) * sizeof *v);
  p->sbi = malloc(((size_t)nb + 1) * sizeof *p->sbi);
  p->sbuf = malloc(((size_t)p->snnz + 1) * sizeof *p->sbuf);
  if (!v || !p->sbi || !p->sbuf) {
    free(v), free(bi), free(bj), free(sv);
    snprintf(err, errlen, "out of memory for the symmetric matrix values");
    return -1;
  }
  // The diagonal block's values, then the rest's; bj keeps the rest's
  // columns (compacted in place).
  PetscInt nv = 0, no = 0;
  p->sbi[0] = 0;
  for (PetscInt i = 0; i < nb; i++) {
    const PetscInt n = bi[i + 1] - bi[i];
    PetscInt nd = 0;
    while (same && nd < n && bj[bi[i] + nd] < rb1)
      nd++;
    for (PetscInt b = 0; b < nd; b++)
      for (int q = 0; q < 3; q++)
        for (int r = 0; r < 3; r++)
          v[nv++] = sv[9 * bi[i] + r * 3 * n + 3 * b + q];
    p->sbi[i + 1] = p->sbi[i] + n - nd;
  }
  p->sdn = nv;
  for (PetscInt i = 0; i < nb; i++) {
    const PetscInt n = bi[i + 1] - bi[i], nd = n - (p->sbi[i + 1] - p->sbi[i]);
    for (int r = 0; r < 3; r++)
      for (PetscInt b = nd; b < n; b++)
        for (int q = 0; q < 3; q++)
          v[nv++] = sv[9 * bi[i] + r * 3 * n + 3 * b + q];
    for (PetscInt b = nd; b < n; b++)
      bj[no++] = bj[bi[i] + b];
  }
  free(bi), free(sv);
  p->sv = v;
  p->sbj = bj;
  return 0;
}

// Across ranks, AMG: S (struct implicit_petsc) as MPISBAIJ from A's
// assembled pattern (after MatSetPreallocationCOO: the union of the ranks'
// shares), this rank's block rows of it, when every rank holds at least
// -ek_sbaij_min_nnz of A's values and its rows are dense 3x3 blocks; else
// S stays unset on every rank (the decision is collective).
static int setup_mpisbaij(implicit_petsc *p, char *err, size_t errlen) {
  Mat Ad, Ao;
  const PetscInt *garray, *di, *dj, *oi, *oj;
  PetscInt nd, no;
  PetscBool okd = PETSC_FALSE, oko = PETSC_FALSE;
  PCHK(MatMPIAIJGetSeqAIJ(p->A, &Ad, &Ao, &garray));
  PCHK(MatGetRowIJ(Ad, 0, PETSC_FALSE, PETSC_FALSE, &nd, &di, &dj, &okd));
  PCHK(MatGetRowIJ(Ao, 0, PETSC_FALSE, PETSC_FALSE, &no, &oi, &oj, &oko));
  const PetscInt nloc = p->rend - p->rstart, nb = nloc / 3;
  PetscInt min_nnz = (PetscInt)SBAIJ_MIN_NNZ;
  PCHK(PetscOptionsGetInt(NULL, NULL, "-ek_sbaij_min_nnz", &min_nnz, NULL));
  int ok =
      okd && oko && nd == nloc && no == nloc && nloc % 3 == 0 && di[nloc] + oi[nloc] >= min_nnz;
  // Each block row's upper blocks: those of its first row, whose other two
  // rows must hold the same columns; a block's place among A's values
  // (diagonal part: local columns; off-diagonal part: garray's, sorted).
  const PetscInt cstart = p->rstart, nad = ok ? di[nloc] : 0;
  PetscInt *bi = ok ? malloc(((size_t)nb + 1) * sizeof *bi) : NULL;
  PetscInt *bj = ok ? malloc(((size_t)(di[nloc] + oi[nloc]) / 9 + 1) * sizeof *bj) : NULL;
  PetscInt *sv = ok ? malloc(((size_t)(di[nloc] + oi[nloc]) + 1) * sizeof *sv) : NULL;
  if (ok && (!bi || !bj || !sv))
    ok = 0;
  PetscInt nbz = 0, ns = 0;
  if (ok)
    bi[0] = 0;
  for (PetscInt i = 0; ok && i < nb; i++) {
    const PetscInt r0 = 3 * i;
    // The first row's upper columns: diagonal part from column r0 on, then
    // the off-diagonal part's columns beyond this rank's rows.
    PetscInt b0 = nbz, kd = di[r0], ko = oi[r0];
    while (kd < di[r0 + 1] && dj[kd] < r0)
      kd++;
    while (ko < oi[r0 + 1] && garray[oj[ko]] < p->rend)
      ko++;
    const PetscInt kd0 = kd, ko0 = ko;
    for (PetscInt k = kd0; ok && k < di[r0 + 1]; k += 3) {
      ok = k + 2 < di[r0 + 1] && dj[k] % 3 == 0 && dj[k + 1] == dj[k] + 1 && dj[k + 2] == dj[k] + 2;
      if (ok)
        bj[nbz++] = (cstart + dj[k]) / 3;
    }
    for (PetscInt k = ko0; ok && k < oi[r0 + 1]; k += 3) {
      ok = k + 2 < oi[r0 + 1] && garray[oj[k]] % 3 == 0 && garray[oj[k + 1]] == garray[oj[k]] + 1 &&
           garray[oj[k + 2]] == garray[oj[k]] + 2;
      if (ok)
        bj[nbz++] = garray[oj[k]] / 3;
    }
    // The values, row by row of the block row: the same columns in each
    // row (the diagonal part's from kd0 - di[r0] entries in, as in row r0
    // shifted by the row's start; checked).
    for (PetscInt r = 0; ok && r < 3; r++) {
      const PetscInt row = r0 + r;
      PetscInt jd = di[row], jo = oi[row];
      while (jd < di[row + 1] && dj[jd] < r0)
        jd++;
      while (jo < oi[row + 1] && garray[oj[jo]] < p->rend)
        jo++;
      ok = di[row + 1] - jd == di[r0 + 1] - kd0 && oi[row + 1] - jo == oi[r0 + 1] - ko0;
      for (PetscInt b = b0; ok && b < nbz; b++)
        for (PetscInt q = 0; ok && q < 3; q++) {
          const PetscInt c = 3 * bj[b] + q;
          if (c < p->rend) {
            ok = dj[jd] + cstart == c;
            sv[ns + (b - b0) * 3 + q] = jd++;
          } else {
            ok = garray[oj[jo]] == c;
            sv[ns + (b - b0) * 3 + q] = nad + jo++;
          }
        }
      ns += 3 * (nbz - b0);
    }
    if (ok)
      bi[i + 1] = nbz;
  }
  // sv above is row-major per block row (row r, block b, column q):
  // MatSetValuesBlocked's layout for one block row of nbz - b0 blocks.
  PCHK(MatRestoreRowIJ(Ad, 0, PETSC_FALSE, PETSC_FALSE, &nd, &di, &dj, &okd));
  PCHK(MatRestoreRowIJ(Ao, 0, PETSC_FALSE, PETSC_FALSE, &no, &oi, &oj, &oko));
  int all = 0;
  PCHK(MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, PETSC_COMM_WORLD));
  PetscErrorCode e = 0;
  if (all) {
    e = MatCreate(PETSC_COMM_WORLD, &p->S);
    if (!e)
      e = MatSetSizes(p->S, nloc, nloc, p->n, p->n);
    if (!e)
      e = MatSetType(p->S, MATMPISBAIJ);
    if (!e)
      e = MatMPISBAIJSetPreallocationCSR(p->S, 3, bi, bj, NULL);
    if (!e)
      e = MatSetOption(p->S, MAT_NEW_NONZERO_LOCATION_ERR, PETSC_TRUE);
  }
  int good = !e, allgood = 0;
  PCHK(MPI_Allreduce(&good, &allgood, 1, MPI_INT, MPI_MIN, PETSC_COMM_WORLD));
  if (all && allgood) {
    p->snnz = ns;
    p->adnnz = nad;
    return split_mpisbaij(p, nb, bi, bj, sv, err, errlen);
  }
  free(bi), free(bj), free(sv);
  MatDestroy(&p->S);
  PCHK(e);
  return 0;
}

implicit_petsc *implicit_petsc_create_mpi(int direct, const ek_csr_pattern *local, size_t nv,
                                          const int32_t *perm, const double *X, double rtol,
                                          long max_its, char *err, size_t errlen) {
  if (local->nnz > (size_t)PETSC_MAX_INT || 3 * nv > (size_t)PETSC_MAX_INT) {
    snprintf(err, errlen, "%zu nonzeros: more than this PETSc's indices hold", local->nnz);
    return NULL;
  }
  if (!mpi_started) {
    snprintf(err, errlen, "no MPI session (implicit_mpi_start)");
    return NULL;
  }
  implicit_petsc *p = calloc(1, sizeof *p);
  if (!p) {
    snprintf(err, errlen, "out of memory");
    return NULL;
  }
  p->direct = direct;
  p->mpi = 1;
  // Rank r owns the vertices [nv r / size, nv (r + 1) / size).
  const size_t v0 = nv * (size_t)mpi_rank / (size_t)mpi_size;
  const size_t v1 = nv * (size_t)(mpi_rank + 1) / (size_t)mpi_size;
  p->n = (PetscInt)(3 * nv);
  p->nnz = (PetscInt)local->nnz;
  p->rstart = (PetscInt)(3 * v0);
  p->rend = (PetscInt)(3 * v1);
  const PetscInt nloc = p->rend - p->rstart;
  const size_t ncoo = local->nnz + (size_t)nloc;
  p->newrow = malloc((3 * nv + 1) * sizeof(PetscInt));
  p->oldrow = malloc(((size_t)nloc + 1) * sizeof(PetscInt));
  p->cv = malloc((ncoo + 1) * sizeof(PetscScalar));
  PetscInt *ci = malloc((ncoo + 1) * sizeof(PetscInt)), *cj = malloc((ncoo + 1) * sizeof(PetscInt));
  if (!p->newrow || !p->oldrow || !p->cv || !ci || !cj || local->nrows != 3 * nv) {
    snprintf(err, errlen, "%s",
             local->nrows != 3 * nv ? "the pattern is not 3 nv rows" : "no memory");
    free(ci), free(cj);
    implicit_petsc_destroy(p);
    return NULL;
  }
  for (size_t r = 0; r < 3 * nv; r++) {
    const PetscInt q = 3 * (PetscInt)perm[r / 3] + (PetscInt)(r % 3);
    p->newrow[r] = q;
    if (q >= p->rstart && q < p->rend)
      p->oldrow[q - p->rstart] = (PetscInt)r;
  }
  // The COO pattern: this rank's share (a row of 3 entries is a vertex in
  // none of its elements, a vertex in a tet having at least 4 blocks:
  // hessian.h's pattern; its zeros are left out by a negative row, which
  // PETSc skips), then each owned row's diagonal. PETSc sums repeated
  // entries, the other ranks' included, in an order fixed here once: one
  // message per neighbour per assembly instead of MatSetValues' stash.
  for (size_t r = 0; r < 3 * nv; r++) {
    const int32_t k0 = local->row_ptr[r], k1 = local->row_ptr[r + 1];
    for (int32_t k = k0; k < k1; k++) {
      ci[k] = k1 - k0 > 3 ? p->newrow[r] : -1;
      cj[k] = p->newrow[local->col[k]];
    }
  }
  for (PetscInt q = 0; q < nloc; q++)
    ci[local->nnz + (size_t)q] = cj[local->nnz + (size_t)q] = p->rstart + q;
  int rc = -1;
  PetscErrorCode e = MatCreate(PETSC_COMM_WORLD, &p->A);
  if (!e)
    e = MatSetSizes(p->A, nloc, nloc, p->n, p->n);
  if (!e)
    e = MatSetBlockSize(p->A, 3);
  if (!e)
    e = MatSetType(p->A, MATMPIAIJ);
  if (e) {
    const char *text = NULL;
    PetscErrorMessage(e, &text, NULL);
    snprintf(err, errlen, "PETSc: the parallel matrix: %s", text ? text : "?");
  } else if (MatSetPreallocationCOO(p->A, (PetscCount)ncoo, ci, cj) == 0 &&
             (direct || setup_mpisbaij(p, err, errlen) == 0) &&
             setup_solver(p, X, rtol, max_its, err, errlen) == 0 &&
             VecScatterCreateToAll(p->x, &p->gather, &p->xall) == 0) {
    rc = 0;
  } else if (!err[0]) {
    snprintf(err, errlen, "PETSc: the parallel solver's setup failed");
  }
  free(ci), free(cj);
  if (rc < 0) {
    implicit_petsc_destroy(p);
    return NULL;
  }
  return p;
}

void implicit_petsc_destroy(implicit_petsc *p) {
  if (!p)
    return;
  KSPDestroy(&p->ksp);
  VecDestroy(&p->x);
  VecDestroy(&p->b);
  VecDestroy(&p->r);
  VecDestroy(&p->xall);
  VecScatterDestroy(&p->gather);
  MatDestroy(&p->A);
  MatDestroy(&p->S);
  free(p->sv);
  free(p->sbi);
  free(p->sbj);
  free(p->sbuf);
  free(p->cv);
  free(p->newrow);
  free(p->oldrow);
  free(p);
}

// A's values: one process copies them into its AIJ arrays (the pattern's
// order is PETSc's); across ranks each rank adds its share, rows of other
// ranks included, and the owner its diagonal.
static int set_values(implicit_petsc *p, const double *values, const double *diag, char *err,
                      size_t errlen) {
  if (!p->mpi) {
    PetscScalar *a;
    PCHK(MatSeqAIJGetArrayWrite(p->A, &a));
    memcpy(a, values, (size_t)p->nnz * sizeof(double));
    PCHK(MatSeqAIJRestoreArrayWrite(p->A, &a));
    if (p->S) {
      PCHK(MatSeqSBAIJGetArray(p->S, &a));
      for (PetscInt i = 0; i < p->snnz; i++)
        a[i] = values[p->sv[i]];
      PCHK(MatSeqSBAIJRestoreArray(p->S, &a));
      PCHK(MatAssemblyBegin(p->S, MAT_FINAL_ASSEMBLY));
      PCHK(MatAssemblyEnd(p->S, MAT_FINAL_ASSEMBLY));
    }
    return 0;
  }
  memcpy(p->cv, values, (size_t)p->nnz * sizeof(double));
  for (PetscInt q = 0; q < p->rend - p->rstart; q++)
    p->cv[p->nnz + q] = diag[p->oldrow[q]];
  PCHK(MatSetValuesCOO(p->A, p->cv, INSERT_VALUES));
  if (p->S) {
    Mat Ad, Ao;
    const PetscInt *garray;
    const PetscScalar *ad, *ao;
    PCHK(MatMPIAIJGetSeqAIJ(p->A, &Ad, &Ao, &garray));
    PCHK(MatSeqAIJGetArrayRead(Ad, &ad));
    PCHK(MatSeqAIJGetArrayRead(Ao, &ao));
    Mat Sd;
    PetscScalar *a;
    PCHK(MatGetDiagonalBlock(p->S, &Sd));
    PCHK(MatSeqSBAIJGetArray(Sd, &a));
    for (PetscInt i = 0; i < p->sdn; i++)
      a[i] = p->sv[i] < p->adnnz ? ad[p->sv[i]] : ao[p->sv[i] - p->adnnz];
    PCHK(MatSeqSBAIJRestoreArray(Sd, &a));
    for (PetscInt i = p->sdn; i < p->snnz; i++)
      p->sbuf[i - p->sdn] = p->sv[i] < p->adnnz ? ad[p->sv[i]] : ao[p->sv[i] - p->adnnz];
    PCHK(MatSeqAIJRestoreArrayRead(Ad, &ad));
    PCHK(MatSeqAIJRestoreArrayRead(Ao, &ao));
    const PetscInt nb = (p->rend - p->rstart) / 3;
    for (PetscInt i = 0; i < nb; i++) {
      const PetscInt row = p->rstart / 3 + i, k0 = p->sbi[i];
      if (p->sbi[i + 1] > k0)
        PCHK(MatSetValuesBlocked(p->S, 1, &row, p->sbi[i + 1] - k0, p->sbj + k0, p->sbuf + 9 * k0,
                                 INSERT_VALUES));
    }
    PCHK(MatAssemblyBegin(p->S, MAT_FINAL_ASSEMBLY));
    PCHK(MatAssemblyEnd(p->S, MAT_FINAL_ASSEMBLY));
  }
  return 0;
}

void implicit_petsc_set_rtol(implicit_petsc *p, double rtol) { p->rtol = rtol; }
int implicit_petsc_forcing(const implicit_petsc *p) { return p->forcing; }

// GAMG's near-null space for its next rebuild: the rigid-body modes of
// pos (this rank's rows), through PCSetCoordinates (PETSc's smoothed
// aggregation then builds the three translations and the three rotations
// from them; a rebuild would otherwise reuse the modes of its first setup,
// those of the rest shape X).
static int rigid_modes_now(implicit_petsc *p, PC pc, const double *pos, char *err, size_t errlen) {
  const PetscInt nloc = p->rend - p->rstart;
  PetscReal *c = malloc(((size_t)nloc + 1) * sizeof *c);
  if (!c) {
    snprintf(err, errlen, "out of memory for the coordinates");
    return -1;
  }
  for (PetscInt i = 0; i < nloc; i++)
    c[i] = pos[p->oldrow ? p->oldrow[i] : i];
  PetscErrorCode e = PCSetCoordinates(pc, 3, nloc / 3, c);
  free(c);
  PCHK(e);
  return 0;
}

int implicit_petsc_solve(implicit_petsc *p, const double *values, const double *diag,
                         const double *b, const double *pos, double *x, long *its, double *rel,
                         double *t_setup, double *t_solve, char *err, size_t errlen) {
  double t0 = sim_now();
  int rc;
  if (set_values(p, values, diag, err, errlen) < 0)
    return -1;
  PCHK(KSPSetOperators(p->ksp, p->S ? p->S : p->A, p->A));
  PetscScalar *bv;
  PCHK(VecGetArrayWrite(p->b, &bv));
  if (p->mpi)
    for (PetscInt i = 0; i < p->rend - p->rstart; i++)
      bv[i] = b[p->oldrow[i]];
  else
    memcpy(bv, b, (size_t)p->n * sizeof(double));
  PCHK(VecRestoreArrayWrite(p->b, &bv));
  // AMG: keep the last hierarchy (a preconditioner of a nearby matrix; CG
  // still solves with the new one to rtol) until the iterations the kept
  // solves took beyond the fresh one's rate add up to excess_max, then
  // rebuild it, its near-null space the rigid-body modes of the current
  // positions pos; rebuild also after a kept one failed
  // (AMG_REBUILD_EXCESS says why).
  int keep = !p->direct && p->fresh_rate > 0 && p->excess < p->excess_max;
  const double decades = -log10(p->rtol);
  if (!p->direct)
    PCHK(KSPSetTolerances(p->ksp, p->rtol, p->atol, p->dtol, p->max_its));
  PC pc;
  PCHK(KSPGetPC(p->ksp, &pc));
  KSPConvergedReason why;
  PetscInt n;
  for (int attempt = 0; attempt < 2; attempt++) {
    PCHK(KSPSetReusePreconditioner(p->ksp, keep ? PETSC_TRUE : PETSC_FALSE));
    if (!keep && !p->direct && pos && (rc = rigid_modes_now(p, pc, pos, err, errlen)) < 0)
      return rc;
    PCHK(KSPSetUp(p->ksp));
    double t1 = sim_now();
    *t_setup += t1 - t0;
    PCHK(KSPSolve(p->ksp, p->b, p->x));
    *t_solve += sim_now() - t1;
    t0 = sim_now();
    PCHK(KSPGetConvergedReason(p->ksp, &why));
    PCHK(KSPGetIterationNumber(p->ksp, &n));
    if (keep && why < 0) {
      keep = 0; // the kept hierarchy failed: rebuild, solve again
      continue;
    }
    if (!keep) {
      p->fresh_rate = n > 0 ? (double)n / decades : 0;
      p->excess = 0;
    } else if ((double)n > p->fresh_rate * decades) {
      p->excess += (double)n - p->fresh_rate * decades;
    }
    break;
  }
  if (why < 0 && why != KSP_DIVERGED_ITS) {
    snprintf(err, errlen, "PETSc: the %s solve failed: %s after %ld iterations",
             p->direct ? "direct" : "AMG-CG", KSPConvergedReasons[why], (long)n);
    return -1;
  }
  // The true residual (the direct solver reports none).
  PetscReal rn, bn;
  PCHK(MatMult(p->A, p->x, p->r));
  PCHK(VecAYPX(p->r, -1, p->b));
  PCHK(VecNorm(p->r, NORM_2, &rn));
  PCHK(VecNorm(p->b, NORM_2, &bn));
  Vec whole = p->x;
  if (p->mpi) {
    PCHK(VecScatterBegin(p->gather, p->x, p->xall, INSERT_VALUES, SCATTER_FORWARD));
    PCHK(VecScatterEnd(p->gather, p->x, p->xall, INSERT_VALUES, SCATTER_FORWARD));
    whole = p->xall;
  }
  const PetscScalar *xv;
  PCHK(VecGetArrayRead(whole, &xv));
  if (p->mpi)
    for (PetscInt r = 0; r < p->n; r++)
      x[r] = xv[p->newrow[r]];
  else
    memcpy(x, xv, (size_t)p->n * sizeof(double));
  PCHK(VecRestoreArrayRead(whole, &xv));
  *its = p->direct ? 1 : (long)n;
  *rel = bn > 0 ? rn / bn : 0;
  *t_solve += sim_now() - t0;
  return 0;
}
#endif
