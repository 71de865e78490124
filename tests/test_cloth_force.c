// Cloth forces (include/ek/cloth_force.h) and their scalar double
// reference (reference/cloth_force/cloth_force_ref.c), on a jittered flat
// grid tilted by a random rotation with its vertices renumbered at random:
//   a. the reference's forces equal central differences of its energy;
//   b. the library's rest data (areas, hinge coefficients) and energy equal
//      the reference's;
//   c. forces of every ISA x precision x membrane model (bending on) match
//      the reference (EK_CLOTH_FORCE_TOL_F32 / _F64) and sum to zero (momentum);
//      the library's f64 forces equal central differences of its energy;
//   d. the Hessian product equals central differences of the forces; the
//      projected product equals it on a stretched cloth and is PSD on a
//      crumpled one;
//   e. a flat cloth at rest feels no force (membrane and bending);
//   f. the same bits at 1 and 2 threads above the parallel threshold (the
//      energies at 1, 2, 3 and 7, and the f32 energy in its block order);
//   g. bad input is refused with a message naming the triangle;
//   h. ARAP on near rank-deficient triangles (the kernel's slow lanes)
//      against the reference, and finite on collapsed ones;
//   i. the vector energy and Hessian product of every ISA x precision
//      against the reference's energy and the double Hessian product
//      (EK_CLOTH_MEMBRANE_TOL_F32 / _F64), projected and not, stretched and
//      compressed; f64 against central differences of the reference forces.
#include <ek/cloth_force.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels/elements/tris.h" // the f32 energy's blocks, its triangle energies
#include "check.h"
#include "cli.h"
#include "cloth_force/cloth_force_ref.h"
#include "test_tolerances.h"

static int failures = 0;

static void report(const char *what, double err, double budget) {
  double r = err / budget;
  const char *v = ek_verdict_name(ek_check_verdict(err, budget));
  printf("%-64s err %.3e  budget %.1e  err/budget %.3f  %s\n", what, err, budget, r, v);
  if (!(r <= 1.0))
    failures++;
}

static void check(const char *what, int ok) {
  printf("%-64s %s\n", what, ok ? "PASS" : "FAIL");
  if (!ok)
    failures++;
}

#define CELL 0.1
#define MU 1e3       // N/m: a membrane of E ~ 2.6 MPa, 1 mm thick
#define LAMBDA 5e2   // N/m
#define BENDING 1e-3 // N m, bending forces comparable to the membrane's at 10% strain

typedef struct {
  size_t nv, nt;
  double *X;
  int32_t *T;
} tri_mesh;

// nx x ny cells of CELL, two triangles each (alternating diagonals),
// interior vertices jittered in the plane by `jitter` cells, rotated by a
// random rotation, vertices renumbered at random.
static tri_mesh grid_random(ek_rng *rng, int nx, int ny, double jitter) {
  tri_mesh m;
  m.nv = (size_t)(nx + 1) * (size_t)(ny + 1);
  m.nt = 2 * (size_t)nx * (size_t)ny;
  m.X = malloc(3 * m.nv * sizeof(double));
  m.T = malloc(3 * m.nt * sizeof(int32_t));
  size_t *perm = malloc(m.nv * sizeof *perm);
  for (size_t i = 0; i < m.nv; ++i)
    perm[i] = i;
  for (size_t i = m.nv - 1; i > 0; --i) {
    size_t j = ek_rng_next(rng) % (i + 1), t = perm[i];
    perm[i] = perm[j];
    perm[j] = t;
  }
  double R[9];
  ek_rng_rotation(rng, R);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      double p[3] = {i * CELL, j * CELL, 0};
      if (i > 0 && i < nx && j > 0 && j < ny)
        for (int k = 0; k < 2; ++k)
          p[k] += jitter * CELL * (2 * ek_rng_uniform(rng) - 1);
      size_t v = perm[(size_t)j * (size_t)(nx + 1) + (size_t)i];
      for (int r = 0; r < 3; ++r)
        m.X[3 * v + r] = R[3 * r] * p[0] + R[3 * r + 1] * p[1] + R[3 * r + 2] * p[2] + 0.3 * r;
    }
  size_t t = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      int32_t a = (int32_t)perm[(size_t)j * (size_t)(nx + 1) + (size_t)i],
              b = (int32_t)perm[(size_t)j * (size_t)(nx + 1) + (size_t)i + 1],
              c = (int32_t)perm[(size_t)(j + 1) * (size_t)(nx + 1) + (size_t)i],
              d = (int32_t)perm[(size_t)(j + 1) * (size_t)(nx + 1) + (size_t)i + 1];
      int32_t q[6] = {a, b, d, a, d, c};
      if ((i + j) % 2) {
        int32_t r2[6] = {a, b, c, b, d, c};
        memcpy(q, r2, sizeof q);
      }
      memcpy(m.T + 3 * t, q, sizeof q);
      t += 2;
    }
  free(perm);
  return m;
}

