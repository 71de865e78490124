// ek-verify family "cloth": the cloth kernels (include/ek/cloth.h), every
// ISA x precision, against the double references (reference/cloth/) on a
// random set and every extremes family of check_cloth.c, in the norms of
// cloth.h (budgets EK_CLOTH_TOL_F32 / _F64). One row per kernel x ISA x
// precision; its worst family is named.
//   polar32: recon, orth, uc, sigma, rdiff (R against dgesvd's times
//     sigma2 / sigma1); a non-finite F must give NaN in its own lane only;
//   kabsch: orth, det, objective excess over LAPACK's, rdiff (times
//     (s2 + s3) / s1), one-ring sets of 4..9 points;
//   tri_velgrad: L, D, W against dgesvd's pseudo-inverse (relative to
//     |Vs| |Ds^+| cond).
#include <ek/ek.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "check_cloth.h"
#include "cloth/cloth_ref.h"
#include "verify.h"

static void keep_worst(ek_verify_row *row, int nm, const double *v, double worst,
                       const char *family) {
  for (int i = 0; i < nm; i++)
    row->value[i] = fmax(row->value[i], v[i]);
  if (worst > row->worst || (isnan(worst) && !isnan(row->worst))) {
    row->worst = worst;
    snprintf(row->worst_case, sizeof row->worst_case, "%s", family);
  }
}

static void polar32_rows(ek_verify_ctx *ctx, ek_isa isa, int bits) {
  ek_verify_row row = {.kernel = "polar32"};
  snprintf(row.variant, sizeof row.variant, "%s f%d", ek_isa_name(isa), bits);
  snprintf(row.inputs, sizeof row.inputs, "random + %d families", ek_polar32_nfamilies - 1);
  if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
    return;
  static const char *const names[5] = {"recon", "orth", "uc", "sigma", "rdiff"};
  row.nmetrics = 5;
  for (int i = 0; i < 5; i++)
    row.metric[i] = names[i];
  for (int f = 0; f < ek_polar32_nfamilies; f++) {
    const ek_polar32_family *fam = &ek_polar32_families[f];
    if (!(fam->flags & (bits == 32 ? EK_FAMILY_F32 : EK_FAMILY_F64)))
      continue;
    size_t n = f == 0 ? ek_verify_n_random(ctx) : ek_verify_n_family(ctx);
    double *F = ek_check_malloc(6 * n * sizeof(double)),
           *R = ek_check_malloc(6 * n * sizeof(double));
    double *Uc = ek_check_malloc(4 * n * sizeof(double));
    ek_rng rng;
    ek_rng_seed(&rng, ek_check_stream_seed(ek_verify_seed(ctx), fam->name));
    fam->generate(&rng, n, F);
    if (bits == 32)
      for (size_t i = 0; i < 6 * n; i++)
        F[i] = (double)(float)F[i];
    if (ek_check_run_polar32(bits, isa, n, F, R, Uc) != 0)
      row.nonfinite += (long)n;
    for (size_t k = 0; k < n; k++) {
      const double *Fk = F + 6 * k;
      int finite = 1;
      for (int i = 0; i < 6; i++)
        finite &= isfinite(Fk[i]) != 0;
      if (!finite) {
        int all_nan = 1;
        for (int i = 0; i < 6; i++)
          all_nan &= isnan(R[6 * k + i]) != 0;
        for (int i = 0; i < 4; i++)
          all_nan &= isnan(Uc[4 * k + i]) != 0;
        row.leaks += !all_nan;
        continue;
      }
      double Rr[6], Ur[4], s[2];
      ek_polar32_ref(Fk, Rr, Ur, s);
      ek_polar32_metrics m;
      ek_check_polar32(Fk, R + 6 * k, Uc + 4 * k, Rr, Ur, s, &m);
      if (m.nonfinite) {
        row.nonfinite++;
        if (!row.nonfinite_case[0])
          snprintf(row.nonfinite_case, sizeof row.nonfinite_case, "%s", fam->name);
        continue;
      }
      double v[5] = {m.recon, m.orth, m.uc, m.sigma, m.rdiff};
      keep_worst(&row, 5, v, ek_polar32_metrics_worst(&m), fam->name);
    }
    row.count += n;
    free(F), free(R), free(Uc);
  }
  row.budget = bits == 32 ? EK_CLOTH_TOL_F32 : EK_CLOTH_TOL_F64;
  ek_verify_emit(ctx, &row);
}

