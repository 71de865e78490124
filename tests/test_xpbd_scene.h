// The XPBD tests' scene (test_xpbd.c, test_xpbd_snh.c): a random box mesh
// (test_fvm_common.h), lumped masses m_i = density * sum of V_t / 4 over
// vertex i's tets, inverse masses (a fraction `pinned` of the vertices
// held), the bounding-box diagonal, the reference's tet and cluster sets
// (reference/xpbd) and the element layer; and the helpers both tests
// share (rounding, the largest difference, the library in either precision).
#ifndef EK_TEST_XPBD_SCENE_H
#define EK_TEST_XPBD_SCENE_H

#include <ek/elements.h>
#include <ek/xpbd.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_fvm_common.h"
#include "xpbd/xpbd_ref.h"

typedef struct {
  test_mesh t;
  double *mass, *w, diag;
  ek_xpbd_ref_set set[EK_XPBD_ELEMENTS_COUNT];
  ek_tets *el;
} scene;

static inline void scene_init(scene *sc, ek_rng *rng, int nx, int ny, int nz, double pinned,
                              double density) {
  sc->t = test_mesh_random(rng, nx, ny, nz, 0.2);
  size_t nv = sc->t.nverts;
  if (ek_xpbd_ref_tets(nv, sc->t.X, sc->t.ntets, sc->t.T, &sc->set[EK_XPBD_TETS])) {
    printf("ek_xpbd_ref_tets failed\nFAIL\n");
    exit(1);
  }
  sc->mass = calloc(nv, sizeof(double));
  sc->w = malloc(nv * sizeof(double));
  for (size_t e = 0; e < sc->t.ntets; e++)
    for (int k = 0; k < 4; k++)
      sc->mass[sc->t.T[4 * e + k]] += density * sc->set[EK_XPBD_TETS].V[e] / 4;
  for (size_t v = 0; v < nv; v++)
    sc->w[v] = ek_rng_uniform(rng) < pinned ? 0 : 1 / sc->mass[v];
  size_t bad = 0;
  if (ek_xpbd_ref_clusters(nv, sc->t.X, sc->t.ntets, sc->t.T, sc->mass, &sc->set[EK_XPBD_CLUSTERS],
                           &bad)) {
    printf("ek_xpbd_ref_clusters failed at vertex %zu\nFAIL\n", bad);
    exit(1);
  }
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t v = 0; v < nv; v++)
    for (int r = 0; r < 3; r++) {
      lo[r] = fmin(lo[r], sc->t.X[3 * v + r]);
      hi[r] = fmax(hi[r], sc->t.X[3 * v + r]);
    }
  sc->diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                  (hi[2] - lo[2]) * (hi[2] - lo[2]));
  sc->el = ek_tets_create(nv, sc->t.X, sc->t.ntets, sc->t.T);
  if (!sc->el) {
    printf("ek_tets_create: %s\nFAIL\n", ek_last_error());
    exit(1);
  }
}

static inline void scene_free(scene *sc) {
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++)
    ek_xpbd_ref_free(&sc->set[e]);
  free(sc->mass);
  free(sc->w);
  ek_tets_destroy(sc->el);
  test_mesh_free(&sc->t);
}

// Momentum change of one substep h as the tests measure it,
// |sum_i m_i (x_i - pred_i)| / h relative to sum_i m_i |v0_i|, with
// v0 = (pred - xs) / h and m_i = 1 / w_i (every vertex free).
static inline double scene_momentum_error(const scene *sc, double h, const double *w,
                                          const double *xs, const double *pred, const double *x) {
  double dp[3] = {0, 0, 0}, p = 0;
  for (size_t v = 0; v < sc->t.nverts; v++) {
    double m = 1 / w[v], v0 = 0;
    for (int r = 0; r < 3; r++) {
      dp[r] += m * (x[3 * v + r] - pred[3 * v + r]) / h;
      double vr = (pred[3 * v + r] - xs[3 * v + r]) / h;
      v0 += vr * vr;
    }
    p += m * sqrt(v0);
  }
  return fmax(fabs(dp[0]), fmax(fabs(dp[1]), fabs(dp[2]))) / p;
}

// ---- Helpers both XPBD tests use ----
// Round x to the precision's values (so f32 and f64 runs start alike).
static inline void round_to(int prec, size_t n, double *x) {
  if (prec == 32)
    for (size_t i = 0; i < n; i++)
      x[i] = (float)x[i];
}

// Largest |a - b| (NaN counts as the worst).
static inline double max_abs_diff(size_t n, const double *a, const double *b) {
  double e = 0;
  for (size_t i = 0; i < n; i++) {
    double d = fabs(a[i] - b[i]);
    if (!(d <= e)) // NaN counts as the worst
      e = d;
  }
  return e;
}

// Members of the reference set's constraint j: K vertices and the rest
// data b.
static inline const int32_t *ref_members(const ek_xpbd_ref_set *s, size_t j, const double **b,
                                         int *K) {
  *K = s->start[j + 1] - s->start[j];
  *b = s->b + 3 * ((size_t)s->start[j] - j);
  return s->members + s->start[j];
}