// x = G X + noise: G a stretch (s) composed with a rotation, plus a
// per-vertex displacement of `noise` cells (crumples the cloth).
static void deform(ek_rng *rng, const tri_mesh *m, double s, double noise, double *x) {
  double R[9];
  ek_rng_rotation(rng, R);
  for (size_t v = 0; v < m->nv; ++v)
    for (int r = 0; r < 3; ++r) {
      double y = 0;
      for (int k = 0; k < 3; ++k)
        y += R[3 * r + k] * s * m->X[3 * v + k];
      x[3 * v + r] = y + noise * CELL * (2 * ek_rng_uniform(rng) - 1);
    }
}

// Maxima that keep a NaN (fmax drops one): a NaN output, such as the
// poison (ek_check_poison) an element that a call did not write keeps,
// fails its budget instead of passing unseen.
static double maxabs(size_t n, const double *a) {
  double m = 0;
  for (size_t i = 0; i < n; ++i) {
    double d = fabs(a[i]);
    m = d > m || isnan(d) ? d : m;
  }
  return m;
}

static double maxdiff(size_t n, const double *a, const double *b) {
  double m = 0;
  for (size_t i = 0; i < n; ++i) {
    double d = fabs(a[i] - b[i]);
    m = d > m || isnan(d) ? d : m;
  }
  return m;
}

