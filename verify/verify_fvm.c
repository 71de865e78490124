// ek-verify family "fvm": the FVM force (ek_fvm_forces_ex_*) and the
// gradient and Hessian products of the implicit loop (include/ek/
// hessian.h), every ISA x precision x model x clamp (off, 0.3), against the
// double references (reference/fvm/) on a jittered, deformed box mesh whose
// tet count is not a multiple of a block. Norm of include/ek/fvm.h:
// max_i |f_i - f_ref_i| / max_i s_i, s_i the sum of the contributions'
// absolute values.
//   fvm rows: one metric per scatter strategy; "atomic(nondet)" is the
//     strategy whose sums are not reproducible from run to run (every other
//     gives the same bits at any thread count).
//   hessian rows: the gradient (vs minus the reference force) and K p with
//     each projection (none, clamp, abs; the reference projects the 9x9
//     Hessian with LAPACK).
//   hessian_assembly rows: the assembled K (ek_fvm_hessian_assemble) per
//     projection against the plain dense assembly of the reference's
//     element Hessians: max entry error / max entry scale (the sum of the
//     contributions' absolute values).
//   hessian_assembly_upper rows: the same for K's upper block triangle in
//     the cache's precision (ek_fvm_hessian_assemble_upper_*), mirrored.
#include <ek/ek.h>
#include <ek/sim/sim.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "fvm/fvm_ref.h"
#include "verify.h"

typedef struct {
  size_t nv, nt;
  double *X, *x, *R, *p, *ref, *scale, *out;
  int32_t *T;
  ek_mesh *mesh;
  ek_tet_state *R_state;
} fvm_case;

static int make_case(fvm_case *c, uint64_t seed) {
  ek_mesh *box = ek_mesh_box(5, 3, 3, 0.5, 0.3, 0.3); // 270 tets
  if (!box)
    return -1;
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  c->nv = ek_mesh_nverts(box), c->nt = ek_mesh_ntets(box);
  size_t n3 = 3 * c->nv;
  c->X = ek_check_malloc(n3 * sizeof(double));
  c->x = ek_check_malloc(n3 * sizeof(double));
  c->p = ek_check_malloc(n3 * sizeof(double));
  c->ref = ek_check_malloc(n3 * sizeof(double));
  c->scale = ek_check_malloc(n3 * sizeof(double));
  c->out = ek_check_malloc(n3 * sizeof(double));
  c->R = ek_check_malloc(c->nt * 9 * sizeof(double));
  c->T = ek_check_malloc(c->nt * 4 * sizeof(int32_t));
  memcpy(c->T, ek_mesh_tets(box), c->nt * 4 * sizeof(int32_t));
  const double *X = ek_mesh_rest_positions(box);
  double A[9];
  ek_rng_deformation(&rng, 0.2, A);
  for (size_t v = 0; v < c->nv; v++)
    for (int i = 0; i < 3; i++) {
      // Interior vertices jittered by up to 15% of a cell in the rest
      // shape; the deformed state x = A X + noise.
      double xi = X[3 * v + i], len = i == 0 ? 0.5 : 0.3;
      int interior = xi > 1e-9 && xi < len - 1e-9;
      c->X[3 * v + i] = xi + (interior ? 0.015 * (2 * ek_rng_uniform(&rng) - 1) : 0);
    }
  for (size_t v = 0; v < c->nv; v++)
    for (int i = 0; i < 3; i++) {
      double s = 0;
      for (int k = 0; k < 3; k++)
        s += A[3 * i + k] * c->X[3 * v + k];
      c->x[3 * v + i] = s + 0.01 * (2 * ek_rng_uniform(&rng) - 1);
      c->p[3 * v + i] = 0.1 * (2 * ek_rng_uniform(&rng) - 1);
    }
  for (size_t e = 0; e < c->nt; e++)
    ek_rng_rotation(&rng, c->R + 9 * e);
  ek_mesh_destroy(box);
  c->mesh = ek_mesh_create(c->nv, c->X, c->nt, c->T);
  c->R_state = c->mesh ? ek_tet_state_create(ek_mesh_elements(c->mesh), 9, 1) : NULL;
  if (!c->R_state || ek_tet_state_set_f64(c->R_state, c->R) < 0)
    return -1;
  return 0;
}

