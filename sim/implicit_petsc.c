// The implicit loop's assembled linear solvers on PETSc (implicit_petsc.h):
//   amg:    KSPCG + PCGAMG (smoothed aggregation; Adams et al. 2004, "Ultra-
//           scalable implicit finite element analyses in solid mechanics
//           with over a half a billion degrees of freedom") with the six
//           rigid-body modes as the near-null space (MatNullSpaceCreate-
//           RigidBody), as PETSc's elasticity examples (ksp ex56) set it;
//   direct: KSPPREONLY + PCCHOLESKY by CHOLMOD (supernodal; Chen et al.
//           2008), else MUMPS, else PETSc's own.
// One sequential AIJ matrix with block size 3, created once from ek's CSR
// pattern (hessian.h); each solve copies the values in and sets the solver
// up again. PETSc is initialised on first use without its signal handlers
// (ek-sim's SIGINT handling stays) and with errors returned, not printed;
// PETSC_OPTIONS in the environment still reaches KSPSetFromOptions.
#include "implicit_petsc.h"

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
void implicit_petsc_destroy(implicit_petsc *p) { (void)p; }
int implicit_petsc_solve(implicit_petsc *p, const double *values, const double *b, double *x,
                         long *its, double *rel, double *t_setup, double *t_solve, char *err,
                         size_t errlen) {
  (void)p, (void)values, (void)b, (void)x, (void)its, (void)rel, (void)t_setup, (void)t_solve;
  snprintf(err, errlen, "built without PETSc");
  return -1;
}
int ek_linear_solver_available(ek_linear_solver s) { return s == EK_LINSOLVE_MATRIX_FREE; }

#else
#include <petscksp.h>

struct implicit_petsc {
  Mat A;
  KSP ksp;
  Vec b, x, r;
  PetscInt n, nnz;
  int direct;
  // AMG: the hierarchy is kept across solves while they stay cheap (fresh:
  // the iterations of the last solve after a rebuild; last: the last
  // solve's; 0 = rebuild).
  long fresh_its, last_its;
};

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

