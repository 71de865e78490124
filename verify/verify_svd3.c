// ek-verify family "svd3": every ISA x precision x sweeps x rsqrt variant of
// ek_svd3_*, the refine knob (none, 1, 3) at the default sweeps, and the
// default and approximate ek_polar3_* against LAPACK
// dgesvd (reference/svd3/svd3_ref.c) on a random set and every family of
// the extremes catalogue. Budgets: EK_SVD3_TOL_F32 / _F64, for the default
// options; the other rows are the speed/accuracy trade.
#include <ek/ek.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "verify.h"

static int all_nan(const double *x, int n) {
  for (int i = 0; i < n; i++)
    if (!isnan(x[i]))
      return 0;
  return 1;
}

// Result of one variant on one set: the metrics' maxima and the counts.
typedef struct {
  double value[5];
  double worst;
  long nonfinite, leaks;
} set_result;

static const char *const svd_metrics[5] = {"recon", "orth", "det", "sigma", "order"};
static const char *const polar_metrics[5] = {"recon", "orth", "det", "sym", "rdiff"};

static int measure(int bits, int polar, const ek_svd3_set *s, const ek_svd3_opts *o, double budget,
                   double *U, double *S, double *V, set_result *res) {
  memset(res, 0, sizeof *res);
  int rc = ek_check_run_svd3(bits, polar, s->n, s->A, U, S, V, o);
  if (rc != 0) {
    fprintf(stderr, "ek-verify: kernel returned %d on %s: %s\n", rc, s->name, ek_last_error());
    return rc;
  }
  for (size_t i = 0; i < s->n; i++) {
    const double *A = s->A + 9 * i, *Sr = s->S_ref + 3 * i;
    if (s->bad[i]) {
      int nan_out = polar ? all_nan(U + 9 * i, 9) && all_nan(V + 9 * i, 9)
                          : all_nan(U + 9 * i, 9) && all_nan(S + 3 * i, 3) && all_nan(V + 9 * i, 9);
      res->leaks += !nan_out;
      continue;
    }
    double v[5], w;
    int nonfinite;
    if (polar) {
      ek_polar3_metrics m;
      ek_check_polar3(A, U + 9 * i, V + 9 * i, Sr, s->R_ref + 9 * i, &m);
      v[0] = m.recon, v[1] = m.orth, v[2] = m.det, v[3] = m.sym, v[4] = m.rdiff;
      w = ek_polar3_metrics_worst(&m), nonfinite = m.nonfinite;
    } else {
      ek_svd3_metrics m;
      ek_check_svd3(A, U + 9 * i, S + 3 * i, V + 9 * i, Sr, budget, &m);
      v[0] = m.recon, v[1] = m.orth, v[2] = m.det, v[3] = m.sigma, v[4] = m.order;
      w = ek_svd3_metrics_worst(&m), nonfinite = m.nonfinite;
      if (m.sign_wrong)
        v[3] = INFINITY; // a wrong sign is a wrong singular value
    }
    if (nonfinite) {
      // In a batch with NaN lanes, a non-finite good lane is a leak.
      if (s->nonfinite_family)
        res->leaks++;
      else
        res->nonfinite++;
      continue;
    }
    for (int k = 0; k < 5; k++)
      res->value[k] = fmax(res->value[k], v[k]);
    res->worst = fmax(res->worst, w);
  }
  return 0;
}

static void fill_row(ek_verify_row *row, const char *kernel, const char *variant,
                     const char *inputs, int polar, double budget, int trade) {
  memset(row, 0, sizeof *row);
  row->kernel = kernel;
  snprintf(row->variant, sizeof row->variant, "%s", variant);
  snprintf(row->inputs, sizeof row->inputs, "%s", inputs);
  row->nmetrics = 5;
  for (int k = 0; k < 5; k++)
    row->metric[k] = polar ? polar_metrics[k] : svd_metrics[k];
  row->budget = budget;
  row->trade = trade;
}

static void row_add(ek_verify_row *row, const set_result *r, size_t count, const char *name) {
  for (int k = 0; k < 5; k++)
    row->value[k] = fmax(row->value[k], r->value[k]);
  if (r->worst > row->worst || (r->worst == row->worst && !row->worst_case[0]))
    snprintf(row->worst_case, sizeof row->worst_case, "%s", name);
  row->worst = fmax(row->worst, r->worst);
  row->count += count;
  if ((r->nonfinite || r->leaks) && !row->nonfinite_case[0] && name[0])
    snprintf(row->nonfinite_case, sizeof row->nonfinite_case, "%s", name);
  row->nonfinite += r->nonfinite;
  row->leaks += r->leaks;
}

