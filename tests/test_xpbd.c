// XPBD with the Hookean constraint of seed 001 (include/ek/xpbd.h) and its
// scalar double reference (reference/xpbd/xpbd_ref.c):
//   a. the reference's grad C equals central differences of its C, tets
//      and clusters, on a jittered, renumbered box deformed by ~10%; and
//      the seed's S F is not the derivative where F and S do not commute
//      (F S matches the differences, S F does not);
//   b. the reference's dlambda solves its linearised scalar equation
//      C + grad C . dx + alpha~ (lambda + dlambda) = 0;
//   c. at rest (x = X) the library leaves x bitwise unchanged, lambda 0
//      and nothing NaN (every ISA x precision x solver x elements);
//   d. the library against the reference, every ISA x precision x solver
//      x elements: positions after a few sweeps (EK_XPBD_TOL_F32/_F64),
//      multipliers, residuals, and the constraint data (members, b);
//   e. the same bits at 1, 2 and 3 threads, above the parallel threshold;
//   f. a free body without gravity keeps its momentum;
//   g. bad arguments are refused with a message; ISAs the CPU lacks are
//      reported as skipped.
#include <ek/elements.h>
#include <ek/xpbd.h>
#include <omp.h>

#include "cli.h"
#include "test_fvm_common.h"
#include "test_tolerances.h"
#include "test_xpbd_scene.h"
#include "xpbd/xpbd_ref.h"

// Material and substep of every scene: a stiff rubber, E = 10 MPa,
// nu = 0.3, density 1000 kg/m^3, cells of 0.1 m, h = 1 ms. Then
// k sum_i w_i |grad_i C|^2 (k = V E h^2) spans ~0.1 to ~10 over the tets
// (~0.1 to ~2 over the clusters): neither only the stiff nor only the
// compliant limit.
#define YOUNG 1e7
#define NU 0.3
#define MU (YOUNG / (2 * (1 + NU)))
#define LAMBDA (YOUNG * NU / ((1 + NU) * (1 - 2 * NU)))
#define DENSITY 1000.0
#define SUBSTEP 1e-3
#define SWEEPS 4
#define CELL 0.1

// a: central differences of C with step 1e-6 of a cell (1e-7 m): rounding
// of C (~1e-16 |x| |grad C|) over the step is ~1e-9 of |grad C|, truncation
// (step^2 times C''' ~ 1/(cell^3 strain^2)) below that; the material
// reference's FD budget (EK_MATERIAL_FD_TOL).
#define EK_XPBD_FD_TOL 1e-6
#define EK_XPBD_FD_STEP (1e-6 * CELL)
// a: S F's gradient misses the differences by at least this (relative to
// |grad C|) on the non-commuting deformation (a rotated shear): there
// F S - S F is of the order of P itself (0.9 |F S| with this seed),
// 10^4 times the FD budget.
#define EK_XPBD_SF_GAP 1e-2
// b: the linearised equation C + grad C . dx + alpha~ (lambda + dlambda),
// relative to the sum of its terms' sizes: dx is read back as x_new - x_old
// (rounding u |x| per component, |x| <= ~0.3 m here, times |grad C| ~
// 1/cell, against terms ~0.1): ~1e-14; 1e-12 leaves a factor 100.
#define EK_XPBD_LIN_TOL 1e-12
// d: b_k of the library against the reference's, both in double from the
// same rest positions by different inverses (Dm^-1, Q^-1): rounding times
// the condition of Dm or Q (< 100 on the jittered box), max over a
// constraint relative to its largest |b_k|.
#define EK_XPBD_B_TOL 1e-12
// f: momentum, |sum_i m_i (v_i - v0_i)| / sum_i m_i |v0_i|, v = (x - x_start)
// / h. Every position update rounds x by up to u |x| (|x| <= ~0.3 m here),
// u |x| / (h |v|) of a vertex's velocity (h |v| ~ 1.6 mm): f64 2^-53 *
// 200 ~ 2e-14 per update; ~80 updates per vertex (n_i ~ 20 constraints x
// SWEEPS) and ~80 vertices adding like random walks, relative to the sum
// of |m v|: ~2e-14 expected, so 1e-12. f32: 2^-24 * 200 ~ 1e-5 per update,
// the same accumulation, ~1e-5 expected: float positions know the velocity
// only to that, so 1e-4.
#define EK_XPBD_MOMENTUM_TOL_F64 1e-12
#define EK_XPBD_MOMENTUM_TOL_F32 1e-4

static int failures = 0;

static void fail_if(int bad, const char *what) {
  printf("%-64s %s\n", what, bad ? "FAIL" : "PASS");
  failures += bad != 0;
}

static const ek_xpbd_ref_material ref_mat = {MU, LAMBDA, YOUNG, 0};
static const ek_material lib_mat = {EK_MODEL_STVK, MU, LAMBDA, 0};

static double cmin_of(int prec) { return prec == 32 ? EK_XPBD_C_MIN_F32 : EK_XPBD_C_MIN_F64; }
static double tol_of(int prec) { return prec == 32 ? EK_XPBD_TOL_F32 : EK_XPBD_TOL_F64; }

