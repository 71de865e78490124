// ek-verify family "cloth_force": the cloth forces (include/ek/cloth_force.h:
// membrane StVK and ARAP, Bergou bending), every ISA x precision x model,
// against the double reference (reference/cloth_force/, the metric form and
// LAPACK) on a jittered grid tilted by a random rotation:
//   "crumpled": stretched by 10%, rotated, vertices displaced by 15% of a
//     cell; metric "f" = max |f - f_ref| / max |f_ref| (cloth_force.h's
//     EK_CLOTH_FORCE_TOL_F32 / _F64), "momentum" = |sum f| / sum |f|;
//   "rest": the flat rest shape; metric "f_rest" = max |f| / (mu h + k_b /
//     h), h the longest rest edge (EK_CLOTH_FORCE_REST_TOL_F32 / _F64).
// Kernel "cloth_membrane": the vector energy and Hessian product
// (ek_cloth_energy_ex_*, ek_cloth_hessian_apply_ex_*) on the crumpled state:
// "energy" = |E - E_ref| / E_ref against the reference, "hessian" =
// max |q - q64| / max |q64| against the double path
// (ek_cloth_hessian_apply_f64), projected and not
// (EK_CLOTH_MEMBRANE_TOL_F32 / _F64).
#include <ek/ek.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "cloth_force/cloth_force_ref.h"
#include "verify.h"

#define NX 12
#define NY 9
#define CELL 0.1
#define MU 1e3
#define LAMBDA 5e2
#define BENDING 1e-3