// The library in either precision, on double arrays (exact for float
// values).
static inline int lib_iterate(ek_xpbd *xp, int prec, size_t n3, double *x, int iterations) {
  if (prec == 64)
    return ek_xpbd_iterate_f64(xp, NULL, x, iterations);
  float *xf = malloc(n3 * sizeof(float));
  for (size_t i = 0; i < n3; i++)
    xf[i] = (float)x[i];
  int rc = ek_xpbd_iterate_f32(xp, NULL, xf, iterations);
  for (size_t i = 0; i < n3; i++)
    x[i] = xf[i];
  free(xf);
  return rc;
}

static inline int lib_residual(const ek_xpbd *xp, int prec, size_t n3, const double *x, double *res,
                               double *cmax) {
  if (prec == 64)
    return ek_xpbd_residual_f64(xp, NULL, x, res, cmax);
  float *xf = malloc(n3 * sizeof(float));
  for (size_t i = 0; i < n3; i++)
    xf[i] = (float)x[i];
  int rc = ek_xpbd_residual_f32(xp, NULL, xf, res, cmax);
  free(xf);
  return rc;
}

// e: the library's substep h (the scene's weights, `sweeps` sweeps from xs
// rounded to o's precision) at 1, 2 and 3 threads: 1 if all give the same
// bits of the positions, the multipliers (nlam per constraint: lambda, and
// lambda_H where nlam is 2) and the residual.
static inline int lib_same_bits_1_2_3_threads(const scene *sc, const ek_material *mat, double young,
                                              ek_xpbd_opts o, double h, int sweeps,
                                              const double *xs, int nlam) {
  const size_t n3 = 3 * sc->t.nverts, n = sc->set[o.elements].n;
  double *x[3], *lam[3], res[3][2];
  int ok = 1;
  for (int r = 0; r < 3; r++) {
    x[r] = malloc(n3 * sizeof(double));
    lam[r] = malloc(nlam * n * sizeof(double));
  }
  // 3 threads on 2 cores: the Gauss-Seidel schedule's split at n = 3 and its
  // oversubscribed wait.
  for (int r = 0; r < 3 && ok; r++) {
    omp_set_num_threads(r + 1);
    ek_xpbd *xp = ek_xpbd_create(sc->el, mat, young, sc->mass, &o);
    if (!xp)
      printf("ek_xpbd_create: %s\n", ek_last_error());
    // x is updated in place (xpbd.h): the same start xs every call; the
    // multipliers and the residual are written: poisoned first, so one a
    // chunk did not write cannot match (lam[r] may be a freed buffer of the
    // previous call holding its right values).
    memcpy(x[r], xs, n3 * sizeof(double));
    round_to(o.precision, n3, x[r]);
    ek_check_poison(lam[r], nlam * n * sizeof(double));
    ek_check_poison(res[r], sizeof res[r]);
    int rc = xp ? ek_xpbd_set_weights(xp, sc->w) : EK_EINVAL;
    rc = rc ? rc : ek_xpbd_begin(xp, h);
    rc = rc ? rc : lib_iterate(xp, o.precision, n3, x[r], sweeps);
    rc = rc ? rc : ek_xpbd_lambda(xp, lam[r]);
    rc = rc || nlam < 2 ? rc : ek_xpbd_lambda_h(xp, lam[r] + n);
    rc = rc ? rc : lib_residual(xp, o.precision, n3, x[r], &res[r][0], &res[r][1]);
    ok &= rc == 0;
    ek_xpbd_destroy(xp);
  }
  omp_set_num_threads(2);
  for (int r = 1; r < 3; r++)
    ok = ok && memcmp(x[0], x[r], n3 * sizeof(double)) == 0 &&
         memcmp(lam[0], lam[r], nlam * n * sizeof(double)) == 0 &&
         memcmp(res[0], res[r], sizeof res[0]) == 0;
  for (int r = 0; r < 3; r++) {
    free(x[r]);
    free(lam[r]);
  }
  return ok;
}

// f: scene_momentum_error of the library's substep h (weights w, `sweeps`
// sweeps from pred, xs and pred rounded to o's precision first); NaN where
// the library fails. *dv gets max |x - pred| / h (the velocity change).
static inline double lib_momentum_error(const scene *sc, const ek_material *mat, double young,
                                        ek_xpbd_opts o, double h, int sweeps, const double *w,
                                        const double *xs, const double *pred, double *dv) {
  const size_t n3 = 3 * sc->t.nverts;
  ek_xpbd *xp = ek_xpbd_create(sc->el, mat, young, sc->mass, &o);
  double *xs_p = malloc(n3 * sizeof(double)), *pr = malloc(n3 * sizeof(double));
  double *x = malloc(n3 * sizeof(double));
  memcpy(xs_p, xs, n3 * sizeof(double));
  memcpy(pr, pred, n3 * sizeof(double));
  round_to(o.precision, n3, xs_p);
  round_to(o.precision, n3, pr);
  memcpy(x, pr, n3 * sizeof(double));
  int rc = xp ? 0 : EK_EINVAL;
  rc = rc ? rc : ek_xpbd_set_weights(xp, w);
  rc = rc ? rc : ek_xpbd_begin(xp, h);
  rc = rc ? rc : lib_iterate(xp, o.precision, n3, x, sweeps);
  double err = rc == 0 ? scene_momentum_error(sc, h, w, xs_p, pr, x) : NAN;
  *dv = max_abs_diff(n3, x, pr) / h;
  free(xs_p);
  free(pr);
  free(x);
  ek_xpbd_destroy(xp);
  return err;
}

#endif
