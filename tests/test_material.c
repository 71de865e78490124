// Material kernels (ek_material_eval_*, ek_pk1_*, ek_energy_f64) against the
// double reference (reference/material/): for every ISA this CPU runs x
// precision x model x clamp (off / on) x project (off / on), psi, P, dP and
// the 9x9 Hessian are within EK_PK1_TOL_F32 / _F64 (norms in
// include/ek/material.h) on random F near the identity, large
// deformations, inverted and near-flat F, and rotations, with n not a
// multiple of the lane count. Behaviour on the extremes (zero, rank 1 and
// 2, reflections): finite wherever the model is defined (everywhere with
// the clamp), NaN / +inf only for neo-Hookean without clamp at J <= 0, and
// the return value counts exactly those. A NaN in one element leaves the
// others untouched; invalid parameters give rc < 0 and write nothing; the
// AoSoA forms give the same bits as the AoS ones; 1, 2 and 3 threads give the
// same bits; the neo-Hookean energy is within budget for J from the
// subnormal range up (the vector log's range reduction); the Young/Poisson helpers invert each
// other and refuse nu >= 0.5, nu <= -1, E <= 0.
#include <ek/material.h>
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "cli.h"
#include "material/material_ref.h"

// Random inputs from the shared check library (verify/check.h).
static ek_rng rng;
static double urand(void) { return ek_rng_uniform(&rng); }
static double urange(double a, double b) { return a + (b - a) * urand(); }
static void rotation(double Q[9]) { ek_rng_rotation(&rng, Q); }
static void from_sigma(const double s[3], double F[9]) { ek_rng_with_sigma(&rng, s, F); }

// Random catalogue: singular values in [0.2, 5] (the budgets' range), one
// category per element so every vector mixes them.
enum { NEAR_ID, LARGE, INVERTED, NEAR_FLAT, ROTATION, KINDS };
static const char *const kind_names[KINDS] = {"near-identity", "large", "inverted", "near-flat",
                                              "rotation"};
static void make_F(int kind, double F[9]) {
  double s[3];
  switch (kind) {
  case NEAR_ID:
    for (int k = 0; k < 9; k++)
      F[k] = (k % 4 == 0) + urange(-0.2, 0.2);
    return;
  case LARGE:
    s[0] = urange(0.2, 5), s[1] = urange(0.2, 5), s[2] = urange(0.2, 5);
    break;
  case INVERTED: // sigma_i + sigma_j >= 0.3: away from the polar singularity
    s[0] = urange(0.8, 2), s[1] = urange(0.8, 2), s[2] = -urange(0.1, 0.5);
    break;
  case NEAR_FLAT:
    s[0] = urange(0.8, 2), s[1] = urange(0.8, 2), s[2] = urange(0.2, 0.25);
    break;
  default:
    s[0] = s[1] = s[2] = 1;
    break;
  }
  from_sigma(s, F);
}

static double amax(const double *a, size_t n) {
  double m = 0;
  for (size_t i = 0; i < n; i++)
    m = fmax(m, fabs(a[i]));
  return m;
}
static int all_finite(const double *a, size_t n) {
  for (size_t i = 0; i < n; i++)
    if (!isfinite(a[i]))
      return 0;
  return 1;
}

static int failures;
static void fail(const char *what) {
  failures++;
  printf("    FAIL %s\n", what);
}