// x = Q (I + strain G) X + noise (test_deform) without the random
// translation, so |x| stays ~0.3 m and the rounding of x is that of the
// mesh's scale.
static void deform(ek_rng *rng, const scene *sc, double strain, double *x) {
  test_deform(rng, &sc->t, strain, 0.1, x);
  double c[3] = {0, 0, 0};
  for (size_t v = 0; v < sc->t.nverts; v++)
    for (int r = 0; r < 3; r++)
      c[r] += x[3 * v + r] / (double)sc->t.nverts;
  for (size_t v = 0; v < sc->t.nverts; v++)
    for (int r = 0; r < 3; r++)
      x[3 * v + r] -= c[r];
}

static int any_nan(size_t n, const double *x) {
  for (size_t i = 0; i < n; i++)
    if (isnan(x[i]))
      return 1;
  return 0;
}

// ---- The library's XPBD object ----

static ek_xpbd *lib_create(const scene *sc, int elements, int solver, ek_isa isa, int prec) {
  ek_xpbd_opts o = {.elements = (ek_xpbd_elements)elements,
                    .solver = (ek_xpbd_solver)solver,
                    .isa = isa,
                    .precision = prec};
  ek_xpbd *xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, sc->mass, &o);
  if (!xp) {
    printf("ek_xpbd_create(%s, %s, %s, f%d): %s\nFAIL\n", ek_xpbd_elements_name(o.elements),
           ek_xpbd_solver_name(o.solver), ek_isa_name(isa), prec, ek_last_error());
    failures++;
  }
  return xp;
}

// `sweeps` reference sweeps of a solver; Gauss-Seidel in `order`.
static void ref_sweeps(const ek_xpbd_ref_set *s, int solver, const double *w, double cmin,
                       const int32_t *order, int sweeps, double *x, double *lambda) {
  for (int it = 0; it < sweeps; it++)
    if (solver == EK_XPBD_GAUSS_SEIDEL)
      ek_xpbd_ref_gauss_seidel(s, &ref_mat, w, SUBSTEP, cmin, s->n, order, x, lambda);
    else
      ek_xpbd_ref_jacobi(s, &ref_mat, w, SUBSTEP, cmin, x, lambda);
}

// G = max_j sum_k |grad_k C_j|: a position error of at most d per vertex
// moves any C_j by at most G d (first order). The multipliers (as
// alpha~ lambda, which tends to -C) and the residuals are held to the
// position budget through it: an error e in C units is reported as
// e / (G diag), comparable with EK_XPBD_TOL_F32/_F64.
static double grad_scale(const ek_xpbd_ref_set *s, const double *x, double cmin) {
  double G = 0, *g = malloc(3 * 64 * sizeof(double));
  for (size_t j = 0; j < s->n; j++) {
    int K;
    const double *b;
    const int32_t *mem = ref_members(s, j, &b, &K);
    if (K > 64)
      continue;
    double C = ek_xpbd_ref_eval(&ref_mat, K, mem, b, x, cmin, g);
    if (!(C > cmin))
      continue;
    double sum = 0;
    for (int k = 0; k < K; k++)
      sum += sqrt(g[3 * k] * g[3 * k] + g[3 * k + 1] * g[3 * k + 1] + g[3 * k + 2] * g[3 * k + 2]);
    G = fmax(G, sum);
  }
  free(g);
  return G;
}

// ---- a: gradients by central differences ----
static double fd_error(const ek_xpbd_ref_set *s, size_t j, double *x, const double *grad) {
  int K;
  const double *b;
  const int32_t *mem = ref_members(s, j, &b, &K);
  double err = 0, scale = 0;
  for (int k = 0; k < K; k++)
    for (int r = 0; r < 3; r++) {
      double *xi = x + 3 * mem[k] + r, x0 = *xi;
      *xi = x0 + EK_XPBD_FD_STEP;
      double Cp = ek_xpbd_ref_eval(&ref_mat, K, mem, b, x, 0, NULL);
      *xi = x0 - EK_XPBD_FD_STEP;
      double Cm = ek_xpbd_ref_eval(&ref_mat, K, mem, b, x, 0, NULL);
      *xi = x0;
      double fd = (Cp - Cm) / (2 * EK_XPBD_FD_STEP);
      double d = fabs(fd - grad[3 * k + r]);
      if (!(d <= err))
        err = d;
      scale = fmax(scale, fabs(grad[3 * k + r]));
    }
  return err / scale;
}

static void check_fd(const scene *sc, ek_rng *rng) {
  size_t n3 = sc->t.nverts * 3;
  double *x = malloc(n3 * sizeof(double)), *g = malloc(3 * 64 * sizeof(double));
  deform(rng, sc, 0.1, x);
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++) {
    const ek_xpbd_ref_set *s = &sc->set[e];
    double worst = 0;
    size_t skipped = 0;
    for (size_t j = 0; j < s->n; j++) {
      int K;
      const double *b;
      const int32_t *mem = ref_members(s, j, &b, &K);
      double C = ek_xpbd_ref_eval(&ref_mat, K, mem, b, x, EK_XPBD_C_MIN_F64, g);
      if (!(C > EK_XPBD_C_MIN_F64) || K > 64) {
        skipped++;
        continue;
      }
      double err = fd_error(s, j, x, g);
      if (!(err <= worst))
        worst = err;
    }
    char label[160];
    snprintf(label, sizeof label,
             "a. reference grad C = central differences, %s (%zu, %zu skipped)",
             ek_xpbd_elements_name((ek_xpbd_elements)e), s->n, skipped);
    failures += ek_check_report(label, worst, EK_XPBD_FD_TOL);
  }
  free(x);
  free(g);
}

