// Internal: the implicit loop's assembled linear solvers on PETSc (sim/
// implicit_petsc.c; ek_scene_implicit.linear_solver "amg" and "direct").
// Built with or without PETSc (CMake: EK_HAVE_PETSC); without it create
// fails with a message that says so.
#ifndef EK_SIM_IMPLICIT_PETSC_H
#define EK_SIM_IMPLICIT_PETSC_H

#include <ek/hessian.h>
#include <stddef.h>

typedef struct implicit_petsc implicit_petsc;

// The solver for matrices of `pattern` (3 dofs per vertex); X (nrows / 3 x
// 3): the positions whose rigid-body modes are AMG's near-null space.
// NULL with the message in err.
implicit_petsc *implicit_petsc_create(int direct, const ek_csr_pattern *pattern, const double *X,
                                      double rtol, long max_its, char *err, size_t errlen);
void implicit_petsc_destroy(implicit_petsc *p);

// Solves A x = b, A's values (the pattern's order) given; *its the
// Krylov iterations (1 for the direct solver), *rel |b - A x|_2 / |b|_2,
// seconds of setup (hierarchy or factorisation) and solve added to
// *t_setup, *t_solve. < 0 with the message in err.
int implicit_petsc_solve(implicit_petsc *p, const double *values, const double *b, double *x,
                         long *its, double *rel, double *t_setup, double *t_solve, char *err,
                         size_t errlen);

#endif