// Every model's descriptor (kernels/material/<name>.c) agrees with the
// public name and needs functions and with the reference's own table, which
// must cover every model; its linearisation and inverse round-trip.
static void check_descriptors(void) {
  if (ek_material_ref_model_count() != EK_MODEL_COUNT) {
    printf("  the reference table has %d models, ek_model %d\n", ek_material_ref_model_count(),
           EK_MODEL_COUNT);
    fail("reference table coverage");
  }
  if (ek_model_describe((ek_model)EK_MODEL_COUNT) != NULL)
    fail("ek_model_describe(EK_MODEL_COUNT) is not NULL");
  for (int m = 0; m < EK_MODEL_COUNT; m++) {
    const ek_model_desc *d = ek_model_describe((ek_model)m);
    ek_model by_name = EK_MODEL_COUNT, by_long = EK_MODEL_COUNT;
    if (!d || d->model != (ek_model)m) {
      printf("  model %d: descriptor %s\n", m, d ? "of another model" : "missing");
      fail("descriptor table order");
      continue;
    }
    ek_model_from_name(d->name, &by_name);
    ek_model_from_name(d->long_name, &by_long);
    double mu = 1.3, lambda = d->volume_term ? 2.1 : 0, mu_lin, lambda_lin, mu2, lambda2;
    char why[200] = "";
    d->linearise(mu, lambda, &mu_lin, &lambda_lin);
    int rc = d->from_linear(mu_lin, lambda_lin, &mu2, &lambda2, why, sizeof why);
    printf("  descriptor %-12s %-18s needs %d clampable %d (reference %d) isotropic %d cache %d "
           "linearised (%g, %g)\n",
           d->name, d->long_name, (int)d->needs, d->clampable, ek_material_ref_clampable(m),
           d->isotropic, d->cache_planes, mu_lin, lambda_lin);
    if (by_name != (ek_model)m || by_long != (ek_model)m ||
        strcmp(ek_model_name((ek_model)m), d->name) != 0 ||
        strcmp(ek_model_long_name((ek_model)m), d->long_name) != 0)
      fail("names");
    if (ek_model_need((ek_model)m, 0) != d->needs ||
        ek_model_need((ek_model)m, 0.3) != (d->clampable ? EK_NEEDS_SVD : d->needs))
      fail("needs");
    if (d->clampable != ek_material_ref_clampable(m))
      fail("clampable: descriptor and reference disagree");
    if (rc != EK_OK || fabs(mu2 - mu) > 1e-15 * mu || fabs(lambda2 - lambda) > 1e-15 * mu) {
      printf("  %s: (%g, %g) -> (%g, %g) -> (%g, %g) rc %d %s\n", d->name, mu, lambda, mu_lin,
             lambda_lin, mu2, lambda2, rc, why);
      fail("linearisation round trip");
    }
  }
}

static const char *const op_names[4] = {"psi", "P", "dP", "H"};

static void print_element(const char *label, const double *a, size_t n) {
  printf("      %-9s", label);
  for (size_t i = 0; i < n && i < 9; i++)
    printf(" %.9g", a[i]);
  printf("%s\n", n > 9 ? " ..." : "");
}