// S (the second Piola-Kirchhoff stress) of StVK at F.
static void stvk_S(const double F[9], double S[9]) {
  double e[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      e[3 * i + j] =
          0.5 * (F[i] * F[j] + F[3 + i] * F[3 + j] + F[6 + i] * F[6 + j] - (double)(i == j));
  double tr = e[0] + e[4] + e[8];
  for (int k = 0; k < 9; k++)
    S[k] = 2 * MU * e[k] + (k % 4 == 0 ? LAMBDA * tr : 0);
}

// The seed's gradient (S F instead of F S) against the reference's and the
// differences, on x = A X with A a rotated shear (F = A for every element:
// F = Ds Dm^-1 and shape matching both reproduce an affine map), where F
// and S do not commute.
static void check_sf(const scene *sc, ek_rng *rng) {
  size_t n3 = sc->t.nverts * 3;
  double *x = malloc(n3 * sizeof(double)), *g = malloc(3 * 64 * sizeof(double));
  double *gs = malloc(3 * 64 * sizeof(double));
  double Rm[9], A[9], Sh[9] = {1, 0.3, 0, 0, 1, 0.2, 0, 0, 1.1};
  ek_rng_rotation(rng, Rm);
  ek_mul3(Rm, Sh, A);
  for (size_t v = 0; v < sc->t.nverts; v++)
    for (int r = 0; r < 3; r++)
      x[3 * v + r] = A[3 * r] * sc->t.X[3 * v] + A[3 * r + 1] * sc->t.X[3 * v + 1] +
                     A[3 * r + 2] * sc->t.X[3 * v + 2];
  double S[9], FS[9], SF[9], comm = 0, Pn = 0;
  stvk_S(A, S);
  ek_mul3(A, S, FS);
  ek_mul3(S, A, SF);
  for (int k = 0; k < 9; k++) {
    comm = fmax(comm, fabs(FS[k] - SF[k]));
    Pn = fmax(Pn, fabs(FS[k]));
  }
  printf("a. rotated shear: |F S - S F|_max / |F S|_max = %.3g\n", comm / Pn);
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++) {
    const ek_xpbd_ref_set *s = &sc->set[e];
    // The element with the most members (a tet, or an interior cluster).
    size_t j = 0;
    for (size_t q = 1; q < s->n; q++)
      if (s->start[q + 1] - s->start[q] > s->start[j + 1] - s->start[j])
        j = q;
    int K;
    const double *b;
    const int32_t *mem = ref_members(s, j, &b, &K);
    double C = ek_xpbd_ref_eval(&ref_mat, K, mem, b, x, EK_XPBD_C_MIN_F64, g);
    // Seed 001: grad_k C = S F b_k / (E C) (its m_k Q^-T rbar_k is b_k).
    for (int r = 0; r < 3; r++)
      gs[r] = 0;
    for (int k = 1; k < K; k++)
      for (int r = 0; r < 3; r++) {
        const double *bk = b + 3 * (k - 1);
        gs[3 * k + r] =
            (SF[3 * r] * bk[0] + SF[3 * r + 1] * bk[1] + SF[3 * r + 2] * bk[2]) / (YOUNG * C);
        gs[r] -= gs[3 * k + r];
      }
    double efs = fd_error(s, j, x, g), esf = fd_error(s, j, x, gs);
    printf("a. %-8s (%d members): central differences vs F S: %.3g, vs the seed's S F: %.3g\n",
           ek_xpbd_elements_name((ek_xpbd_elements)e), K, efs, esf);
    char label[160];
    snprintf(label, sizeof label, "a. %s: F S is the derivative (FD error <= %g)",
             ek_xpbd_elements_name((ek_xpbd_elements)e), EK_XPBD_FD_TOL);
    fail_if(!(efs <= EK_XPBD_FD_TOL), label);
    snprintf(label, sizeof label, "a. %s: S F is not (FD error >= %g)",
             ek_xpbd_elements_name((ek_xpbd_elements)e), EK_XPBD_SF_GAP);
    fail_if(!(esf >= EK_XPBD_SF_GAP), label);
  }
  free(x);
  free(g);
  free(gs);
}

