// ek-verify family "xpbd": the XPBD constraint sweeps (include/ek/xpbd.h),
// every ISA x precision x solver x elements (tets, clusters), against the
// double reference (reference/xpbd/) on a jittered, deformed box mesh with
// one face pinned: SWEEPS sweeps from lambda = 0, Gauss-Seidel in the order
// ek_xpbd_order gives. Norm of xpbd.h: max_i |x_i - x_ref,i| / the mesh's
// bounding-box diagonal (metric "x"), and the residual max |C + alpha~
// lambda| after the sweeps against the reference's (metric "residual",
// the absolute difference; C is dimensionless).
#include <ek/ek.h>
#include <ek/sim/sim.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "verify.h"
#include "xpbd/xpbd_ref.h"

#define SWEEPS 3
#define SUBSTEP 1e-2

typedef struct {
  size_t nv, nt;
  double *X, *x, *w, *mass, diag;
  int32_t *T;
  ek_mesh *mesh;
} xpbd_case;

static int make_case(xpbd_case *c, uint64_t seed) {
  ek_mesh *box = ek_mesh_box(5, 4, 3, 0.5, 0.4, 0.3); // 360 tets
  if (!box)
    return -1;
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  c->nv = ek_mesh_nverts(box), c->nt = ek_mesh_ntets(box);
  const size_t n3 = 3 * c->nv;
  c->X = ek_check_malloc(n3 * sizeof(double));
  c->x = ek_check_malloc(n3 * sizeof(double));
  c->w = ek_check_malloc(c->nv * sizeof(double));
  c->mass = ek_check_malloc(c->nv * sizeof(double));
  c->T = ek_check_malloc(c->nt * 4 * sizeof(int32_t));
  memcpy(c->T, ek_mesh_tets(box), c->nt * 4 * sizeof(int32_t));
  const double *X = ek_mesh_rest_positions(box), len[3] = {0.5, 0.4, 0.3};
  double A[9];
  ek_rng_deformation(&rng, 0.1, A);
  for (size_t v = 0; v < c->nv; v++)
    for (int i = 0; i < 3; i++) {
      // Interior vertices jittered by up to 15% of a cell; x = A X + noise.
      double xi = X[3 * v + i];
      int interior = xi > 1e-9 && xi < len[i] - 1e-9;
      c->X[3 * v + i] = xi + (interior ? 0.015 * (2 * ek_rng_uniform(&rng) - 1) : 0);
    }
  for (size_t v = 0; v < c->nv; v++)
    for (int i = 0; i < 3; i++) {
      double s = 0;
      for (int k = 0; k < 3; k++)
        s += A[3 * i + k] * c->X[3 * v + k];
      c->x[3 * v + i] = s + 0.005 * (2 * ek_rng_uniform(&rng) - 1);
    }
  ek_mesh_destroy(box);
  c->mesh = ek_mesh_create(c->nv, c->X, c->nt, c->T);
  if (!c->mesh)
    return -1;
  // Masses of density 1000; the face x = 0 pinned (w = 0).
  const double *lumped = ek_mesh_lumped_volume(c->mesh);
  for (size_t v = 0; v < c->nv; v++) {
    c->mass[v] = 1000 * lumped[v];
    c->w[v] = c->X[3 * v] < 1e-9 ? 0 : 1 / c->mass[v];
  }
  c->diag = sqrt(len[0] * len[0] + len[1] * len[1] + len[2] * len[2]);
  return 0;
}

static void free_case(xpbd_case *c) {
  ek_mesh_destroy(c->mesh);
  free(c->X), free(c->x), free(c->w), free(c->mass), free(c->T);
}

// The library's sweeps on x (in its precision), its residual after them,
// and the order its Gauss-Seidel projects in (*norder ids into order).
static int library(const xpbd_case *c, const ek_material *m, double young, ek_isa isa, int f32,
                   ek_xpbd_solver solver, ek_xpbd_elements el, double *x, double *residual,
                   int32_t *order, size_t *norder) {
  ek_xpbd_opts o = {.elements = el, .solver = solver, .isa = isa, .precision = f32 ? 32 : 64};
  ek_xpbd *xp = ek_xpbd_create(ek_mesh_elements(c->mesh), m, young, c->mass, &o);
  if (!xp || ek_xpbd_set_weights(xp, c->w) < 0 || ek_xpbd_begin(xp, SUBSTEP) < 0) {
    ek_xpbd_destroy(xp);
    return -1;
  }
  const size_t n3 = 3 * c->nv;
  int rc;
  if (f32) {
    float *xf = ek_check_malloc(n3 * sizeof(float));
    ek_check_to_f32(n3, c->x, xf);
    rc = ek_xpbd_iterate_f32(xp, NULL, xf, SWEEPS);
    if (rc == 0)
      rc = ek_xpbd_residual_f32(xp, NULL, xf, residual, NULL);
    ek_check_from_f32(n3, xf, x);
    free(xf);
  } else {
    memcpy(x, c->x, n3 * sizeof(double));
    rc = ek_xpbd_iterate_f64(xp, NULL, x, SWEEPS);
    if (rc == 0)
      rc = ek_xpbd_residual_f64(xp, NULL, x, residual, NULL);
  }
  int n = ek_xpbd_order(xp, order);
  *norder = n > 0 ? (size_t)n : 0;
  ek_xpbd_destroy(xp);
  return rc;
}