static void free_case(fvm_case *c) {
  ek_tet_state_destroy(c->R_state);
  ek_mesh_destroy(c->mesh);
  free(c->X), free(c->x), free(c->p), free(c->ref), free(c->scale), free(c->out), free(c->R);
  free(c->T);
}

// max |out - ref| / max scale; NaN anywhere counts as non-finite.
static double error_of(const fvm_case *c, ek_verify_row *row) {
  double s = 0, e = 0;
  for (size_t i = 0; i < 3 * c->nv; i++) {
    s = fmax(s, c->scale[i]);
    if (!isfinite(c->out[i]))
      row->nonfinite++;
    else
      e = fmax(e, fabs(c->out[i] - c->ref[i]));
  }
  return s > 0 ? e / s : e;
}

static int forces(fvm_case *c, const ek_material *m, ek_isa isa, int f32, ek_scatter s) {
  ek_fvm_opts o = {.scatter = s, .isa = isa, .R = c->R};
  size_t n3 = 3 * c->nv;
  if (!f32)
    return ek_mesh_fvm_forces_ex_f64(c->mesh, m, c->x, c->out, &o);
  float *xf = ek_check_malloc(n3 * sizeof(float)), *ff = ek_check_malloc(n3 * sizeof(float));
  ek_check_to_f32(n3, c->x, xf);
  int rc = ek_mesh_fvm_forces_ex_f32(c->mesh, m, xf, ff, &o);
  ek_check_from_f32(n3, ff, c->out);
  free(xf), free(ff);
  return rc;
}

// gradient (into out, as minus the force) or K p, with a fresh Hessian.
static int hessian(fvm_case *c, const ek_material *m, ek_isa isa, int f32, ek_projection pr,
                   int product) {
  ek_fvm_hessian_opts o = {.isa = isa, .precision = f32 ? 32 : 64, .projection = pr};
  ek_fvm_hessian *h = ek_fvm_hessian_create(ek_mesh_elements(c->mesh), m, &o);
  if (!h)
    return -1;
  const ek_tet_state *R = ek_model_need(m->model, 0) == EK_NEEDS_R_INPUT ? c->R_state : NULL;
  size_t n3 = 3 * c->nv;
  int rc = ek_fvm_hessian_gradient_f64(h, c->x, R, c->out, NULL, 1);
  if (rc == 0 && product) {
    if (f32) {
      float *pf = ek_check_malloc(n3 * sizeof(float)), *yf = ek_check_malloc(n3 * sizeof(float));
      ek_check_to_f32(n3, c->p, pf);
      rc = ek_fvm_hessian_apply_f32(h, pf, yf);
      ek_check_from_f32(n3, yf, c->out);
      free(pf), free(yf);
    } else {
      rc = ek_fvm_hessian_apply_f64(h, c->p, c->out);
    }
  }
  ek_fvm_hessian_destroy(h);
  return rc;
}