static int petsc_start(char *err, size_t errlen) {
  PetscBool up = PETSC_FALSE;
  PetscInitialized(&up);
  if (up)
    return 0;
  PCHK(PetscOptionsSetValue(NULL, "-no_signal_handler", NULL));
  PCHK(PetscInitializeNoArguments());
  PCHK(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
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
  PCHK(MatSetOption(p->A, MAT_SYMMETRIC, PETSC_TRUE));
  PCHK(MatSetOption(p->A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  PCHK(MatSetOption(p->A, MAT_SPD, PETSC_TRUE));
  PCHK(MatSetOption(p->A, MAT_SPD_ETERNAL, PETSC_TRUE));
  PCHK(MatCreateVecs(p->A, &p->x, &p->b));
  PCHK(VecDuplicate(p->b, &p->r));
  PCHK(KSPCreate(PETSC_COMM_SELF, &p->ksp));
  PC pc;
  PCHK(KSPGetPC(p->ksp, &pc));
  if (p->direct) {
    PCHK(KSPSetType(p->ksp, KSPPREONLY));
    PCHK(PCSetType(pc, PCCHOLESKY));
#if defined(PETSC_HAVE_SUITESPARSE)
    PCHK(PCFactorSetMatSolverType(pc, MATSOLVERCHOLMOD));
#elif defined(PETSC_HAVE_MUMPS)
    PCHK(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
#endif
  } else {
    // The rigid-body modes of X (translations and the three rotations).
    Vec coords;
    MatNullSpace nsp;
    PCHK(VecCreateSeq(PETSC_COMM_SELF, p->n, &coords));
    PCHK(VecSetBlockSize(coords, 3));
    PetscScalar *c;
    PCHK(VecGetArray(coords, &c));
    for (PetscInt i = 0; i < p->n; i++)
      c[i] = X[i];
    PCHK(VecRestoreArray(coords, &c));
    PCHK(MatNullSpaceCreateRigidBody(coords, &nsp));
    PCHK(MatSetNearNullSpace(p->A, nsp));
    PCHK(MatNullSpaceDestroy(&nsp));
    PCHK(VecDestroy(&coords));
    PCHK(KSPSetType(p->ksp, KSPCG));
    PCHK(PCSetType(pc, PCGAMG));
    // Smoothing by one damped Jacobi sweep per level (Richardson, scale
    // 0.5), not PETSc's Chebyshev: the hierarchy is kept for the next
    // Newton matrices (implicit_petsc_solve), and Chebyshev's eigenvalue
    // bounds then go stale: CG's directions were poor (the cantilever took
    // 29 Newton iterations per step instead of 5, 900 backtracks). SOR was
    // faster on the cantilever but its setup failed on the bracket
    // (DIVERGED_PC_FAILED). A coarse problem of up to 1000 equations.
    // Measured (busy 2-core Zen 5, 1 thread): the cantilever 18 CG
    // iterations per Newton iteration, ~100 ms per step (PETSc's defaults
    // with a rebuild per solve: 11 iterations, ~140 ms); the bracket 17.5.
    // PETSC_OPTIONS still wins.
    static const char *const defaults[][2] = {{"-mg_levels_ksp_type", "richardson"},
                                              {"-mg_levels_pc_type", "jacobi"},
                                              {"-mg_levels_ksp_richardson_scale", "0.5"},
                                              {"-mg_levels_ksp_max_it", "1"},
                                              {"-pc_gamg_coarse_eq_limit", "1000"}};
    for (size_t i = 0; i < sizeof defaults / sizeof defaults[0]; i++) {
      PetscBool set = PETSC_FALSE;
      PCHK(PetscOptionsHasName(NULL, NULL, defaults[i][0], &set));
      if (!set)
        PCHK(PetscOptionsSetValue(NULL, defaults[i][0], defaults[i][1]));
    }
    PCHK(KSPSetNormType(p->ksp, KSP_NORM_UNPRECONDITIONED));
    PCHK(KSPSetTolerances(p->ksp, rtol, 1e-300, PETSC_DEFAULT, (PetscInt)max_its));
  }
  PCHK(KSPSetFromOptions(p->ksp));
  return 0;
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

void implicit_petsc_destroy(implicit_petsc *p) {
  if (!p)
    return;
  KSPDestroy(&p->ksp);
  VecDestroy(&p->x);
  VecDestroy(&p->b);
  VecDestroy(&p->r);
  MatDestroy(&p->A);
  free(p);
}

int implicit_petsc_solve(implicit_petsc *p, const double *values, const double *b, double *x,
                         long *its, double *rel, double *t_setup, double *t_solve, char *err,
                         size_t errlen) {
  double t0 = sim_now();
  PetscScalar *a;
  PCHK(MatSeqAIJGetArrayWrite(p->A, &a));
  memcpy(a, values, (size_t)p->nnz * sizeof(double));
  PCHK(MatSeqAIJRestoreArrayWrite(p->A, &a));
  PCHK(KSPSetOperators(p->ksp, p->A, p->A));
  PetscScalar *bv;
  PCHK(VecGetArrayWrite(p->b, &bv));
  memcpy(bv, b, (size_t)p->n * sizeof(double));
  PCHK(VecRestoreArrayWrite(p->b, &bv));
  // AMG: keep the last hierarchy (a preconditioner of a nearby matrix; CG
  // still solves with the new one to rtol) while a solve takes at most
  // twice the iterations of the one after its rebuild, plus 5; rebuild
  // after one that took more, or failed.
  const int reuse = !p->direct && p->fresh_its > 0 && p->last_its <= 2 * p->fresh_its + 5;
  KSPConvergedReason why;
  PetscInt n;
  for (int attempt = reuse ? 0 : 1; attempt < 2; attempt++) {
    PCHK(KSPSetReusePreconditioner(p->ksp, attempt == 0 ? PETSC_TRUE : PETSC_FALSE));
    PCHK(KSPSetUp(p->ksp));
    double t1 = sim_now();
    *t_setup += t1 - t0;
    PCHK(KSPSolve(p->ksp, p->b, p->x));
    *t_solve += sim_now() - t1;
    t0 = sim_now();
    PCHK(KSPGetConvergedReason(p->ksp, &why));
    PCHK(KSPGetIterationNumber(p->ksp, &n));
    if (attempt == 0 && why < 0)
      continue; // the kept hierarchy failed: rebuild, solve again
    if (attempt == 1)
      p->fresh_its = (long)n;
    p->last_its = (long)n;
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
  const PetscScalar *xv;
  PCHK(VecGetArrayRead(p->x, &xv));
  memcpy(x, xv, (size_t)p->n * sizeof(double));
  PCHK(VecRestoreArrayRead(p->x, &xv));
  *its = p->direct ? 1 : (long)n;
  *rel = bn > 0 ? rn / bn : 0;
  *t_solve += sim_now() - t0;
  return 0;
}
#endif