static const char *model_name(int m) { return m == EK_MEMBRANE_STVK ? "stvk" : "arap"; }

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  tri_mesh m = grid_random(&rng, 7, 5, 0.25);
  size_t n3 = 3 * m.nv;
  ek_cloth *cl = ek_cloth_create(m.nv, m.X, m.nt, m.T);
  if (!cl) {
    printf("ek_cloth_create: %s\nFAIL\n", ek_last_error());
    return 1;
  }
  size_t nh = ek_cloth_nhinges(cl);
  check("hinges: every interior edge (3 nx ny - nx - ny of a grid)", nh == 3 * 35 - 7 - 5);
  double *x = malloc(n3 * sizeof(double)), *f = malloc(n3 * sizeof(double)),
         *fr = malloc(n3 * sizeof(double)), *fd = malloc(n3 * sizeof(double)),
         *xp = malloc(n3 * sizeof(double)), *dx = malloc(n3 * sizeof(double)),
         *q = malloc(n3 * sizeof(double)), *q2 = malloc(n3 * sizeof(double)),
         *f1 = malloc(n3 * sizeof(double)), *f2 = malloc(n3 * sizeof(double));
  float *xf = malloc(n3 * sizeof(float)), *ff = malloc(n3 * sizeof(float));

  // b. rest data against the reference.
  {
    double ea = 0, ek = 0, kmax = 0;
    const double *A = ek_cloth_rest_areas(cl);
    for (size_t t = 0; t < m.nt; ++t) {
      const int32_t *T = m.T + 3 * t;
      double Ar = cloth_ref_area(m.X + 3 * T[0], m.X + 3 * T[1], m.X + 3 * T[2]);
      ea = fmax(ea, fabs(A[t] - Ar) / Ar);
    }
    for (size_t h = 0; h < nh; ++h) {
      double kr[4];
      cloth_ref_hinge_k(m.X, ek_cloth_hinges(cl) + 4 * h, kr);
      for (int c = 0; c < 4; ++c) {
        ek = fmax(ek, fabs(kr[c] - ek_cloth_hinge_k(cl)[4 * h + c]));
        kmax = fmax(kmax, fabs(kr[c]));
      }
    }
    report("b. rest areas vs reference (relative)", ea, EK_CLOTH_FORCE_TOL_F64);
    report("b. hinge coefficients vs reference (relative to max |k|)", ek / kmax,
           EK_CLOTH_FORCE_TOL_F64);
  }

  for (int model = 0; model < EK_MEMBRANE_COUNT; ++model) {
    ek_cloth_params p = {(ek_membrane_model)model, MU, LAMBDA, BENDING};
    cloth_ref_params rp = {model, MU, LAMBDA, BENDING};
    char what[160];
    // A crumpled, stretched state: s = 1.1, noise 0.15 cells.
    deform(&rng, &m, 1.1, 0.15, x);

    // a. reference forces vs central differences of its energy.
    double Er = cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), x, fr);
    double best = INFINITY;
    for (double eps = 1e-4; eps >= 1e-8; eps /= 10) {
      memcpy(xp, x, n3 * sizeof(double));
      for (size_t i = 0; i < n3; ++i) {
        xp[i] = x[i] + eps * CELL;
        double Ep = cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), xp, NULL);
        xp[i] = x[i] - eps * CELL;
        double Em = cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), xp, NULL);
        xp[i] = x[i];
        fd[i] = -(Ep - Em) / (2 * eps * CELL);
      }
      best = fmin(best, maxdiff(n3, fr, fd) / maxabs(n3, fr));
    }
    snprintf(what, sizeof what, "a. %s: reference f vs -dE/dx by central differences",
             model_name(model));
    report(what, best, EK_CLOTH_FORCE_FD_TOL);

    // b. energy.
    double E = ek_cloth_energy_f64(cl, &p, x);
    snprintf(what, sizeof what, "b. %s: energy vs reference (relative)", model_name(model));
    report(what, fabs(E - Er) / fabs(Er), EK_CLOTH_FORCE_TOL_F64);

    // c. library forces: f64 against differences of its energy, then every
    // ISA x precision against the reference.
    best = INFINITY;
    ek_cloth_forces_f64(cl, &p, x, f, NULL);
    for (double eps = 1e-4; eps >= 1e-8; eps /= 10) {
      memcpy(xp, x, n3 * sizeof(double));
      for (size_t i = 0; i < n3; ++i) {
        xp[i] = x[i] + eps * CELL;
        double Ep = ek_cloth_energy_f64(cl, &p, xp);
        xp[i] = x[i] - eps * CELL;
        double Em = ek_cloth_energy_f64(cl, &p, xp);
        xp[i] = x[i];
        fd[i] = -(Ep - Em) / (2 * eps * CELL);
      }
      best = fmin(best, maxdiff(n3, f, fd) / maxabs(n3, f));
    }
    snprintf(what, sizeof what, "c. %s: library f64 vs -dE/dx by central differences",
             model_name(model));
    report(what, best, EK_CLOTH_FORCE_FD_TOL);
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; ++isa) {
      if (!ek_isa_available((ek_isa)isa)) {
        printf("c. %s: %s not available here: skipped\n", model_name(model),
               ek_isa_name((ek_isa)isa));
        continue;
      }
      ek_cloth_force_opts o = {.isa = (ek_isa)isa};
      // Outputs poisoned before each call: f and ff hold the previous
      // ISA's forces (f the default ISA's before the first), right values
      // an element this ISA did not write would keep.
      ek_check_poison(f, n3 * sizeof(double));
      int rc = ek_cloth_forces_f64(cl, &p, x, f, &o);
      snprintf(what, sizeof what, "c. %s %s f64 vs reference", model_name(model),
               ek_isa_name((ek_isa)isa));
      report(what, rc ? INFINITY : maxdiff(n3, f, fr) / maxabs(n3, fr), EK_CLOTH_FORCE_TOL_F64);
      double sum[3] = {0, 0, 0}, mag = 0;
      for (size_t v = 0; v < m.nv; ++v)
        for (int k = 0; k < 3; ++k) {
          sum[k] += f[3 * v + k];
          mag += fabs(f[3 * v + k]);
        }
      snprintf(what, sizeof what, "c. %s %s f64: |sum f| / sum |f| (momentum)", model_name(model),
               ek_isa_name((ek_isa)isa));
      report(what, sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]) / mag,
             EK_CLOTH_FORCE_MOMENTUM_TOL_F64);
      for (size_t i = 0; i < n3; ++i)
        xf[i] = (float)x[i];
      ek_check_poison(ff, n3 * sizeof(float));
      rc = ek_cloth_forces_f32(cl, &p, xf, ff, &o);
      for (size_t i = 0; i < n3; ++i)
        f[i] = ff[i];
      snprintf(what, sizeof what, "c. %s %s f32 vs reference", model_name(model),
               ek_isa_name((ek_isa)isa));
      report(what, rc ? INFINITY : maxdiff(n3, f, fr) / maxabs(n3, fr), EK_CLOTH_FORCE_TOL_F32);
    }

    // d. Hessian product vs central differences of the forces (unprojected),
    // at the crumpled state.
    for (size_t i = 0; i < n3; ++i)
      dx[i] = 2 * ek_rng_uniform(&rng) - 1;
    ek_cloth_hessian_apply_f64(cl, &p, x, 0, dx, q);
    best = INFINITY;
    for (double eps = 1e-3; eps >= 1e-8; eps /= 10) {
      double h = eps * CELL;
      for (size_t i = 0; i < n3; ++i)
        xp[i] = x[i] + h * dx[i];
      ek_cloth_forces_f64(cl, &p, xp, f1, NULL);
      for (size_t i = 0; i < n3; ++i)
        xp[i] = x[i] - h * dx[i];
      ek_cloth_forces_f64(cl, &p, xp, f2, NULL);
      for (size_t i = 0; i < n3; ++i)
        fd[i] = -(f1[i] - f2[i]) / (2 * h);
      best = fmin(best, maxdiff(n3, q, fd) / maxabs(n3, q));
    }
    snprintf(what, sizeof what, "d. %s: H dx vs -(df/dx) dx by central differences",
             model_name(model));
    report(what, best, EK_CLOTH_FORCE_FD_TOL);
    // Projected: PSD on the crumpled state (random directions) and on a
    // flat cloth compressed to 0.8 (random displacements normal to it,
    // where the unprojected Hessian has negative curvature: a compressed
    // membrane buckles).
    deform(&rng, &m, 0.8, 0, xp);
    double nrm[3];
    {
      const int32_t *T = m.T;
      double e1[3], e2[3];
      for (int k = 0; k < 3; ++k) {
        e1[k] = xp[3 * T[1] + k] - xp[3 * T[0] + k];
        e2[k] = xp[3 * T[2] + k] - xp[3 * T[0] + k];
      }
      nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
      nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
      nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
    }
    double worst = 0, worst_unprojected = 0;
    for (int trial = 0; trial < 40; ++trial) {
      const double *xs = trial < 20 ? x : xp;
      for (size_t v = 0; v < m.nv; ++v) {
        double r = 2 * ek_rng_uniform(&rng) - 1;
        for (int k = 0; k < 3; ++k)
          dx[3 * v + k] = trial < 20 ? 2 * ek_rng_uniform(&rng) - 1 : r * nrm[k];
      }
      ek_cloth_hessian_apply_f64(cl, &p, xs, 1, dx, q);
      ek_cloth_hessian_apply_f64(cl, &p, xs, 0, dx, q2);
      double pq = 0, pq2 = 0, scale = 0;
      for (size_t i = 0; i < n3; ++i) {
        pq += dx[i] * q[i];
        pq2 += dx[i] * q2[i];
        scale += fabs(dx[i] * q[i]) + fabs(dx[i] * q2[i]);
      }
      worst = fmin(worst, pq / scale);
      worst_unprojected = fmin(worst_unprojected, pq2 / scale);
    }
    snprintf(what, sizeof what, "d. %s: projected dx.H dx >= 0 (worst / scale)", model_name(model));
    report(what, -worst, EK_CLOTH_FORCE_TOL_F64);
    snprintf(what, sizeof what, "d. %s: ... where the unprojected one is not PSD",
             model_name(model));
    check(what, worst_unprojected < 0);
    printf("   (worst unprojected dx.H dx / scale %.3g)\n", worst_unprojected);
    // Projected = unprojected on a stretched flat cloth (s = 1.2, no noise).
    deform(&rng, &m, 1.2, 0, x);
    ek_cloth_hessian_apply_f64(cl, &p, x, 1, dx, q);
    ek_cloth_hessian_apply_f64(cl, &p, x, 0, dx, q2);
    snprintf(what, sizeof what, "d. %s: projected = unprojected on a stretched cloth",
             model_name(model));
    report(what, maxdiff(n3, q, q2) / maxabs(n3, q2), EK_CLOTH_FORCE_TOL_F64);

    // i. the vector energy and Hessian product (ek_cloth_energy_ex_*,
    // ek_cloth_hessian_apply_ex_*): every ISA x precision against the
    // reference's energy and the double Hessian product, on a crumpled
    // stretched state and a crumpled compressed one (the projection
    // clamps there); f64 unprojected against central differences of the
    // reference's forces.
    for (int state = 0; state < 2; ++state) {
      double *xs = malloc(n3 * sizeof(double)), *qr = malloc(n3 * sizeof(double));
      float *xsf = malloc(n3 * sizeof(float)), *dxf = malloc(n3 * sizeof(float)),
            *qf = malloc(n3 * sizeof(float));
      const char *sn = state ? "compressed" : "stretched";
      deform(&rng, &m, state ? 0.85 : 1.1, 0.15, xs);
      for (size_t i = 0; i < n3; ++i) {
        dx[i] = 2 * ek_rng_uniform(&rng) - 1;
        xsf[i] = (float)xs[i], dxf[i] = (float)dx[i];
      }
      double Ers = cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), xs, NULL);
      double E64 = NAN;
      ek_cloth_hessian_apply_ex_f64(cl, &p, xs, 0, dx, q, NULL);
      best = INFINITY;
      for (double eps = 1e-3; eps >= 1e-8; eps /= 10) {
        double h = eps * CELL;
        for (size_t i = 0; i < n3; ++i)
          xp[i] = xs[i] + h * dx[i];
        cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), xp, f1);
        for (size_t i = 0; i < n3; ++i)
          xp[i] = xs[i] - h * dx[i];
        cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), xp, f2);
        for (size_t i = 0; i < n3; ++i)
          fd[i] = -(f1[i] - f2[i]) / (2 * h);
        best = fmin(best, maxdiff(n3, q, fd) / maxabs(n3, q));
      }
      snprintf(what, sizeof what, "i. %s %s: H_ex dx (f64) vs reference central differences",
               model_name(model), sn);
      report(what, best, EK_CLOTH_FORCE_FD_TOL);
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; ++isa) {
        if (!ek_isa_available((ek_isa)isa)) {
          printf("i. %s: %s not available here: skipped\n", model_name(model),
                 ek_isa_name((ek_isa)isa));
          continue;
        }
        ek_cloth_force_opts o = {.isa = (ek_isa)isa};
        for (int f32 = 0; f32 < 2; ++f32) {
          double tol = f32 ? EK_CLOTH_MEMBRANE_TOL_F32 : EK_CLOTH_MEMBRANE_TOL_F64;
          const char *pn = f32 ? "f32" : "f64";
          // E64, q and qf poisoned before each call: they hold the
          // previous ISA's or precision's results.
          ek_check_poison(&E64, sizeof E64);
          int rc = f32 ? ek_cloth_energy_ex_f32(cl, &p, xsf, &E64, &o)
                       : ek_cloth_energy_ex_f64(cl, &p, xs, &E64, &o);
          snprintf(what, sizeof what, "i. %s %s %s %s: energy_ex vs reference", model_name(model),
                   sn, ek_isa_name((ek_isa)isa), pn);
          report(what, rc ? INFINITY : fabs(E64 - Ers) / fabs(Ers), tol);
          for (int project = 0; project < 2; ++project) {
            ek_cloth_hessian_apply_f64(cl, &p, xs, project, dx, qr);
            ek_check_poison(q, n3 * sizeof(double)), ek_check_poison(qf, n3 * sizeof(float));
            if (f32) {
              rc = ek_cloth_hessian_apply_ex_f32(cl, &p, xsf, project, dxf, qf, &o);
              for (size_t i = 0; i < n3; ++i)
                q[i] = qf[i];
            } else {
              rc = ek_cloth_hessian_apply_ex_f64(cl, &p, xs, project, dx, q, &o);
            }
            snprintf(what, sizeof what, "i. %s %s %s %s: hessian_apply_ex%s vs double path",
                     model_name(model), sn, ek_isa_name((ek_isa)isa), pn,
                     project ? " projected" : "");
            double err = rc ? INFINITY : maxdiff(n3, q, qr) / maxabs(n3, qr);
            report(what, err, tol);
            if (!(err <= tol))
              for (size_t i = 0; i < n3 && i < 12; ++i)
                printf("   q[%zu] expected %.17g actual %.17g\n", i, qr[i], q[i]);
          }
        }
      }
      free(xs), free(qr), free(xsf), free(dxf), free(qf);
    }

    // e. a flat cloth at rest: no force, every ISA x precision.
    double longest = 1.5 * CELL * sqrt(2.0), scale = MU * longest + BENDING / longest;
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; ++isa) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      ek_cloth_force_opts o = {.isa = (ek_isa)isa};
      // Poisoned: f and ff hold the previous ISA's forces at rest.
      ek_check_poison(f, n3 * sizeof(double)), ek_check_poison(ff, n3 * sizeof(float));
      ek_cloth_forces_f64(cl, &p, m.X, f, &o);
      snprintf(what, sizeof what, "e. %s %s f64: max |f| at rest / (mu h + k_b / h)",
               model_name(model), ek_isa_name((ek_isa)isa));
      report(what, maxabs(n3, f) / scale, EK_CLOTH_FORCE_REST_TOL_F64);
      for (size_t i = 0; i < n3; ++i)
        xf[i] = (float)m.X[i];
      ek_cloth_forces_f32(cl, &p, xf, ff, &o);
      for (size_t i = 0; i < n3; ++i)
        f[i] = ff[i];
      snprintf(what, sizeof what, "e. %s %s f32: max |f| at rest / (mu h + k_b / h)",
               model_name(model), ek_isa_name((ek_isa)isa));
      report(what, maxabs(n3, f) / scale, EK_CLOTH_FORCE_REST_TOL_F32);
    }
  }

  // h. ARAP near rank-deficient (every triangle squashed to 1e-3 along an
  // in-plane axis: sigma2 / sigma1 ~ 1e-3, the kernel's slow lanes) against
  // the reference, and fully collapsed (rank 1) finite.
  {
    const int32_t *T = m.T;
    double a[3], na = 0;
    for (int k = 0; k < 3; ++k) {
      a[k] = m.X[3 * T[1] + k] - m.X[3 * T[0] + k];
      na += a[k] * a[k];
    }
    for (int k = 0; k < 3; ++k)
      a[k] /= sqrt(na);
    ek_cloth_params p = {EK_MEMBRANE_ARAP, MU, LAMBDA, BENDING};
    cloth_ref_params rp = {EK_MEMBRANE_ARAP, MU, LAMBDA, BENDING};
    for (int collapsed = 0; collapsed < 2; ++collapsed) {
      double squash = collapsed ? 0 : 1e-3;
      for (size_t v = 0; v < m.nv; ++v) {
        double d = 0;
        for (int k = 0; k < 3; ++k)
          d += m.X[3 * v + k] * a[k];
        for (int k = 0; k < 3; ++k)
          x[3 * v + k] = m.X[3 * v + k] - (1 - squash) * d * a[k];
      }
      if (!collapsed)
        cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), x, fr);
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; ++isa) {
        if (!ek_isa_available((ek_isa)isa))
          continue;
        ek_cloth_force_opts o = {.isa = (ek_isa)isa};
        for (int f32 = 0; f32 < 2; ++f32) {
          int rc;
          // Poisoned: f and ff hold the previous ISA's or precision's
          // forces (the finite check then fails an unwritten element).
          ek_check_poison(f, n3 * sizeof(double)), ek_check_poison(ff, n3 * sizeof(float));
          if (f32) {
            // The reference takes the same float-rounded positions: rounding
            // x moves the squashed edges (1e-4 m) by 6e-8 m, a 6e-4 change
            // of F's small column that no kernel can undo.
            for (size_t i = 0; i < n3; ++i) {
              xf[i] = (float)x[i];
              xp[i] = (double)xf[i];
            }
            if (!collapsed)
              cloth_ref_forces(&rp, m.nv, m.X, m.nt, m.T, nh, ek_cloth_hinges(cl), xp, fd);
            rc = ek_cloth_forces_f32(cl, &p, xf, ff, &o);
            for (size_t i = 0; i < n3; ++i)
              f[i] = ff[i];
          } else {
            rc = ek_cloth_forces_f64(cl, &p, x, f, &o);
          }
          int finite = rc == 0;
          for (size_t i = 0; i < n3; ++i)
            finite &= isfinite(f[i]);
          char what[160];
          if (collapsed) {
            snprintf(what, sizeof what, "h. arap %s f%d: collapsed (rank 1) cloth: finite forces",
                     ek_isa_name((ek_isa)isa), f32 ? 32 : 64);
            check(what, finite);
          } else {
            snprintf(what, sizeof what, "h. arap %s f%d: squashed 1e-3 (slow lanes) vs reference",
                     ek_isa_name((ek_isa)isa), f32 ? 32 : 64);
            const double *ref = f32 ? fd : fr;
            report(what, finite ? maxdiff(n3, f, ref) / maxabs(n3, ref) : INFINITY,
                   f32 ? EK_CLOTH_FORCE_TOL_F32 : EK_CLOTH_FORCE_TOL_F64);
          }
        }
      }
    }
  }

  // f. 1 vs 2 threads, above EK_CLOTH_PARALLEL_MIN_TRIS (4096): 48 x 48
  // cells = 4608 triangles.
  {
    tri_mesh big = grid_random(&rng, 48, 48, 0.25);
    ek_cloth *cb = ek_cloth_create(big.nv, big.X, big.nt, big.T);
    size_t nb3 = 3 * big.nv;
    double *xb = malloc(nb3 * sizeof(double)), *fa = malloc(nb3 * sizeof(double)),
           *fb = malloc(nb3 * sizeof(double));
    float *xbf = malloc(nb3 * sizeof(float)), *fa32 = malloc(nb3 * sizeof(float)),
          *fb32 = malloc(nb3 * sizeof(float));
    deform(&rng, &big, 1.05, 0.1, xb);
    for (size_t i = 0; i < nb3; ++i)
      xbf[i] = (float)xb[i];
    for (int model = 0; model < EK_MEMBRANE_COUNT; ++model)
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; ++isa) {
        if (!cb || !ek_isa_available((ek_isa)isa))
          continue;
        ek_cloth_params p = {(ek_membrane_model)model, MU, LAMBDA, BENDING};
        ek_cloth_force_opts o = {.isa = (ek_isa)isa};
        // Every output poisoned before its call (all are overwritten,
        // cloth_force.h): the buffers hold the previous model's or ISA's
        // results, which a chunk that did not run would leave.
        ek_check_poison(fa, nb3 * sizeof(double)), ek_check_poison(fa32, nb3 * sizeof(float));
        ek_check_poison(fb, nb3 * sizeof(double)), ek_check_poison(fb32, nb3 * sizeof(float));
        omp_set_num_threads(1);
        ek_cloth_forces_f64(cb, &p, xb, fa, &o);
        ek_cloth_forces_f32(cb, &p, xbf, fa32, &o);
        omp_set_num_threads(2);
        ek_cloth_forces_f64(cb, &p, xb, fb, &o);
        ek_cloth_forces_f32(cb, &p, xbf, fb32, &o);
        char what[160];
        snprintf(what, sizeof what, "f. %s %s: same bits at 1 and 2 threads (f64, f32)",
                 model_name(model), ek_isa_name((ek_isa)isa));
        check(what, memcmp(fa, fb, nb3 * sizeof(double)) == 0 &&
                        memcmp(fa32, fb32, nb3 * sizeof(float)) == 0);
        // The energies: f64, one ordered double sum whose adds thread 0
        // overlaps with its share; f32, block sums added in block order
        // (cloth_force.c, energy_sum). 1, 2, 3 and 7 threads (7 leaves
        // shares that no smaller count has).
        static const int counts[4] = {1, 2, 3, 7};
        double E[4][3];
        int same = 1;
        for (int c = 0; c < 4; ++c) {
          omp_set_num_threads(counts[c]);
          ek_check_poison(E[c], sizeof E[c]);
          ek_cloth_energy_ex_f64(cb, &p, xb, &E[c][0], &o);
          ek_cloth_energy_ex_f32(cb, &p, xbf, &E[c][1], &o);
          E[c][2] = ek_cloth_energy_f64(cb, &p, xb);
          same &= memcmp(E[0], E[c], sizeof E[0]) == 0;
        }
        snprintf(what, sizeof what,
                 "f. %s %s: energies (f64, f32, default) same bits at 1, 2, 3, 7 threads",
                 model_name(model), ek_isa_name((ek_isa)isa));
        check(what, same && isfinite(E[0][0]) && isfinite(E[0][1]) && isfinite(E[0][2]));
        // ... and the f32 energy is its documented order (cloth_force.h),
        // rebuilt from the triangle energies it leaves in the corner
        // buffer (tris.h) and the hinge energies in double (a 2-thread call,
        // whose shares differ from the blocks).
        omp_set_num_threads(2);
        double E32 = NAN, blocks = 0;
        ek_cloth_energy_ex_f32(cb, &p, xbf, &E32, &o);
        const size_t B = EK_CLOTH_ENERGY_BLOCK_F32, nhb = ek_cloth_nhinges(cb);
        for (size_t t0 = 0; t0 < big.nt; t0 += B) {
          double s = 0;
          for (size_t t = t0; t < t0 + B && t < big.nt; ++t)
            s += (double)cb->tri_corner_f32[t];
          blocks += s;
        }
        for (size_t h0 = 0; h0 < nhb; h0 += B) {
          double s = 0;
          for (size_t h = h0; h < h0 + B && h < nhb; ++h) {
            const int32_t *q = ek_cloth_hinges(cb) + 4 * h;
            const double *k = ek_cloth_hinge_k(cb) + 4 * h;
            double v[3] = {0, 0, 0};
            for (int c = 0; c < 4; ++c)
              for (int i = 0; i < 3; ++i)
                v[i] += k[c] * (double)xbf[3 * (size_t)q[c] + (size_t)i];
            s += 0.5 * p.bending * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
          }
          blocks += s;
        }
        snprintf(what, sizeof what,
                 "f. %s %s: f32 energy = its blocks of %zu summed in order, bit for bit",
                 model_name(model), ek_isa_name((ek_isa)isa), B);
        check(what, E32 == blocks && E32 == E[0][1] && big.nt > 2 * B && nhb > 2 * B);
        if (isa == EK_ISA_SCALAR) { // the fields (no ISA): per triangle, any partition
          double *fl = ek_check_poison(malloc(4 * 2 * big.nt * sizeof(double)),
                                       4 * 2 * big.nt * sizeof(double));
          for (int nt = 1; nt <= 2 && fl; ++nt) {
            double *o4 = fl + 4 * (size_t)(nt - 1) * big.nt;
            omp_set_num_threads(nt);
            ek_cloth_fields_f64(cb, &p, xb, o4, o4 + big.nt, o4 + 2 * big.nt, o4 + 3 * big.nt);
          }
          snprintf(what, sizeof what, "f. %s: fields same bits at 1 and 2 threads",
                   model_name(model));
          check(what, fl && memcmp(fl, fl + 4 * big.nt, 4 * big.nt * sizeof(double)) == 0);
          free(fl);
          // The diagonal blocks: per vertex, its corners in element order.
          double *db = ek_check_poison(malloc(2 * 9 * big.nv * sizeof(double)),
                                       2 * 9 * big.nv * sizeof(double));
          for (int nt = 1; nt <= 2 && db; ++nt) {
            omp_set_num_threads(nt);
            ek_cloth_hessian_diagonal_f64(cb, &p, xb, db + 9 * (size_t)(nt - 1) * big.nv);
          }
          snprintf(what, sizeof what, "f. %s: Hessian diagonal same bits at 1 and 2 threads",
                   model_name(model));
          check(what, db && memcmp(db, db + 9 * big.nv, 9 * big.nv * sizeof(double)) == 0);
          // ... and column j of vertex v's block is vertex v's part of the
          // projected product with e_vj (the same element products, summed
          // in the same order): a few vertices, bit for bit.
          double *ev = calloc(nb3, sizeof(double)), *qv = malloc(nb3 * sizeof(double));
          int same = db && ev && qv;
          for (size_t v = 7; same && v < big.nv; v += big.nv / 3)
            for (int j = 0; j < 3; ++j) {
              ev[3 * v + (size_t)j] = 1;
              ek_cloth_hessian_apply_f64(cb, &p, xb, 1, ev, qv);
              ev[3 * v + (size_t)j] = 0;
              for (int i = 0; i < 3; ++i)
                same &= db[9 * v + 3 * (size_t)i + (size_t)j] == qv[3 * v + (size_t)i];
            }
          snprintf(what, sizeof what,
                   "f. %s: Hessian diagonal = the product's columns, bit for bit",
                   model_name(model));
          check(what, same);
          free(ev), free(qv);
          free(db);
        }
        {
          // The Hessian products at 1, 2 and 3 threads: the default f64
          // (the vector kernel for StVK, plain double for ARAP) and the
          // f32 vector path, every model.
          double *dxb = fa, *qa = malloc(nb3 * sizeof(double)), *qb = malloc(nb3 * sizeof(double));
          float *dxf = fb32, *qf[2] = {malloc(nb3 * sizeof(float)), malloc(nb3 * sizeof(float))};
          for (size_t i = 0; i < nb3; ++i) {
            dxb[i] = 2 * ek_rng_uniform(&rng) - 1;
            dxf[i] = (float)dxb[i];
          }
          int hsame = qa && qb && qf[0] && qf[1];
          for (int nt = 1; nt <= 3 && hsame; ++nt) {
            omp_set_num_threads(nt);
            ek_check_poison(nt == 1 ? qa : qb, nb3 * sizeof(double));
            ek_check_poison(qf[nt > 1], nb3 * sizeof(float));
            ek_cloth_hessian_apply_f64(cb, &p, xb, 1, dxb, nt == 1 ? qa : qb);
            ek_cloth_hessian_apply_ex_f32(cb, &p, xbf, 1, dxf, qf[nt > 1], &o);
            if (nt > 1)
              hsame = memcmp(qa, qb, nb3 * sizeof(double)) == 0 &&
                      memcmp(qf[0], qf[1], nb3 * sizeof(float)) == 0;
          }
          omp_set_num_threads(2);
          snprintf(what, sizeof what,
                   "f. %s %s: Hessian products (f64, f32), same bits at 1, 2 and 3 threads",
                   model_name(model), ek_isa_name((ek_isa)isa));
          check(what, hsame);
          free(qa);
          free(qb);
          free(qf[0]);
          free(qf[1]);
        }
      }
    check("f. 48 x 48 grid built", cb != NULL);
    ek_cloth_destroy(cb);
    free(xb), free(fa), free(fb), free(xbf), free(fa32), free(fb32);
    free(big.X), free(big.T);
  }

  // g. bad input.
  {
    double X[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0};
    int32_t T[6] = {0, 1, 2, 0, 1, 3}; // triangle 1 is collinear: zero area
    ek_cloth *bad = ek_cloth_create(4, X, 2, T);
    check("g. zero-area triangle refused", bad == NULL);
    check("g. ... and the message names triangle 1", strstr(ek_last_error(), "triangle 1") != NULL);
    printf("   message: %s\n", ek_last_error());
    int32_t T2[3] = {0, 1, 7};
    bad = ek_cloth_create(4, X, 1, T2);
    check("g. index out of range refused, naming the index",
          bad == NULL && strstr(ek_last_error(), "7") != NULL);
    ek_cloth_params p = {EK_MEMBRANE_STVK, -1, 0, 0};
    check("g. mu <= 0 refused", ek_cloth_forces_f64(cl, &p, x, f, NULL) == EK_EINVAL);
  }

  ek_cloth_destroy(cl);
  free(x), free(f), free(fr), free(fd), free(xp), free(dx), free(q), free(q2), free(f1), free(f2);
  free(xf), free(ff), free(m.X), free(m.T);
  printf("%s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures != 0;
}