// ---- b: dlambda solves the linearised equation ----
static void check_dlambda(const scene *sc, ek_rng *rng) {
  size_t n3 = sc->t.nverts * 3;
  double *x = malloc(n3 * sizeof(double)), *xo = malloc(n3 * sizeof(double));
  double *g = malloc(3 * 64 * sizeof(double));
  deform(rng, sc, 0.1, x);
  double *x0 = malloc(n3 * sizeof(double));
  memcpy(x0, x, n3 * sizeof(double));
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++) {
    const ek_xpbd_ref_set *s = &sc->set[e];
    double *lambda = calloc(s->n, sizeof(double));
    memcpy(x, x0, n3 * sizeof(double));
    // One sweep first, so that lambda_old is not 0.
    ek_xpbd_ref_gauss_seidel(s, &ref_mat, sc->w, SUBSTEP, EK_XPBD_C_MIN_F64, s->n, NULL, x, lambda);
    double worst = 0;
    size_t tested = 0;
    for (size_t j = 0; j < s->n; j++) {
      int K;
      const double *b;
      const int32_t *mem = ref_members(s, j, &b, &K);
      double C = ek_xpbd_ref_eval(&ref_mat, K, mem, b, x, EK_XPBD_C_MIN_F64, g);
      if (!(C > EK_XPBD_C_MIN_F64) || K > 64)
        continue;
      memcpy(xo, x, n3 * sizeof(double));
      int32_t one = (int32_t)j;
      ek_xpbd_ref_gauss_seidel(s, &ref_mat, sc->w, SUBSTEP, EK_XPBD_C_MIN_F64, 1, &one, x, lambda);
      double alpha = 1 / (s->V[j] * YOUNG * SUBSTEP * SUBSTEP); // alpha~ = 1 / (V E h^2)
      double lin = C + alpha * lambda[j], scale = fabs(C) + fabs(alpha * lambda[j]);
      for (int k = 0; k < K; k++)
        for (int r = 0; r < 3; r++) {
          size_t i = 3 * (size_t)mem[k] + r;
          double t = g[3 * k + r] * (x[i] - xo[i]);
          lin += t;
          scale += fabs(t);
        }
      double err = fabs(lin) / scale;
      if (!(err <= worst))
        worst = err;
      tested++;
    }
    char label[160];
    snprintf(label, sizeof label,
             "b. reference dlambda solves C + grad C.dx + alpha~ lambda = 0, %s",
             ek_xpbd_elements_name((ek_xpbd_elements)e));
    failures += ek_check_report(label, worst, EK_XPBD_LIN_TOL);
    fail_if(tested < s->n / 2, "b. most constraints tested (not skipped)");
    free(lambda);
  }
  free(x);
  free(xo);
  free(x0);
  free(g);
}

// ---- c: at rest nothing moves ----
static void check_rest(const scene *sc) {
  size_t n3 = sc->t.nverts * 3;
  double *x = malloc(n3 * sizeof(double)), *x0 = malloc(n3 * sizeof(double));
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++)
    for (int prec = 32; prec <= 64; prec += 32) {
      int cases = 0, ok = 1;
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
        if (!ek_isa_available((ek_isa)isa))
          continue;
        for (int solver = 0; solver < EK_XPBD_SOLVER_COUNT; solver++) {
          ek_xpbd *xp = lib_create(sc, e, solver, (ek_isa)isa, prec);
          if (!xp) {
            ok = 0;
            continue;
          }
          memcpy(x0, sc->t.X, n3 * sizeof(double));
          round_to(prec, n3, x0);
          memcpy(x, x0, n3 * sizeof(double));
          size_t n = ek_xpbd_count(xp);
          double *lambda = malloc((n ? n : 1) * sizeof(double)), res = NAN, cmax = NAN;
          int rc = ek_xpbd_set_weights(xp, sc->w);
          rc = rc ? rc : ek_xpbd_begin(xp, SUBSTEP);
          rc = rc ? rc : lib_iterate(xp, prec, n3, x, SWEEPS);
          rc = rc ? rc : ek_xpbd_lambda(xp, lambda);
          rc = rc ? rc : lib_residual(xp, prec, n3, x, &res, &cmax);
          int same = memcmp(x, x0, n3 * sizeof(double)) == 0, zero = 1;
          for (size_t j = 0; j < n; j++)
            zero &= lambda[j] == 0;
          int good = rc == 0 && same && zero && !any_nan(n3, x) && res == 0 && !isnan(cmax);
          if (!good) {
            printf("c. at rest %s %s f%d %s: rc %d, x unchanged %d, lambda 0 %d, residual %g, "
                   "cmax %g (C_min %g)\n",
                   ek_xpbd_elements_name((ek_xpbd_elements)e), ek_isa_name((ek_isa)isa), prec,
                   ek_xpbd_solver_name((ek_xpbd_solver)solver), rc, same, zero, res, cmax,
                   cmin_of(prec));
            ok = 0;
          }
          cases++;
          free(lambda);
          ek_xpbd_destroy(xp);
        }
      }
      char label[160];
      snprintf(label, sizeof label,
               "c. at rest: x same bits, lambda 0, residual 0, no NaN, %s f%d (%d cases)",
               ek_xpbd_elements_name((ek_xpbd_elements)e), prec, cases);
      fail_if(!ok, label);
    }
  free(x);
  free(x0);
}