// One variant (sweeps, rsqrt) of svd3 or polar3 on one ISA and precision.
// Default options: one row per input set. Others: a "random" row and an
// "extremes" row (worst family named).
// refine: the option (0 = default; EK_SVD3_REFINE_NONE, 1..3), named in the
// variant when not the default.
static int run_variant(ek_verify_ctx *ctx, int bits, ek_isa isa, int polar, int sweeps, int rsqrt,
                       int refine, ek_svd3_set *sets, int nsets, double *U, double *S, double *V) {
  const char *kernel = polar ? "polar3" : "svd3";
  double budget = bits == 32 ? EK_SVD3_TOL_F32 : EK_SVD3_TOL_F64;
  // Judged: the default sweeps with either rsqrt mode (both are meant to
  // meet the budget), with the default refinement or more; other sweep
  // counts and less refinement are the reported trade.
  int def_refine = bits == 32 ? ek_svd3_default_refine_f32() : ek_svd3_default_refine_f64();
  int is_default = sweeps == 0 && (refine == 0 || refine >= def_refine);
  char variant[96], sw[16];
  if (sweeps)
    snprintf(sw, sizeof sw, "%d", sweeps);
  else
    snprintf(sw, sizeof sw, "def");
  int exact =
      rsqrt ? rsqrt > 0
            : (bits == 32 ? ek_svd3_default_exact_rsqrt_f32() : ek_svd3_default_exact_rsqrt_f64());
  char rf[24] = "";
  if (refine == EK_SVD3_REFINE_NONE)
    snprintf(rf, sizeof rf, " refine=none");
  else if (refine)
    snprintf(rf, sizeof rf, " refine=%d", refine);
  snprintf(variant, sizeof variant, "%s f%d sweeps=%s rsqrt=%s%s%s", ek_isa_name(isa), bits, sw,
           exact ? "exact" : "approx", rsqrt ? "" : "(def)", rf);
  ek_svd3_opts o = {.sweeps = sweeps, .exact_rsqrt = rsqrt, .isa = isa, .refine = refine};
  int errors = 0;
  ek_verify_row agg[2];
  fill_row(&agg[0], kernel, variant, "random", polar, budget, !is_default);
  fill_row(&agg[1], kernel, variant, "extremes", polar, budget, !is_default);
  int used[2] = {0, 0};
  for (int k = 0; k < nsets; k++) {
    int which = k == 0 ? 0 : 1;
    int per_set = is_default && !polar && !refine;
    const char *label = per_set || which == 0 ? sets[k].name : "extremes";
    if (!ek_verify_selected(ctx, kernel, variant, label))
      continue;
    set_result r;
    if (measure(bits, polar, &sets[k], &o, budget, U, S, V, &r)) {
      errors++;
      continue;
    }
    if (per_set) {
      ek_verify_row row;
      fill_row(&row, kernel, variant, sets[k].name, polar, budget, 0);
      row_add(&row, &r, sets[k].n, "");
      row.worst_case[0] = 0;
      ek_verify_emit(ctx, &row);
    } else {
      row_add(&agg[which], &r, sets[k].n, sets[k].name);
      used[which] = 1;
    }
  }
  for (int w = 0; w < 2; w++)
    if (used[w]) {
      if (w == 0)
        agg[w].worst_case[0] = 0;
      ek_verify_emit(ctx, &agg[w]);
    }
  return errors;
}

int verify_svd3(ek_verify_ctx *ctx) {
  uint64_t seed = ek_verify_seed(ctx);
  int quick = ek_verify_quick(ctx);
  int errors = 0;
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    if (!ek_isa_available((ek_isa)isa))
      ek_verify_note(ctx, "svd3: ISA %s skipped: not built or not supported by this CPU",
                     ek_isa_name((ek_isa)isa));
  printf("default sweeps: f32 %d, f64 %d; budgets f32 %g, f64 %g\n", ek_svd3_default_sweeps_f32(),
         ek_svd3_default_sweeps_f64(), EK_SVD3_TOL_F32, EK_SVD3_TOL_F64);
  for (int bits = 32; bits <= 64; bits += 32) {
    // The input sets of this precision: random, then every family.
    ek_svd3_set *sets = ek_check_malloc((size_t)(ek_check_nfamilies + 1) * sizeof *sets);
    int nsets = 0;
    size_t nmax = 0;
    ek_svd3_set_init(&sets[nsets++], &ek_check_families[0], "random", seed, ek_verify_n_random(ctx),
                     bits);
    for (int f = 0; f < ek_check_nfamilies; f++)
      if (ek_check_family_for(&ek_check_families[f], bits))
        ek_svd3_set_init(&sets[nsets++], &ek_check_families[f], ek_check_families[f].name, seed,
                         ek_verify_n_family(ctx), bits);
    for (int k = 0; k < nsets; k++)
      nmax = sets[k].n > nmax ? sets[k].n : nmax;
    double *U = ek_check_malloc(9 * nmax * sizeof(double)),
           *S = ek_check_malloc(3 * nmax * sizeof(double));
    double *V = ek_check_malloc(9 * nmax * sizeof(double));
    static const int quick_sweeps[] = {0, 2, 4};
    int nsw = quick ? 3 : 9;
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      for (int si = 0; si < nsw; si++) {
        int sweeps = quick ? quick_sweeps[si] : si;
        for (int rsqrt = 1; rsqrt >= -1; rsqrt--)
          errors += run_variant(ctx, bits, (ek_isa)isa, 0, sweeps, rsqrt, 0, sets, nsets, U, S, V);
      }
      // The refine knob at the default sweeps and rsqrt: none (McAdams et
      // al. 2011's algorithm at these sweeps), 1, and the most (judged).
      static const int refines[] = {EK_SVD3_REFINE_NONE, 1, EK_SVD3_MAX_REFINE};
      for (int r = 0; r < 3; r++)
        errors += run_variant(ctx, bits, (ek_isa)isa, 0, 0, 0, refines[r], sets, nsets, U, S, V);
      for (int rsqrt = 1; rsqrt >= -1; rsqrt--)
        errors += run_variant(ctx, bits, (ek_isa)isa, 1, 0, rsqrt, 0, sets, nsets, U, S, V);
    }
    free(U), free(S), free(V);
    for (int k = 0; k < nsets; k++)
      ek_svd3_set_free(&sets[k]);
    free(sets);
  }
  return errors;
}