// Accuracy of one (isa, precision, model, clamp, op, project) against the
// reference. Returns 0 if within budget.
static double check_accuracy(int f32, ek_isa isa, const ek_material *m, ek_material_op op,
                             int project, size_t n, int verbose_fail) {
  const size_t nout = op == EK_MAT_ENERGY ? 1 : op == EK_MAT_HESSIAN ? 81 : 9;
  double *F = malloc(n * 9 * sizeof *F), *R = malloc(n * 9 * sizeof *R);
  double *dF = malloc(n * 9 * sizeof *dF), *out = calloc(n * nout, sizeof *out);
  int *kind = malloc(n * sizeof *kind);
  for (size_t e = 0; e < n; e++) {
    kind[e] = (int)(urand() * KINDS);
    make_F(kind[e], F + 9 * e);
    rotation(R + 9 * e);
    for (int k = 0; k < 9; k++)
      dF[9 * e + k] = urange(-1, 1);
    if (f32) // the reference sees exactly the float input
      for (int k = 0; k < 9; k++) {
        F[9 * e + k] = (float)F[9 * e + k];
        R[9 * e + k] = (float)R[9 * e + k];
        dF[9 * e + k] = (float)dF[9 * e + k];
      }
  }
  int rc = ek_check_run_material(f32, m, op, isa, n, F, R, dF, out, project);
  ek_material_ref mr = {(int)m->model, m->mu, m->lambda, m->clamp};
  double worst = 0;
  long outside = 0;
  const double tol = f32 ? EK_PK1_TOL_F32 : EK_PK1_TOL_F64;
  for (size_t e = 0; e < n; e++) {
    const double *Fe = F + 9 * e, *Re = R + 9 * e, *dFe = dF + 9 * e, *got = out + nout * e;
    double ref[81];
    switch (op) {
    case EK_MAT_ENERGY:
      ref[0] = ek_psi_ref(&mr, Fe, Re);
      break;
    case EK_MAT_PK1:
      ek_pk1_ref(&mr, Fe, Re, ref);
      break;
    case EK_MAT_PK1_DIFF:
      ek_pk1_diff_ref(&mr, Fe, Re, dFe, ref, project);
      break;
    default:
      ek_hessian_ref(&mr, Fe, Re, ref, project);
      break;
    }
    const double s = fmax(1, amax(Fe, 9)), lame = m->mu + fabs(m->lambda);
    if (!all_finite(ref, nout)) { // outside the domain: must match
      outside++;
      int ok = op == EK_MAT_ENERGY ? got[0] == INFINITY : isnan(got[0]);
      if (!ok) {
        fail("outside the domain but not NaN / +inf");
        print_element("F", Fe, 9), print_element("expected", ref, nout),
            print_element("actual", got, nout);
      }
      continue;
    }
    double scale = op == EK_MAT_ENERGY     ? lame * s * s * s * s
                   : op == EK_MAT_PK1      ? lame * s * s * s
                   : op == EK_MAT_PK1_DIFF ? lame * s * s * amax(dFe, 9)
                                           : lame * s * s;
    double d = 0;
    for (size_t k = 0; k < nout; k++)
      d = fmax(d, fabs(got[k] - ref[k]));
    if (!all_finite(got, nout))
      d = INFINITY;
    double err = d / fmax(amax(ref, nout), scale);
    if (!(err <= worst))
      worst = err;
    if (!(err <= tol) && verbose_fail) {
      printf("    element %zu (%s): err %.3e > %.1e\n", e, kind_names[kind[e]], err, tol);
      print_element("F", Fe, 9), print_element("expected", ref, nout),
          print_element("actual", got, nout);
      verbose_fail--;
    }
  }
  if (rc != outside) {
    printf("    return value %d, expected %ld elements outside the domain\n", rc, outside);
    fail("return value");
  }
  free(F), free(R), free(dF), free(out), free(kind);
  return worst;
}

// Extremes: finite where defined, NaN only where the table says.
static void check_extremes(int f32, ek_isa isa, const ek_material *m, int project) {
  double ext[][9] = {
      {0, 0, 0, 0, 0, 0, 0, 0, 0},      // zero
      {1, 2, 3, 2, 4, 6, 3, 6, 9},      // rank 1
      {1, 0, 0, 0, 1, 0, 0, 0, 0},      // rank 2 (flat)
      {1, 0, 0, 0, 1, 0, 0, 0, -1},     // reflection
      {-1, 0, 0, 0, -1, 0, 0, 0, -1},   // point reflection
      {0.5, 0.1, 0, 0, -2, 0, 0, 0, 1}, // inverted
      {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-6}, {3, 0, 0, 0, 3, 0, 0, 0, 3},
  };
  const size_t n = sizeof ext / sizeof ext[0];
  double R[sizeof ext / sizeof ext[0]][9], dF[sizeof ext / sizeof ext[0]][9];
  for (size_t e = 0; e < n; e++) {
    rotation(R[e]);
    for (int k = 0; k < 9; k++)
      dF[e][k] = urange(-1, 1);
  }
  int clamped = m->clamp > 0;
  int polar = m->model == EK_MODEL_FIXED_COROTATED || m->model == EK_MODEL_ARAP;
  for (int op = EK_MAT_ENERGY; op <= EK_MAT_HESSIAN; op++) {
    const size_t nout = op == EK_MAT_ENERGY ? 1 : op == EK_MAT_HESSIAN ? 81 : 9;
    double out[sizeof ext / sizeof ext[0] * 81];
    int rc = ek_check_run_material(f32, m, (ek_material_op)op, isa, n, &ext[0][0], &R[0][0],
                                   &dF[0][0], out, project);
    int expect_rc = 0;
    for (size_t e = 0; e < n; e++) {
      double J = ext[e][0] * (ext[e][4] * ext[e][8] - ext[e][5] * ext[e][7]) -
                 ext[e][1] * (ext[e][3] * ext[e][8] - ext[e][5] * ext[e][6]) +
                 ext[e][2] * (ext[e][3] * ext[e][7] - ext[e][4] * ext[e][6]);
      int nan_domain = m->model == EK_MODEL_NEO_HOOKEAN && !clamped && J <= 0;
      // Fixed corotated / ARAP without clamp: dP holds 1/(sigma_i + sigma_j),
      // infinite at the zero, rank-1 and reflected inputs, where some
      // sigma_i + sigma_j = 0 (their own singularity, material.h); no
      // requirement there.
      int singular =
          polar && !clamped && op >= EK_MAT_PK1_DIFF && (e == 0 || e == 1 || e == 3 || e == 4);
      const double *got = out + nout * e;
      if (nan_domain) {
        expect_rc++;
        int ok = op == EK_MAT_ENERGY ? got[0] == INFINITY : isnan(got[0]);
        if (!ok) {
          printf("    extreme %zu %s: expected NaN / +inf\n", e, op_names[op]);
          print_element("F", ext[e], 9), print_element("actual", got, nout);
          fail("extremes: NaN expected");
        }
      } else if (!singular && !all_finite(got, nout)) {
        printf("    extreme %zu %s: expected finite\n", e, op_names[op]);
        print_element("F", ext[e], 9), print_element("actual", got, nout);
        fail("extremes: finite expected");
      }
    }
    if (rc != expect_rc) {
      printf("    extremes %s: rc %d, expected %d\n", op_names[op], rc, expect_rc);
      fail("extremes: return value");
    }
  }
}