// ---- d: the library against the reference ----
// Members and b of every constraint against the reference's; returns the
// worst b error (EK_XPBD_B_TOL's metric), +inf on a member mismatch.
static double check_members(const ek_xpbd *xp, const ek_xpbd_ref_set *s, const char *label) {
  if (ek_xpbd_count(xp) != s->n) {
    printf("%s: ek_xpbd_count %zu, reference %zu\n", label, ek_xpbd_count(xp), s->n);
    return INFINITY;
  }
  int maxK = 0;
  for (size_t j = 0; j < s->n; j++)
    maxK = s->start[j + 1] - s->start[j] > maxK ? s->start[j + 1] - s->start[j] : maxK;
  if (ek_xpbd_max_members(xp) != maxK) {
    printf("%s: ek_xpbd_max_members %d, reference %d\n", label, ek_xpbd_max_members(xp), maxK);
    return INFINITY;
  }
  int32_t *mem = malloc((size_t)maxK * sizeof(int32_t));
  double *b = malloc((size_t)maxK * 3 * sizeof(double)), worst = 0;
  for (size_t j = 0; j < s->n; j++) {
    int K;
    const double *bref;
    const int32_t *mref = ref_members(s, j, &bref, &K);
    int Kl = ek_xpbd_members(xp, j, NULL, NULL);
    if (Kl != K || ek_xpbd_members(xp, j, mem, b) != K ||
        memcmp(mem, mref, (size_t)K * sizeof(int32_t)) != 0) {
      printf("%s: constraint %zu: %d members (reference %d), member 0 %d (reference %d)\n", label,
             j, Kl, K, Kl > 0 ? mem[0] : -1, mref[0]);
      worst = INFINITY;
      break;
    }
    double scale = 0, e = max_abs_diff(3 * (size_t)(K - 1), b, bref);
    for (int q = 0; q < 3 * (K - 1); q++)
      scale = fmax(scale, fabs(bref[q]));
    if (!(e / scale <= worst))
      worst = e / scale;
  }
  free(mem);
  free(b);
  return worst;
}

// Half at rest: x = X where X_0 <= the box's middle, beyond it x = X +
// (X_0 - middle) d with d a random vector of ~0.3 (a shear and stretch
// growing from the middle plane, continuous across it), plus noise there.
// The constraints of the resting half have C at the rounding level and are
// skipped (xpbd.h), the others are not: the skip rule's path.
static void deform_half(ek_rng *rng, const scene *sc, double *x) {
  double lo = INFINITY, hi = -INFINITY, d[3];
  for (size_t v = 0; v < sc->t.nverts; v++) {
    lo = fmin(lo, sc->t.X[3 * v]);
    hi = fmax(hi, sc->t.X[3 * v]);
  }
  for (int r = 0; r < 3; r++)
    d[r] = 0.3 * ek_rng_gauss(rng);
  double mid = (lo + hi) / 2;
  for (size_t v = 0; v < sc->t.nverts; v++) {
    double a = sc->t.X[3 * v] - mid;
    for (int r = 0; r < 3; r++)
      x[3 * v + r] =
          sc->t.X[3 * v + r] + (a > 0 ? a * d[r] + 0.01 * CELL * (2 * ek_rng_uniform(rng) - 1) : 0);
  }
}