int verify_xpbd(ek_verify_ctx *ctx) {
  xpbd_case c;
  memset(&c, 0, sizeof c);
  if (make_case(&c, ek_check_stream_seed(ek_verify_seed(ctx), "xpbd")) != 0) {
    fprintf(stderr, "ek-verify: xpbd: cannot build the test mesh: %s\n", ek_last_error());
    free_case(&c);
    return -1;
  }
  ek_verify_note_skipped_isas(ctx, "xpbd");
  const double young = 1e5, nu = 0.3;
  const ek_material m = {EK_XPBD_MODEL, young / (2 * (1 + nu)),
                         young * nu / ((1 + nu) * (1 - 2 * nu)), 0};
  const ek_xpbd_ref_material mr = {m.mu, m.lambda, young, 0};
  const size_t n3 = 3 * c.nv;
  double *out = ek_check_malloc(n3 * sizeof(double)), *xr = ek_check_malloc(n3 * sizeof(double));
  // Constraints: at most one per tet or per vertex.
  int32_t *order = ek_check_malloc((c.nt > c.nv ? c.nt : c.nv) * sizeof(int32_t));
  size_t norder = 0;
  for (int el = 0; el < EK_XPBD_ELEMENTS_COUNT; el++) {
    ek_xpbd_ref_set set;
    if ((el == EK_XPBD_TETS ? ek_xpbd_ref_tets(c.nv, c.X, c.nt, c.T, &set)
                            : ek_xpbd_ref_clusters(c.nv, c.X, c.nt, c.T, c.mass, &set, NULL)) < 0) {
      fprintf(stderr, "ek-verify: xpbd: the reference cannot build its %s\n",
              ek_xpbd_elements_name((ek_xpbd_elements)el));
      continue;
    }
    double *lambda = ek_check_malloc(set.n * sizeof(double));
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      for (int f32 = 1; f32 >= 0; f32--) {
        ek_verify_row row = {.kernel = "xpbd"};
        snprintf(row.variant, sizeof row.variant, "%s f%d %s", ek_isa_name((ek_isa)isa),
                 f32 ? 32 : 64, ek_xpbd_elements_name((ek_xpbd_elements)el));
        snprintf(row.inputs, sizeof row.inputs, "mesh %zu tets, %d sweeps", c.nt, SWEEPS);
        if (!ek_verify_selected(ctx, row.kernel, row.variant, row.inputs))
          continue;
        static const char *const metrics[4] = {"gs_x", "gs_residual", "jacobi_x",
                                               "jacobi_residual"};
        const double cmin = f32 ? EK_XPBD_C_MIN_F32 : EK_XPBD_C_MIN_F64;
        for (int s = 0; s < EK_XPBD_SOLVER_COUNT; s++) {
          double res = NAN, res_ref;
          if (library(&c, &m, young, (ek_isa)isa, f32, (ek_xpbd_solver)s, (ek_xpbd_elements)el, out,
                      &res, order, &norder) < 0)
            row.nonfinite++;
          // The float sweeps start from positions rounded to float: so
          // does their reference.
          for (size_t i = 0; i < n3; i++)
            xr[i] = f32 ? (double)(float)c.x[i] : c.x[i];
          memset(lambda, 0, set.n * sizeof(double));
          for (int k = 0; k < SWEEPS; k++) {
            if (s == EK_XPBD_GAUSS_SEIDEL)
              ek_xpbd_ref_gauss_seidel(&set, &mr, c.w, SUBSTEP, cmin, norder, order, xr, lambda);
            else
              ek_xpbd_ref_jacobi(&set, &mr, c.w, SUBSTEP, cmin, xr, lambda);
          }
          res_ref = ek_xpbd_ref_residual(&set, &mr, SUBSTEP, cmin, xr, lambda, NULL);
          double e = 0;
          for (size_t i = 0; i < n3; i++) {
            if (!isfinite(out[i]))
              row.nonfinite++;
            else
              e = fmax(e, fabs(out[i] - xr[i]));
          }
          row.metric[2 * s] = metrics[2 * s];
          row.value[2 * s] = e / c.diag;
          row.metric[2 * s + 1] = metrics[2 * s + 1];
          row.value[2 * s + 1] = fabs(res - res_ref);
          if (!isfinite(res))
            row.nonfinite++;
          row.worst = fmax(row.worst, fmax(row.value[2 * s], row.value[2 * s + 1]));
        }
        row.nmetrics = 4;
        row.count = set.n;
        row.budget = f32 ? EK_XPBD_TOL_F32 : EK_XPBD_TOL_F64;
        ek_verify_emit(ctx, &row);
      }
    }
    free(lambda);
    ek_xpbd_ref_free(&set);
  }
  free(out);
  free(xr);
  free(order);
  free_case(&c);
  return 0;
}