// max |K - Kref| / max Kscale of the assembled K with projection pr: the
// scalar CSR, or (upper) the upper block triangle mirrored.
static double assembly_error(fvm_case *c, const ek_material *m, const ek_material_ref *mr,
                             ek_isa isa, int f32, ek_projection pr, int upper, long *bad) {
  const size_t n3 = 3 * c->nv;
  ek_fvm_hessian_opts o = {.isa = isa, .precision = f32 ? 32 : 64, .projection = pr};
  ek_fvm_hessian *h = ek_fvm_hessian_create(ek_mesh_elements(c->mesh), m, &o);
  double *K = ek_check_malloc(n3 * n3 * sizeof(double)),
         *Ks = ek_check_malloc(n3 * n3 * sizeof(double));
  double err = INFINITY;
  ek_csr_pattern pat;
  ek_bsr_pattern up;
  const ek_tet_state *R = ek_model_need(m->model, 0) == EK_NEEDS_R_INPUT ? c->R_state : NULL;
  int rc = h ? ek_fvm_hessian_gradient_f64(h, c->x, R, c->out, NULL, 1) : -1;
  if (rc == 0)
    rc = upper ? ek_fvm_hessian_pattern_upper(h, &up) : ek_fvm_hessian_pattern(h, &pat);
  const size_t nv = rc ? 0 : upper ? 9 * up.nblocks : pat.nnz;
  double *v = rc == 0 ? ek_check_malloc((nv ? nv : 1) * sizeof(double)) : NULL;
  float *vf = rc == 0 && upper && f32 ? ek_check_malloc((nv ? nv : 1) * sizeof(float)) : NULL;
  if (rc == 0 && !upper)
    rc = ek_fvm_hessian_assemble(h, v);
  else if (rc == 0 && f32) {
    rc = ek_fvm_hessian_assemble_upper_f32(h, vf);
    ek_check_from_f32(nv, vf, v);
  } else if (rc == 0)
    rc = ek_fvm_hessian_assemble_upper_f64(h, v);
  if (rc == 0) {
    ek_fvm_hessian_assemble_ref(c->nv, c->X, c->nt, c->T, mr, c->R, c->x,
                                pr == EK_PROJECT_NONE    ? 0
                                : pr == EK_PROJECT_CLAMP ? 1
                                                         : 2,
                                K, Ks);
    double e = 0, s = 0;
    if (upper)
      for (size_t b = 0; b < c->nv; b++)
        for (int32_t q = up.bptr[b]; q < up.bptr[b + 1]; q++)
          for (size_t i = 0; i < 3; i++)
            for (size_t j = 0; j < 3; j++) {
              const size_t w = (size_t)up.bcol[q], r = 3 * b + i, col = 3 * w + j;
              K[r * n3 + col] -= v[9 * (size_t)q + 3 * i + j];
              if (w != b)
                K[col * n3 + r] -= v[9 * (size_t)q + 3 * i + j];
            }
    else
      for (size_t r = 0; r < n3; r++)
        for (int32_t k = pat.row_ptr[r]; k < pat.row_ptr[r + 1]; k++)
          K[r * n3 + (size_t)pat.col[k]] -= v[k];
    for (size_t i = 0; i < n3 * n3; i++) {
      e = fmax(e, fabs(K[i]));
      s = fmax(s, Ks[i]);
    }
    err = s > 0 ? e / s : e;
  }
  *bad += rc != 0 || !isfinite(err);
  free(vf);
  free(v);
  free(K);
  free(Ks);
  ek_fvm_hessian_destroy(h);
  return err;
}