static void check_against_ref(const scene *sc, ek_rng *rng, int half) {
  size_t nv = sc->t.nverts, n3 = nv * 3;
  double *xs = malloc(n3 * sizeof(double)), *x = malloc(n3 * sizeof(double));
  double *xr = malloc(n3 * sizeof(double));
  const char *start = half ? "half at rest" : "deformed";
  if (half)
    deform_half(rng, sc, xs);
  else
    deform(rng, sc, 0.1, xs);
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    if (!ek_isa_available((ek_isa)isa) && !half)
      printf("d. skipped %s: not available on this CPU/build\n", ek_isa_name((ek_isa)isa));
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++) {
    const ek_xpbd_ref_set *s = &sc->set[e];
    size_t skipped = 0;
    for (size_t j = 0; j < s->n; j++) {
      int K;
      const double *b;
      const int32_t *mem = ref_members(s, j, &b, &K);
      skipped +=
          !(ek_xpbd_ref_eval(&ref_mat, K, mem, b, xs, EK_XPBD_C_MIN_F64, NULL) > EK_XPBD_C_MIN_F64);
    }
    printf("d. %s, %s: %zu of %zu constraints skipped at the start (f64)\n", start,
           ek_xpbd_elements_name((ek_xpbd_elements)e), skipped, s->n);
    double *lr = malloc(s->n * sizeof(double)), *ll = malloc(s->n * sizeof(double));
    for (int prec = 32; prec <= 64; prec += 32) {
      double worst[5] = {0}; // x, lambda, residual, residual at x, b
      int cases = 0;
      double tol = tol_of(prec), cmin = cmin_of(prec);
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
        if (!ek_isa_available((ek_isa)isa))
          continue;
        for (int solver = 0; solver < EK_XPBD_SOLVER_COUNT; solver++) {
          char label[160];
          snprintf(label, sizeof label, "d. %-8s %-6s f%d %-12s%s",
                   ek_xpbd_elements_name((ek_xpbd_elements)e), ek_isa_name((ek_isa)isa), prec,
                   ek_xpbd_solver_name((ek_xpbd_solver)solver), half ? " half" : "");
          ek_xpbd *xp = lib_create(sc, e, solver, (ek_isa)isa, prec);
          if (!xp)
            continue;
          double eb = check_members(xp, s, label);
          int32_t *order = malloc(s->n * sizeof(int32_t));
          memcpy(x, xs, n3 * sizeof(double));
          round_to(prec, n3, x);
          memcpy(xr, x, n3 * sizeof(double));
          // ek_xpbd_order returns the count (or < 0 on an error).
          int rc = ek_xpbd_order(xp, order);
          rc = rc == (int)s->n ? 0 : rc < 0 ? rc : EK_EINVAL;
          rc = rc ? rc : ek_xpbd_set_weights(xp, sc->w);
          rc = rc ? rc : ek_xpbd_begin(xp, SUBSTEP);
          rc = rc ? rc : lib_iterate(xp, prec, n3, x, SWEEPS);
          rc = rc ? rc : ek_xpbd_lambda(xp, ll);
          double res = NAN, cmax = NAN, res_at = NAN;
          rc = rc ? rc : lib_residual(xp, prec, n3, x, &res, &cmax);
          if (rc != 0) {
            printf("%s: rc %d (%s)\nFAIL\n", label, rc, ek_last_error());
            failures++;
            free(order);
            ek_xpbd_destroy(xp);
            continue;
          }
          // The reference from the same start; Gauss-Seidel in the library's order.
          memset(lr, 0, s->n * sizeof(double));
          ref_sweeps(s, solver, sc->w, cmin, order, SWEEPS, xr, lr);
          double cmax_ref;
          double res_ref = ek_xpbd_ref_residual(s, &ref_mat, SUBSTEP, cmin, xr, lr, &cmax_ref);
          res_at = ek_xpbd_ref_residual(s, &ref_mat, SUBSTEP, cmin, x, ll, NULL);
          double G = grad_scale(s, xr, cmin), dl = 0;
          for (size_t j = 0; j < s->n; j++) {
            double d = fabs(ll[j] - lr[j]) / (s->V[j] * YOUNG * SUBSTEP * SUBSTEP);
            if (!(d <= dl))
              dl = d;
          }
          double m[5] = {max_abs_diff(n3, x, xr) / sc->diag, dl / (G * sc->diag),
                         fmax(fabs(res - res_ref), fabs(cmax - cmax_ref)) / (G * sc->diag),
                         fabs(res - res_at) / (G * sc->diag), eb};
          if (isnan(res) || isnan(cmax))
            m[2] = NAN;
          int bad = 0;
          for (int k = 0; k < 5; k++) {
            double budget = k == 4 ? EK_XPBD_B_TOL : tol;
            bad |= !(m[k] <= budget);
            if (!(m[k] <= worst[k]))
              worst[k] = m[k];
          }
          printf("%s x %.2e lambda %.2e res %.2e (%.3g vs ref %.3g) res@x %.2e b %.2e %s\n", label,
                 m[0], m[1], m[2], res, res_ref, m[3], m[4], bad ? "FAIL" : "ok");
          cases++;
          free(order);
          ek_xpbd_destroy(xp);
        }
      }
      static const char *what[5] = {
          "positions / diag", "alpha~ lambda / (G diag)", "residual, max C (trajectory) / (G diag)",
          "residual at the library's state / (G diag)", "b_k (members equal)"};
      for (int k = 0; k < 5; k++) {
        char label[200];
        snprintf(label, sizeof label, "d. %s, %s f%d %s (%d cases)", start,
                 ek_xpbd_elements_name((ek_xpbd_elements)e), prec, what[k], cases);
        failures += ek_check_report(label, worst[k], k == 4 ? EK_XPBD_B_TOL : tol);
      }
    }
    free(lr);
    free(ll);
  }
  free(xs);
  free(x);
  free(xr);
}

// ---- e: 1, 2 and 3 threads (tets at 2 and 3: the chunks split by Morton rank
// and run without phase barriers, kernels/xpbd/xpbd.c sweeps_flow) ----
static void check_threads(ek_rng *rng) {
  // Tets: 12^3 cells, 10368 tets; clusters are per vertex: 20^3 cells,
  // 9261 vertices. Both above the ~4096 constraints of the parallel path.
  scene big[EK_XPBD_ELEMENTS_COUNT];
  scene_init(&big[EK_XPBD_TETS], rng, 12, 12, 12, 0.05, DENSITY);
  scene_init(&big[EK_XPBD_CLUSTERS], rng, 20, 20, 20, 0.05, DENSITY);
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++) {
    const scene *sc = &big[e];
    double *xs = malloc(sc->t.nverts * 3 * sizeof(double));
    deform(rng, sc, 0.1, xs);
    for (int prec = 32; prec <= 64; prec += 32)
      for (int solver = 0; solver < EK_XPBD_SOLVER_COUNT; solver++) {
        ek_xpbd_opts o = {
            .elements = (ek_xpbd_elements)e, .solver = (ek_xpbd_solver)solver, .precision = prec};
        int ok = lib_same_bits_1_2_3_threads(sc, &lib_mat, YOUNG, o, SUBSTEP, SWEEPS, xs, 1);
        char label[200];
        snprintf(
            label, sizeof label, "e. 1, 2 and 3 threads, same bits: %s f%d %s (%zu constraints)",
            ek_xpbd_elements_name(o.elements), prec, ek_xpbd_solver_name(o.solver), sc->set[e].n);
        fail_if(!ok, label);
      }
    free(xs);
  }
  scene_free(&big[0]);
  scene_free(&big[1]);
}

