// Invariants of the double FVM reference (reference/fvm/fvm_ref.c), for
// every model on random small meshes (jittered, renumbered boxes) and
// random deformations:
//   1. f = -dE/dx: each force component equals minus the central
//      difference of ek_fvm_energy_ref (step swept, best kept), within
//      EK_FVM_FD_TOL relative to the force scale of fvm.h;
//   2. momentum: sum_i f_i = 0 (every model: the four corner forces of a
//      tet sum to zero by construction, Teran et al. 2003 sec. 4);
//   3. angular momentum: sum_i x_i x f_i = 0 for the rotation-invariant
//      models (P F^T symmetric); linear and corotated linear with a fixed
//      R are not rotation-invariant and are exempt;
//   4. f = 0 at the rest shape (corotated linear with R = I).
// Also: ek_mesh_fvm_energy_f64 (the library) equals the reference energy.
#include <ek/sim/mesh.h>

#include "cli.h"
#include "test_fvm_common.h"
#include "test_tolerances.h"

static int failures = 0;

static double energy(const test_mesh *t, const ek_material_ref *m, const double *R,
                     const double *x) {
  return ek_fvm_energy_ref(t->nverts, t->X, t->ntets, t->T, m, R, x);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 2003, NULL);
  printf("test_fvm_ref: seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  static const double steps[] = {1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6};

  for (int mi = 0; mi < test_nmodels; mi++) {
    const test_model *tm = &test_models[mi];
    ek_material_ref m = test_ref_material(&tm->mat);
    test_mesh t = test_mesh_random(&rng, 2, 2, 2, 0.2);
    size_t n3 = t.nverts * 3;
    double *x = malloc(n3 * sizeof(double)), *f = malloc(n3 * sizeof(double));
    double *s = malloc(n3 * sizeof(double)), *xp = malloc(n3 * sizeof(double));
    double *R = test_rotations(&rng, t.ntets);
    test_deform(&rng, &t, 0.15, 0.15, x);
    ek_fvm_forces_ref(t.nverts, t.X, t.ntets, t.T, &m, R, x, f, s);
    double scale = 0;
    for (size_t i = 0; i < n3; i++)
      scale = fmax(scale, s[i]);
    char label[160];

    // 1. Central differences of the energy.
    double worst = 0;
    size_t worst_i = 0;
    double worst_fd = 0;
    memcpy(xp, x, n3 * sizeof(double));
    for (size_t i = 0; i < n3; i++) {
      double best = INFINITY, best_fd = 0;
      for (size_t k = 0; k < sizeof steps / sizeof steps[0]; k++) {
        double h = steps[k] * 0.1; // relative to the cell size 0.1
        xp[i] = x[i] + h;
        double ep = energy(&t, &m, R, xp);
        xp[i] = x[i] - h;
        double em = energy(&t, &m, R, xp);
        xp[i] = x[i];
        double fd = -(ep - em) / (2 * h);
        double e = fabs(fd - f[i]);
        if (e < best) {
          best = e;
          best_fd = fd;
        }
      }
      if (!(best <= worst)) {
        worst = best;
        worst_i = i;
        worst_fd = best_fd;
      }
    }
    snprintf(label, sizeof label, "%-18s f = -dE/dx (central differences)", tm->name);
    if (ek_check_report(label, worst / scale, EK_FVM_FD_TOL)) {
      failures++;
      printf("  vertex %zu component %zu: force %.17g, -dE/dx %.17g, scale %.3g\n", worst_i / 3,
             worst_i % 3, f[worst_i], worst_fd, scale);
    }

    // 2. Total force.
    double total[3] = {0, 0, 0};
    for (size_t v = 0; v < t.nverts; v++)
      for (int k = 0; k < 3; k++)
        total[k] += f[v * 3 + k];
    double tf = fmax(fabs(total[0]), fmax(fabs(total[1]), fabs(total[2])));
    snprintf(label, sizeof label, "%-18s sum f = 0", tm->name);
    if (ek_check_report(label, tf / scale, EK_FVM_TOL_F64)) {
      failures++;
      printf("  sum f = (%g, %g, %g), scale %g\n", total[0], total[1], total[2], scale);
    }

    // 3. Total torque (rotation-invariant models).
    int invariant = tm->mat.model != EK_MODEL_LINEAR && tm->mat.model != EK_MODEL_COROTATED_LINEAR;
    if (invariant) {
      double tq[3] = {0, 0, 0}, tq_scale = 0;
      for (size_t v = 0; v < t.nverts; v++) {
        const double *p = x + v * 3, *q = f + v * 3;
        tq[0] += p[1] * q[2] - p[2] * q[1];
        tq[1] += p[2] * q[0] - p[0] * q[2];
        tq[2] += p[0] * q[1] - p[1] * q[0];
        double px = fmax(fabs(p[0]), fmax(fabs(p[1]), fabs(p[2])));
        double sx = fmax(s[v * 3], fmax(s[v * 3 + 1], s[v * 3 + 2]));
        tq_scale += 2 * px * sx;
      }
      double tmax = fmax(fabs(tq[0]), fmax(fabs(tq[1]), fabs(tq[2])));
      snprintf(label, sizeof label, "%-18s sum x cross f = 0", tm->name);
      if (ek_check_report(label, tmax / tq_scale, EK_FVM_TOL_F64)) {
        failures++;
        printf("  torque (%g, %g, %g), scale %g\n", tq[0], tq[1], tq[2], tq_scale);
      }
    }

    // 4. Rest shape: f = 0 (R = I for corotated linear), relative to the
    // force scale of the deformed state above.
    double *I9 = malloc(t.ntets * 9 * sizeof(double));
    for (size_t e = 0; e < t.ntets; e++)
      for (int k = 0; k < 9; k++)
        I9[e * 9 + k] = (k % 4 == 0);
    ek_fvm_forces_ref(t.nverts, t.X, t.ntets, t.T, &m, I9, t.X, f, NULL);
    double frest = 0;
    for (size_t i = 0; i < n3; i++)
      frest = fmax(frest, fabs(f[i]));
    snprintf(label, sizeof label, "%-18s f = 0 at rest", tm->name);
    failures += ek_check_report(label, frest / scale, EK_FVM_TOL_F64);

    // The library's energy (through ek_mesh and ek_energy_f64) against the
    // reference energy: same sum, different code.
    ek_mesh *mesh = ek_mesh_create(t.nverts, t.X, t.ntets, t.T);
    if (!mesh) {
      printf("ek_mesh_create: %s\n", ek_last_error());
      failures++;
    } else {
      double El = ek_mesh_fvm_energy_ex_f64(mesh, &tm->mat, x, R), Er = energy(&t, &m, R, x);
      snprintf(label, sizeof label, "%-18s ek_mesh_fvm_energy_f64 = reference", tm->name);
      if (ek_check_report(label, fabs(El - Er) / fabs(Er), EK_FVM_TOL_F64)) {
        failures++;
        printf("  library %.17g reference %.17g\n", El, Er);
      }
      ek_mesh_destroy(mesh);
    }
    free(I9);
    free(x);
    free(f);
    free(s);
    free(xp);
    free(R);
    test_mesh_free(&t);
  }
  printf("test_fvm_ref: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