int verify_fvm(ek_verify_ctx *ctx) {
  fvm_case c;
  memset(&c, 0, sizeof c);
  if (make_case(&c, ek_check_stream_seed(ek_verify_seed(ctx), "fvm")) != 0) {
    fprintf(stderr, "ek-verify: fvm: cannot build the test mesh: %s\n", ek_last_error());
    free_case(&c);
    return -1;
  }
  ek_verify_note_skipped_isas(ctx, "fvm");
  static const ek_scatter strategies[4] = {EK_SCATTER_COLORED, EK_SCATTER_THREAD_BUFFERS,
                                           EK_SCATTER_GATHER, EK_SCATTER_ATOMIC};
  static const char *const strategy_metric[4] = {"colored", "thread_buffers", "gather",
                                                 "atomic(nondet)"};
  static const char *const hessian_metric[4] = {"grad", "Kp_none", "Kp_clamp", "Kp_abs"};
  static const ek_projection projections[3] = {EK_PROJECT_NONE, EK_PROJECT_CLAMP, EK_PROJECT_ABS};
  const double clamps[2] = {0, 0.3};
  size_t n3 = 3 * c.nv;
  double *p32 = ek_check_malloc(n3 * sizeof(double));
  for (int model = 0; model < EK_MODEL_COUNT; model++)
    for (int ci = 0; ci < 2; ci++) {
      if (ci && ek_model_need((ek_model)model, clamps[ci]) != EK_NEEDS_SVD)
        continue; // not clampable: the clamp changes nothing
      ek_material m = {(ek_model)model, 1.3, 2.1, clamps[ci]};
      ek_material_ref mr = {model, m.mu, m.lambda, m.clamp};
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
        if (!ek_isa_available((ek_isa)isa))
          continue;
        for (int f32 = 1; f32 >= 0; f32--) {
          // The float kernels read positions rounded to float: so does
          // their reference.
          double *x = c.x;
          double *xr = ek_check_malloc(n3 * sizeof(double));
          for (size_t i = 0; i < n3; i++)
            xr[i] = f32 ? (double)(float)x[i] : x[i];
          ek_verify_row fr = {.kernel = "fvm"}, hr = {.kernel = "hessian"};
          snprintf(fr.variant, sizeof fr.variant, "%s f%d %s clamp=%g", ek_isa_name((ek_isa)isa),
                   f32 ? 32 : 64, ek_model_name((ek_model)model), m.clamp);
          snprintf(hr.variant, sizeof hr.variant, "%s", fr.variant);
          snprintf(fr.inputs, sizeof fr.inputs, "mesh %zu tets", c.nt);
          snprintf(hr.inputs, sizeof hr.inputs, "mesh %zu tets", c.nt);
          if (ek_verify_selected(ctx, fr.kernel, fr.variant, fr.inputs)) {
            ek_fvm_forces_ref(c.nv, c.X, c.nt, c.T, &mr, c.R, xr, c.ref, c.scale);
            for (int k = 0; k < 4; k++) {
              fr.metric[k] = strategy_metric[k];
              if (forces(&c, &m, (ek_isa)isa, f32, strategies[k]) < 0)
                fr.nonfinite++;
              fr.value[k] = error_of(&c, &fr);
              fr.worst = fmax(fr.worst, fr.value[k]);
            }
            fr.nmetrics = 4;
            fr.count = c.nt;
            fr.budget = f32 ? EK_FVM_TOL_F32 : EK_FVM_TOL_F64;
            ek_verify_emit(ctx, &fr);
          }
          if (ek_verify_selected(ctx, hr.kernel, hr.variant, hr.inputs)) {
            // The gradient is double whatever the products' precision.
            ek_fvm_forces_ref(c.nv, c.X, c.nt, c.T, &mr, c.R, x, c.ref, c.scale);
            for (size_t i = 0; i < n3; i++)
              c.ref[i] = -c.ref[i];
            hr.metric[0] = hessian_metric[0];
            if (hessian(&c, &m, (ek_isa)isa, f32, EK_PROJECT_CLAMP, 0) < 0)
              hr.nonfinite++;
            hr.value[0] = error_of(&c, &hr);
            double *psave = c.p;
            for (size_t i = 0; i < n3; i++)
              p32[i] = f32 ? (double)(float)psave[i] : psave[i];
            for (int k = 0; k < 3; k++) {
              ek_fvm_hessian_apply_ref(c.nv, c.X, c.nt, c.T, &mr, c.R, x, p32,
                                       projections[k] == EK_PROJECT_NONE    ? 0
                                       : projections[k] == EK_PROJECT_CLAMP ? 1
                                                                            : 2,
                                       c.ref, c.scale);
              hr.metric[1 + k] = hessian_metric[1 + k];
              if (hessian(&c, &m, (ek_isa)isa, f32, projections[k], 1) < 0)
                hr.nonfinite++;
              hr.value[1 + k] = error_of(&c, &hr);
            }
            hr.nmetrics = 4;
            // The gradient is held to the double budget, the products to
            // their precision's.
            double tol = f32 ? EK_HESSIAN_TOL_F32 : EK_HESSIAN_TOL_F64;
            hr.worst = fmax(hr.value[0] * tol / EK_FVM_TOL_F64,
                            fmax(hr.value[1], fmax(hr.value[2], hr.value[3])));
            hr.count = c.nt;
            hr.budget = tol;
            ek_verify_emit(ctx, &hr);
          }
          for (int upper = 0; upper < 2; upper++) {
            ek_verify_row ar = {.kernel = upper ? "hessian_assembly_upper" : "hessian_assembly"};
            snprintf(ar.variant, sizeof ar.variant, "%s", fr.variant);
            snprintf(ar.inputs, sizeof ar.inputs, "mesh %zu tets", c.nt);
            if (!ek_verify_selected(ctx, ar.kernel, ar.variant, ar.inputs))
              continue;
            static const char *const kmetric[3] = {"K_none", "K_clamp", "K_abs"};
            for (int k = 0; k < 3; k++) {
              ar.metric[k] = kmetric[k];
              ar.value[k] = assembly_error(&c, &m, &mr, (ek_isa)isa, f32, projections[k], upper,
                                           &ar.nonfinite);
              ar.worst = fmax(ar.worst, ar.value[k]);
            }
            ar.nmetrics = 3;
            ar.count = c.nt;
            ar.budget = f32 ? EK_HESSIAN_TOL_F32 : EK_HESSIAN_TOL_F64;
            ek_verify_emit(ctx, &ar);
          }
          free(xr);
        }
      }
    }
  free(p32);
  free_case(&c);
  return 0;
}
