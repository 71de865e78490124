// ek-verify family "material": every ISA x precision x model x clamp (off,
// 0.3) of ek_material_eval_* (psi, P, dP and the Hessian, each unprojected
// and projected) against the double reference (reference/material/) on a
// seeded random set of F (near identity, large, inverted, near-flat,
// rotations; singular values in [0.2, 5]: verify/check_material.c). Budgets EK_PK1_TOL_F32 / _F64
// in the norms of include/ek/material.h. Elements outside a model's domain (neo-Hookean without
// clamp, J <= 0) must give NaN / +inf exactly where the reference does; a mismatch counts as an
// isolation error.
#include <ek/ek.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "material/material_ref.h"
#include "verify.h"

// The reference Hessian (LAPACK dsyev per element) bounds the set size.
#define MATERIAL_SET_MAX 2000

static double amax(const double *a, size_t n) {
  double m = 0;
  for (size_t i = 0; i < n; i++)
    m = fmax(m, fabs(a[i]));
  return m;
}

int verify_material(ek_verify_ctx *ctx) {
  size_t n = ek_verify_n_random(ctx);
  if (n > MATERIAL_SET_MAX) {
    ek_verify_note(ctx,
                   "material: %d elements per set (the reference Hessian runs LAPACK dsyev "
                   "per element)",
                   MATERIAL_SET_MAX);
    n = MATERIAL_SET_MAX;
  }
  ek_verify_note_skipped_isas(ctx, "material");
  double *F = ek_check_malloc(n * 9 * sizeof *F), *R = ek_check_malloc(n * 9 * sizeof *R);
  double *dF = ek_check_malloc(n * 9 * sizeof *dF);
  double *ref = ek_check_malloc(n * 81 * sizeof *ref), *out = ek_check_malloc(n * 81 * sizeof *out);
  static const char *const metric[6] = {"psi", "P", "dP", "dP_psd", "H", "H_psd"};
  static const ek_material_op ops[6] = {EK_MAT_ENERGY,   EK_MAT_PK1,     EK_MAT_PK1_DIFF,
                                        EK_MAT_PK1_DIFF, EK_MAT_HESSIAN, EK_MAT_HESSIAN};
  static const int projects[6] = {0, 0, 0, 1, 0, 1};
  const double clamps[2] = {0, 0.3};

  for (int f32 = 1; f32 >= 0; f32--) {
    ek_check_material_inputs(ek_verify_seed(ctx), f32, n, F, R, dF);
    for (int model = 0; model < EK_MODEL_COUNT; model++)
      for (int c = 0; c < 2; c++) {
        ek_material m = {(ek_model)model, 1.3, 2.1, clamps[c]};
        ek_material_ref mr = {model, m.mu, m.lambda, m.clamp};
        const double lame = m.mu + fabs(m.lambda);
        ek_verify_row rows[EK_ISA_COUNT];
        memset(rows, 0, sizeof rows);
        for (int k = 0; k < 6; k++) {
          const size_t nout = ops[k] == EK_MAT_ENERGY ? 1 : ops[k] == EK_MAT_HESSIAN ? 81 : 9;
          for (size_t e = 0; e < n; e++) {
            const double *Fe = F + 9 * e, *Re = R + 9 * e;
            double *r = ref + 81 * e;
            if (ops[k] == EK_MAT_ENERGY)
              r[0] = ek_psi_ref(&mr, Fe, Re);
            else if (ops[k] == EK_MAT_PK1)
              ek_pk1_ref(&mr, Fe, Re, r);
            else if (ops[k] == EK_MAT_PK1_DIFF)
              ek_pk1_diff_ref(&mr, Fe, Re, dF + 9 * e, r, projects[k]);
            else
              ek_hessian_ref(&mr, Fe, Re, r, projects[k]);
          }
          for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
            if (!ek_isa_available((ek_isa)isa))
              continue;
            ek_verify_row *row = &rows[isa];
            int rc =
                ek_check_run_material(f32, &m, ops[k], (ek_isa)isa, n, F, R, dF, out, projects[k]);
            if (rc < 0) {
              fprintf(stderr, "ek-verify: material kernel returned %d: %s\n", rc, ek_last_error());
              row->nonfinite++;
              continue;
            }
            double worst = 0;
            for (size_t e = 0; e < n; e++) {
              const double *r = ref + 81 * e, *got = out + nout * e, *Fe = F + 9 * e;
              int ref_finite = 1, got_finite = 1;
              for (size_t q = 0; q < nout; q++)
                ref_finite &= isfinite(r[q]) != 0, got_finite &= isfinite(got[q]) != 0;
              if (!ref_finite) { // outside the domain: same answer required
                int ok = ops[k] == EK_MAT_ENERGY ? got[0] == INFINITY : isnan(got[0]);
                row->leaks += !ok;
                continue;
              }
              if (!got_finite) {
                row->nonfinite++;
                continue;
              }
              const double s = fmax(1, amax(Fe, 9));
              double scale = ops[k] == EK_MAT_ENERGY     ? lame * s * s * s * s
                             : ops[k] == EK_MAT_PK1      ? lame * s * s * s
                             : ops[k] == EK_MAT_PK1_DIFF ? lame * s * s * amax(dF + 9 * e, 9)
                                                         : lame * s * s;
              double d = 0;
              for (size_t q = 0; q < nout; q++)
                d = fmax(d, fabs(got[q] - r[q]));
              worst = fmax(worst, d / fmax(amax(r, nout), scale));
            }
            row->value[k] = worst;
          }
        }
        for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
          if (!ek_isa_available((ek_isa)isa))
            continue;
          ek_verify_row *row = &rows[isa];
          row->kernel = "material";
          snprintf(row->variant, sizeof row->variant, "%s %s %s clamp=%g", ek_isa_name((ek_isa)isa),
                   f32 ? "f32" : "f64", ek_model_name((ek_model)model), m.clamp);
          snprintf(row->inputs, sizeof row->inputs, "random mix");
          if (!ek_verify_selected(ctx, row->kernel, row->variant, row->inputs))
            continue;
          row->count = n;
          row->nmetrics = 6;
          for (int k = 0; k < 6; k++) {
            row->metric[k] = metric[k];
            row->worst = fmax(row->worst, row->value[k]);
          }
          row->budget = f32 ? EK_PK1_TOL_F32 : EK_PK1_TOL_F64;
          ek_verify_emit(ctx, row);
        }
      }
  }
  free(F), free(R), free(dF), free(ref), free(out);
  return 0;
}