static void kabsch_rows(ek_verify_ctx *ctx, ek_isa isa, int bits) {
  ek_verify_row row = {.kernel = "kabsch"};
  snprintf(row.variant, sizeof row.variant, "%s f%d", ek_isa_name(isa), bits);
  snprintf(row.inputs, sizeof row.inputs, "%d set families", ek_kabsch_nfamilies);
  if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
    return;
  static const char *const names[4] = {"orth", "det", "objective", "rdiff"};
  row.nmetrics = 4;
  for (int i = 0; i < 4; i++)
    row.metric[i] = names[i];
  for (int f = 0; f < ek_kabsch_nfamilies; f++) {
    ek_kabsch_set s;
    size_t n = f == 0 ? ek_verify_n_random(ctx) : ek_verify_n_family(ctx);
    ek_kabsch_set_init(&s, ek_kabsch_families[f], ek_verify_seed(ctx), n, bits);
    double *R = ek_check_malloc(9 * n * sizeof(double));
    if (ek_check_run_kabsch(bits, isa, &s, R) != 0)
      row.nonfinite += (long)n;
    for (size_t k = 0; k < n; k++) {
      ek_kabsch_metrics m;
      ek_check_kabsch(&s, k, R + 9 * k, &m);
      if (m.nonfinite) {
        row.nonfinite++;
        continue;
      }
      double v[4] = {m.orth, m.det, m.objective, m.rdiff};
      keep_worst(&row, 4, v, ek_kabsch_metrics_worst(&m), s.name);
    }
    row.count += n;
    free(R);
    ek_kabsch_set_free(&s);
  }
  row.budget = bits == 32 ? EK_CLOTH_TOL_F32 : EK_CLOTH_TOL_F64;
  ek_verify_emit(ctx, &row);
}

static void velgrad_rows(ek_verify_ctx *ctx, ek_isa isa, int bits) {
  ek_verify_row row = {.kernel = "tri_velgrad"};
  snprintf(row.variant, sizeof row.variant, "%s f%d", ek_isa_name(isa), bits);
  snprintf(row.inputs, sizeof row.inputs, "%d families", ek_velgrad_nfamilies);
  if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
    return;
  static const char *const names[3] = {"L", "D", "W"};
  row.nmetrics = 3;
  for (int i = 0; i < 3; i++)
    row.metric[i] = names[i];
  double eps = bits == 32 ? FLT_EPSILON : DBL_EPSILON;
  for (int f = 0; f < ek_velgrad_nfamilies; f++) {
    size_t n = ek_verify_n_family(ctx);
    double *x = ek_check_malloc(9 * n * sizeof(double)),
           *v = ek_check_malloc(9 * n * sizeof(double));
    double *L = ek_check_malloc(9 * n * sizeof(double)),
           *D = ek_check_malloc(9 * n * sizeof(double));
    double *W = ek_check_malloc(9 * n * sizeof(double));
    ek_velgrad_generate(ek_velgrad_families[f], ek_verify_seed(ctx), 3, n, x, v);
    if (bits == 32)
      for (size_t i = 0; i < 9 * n; i++)
        x[i] = (double)(float)x[i], v[i] = (double)(float)v[i];
    if (ek_check_run_tri_velgrad(bits, isa, n, x, v, L, D, W) != 0)
      row.nonfinite += (long)n;
    for (size_t e = 0; e < n; e++) {
      double Lr[9], Dr[9], Wr[9];
      ek_tri_velgrad_ref(x + 9 * e, v + 9 * e, 3 * eps, Lr);
      ek_LDW_ref(Lr, Dr, Wr);
      double val[3] = {ek_check_velgrad_err(3, bits, x + 9 * e, v + 9 * e, L + 9 * e, Lr),
                       ek_check_velgrad_err(3, bits, x + 9 * e, v + 9 * e, D + 9 * e, Dr),
                       ek_check_velgrad_err(3, bits, x + 9 * e, v + 9 * e, W + 9 * e, Wr)};
      int bad = 0;
      for (int i = 0; i < 9; i++)
        bad |= !isfinite(L[9 * e + i]);
      if (bad) {
        row.nonfinite++;
        continue;
      }
      keep_worst(&row, 3, val, fmax(val[0], fmax(val[1], val[2])), ek_velgrad_families[f]);
    }
    row.count += n;
    free(x), free(v), free(L), free(D), free(W);
  }
  row.budget = bits == 32 ? EK_CLOTH_TOL_F32 : EK_CLOTH_TOL_F64;
  ek_verify_emit(ctx, &row);
}

int verify_cloth(ek_verify_ctx *ctx) {
  ek_verify_note_skipped_isas(ctx, "cloth");
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available((ek_isa)isa))
      continue;
    for (int bits = 32; bits <= 64; bits += 32) {
      polar32_rows(ctx, (ek_isa)isa, bits);
      kabsch_rows(ctx, (ek_isa)isa, bits);
      velgrad_rows(ctx, (ek_isa)isa, bits);
    }
  }
  return 0;
}