int verify_cloth_force(ek_verify_ctx *ctx) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(ek_verify_seed(ctx), "cloth_force"));
  const size_t nv = (NX + 1) * (NY + 1), nt = 2 * NX * NY, n3 = 3 * nv;
  double *X = ek_check_malloc(n3 * sizeof(double)), *x = ek_check_malloc(n3 * sizeof(double));
  double *f = ek_check_malloc(n3 * sizeof(double)), *fr = ek_check_malloc(n3 * sizeof(double));
  float *xf = ek_check_malloc(n3 * sizeof(float)), *ff = ek_check_malloc(n3 * sizeof(float));
  int32_t *T = ek_check_malloc(3 * nt * sizeof(int32_t));
  double R[9], Q[9];
  ek_rng_rotation(&rng, R);
  ek_rng_rotation(&rng, Q);
  for (int j = 0; j <= NY; ++j)
    for (int i = 0; i <= NX; ++i) {
      double p[3] = {i * CELL, j * CELL, 0};
      if (i > 0 && i < NX && j > 0 && j < NY)
        for (int k = 0; k < 2; ++k)
          p[k] += 0.25 * CELL * (2 * ek_rng_uniform(&rng) - 1);
      size_t v = (size_t)j * (NX + 1) + (size_t)i;
      for (int r = 0; r < 3; ++r)
        X[3 * v + r] = R[3 * r] * p[0] + R[3 * r + 1] * p[1] + R[3 * r + 2] * p[2];
    }
  size_t t = 0;
  for (int j = 0; j < NY; ++j)
    for (int i = 0; i < NX; ++i) {
      int32_t a = j * (NX + 1) + i, b = a + 1, c = a + NX + 1, d = c + 1;
      int32_t q[6] = {a, b, d, a, d, c};
      memcpy(T + 3 * t, q, sizeof q);
      t += 2;
    }
  for (size_t v = 0; v < nv; ++v)
    for (int r = 0; r < 3; ++r) {
      double y = 0;
      for (int k = 0; k < 3; ++k)
        y += Q[3 * r + k] * 1.1 * X[3 * v + k];
      x[3 * v + r] = y + 0.15 * CELL * (2 * ek_rng_uniform(&rng) - 1);
    }
  ek_cloth *cl = ek_cloth_create(nv, X, nt, T);
  if (!cl) {
    fprintf(stderr, "ek-verify: cloth_force: %s\n", ek_last_error());
    return -1;
  }
  ek_verify_note_skipped_isas(ctx, "cloth_force");
  const double longest = 1.5 * CELL * sqrt(2.0), scale = MU * longest + BENDING / longest;
  for (int model = 0; model < EK_MEMBRANE_COUNT; ++model) {
    const ek_cloth_params p = {(ek_membrane_model)model, MU, LAMBDA, BENDING};
    const cloth_ref_params rp = {model, MU, LAMBDA, BENDING};
    cloth_ref_forces(&rp, nv, X, nt, T, ek_cloth_nhinges(cl), ek_cloth_hinges(cl), x, fr);
    double fmax_ref = 0;
    for (size_t i = 0; i < n3; ++i)
      fmax_ref = fmax(fmax_ref, fabs(fr[i]));
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      for (int f32 = 1; f32 >= 0; f32--) {
        ek_verify_row row = {.kernel = "cloth_force"};
        snprintf(row.variant, sizeof row.variant, "%s f%d %s", ek_isa_name((ek_isa)isa),
                 f32 ? 32 : 64, model == EK_MEMBRANE_STVK ? "stvk" : "arap");
        snprintf(row.inputs, sizeof row.inputs, "grid %zu tris: crumpled, rest", nt);
        if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
          continue;
        const ek_cloth_force_opts o = {.isa = (ek_isa)isa};
        double e = 0, sum[3] = {0, 0, 0}, mag = 0, rest = 0;
        for (int pass = 0; pass < 2; ++pass) { // 0 crumpled, 1 rest
          const double *xs = pass ? X : x;
          int rc;
          if (f32) {
            for (size_t i = 0; i < n3; ++i)
              xf[i] = (float)xs[i];
            rc = ek_cloth_forces_f32(cl, &p, xf, ff, &o);
            for (size_t i = 0; i < n3; ++i)
              f[i] = ff[i];
          } else {
            rc = ek_cloth_forces_f64(cl, &p, xs, f, &o);
          }
          for (size_t i = 0; i < n3; ++i) {
            if (rc || !isfinite(f[i])) {
              row.nonfinite++;
              continue;
            }
            if (pass) {
              rest = fmax(rest, fabs(f[i]) / scale);
            } else {
              e = fmax(e, fabs(f[i] - fr[i]) / fmax_ref);
              sum[i % 3] += f[i];
              mag += fabs(f[i]);
            }
          }
        }
        row.nmetrics = 3;
        row.metric[0] = "f";
        row.value[0] = e;
        row.metric[1] = "momentum";
        row.value[1] = sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]) / mag;
        row.metric[2] = "f_rest";
        row.value[2] = rest;
        const double budget = f32 ? EK_CLOTH_FORCE_TOL_F32 : EK_CLOTH_FORCE_TOL_F64,
                     rest_budget = f32 ? EK_CLOTH_FORCE_REST_TOL_F32 : EK_CLOTH_FORCE_REST_TOL_F64;
        // One number against one budget: each metric as a fraction of its
        // own budget, times the row's budget.
        row.worst = budget * fmax(e / budget, fmax(row.value[1] / budget, rest / rest_budget));
        row.budget = budget;
        row.count = nt;
        ek_verify_emit(ctx, &row);
      }
    }
  }
  // The vector energy and Hessian product (kernel "cloth_membrane").
  double *dx = ek_check_malloc(n3 * sizeof(double)), *q = ek_check_malloc(n3 * sizeof(double));
  float *dxf = ek_check_malloc(n3 * sizeof(float)), *qf = ek_check_malloc(n3 * sizeof(float));
  for (size_t i = 0; i < n3; ++i) {
    dx[i] = 2 * ek_rng_uniform(&rng) - 1;
    dxf[i] = (float)dx[i];
    xf[i] = (float)x[i];
  }
  for (int model = 0; model < EK_MEMBRANE_COUNT; ++model) {
    const ek_cloth_params p = {(ek_membrane_model)model, MU, LAMBDA, BENDING};
    const cloth_ref_params rp = {model, MU, LAMBDA, BENDING};
    const double Eref =
        cloth_ref_forces(&rp, nv, X, nt, T, ek_cloth_nhinges(cl), ek_cloth_hinges(cl), x, NULL);
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      for (int f32 = 1; f32 >= 0; f32--) {
        ek_verify_row row = {.kernel = "cloth_membrane"};
        snprintf(row.variant, sizeof row.variant, "%s f%d %s", ek_isa_name((ek_isa)isa),
                 f32 ? 32 : 64, model == EK_MEMBRANE_STVK ? "stvk" : "arap");
        snprintf(row.inputs, sizeof row.inputs, "grid %zu tris: crumpled", nt);
        if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
          continue;
        const ek_cloth_force_opts o = {.isa = (ek_isa)isa};
        double E = NAN, eh = 0;
        int rc = f32 ? ek_cloth_energy_ex_f32(cl, &p, xf, &E, &o)
                     : ek_cloth_energy_ex_f64(cl, &p, x, &E, &o);
        if (rc || !isfinite(E))
          row.nonfinite++;
        for (int project = 0; project < 2; ++project) {
          ek_cloth_hessian_apply_f64(cl, &p, x, project, dx, fr);
          if (f32) {
            rc = ek_cloth_hessian_apply_ex_f32(cl, &p, xf, project, dxf, qf, &o);
            for (size_t i = 0; i < n3; ++i)
              q[i] = qf[i];
          } else {
            rc = ek_cloth_hessian_apply_ex_f64(cl, &p, x, project, dx, q, &o);
          }
          double qmax = 0, d = 0;
          for (size_t i = 0; i < n3; ++i) {
            qmax = fmax(qmax, fabs(fr[i]));
            if (rc || !isfinite(q[i]))
              row.nonfinite++;
            else
              d = fmax(d, fabs(q[i] - fr[i]));
          }
          eh = fmax(eh, d / qmax);
        }
        row.nmetrics = 2;
        row.metric[0] = "energy";
        row.value[0] = fabs(E - Eref) / fabs(Eref);
        row.metric[1] = "hessian";
        row.value[1] = eh;
        row.budget = f32 ? EK_CLOTH_MEMBRANE_TOL_F32 : EK_CLOTH_MEMBRANE_TOL_F64;
        row.worst = fmax(row.value[0], row.value[1]);
        row.count = nt;
        ek_verify_emit(ctx, &row);
      }
    }
  }
  free(dx), free(q), free(dxf), free(qf);
  ek_cloth_destroy(cl);
  free(X), free(x), free(f), free(fr), free(xf), free(ff), free(T);
  return 0;
}
