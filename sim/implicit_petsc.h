// Internal: the implicit loop's assembled linear solvers on PETSc (sim/
// implicit_petsc.c; ek_scene_implicit.linear_solver "amg" and "direct"),
// and the MPI session of ek-sim under mpirun (PETSc's MPI). Built with or
// without PETSc (CMake: EK_HAVE_PETSC); without it create fails with a
// message that says so, and the session is always one process.
#ifndef EK_SIM_IMPLICIT_PETSC_H
#define EK_SIM_IMPLICIT_PETSC_H

#include <ek/hessian.h>
#include <stddef.h>
#include <stdint.h>

typedef struct implicit_petsc implicit_petsc;

// ---- The MPI session (ek-sim; sim/README.md "MPI") ----
// Started only when the process was launched by an MPI launcher (mpirun
// sets OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK): PETSc and MPI are
// initialised then, before anything else runs. A plain run starts nothing
// here (PETSc starts on first use, as before), so its bits and behaviour
// are those of a build without MPI. 0, or -1 with the message in err.
int implicit_mpi_start(char *err, size_t errlen);
// If implicit_mpi_start started them: PetscFinalize (and MPI_Finalize)
// when rc is 0; else MPI_Abort with rc, which ends every rank (one that
// failed alone would leave the others waiting in a collective call).
void implicit_mpi_finish(int rc);
// This process's rank and the number of ranks (0 and 1 without a session).
int implicit_mpi_rank(void);
int implicit_mpi_size(void);
// v[0..n) = the sum over ranks of v, the same bits on every rank (every
// rank adds all the ranks' values in rank order; the replicated Newton loop
// then takes the same decisions everywhere). Collective. 0, or -1 with the
// message in err.
int implicit_mpi_sum(double *v, size_t n, char *err, size_t errlen);

// ---- The solver ----
// One process: the solver for matrices of `pattern` (3 dofs per vertex);
// X (nrows / 3 x 3): the positions whose rigid-body modes are AMG's
// near-null space. NULL with the message in err.
implicit_petsc *implicit_petsc_create(int direct, const ek_csr_pattern *pattern, const double *X,
                                      double rtol, long max_its, char *err, size_t errlen);
// Across the session's ranks (implicit_mpi_size() > 1): `local` is the
// pattern of this rank's elements' Hessian over all nv vertices (the body's
// numbering: every rank holds every vertex); perm[v] is vertex v's place in
// PETSc's numbering, whose rows rank r owns from place nv r / size to
// nv (r + 1) / size; the parallel matrix's pattern is the union of the
// ranks' `local` patterns. Collective.
implicit_petsc *implicit_petsc_create_mpi(int direct, const ek_csr_pattern *local, size_t nv,
                                          const int32_t *perm, const double *X, double rtol,
                                          long max_its, char *err, size_t errlen);
void implicit_petsc_destroy(implicit_petsc *p);

// Solves A x = b, A's values (the pattern's order) given; *its the
// Krylov iterations (1 for the direct solver), *rel |b - A x|_2 / |b|_2,
// seconds of setup (hierarchy or factorisation) and solve added to
// *t_setup, *t_solve. < 0 with the message in err.
// Across ranks (implicit_petsc_create_mpi): values are this rank's share
// (its elements' entries, added to those of the other ranks), diag (3 nv)
// the diagonal each row's owner adds once, b (3 nv) the whole right-hand
// side (each rank reads its rows), and x (3 nv) comes back whole on every
// rank; all in the body's numbering. Collective. diag is NULL for one
// process. pos (3 nv, whole): the current positions, whose rigid-body
// modes an AMG rebuild takes as its near-null space (NULL: those of X).
int implicit_petsc_solve(implicit_petsc *p, const double *values, const double *diag,
                         const double *b, const double *pos, double *x, long *its, double *rel,
                         double *t_setup, double *t_solve, char *err, size_t errlen);
// The Krylov solver's relative tolerance (|b - A x|_2 <= rtol |b|_2) for
// the next solves (the loop's forcing term: implicit.c); the direct
// solver ignores it. Whether the loop should vary it: 1 for AMG unless
// PETSC_OPTIONS says -ek_newton_forcing 0, else 0 (the scene's cg_tol
// throughout).
void implicit_petsc_set_rtol(implicit_petsc *p, double rtol);
int implicit_petsc_forcing(const implicit_petsc *p);

#endif