// Non-finite input (include/ek/material.h): an element with a NaN or an
// infinity in F (or in R, for the models that read it) gets NaN in every
// output entry, for every op, whichever entry holds it; the other elements
// keep the bits they have without it.
static void check_nan_lane(int f32, ek_isa isa, const ek_material *m) {
  enum { N = 21, BAD = 5 };
  static const double bad_values[3] = {NAN, INFINITY, -INFINITY};
  const int reads_r = ek_model_need(m->model, m->clamp) == EK_NEEDS_R_INPUT;
  double F[N * 9], R[N * 9], dF[N * 9];
  static double a[N * 81], b[N * 81];
  for (size_t e = 0; e < N; e++)
    make_F(NEAR_ID, F + 9 * e), rotation(R + 9 * e), make_F(NEAR_ID, dF + 9 * e);
  for (int op = EK_MAT_ENERGY; op <= EK_MAT_HESSIAN; op++) {
    const size_t nout = op == EK_MAT_ENERGY ? 1 : op == EK_MAT_HESSIAN ? 81 : 9;
    ek_check_run_material(f32, m, (ek_material_op)op, isa, N, F, R, dF, a, 0);
    for (int in_r = 0; in_r <= reads_r; in_r++)
      for (int entry = 0; entry < 9; entry++)
        for (int v = 0; v < 3; v++) {
          double *X = in_r ? R : F, keep = X[9 * BAD + entry];
          X[9 * BAD + entry] = bad_values[v];
          ek_check_run_material(f32, m, (ek_material_op)op, isa, N, F, R, dF, b, 0);
          X[9 * BAD + entry] = keep;
          for (size_t e = 0; e < N; e++) {
            size_t finite = 0;
            for (size_t i = 0; i < nout; i++)
              finite += !isnan(b[nout * e + i]);
            int same = memcmp(a + nout * e, b + nout * e, nout * sizeof(double)) == 0;
            if (e == BAD ? finite != 0 : !same) {
              printf("    %s %s[%d] = %g: element %zu %s (%zu of %zu entries not NaN)\n",
                     op_names[op], in_r ? "R" : "F", entry, bad_values[v], e,
                     e == BAD ? "not all NaN" : "changed", finite, nout);
              fail("non-finite input");
              return;
            }
          }
        }
  }
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  ek_rng_seed(&rng, seed);
  printf("test_material --seed %llu\n", (unsigned long long)seed);
  check_descriptors();
  const double clamps[2] = {0, 0.3};
  const size_t n = 77; // not a multiple of any lane count

  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available((ek_isa)isa)) {
      printf("skip ISA %s: not built or not supported by this CPU\n", ek_isa_name((ek_isa)isa));
      continue;
    }
    for (int f32 = 1; f32 >= 0; f32--) {
      const double tol = f32 ? EK_PK1_TOL_F32 : EK_PK1_TOL_F64;
      printf("ISA %s, %s (budget %.0e)\n", ek_isa_name((ek_isa)isa), f32 ? "f32" : "f64", tol);
      for (int model = 0; model < EK_MODEL_COUNT; model++)
        for (int c = 0; c < 2; c++) {
          ek_material m = {(ek_model)model, 1.3, 2.1, clamps[c]};
          printf("  %-12s clamp %.1f:", ek_model_name((ek_model)model), clamps[c]);
          double worst_all = 0;
          for (int op = EK_MAT_ENERGY; op <= EK_MAT_HESSIAN; op++)
            for (int project = 0; project < (op >= EK_MAT_PK1_DIFF ? 2 : 1); project++) {
              double w = check_accuracy(f32, (ek_isa)isa, &m, (ek_material_op)op, project, n, 2);
              printf(" %s%s %.1e", op_names[op], project ? "+" : "", w);
              worst_all = fmax(worst_all, w);
              if (!(w <= tol))
                fail("accuracy");
            }
          double r = worst_all / tol;
          printf("  err/budget %.3f %s\n", r, !(r <= 1) ? "FAIL" : r > 0.5 ? "MARGINAL" : "PASS");
          for (int project = 0; project < 2; project++)
            check_extremes(f32, (ek_isa)isa, &m, project);
          check_nan_lane(f32, (ek_isa)isa, &m);
        }
    }
  }

  // Neo-Hookean energy over the whole range of J = a (F = diag(a, 1, 1)),
  // subnormal a included: exercises the range reduction of the vector log.
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available((ek_isa)isa))
      continue;
    for (int f32 = 1; f32 >= 0; f32--) {
      const double tol = f32 ? EK_PK1_TOL_F32 : EK_PK1_TOL_F64;
      const int lo = f32 ? -44 : -320, hi = f32 ? 15 : 150; // a^2 stays finite
      const size_t n = (size_t)(hi - lo + 1);
      double *F = calloc(n * 9, sizeof *F), *psi = calloc(n, sizeof *psi);
      for (size_t e = 0; e < n; e++) {
        double a = pow(10.0, lo + (int)e);
        F[9 * e] = f32 ? (float)a : a, F[9 * e + 4] = F[9 * e + 8] = 1;
      }
      ek_material m = {EK_MODEL_NEO_HOOKEAN, 1.3, 2.1, 0};
      ek_material_ref mr = {EK_MODEL_NEO_HOOKEAN, 1.3, 2.1, 0};
      int rc = ek_check_run_material(f32, &m, EK_MAT_ENERGY, (ek_isa)isa, n, F, NULL, NULL, psi, 0);
      double worst = 0;
      for (size_t e = 0; e < n; e++) {
        double ref = ek_psi_ref(&mr, F + 9 * e, NULL);
        double s = fmax(1, F[9 * e]), scale = (m.mu + m.lambda) * s * s * s * s;
        double err = fabs(psi[e] - ref) / fmax(fabs(ref), scale);
        if (!(err <= tol))
          printf("    nh psi at J = %.3g: %.17g, expected %.17g\n", F[9 * e], psi[e], ref);
        if (!(err <= worst))
          worst = err;
      }
      printf("ISA %s %s: neo-Hookean psi for J in 1e%d..1e%d: err %.2e, err/budget %.3f %s\n",
             ek_isa_name((ek_isa)isa), f32 ? "f32" : "f64", lo, hi, worst, worst / tol,
             !(worst <= tol)   ? "FAIL"
             : worst > tol / 2 ? "MARGINAL"
                               : "PASS");
      if (!(worst <= tol) || rc != 0)
        fail("neo-Hookean energy range");
      free(F), free(psi);
    }
  }

  // Invalid parameters: rc < 0 and nothing written.
  {
    const ek_material bad[] = {
        {EK_MODEL_STVK, 0, 1, 0},
        {EK_MODEL_STVK, -1, 1, 0},
        {EK_MODEL_STVK, NAN, 1, 0},
        {EK_MODEL_STVK, 1, INFINITY, 0},
        {EK_MODEL_STVK, 1, -0.7, 0},
        {EK_MODEL_NEO_HOOKEAN, 1, 1, -0.1},
        {EK_MODEL_NEO_HOOKEAN, 1, 1, NAN},
        {(ek_model)8, 1, 1, 0},
        {EK_MODEL_STABLE_NEO_HOOKEAN, 1, 0, 0},
    };
    double F[9 * 3] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, out[81 * 3];
    float Ff[9 * 3] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, outf[81 * 3];
    int bad_ok = 1;
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++)
      for (int op = EK_MAT_ENERGY; op <= EK_MAT_HESSIAN; op++) {
        for (int k = 0; k < 81 * 3; k++)
          out[k] = -12345, outf[k] = -12345;
        int rc = ek_material_eval_f64(&bad[b], (ek_material_op)op, EK_ISA_AUTO, 3, F, F, F, out, 0);
        int rcf =
            ek_material_eval_f32(&bad[b], (ek_material_op)op, EK_ISA_AUTO, 3, Ff, Ff, Ff, outf, 1);
        int untouched = 1;
        for (int k = 0; k < 81 * 3; k++)
          untouched &= out[k] == -12345 && outf[k] == -12345;
        if (rc >= 0 || rcf >= 0 || !untouched) {
          printf("    invalid material %zu (model %d mu %g lambda %g clamp %g): rc %d / %d%s\n", b,
                 (int)bad[b].model, bad[b].mu, bad[b].lambda, bad[b].clamp, rc, rcf,
                 untouched ? "" : ", output written");
          bad_ok = 0;
        }
      }
    ek_material corot = {EK_MODEL_COROTATED_LINEAR, 1, 1, 0};
    for (int k = 0; k < 9; k++)
      out[k] = -12345;
    if (ek_pk1_f64(&corot, 1, F, NULL, out) >= 0 || out[0] != -12345) {
      printf("    corotated linear with R = NULL accepted\n");
      bad_ok = 0;
    }
    ek_material ok = {EK_MODEL_STVK, 1, 1, 0};
    if (ek_pk1_diff_f64(&ok, 1, F, NULL, NULL, out, 0) >= 0) {
      printf("    dF = NULL accepted\n");
      bad_ok = 0;
    }
    printf("invalid arguments: %s\n", bad_ok ? "PASS" : "FAIL");
    if (!bad_ok)
      fail("invalid arguments");
  }

  // AoSoA forms = AoS forms (bits), and 1 thread = 2 threads (bits).
  {
    // Above EK_MATERIAL_PARALLEL_MIN, so that 2 threads really split it.
    const size_t big = 2 * EK_MATERIAL_PARALLEL_MIN + 17,
                 nb = (big + EK_LANES_F64 - 1) / EK_LANES_F64;
    double *F = malloc(big * 9 * sizeof *F), *P1 = malloc(big * 9 * sizeof *P1);
    double *P2 = malloc(big * 9 * sizeof *P2), *dF = malloc(big * 9 * sizeof *dF);
    double *Fs = malloc(nb * EK_LANES_F64 * 9 * sizeof *Fs);
    double *dFs = malloc(nb * EK_LANES_F64 * 9 * sizeof *dFs);
    double *Ps = malloc(nb * EK_LANES_F64 * 9 * sizeof *Ps);
    for (size_t e = 0; e < big; e++) {
      make_F((int)(urand() * KINDS), F + 9 * e);
      for (int k = 0; k < 9; k++)
        dF[9 * e + k] = urange(-1, 1);
    }
    for (size_t b = 0; b < nb; b++)
      for (int q = 0; q < 9; q++)
        for (int l = 0; l < EK_LANES_F64; l++) {
          size_t e = b * EK_LANES_F64 + (size_t)l, s = (b * 9 + (size_t)q) * EK_LANES_F64 + l;
          Fs[s] = e < big ? F[9 * e + q] : q % 4 == 0;
          dFs[s] = e < big ? dF[9 * e + q] : 0;
        }
    double *Ps1 = malloc(nb * EK_LANES_F64 * 9 * sizeof *Ps1);
    const int saved = omp_get_max_threads();
    int same_threads = 1, same_aosoa = 1;
    for (int model = 0; model < EK_MODEL_COUNT; model++) {
      if (model == EK_MODEL_COROTATED_LINEAR)
        continue; // needs R; its kernel is covered above
      // Without a clamp, neo-Hookean counts the inverted elements (the
      // integer reduction): the same count at every thread count too.
      ek_material m = {(ek_model)model, 1.3, 2.1, model == EK_MODEL_NEO_HOOKEAN ? 0 : 0.3};
      // Every output poisoned before its call (dP is overwritten,
      // material.h): the buffers hold the previous call's results, which
      // a chunk that did not run would leave.
      omp_set_num_threads(1);
      ek_check_poison(P1, big * 9 * sizeof *P1);
      ek_check_poison(Ps1, nb * EK_LANES_F64 * 9 * sizeof *Ps1);
      const int rc1 = ek_pk1_diff_f64(&m, big, F, NULL, dF, P1, 1);
      const int rcs1 = ek_pk1_diff_aosoa_f64(&m, nb, Fs, NULL, dFs, Ps1, 1);
      // Chunks go to whichever thread claims them first (kernels/team.h):
      // a few calls per count, so that the helpers take some in most.
      for (int t = 2; t <= 3; t++)
        for (int rep = 0; rep < 3; rep++) {
          omp_set_num_threads(t);
          ek_check_poison(P2, big * 9 * sizeof *P2);
          ek_check_poison(Ps, nb * EK_LANES_F64 * 9 * sizeof *Ps);
          same_threads &= ek_pk1_diff_f64(&m, big, F, NULL, dF, P2, 1) == rc1 &&
                          memcmp(P1, P2, big * 9 * sizeof *P1) == 0;
          same_threads &= ek_pk1_diff_aosoa_f64(&m, nb, Fs, NULL, dFs, Ps, 1) == rcs1 &&
                          memcmp(Ps1, Ps, nb * EK_LANES_F64 * 9 * sizeof *Ps) == 0;
        }
      same_aosoa &= rcs1 == rc1;
      for (size_t e = 0; e < big; e++)
        for (int q = 0; q < 9; q++)
          same_aosoa &= memcmp(Ps + ((e / EK_LANES_F64) * 9 + q) * EK_LANES_F64 + e % EK_LANES_F64,
                               P2 + 9 * e + q, sizeof *Ps) == 0; // bits: NaN = NaN
    }
    omp_set_num_threads(saved);
    free(Ps1);
    printf("1 vs 2 and 3 threads bitwise (AoS and AoSoA, and the count): %s; AoSoA vs AoS "
           "bitwise: %s\n",
           same_threads ? "PASS" : "FAIL", same_aosoa ? "PASS" : "FAIL");
    if (!same_threads || !same_aosoa)
      fail("threads / AoSoA");
    free(F), free(P1), free(P2), free(dF), free(Fs), free(dFs), free(Ps);
  }

  // Young / Poisson helpers.
  {
    double mu, lambda, E, nu;
    int ok = ek_lame_from_young_poisson(1e5, 0.3, &mu, &lambda) == 0 &&
             ek_young_poisson_from_lame(mu, lambda, &E, &nu) == 0 &&
             fabs(E - 1e5) <= EK_PK1_TOL_F64 * 1e5 && fabs(nu - 0.3) <= EK_PK1_TOL_F64 &&
             fabs(mu - 1e5 / 2.6) <= EK_PK1_TOL_F64 * mu;
    ok &= ek_lame_from_young_poisson(1e5, 0.5, &mu, &lambda) < 0;
    ok &= ek_lame_from_young_poisson(1e5, -1, &mu, &lambda) < 0;
    ok &= ek_lame_from_young_poisson(0, 0.3, &mu, &lambda) < 0;
    ok &= ek_lame_from_young_poisson(NAN, 0.3, &mu, &lambda) < 0;
    ok &= ek_young_poisson_from_lame(1, -1, &E, &nu) < 0;
    printf("Young/Poisson helpers: %s\n", ok ? "PASS" : "FAIL");
    if (!ok)
      fail("Young/Poisson");
  }

  printf("%s: %d failure(s)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