// ---- f: momentum of a free body ----
// scene_momentum_error (test_xpbd_scene.h): |sum m (v - v0)|_max / sum m |v0|,
// v0 = (x~ - x_start) / h, v = (x - x_start) / h after the sweeps (x~ as
// rounded to the precision).

static void check_momentum(const scene *sc, ek_rng *rng) {
  size_t nv = sc->t.nverts, n3 = nv * 3;
  double *w = malloc(nv * sizeof(double)), *xs = malloc(n3 * sizeof(double));
  double *pred = malloc(n3 * sizeof(double)), *x = malloc(n3 * sizeof(double));
  for (size_t v = 0; v < nv; v++)
    w[v] = 1 / sc->mass[v]; // free: nothing pinned
  deform(rng, sc, 0.1, xs);
  double vel[3];
  for (size_t v = 0; v < nv; v++) {
    for (int r = 0; r < 3; r++)
      vel[r] = ek_rng_gauss(rng); // ~1 m/s: h |v| ~ 1 mm, a hundredth of a cell
    for (int r = 0; r < 3; r++)
      pred[3 * v + r] = xs[3 * v + r] + SUBSTEP * vel[r];
  }
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++) {
    const ek_xpbd_ref_set *s = &sc->set[e];
    for (int solver = 0; solver < EK_XPBD_SOLVER_COUNT; solver++) {
      // The reference first (f64): it holds to the same budget.
      double *lr = calloc(s->n, sizeof(double));
      memcpy(x, pred, n3 * sizeof(double));
      ref_sweeps(s, solver, w, EK_XPBD_C_MIN_F64, NULL, SWEEPS, x, lr);
      char label[200];
      snprintf(label, sizeof label, "f. momentum, reference %s %s",
               ek_xpbd_elements_name((ek_xpbd_elements)e),
               ek_xpbd_solver_name((ek_xpbd_solver)solver));
      failures += ek_check_report(label, scene_momentum_error(sc, SUBSTEP, w, xs, pred, x),
                                  EK_XPBD_MOMENTUM_TOL_F64);
      free(lr);
      for (int prec = 32; prec <= 64; prec += 32) {
        ek_xpbd_opts o = {
            .elements = (ek_xpbd_elements)e, .solver = (ek_xpbd_solver)solver, .precision = prec};
        double dv,
            err = lib_momentum_error(sc, &lib_mat, YOUNG, o, SUBSTEP, SWEEPS, w, xs, pred, &dv);
        snprintf(label, sizeof label, "f. momentum, library %s %s f%d (max |dv| %.2g m/s)",
                 ek_xpbd_elements_name(o.elements), ek_xpbd_solver_name(o.solver), prec, dv);
        failures += ek_check_report(
            label, err, prec == 32 ? EK_XPBD_MOMENTUM_TOL_F32 : EK_XPBD_MOMENTUM_TOL_F64);
      }
    }
  }
  free(w);
  free(xs);
  free(pred);
  free(x);
}

// ---- g: bad arguments ----
static void refused(int bad, const char *what) {
  const char *msg = ek_last_error();
  char label[200];
  snprintf(label, sizeof label, "g. %s refused", what);
  fail_if(bad || !msg || !msg[0], label);
  printf("     ek_last_error: \"%s\"\n", msg ? msg : "(null)");
}

static void check_errors(const scene *sc) {
  size_t nv = sc->t.nverts, n3 = nv * 3;
  ek_material nh = {EK_MODEL_NEO_HOOKEAN, MU, LAMBDA, 0};
  ek_xpbd_opts clusters = {.elements = EK_XPBD_CLUSTERS};
  ek_xpbd *xp = ek_xpbd_create(sc->el, &nh, YOUNG, sc->mass, NULL);
  refused(xp != NULL, "a non-StVK model (neo-Hookean)");
  ek_xpbd_destroy(xp);
  xp = ek_xpbd_create(sc->el, &lib_mat, 0, sc->mass, NULL);
  refused(xp != NULL, "young = 0");
  ek_xpbd_destroy(xp);
  xp = ek_xpbd_create(sc->el, &lib_mat, -YOUNG, sc->mass, NULL);
  refused(xp != NULL, "young < 0");
  ek_xpbd_destroy(xp);
  xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, NULL, &clusters);
  refused(xp != NULL, "clusters without masses");
  ek_xpbd_destroy(xp);
  // A cluster whose members are all massless but one (and j itself):
  // Q = m rbar rbar^T has rank 1. The reference names the first vertex
  // whose Q is singular; the library's message should name it too.
  double *m = malloc(nv * sizeof(double));
  memcpy(m, sc->mass, nv * sizeof(double));
  const ek_xpbd_ref_set *cl = &sc->set[EK_XPBD_CLUSTERS];
  size_t v = nv / 2;
  for (int32_t q = cl->start[v] + 2; q < cl->start[v + 1]; q++)
    m[cl->members[q]] = 0;
  ek_xpbd_ref_set tmp;
  size_t badv = (size_t)-1;
  int rrc = ek_xpbd_ref_clusters(nv, sc->t.X, sc->t.ntets, sc->t.T, m, &tmp, &badv);
  if (rrc == 0)
    ek_xpbd_ref_free(&tmp);
  xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, m, &clusters);
  char what[160];
  snprintf(what, sizeof what, "a singular cluster Q (massless members; reference: vertex %zu)",
           badv);
  refused(xp != NULL || rrc == 0, what);
  char num[32];
  snprintf(num, sizeof num, "%zu", badv);
  fail_if(strstr(ek_last_error(), num) == NULL, "g. the message names the vertex");
  ek_xpbd_destroy(xp);
  free(m);
  ek_xpbd_opts p16 = {.precision = 16};
  xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, sc->mass, &p16);
  refused(xp != NULL, "precision 16");
  ek_xpbd_destroy(xp);
  ek_xpbd_opts bad_solver = {.solver = EK_XPBD_SOLVER_COUNT};
  xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, sc->mass, &bad_solver);
  refused(xp != NULL, "an unknown solver");
  ek_xpbd_destroy(xp);
  ek_xpbd_opts bad_el = {.elements = EK_XPBD_ELEMENTS_COUNT};
  xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, sc->mass, &bad_el);
  refused(xp != NULL, "unknown elements");
  ek_xpbd_destroy(xp);

  // Precision and h on a valid f64 (then f32) solver.
  double *x = malloc(n3 * sizeof(double)), res;
  float *xf = malloc(n3 * sizeof(float));
  memcpy(x, sc->t.X, n3 * sizeof(double));
  for (size_t i = 0; i < n3; i++)
    xf[i] = (float)x[i];
  for (int prec = 32; prec <= 64; prec += 32) {
    ek_xpbd_opts o = {.precision = prec};
    xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, NULL, &o);
    if (!xp) {
      printf("ek_xpbd_create (tets, f%d): %s\nFAIL\n", prec, ek_last_error());
      failures++;
      continue;
    }
    ek_xpbd_set_weights(xp, sc->w);
    snprintf(what, sizeof what, "f%d: h = 0", prec);
    refused(ek_xpbd_begin(xp, 0) != EK_EINVAL, what);
    snprintf(what, sizeof what, "f%d: h < 0", prec);
    refused(ek_xpbd_begin(xp, -SUBSTEP) != EK_EINVAL, what);
    snprintf(what, sizeof what, "f%d: h = NaN", prec);
    refused(ek_xpbd_begin(xp, NAN) != EK_EINVAL, what);
    fail_if(ek_xpbd_begin(xp, SUBSTEP) != 0, "g. a valid h accepted");
    if (prec == 64) {
      refused(ek_xpbd_iterate_f32(xp, NULL, xf, 1) != EK_EINVAL, "f64 solver: ek_xpbd_iterate_f32");
      refused(ek_xpbd_residual_f32(xp, NULL, xf, &res, NULL) != EK_EINVAL,
              "f64 solver: ek_xpbd_residual_f32");
    } else {
      refused(ek_xpbd_iterate_f64(xp, NULL, x, 1) != EK_EINVAL, "f32 solver: ek_xpbd_iterate_f64");
      refused(ek_xpbd_residual_f64(xp, NULL, x, &res, NULL) != EK_EINVAL,
              "f32 solver: ek_xpbd_residual_f64");
    }
    ek_xpbd_destroy(xp);
  }
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    if (!ek_isa_available((ek_isa)isa)) {
      ek_xpbd_opts o = {.isa = (ek_isa)isa};
      xp = ek_xpbd_create(sc->el, &lib_mat, YOUNG, NULL, &o);
      printf("g. skipped %s: not available on this CPU/build (create refused: %s)\n",
             ek_isa_name((ek_isa)isa), xp ? "FAIL" : "PASS");
      failures += xp != NULL;
      ek_xpbd_destroy(xp);
    }
  free(x);
  free(xf);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 2026, NULL);
  printf("test_xpbd: seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  // 4 x 3 x 3 cells: 216 tets (not a multiple of 16), 80 vertices, 10%
  // of them pinned.
  scene sc;
  scene_init(&sc, &rng, 4, 3, 3, 0.1, DENSITY);
  check_fd(&sc, &rng);
  check_sf(&sc, &rng);
  check_dlambda(&sc, &rng);
  check_errors(&sc);
  check_rest(&sc);
  check_against_ref(&sc, &rng, 0);
  check_against_ref(&sc, &rng, 1);
  check_momentum(&sc, &rng);
  check_threads(&rng);
  scene_free(&sc);
  printf("%s\n", failures ? "FAIL" : "PASS");
  return failures != 0;
}
