// Invariants of the FVM force kernels (ek_mesh_fvm_forces_ex_*):
//   1. every scatter strategy x available ISA x precision x model matches
//      the double reference (reference/fvm) within EK_FVM_TOL_F32/_F64
//      (max_i |f_i - f_ref_i| / max_i s_i, fvm.h), on random jittered
//      meshes with renumbered vertices (caller order != internal order)
//      and tails (tet counts not multiples of a block); f is overwritten
//      (pre-filled with garbage), not accumulated; the phase-split mode
//      gives the same forces;
//   2. COLORED, THREAD_BUFFERS and GATHER give the same bits at 1, 2 and 3
//      threads (ATOMIC is exempt: non-deterministic by design);
//   3. per-tet outputs (J, smallest singular value, energy density) and
//      ek_mesh_fvm_energy_f64 match the reference;
//   4. neo-Hookean without clamp: an inverted tet's vertices get NaN, the
//      rest of the mesh is untouched by it;
//   5. bad arguments give rc < 0 and leave f untouched; an ISA the CPU
//      lacks gives EK_EISA and is reported as skipped;
//   6. corotated linear with its rotations as per-element state
//      (ek_fvm_opts.R_state) gives the same bits as with the caller-order
//      array, for every strategy, ISA and precision; a state of the wrong
//      precision is refused.
#include <ek/sim/mesh.h>
#include <omp.h>

#include "cli.h"
#include "svd3/svd3_ref.h"
#include "test_fvm_common.h"

static int failures = 0;

static const ek_scatter strategies[] = {EK_SCATTER_AUTO, EK_SCATTER_COLORED,
                                        EK_SCATTER_THREAD_BUFFERS, EK_SCATTER_GATHER,
                                        EK_SCATTER_ATOMIC};
#define NSTRAT ((int)(sizeof strategies / sizeof strategies[0]))

// Run one configuration and judge it against f_ref (computed from the
// same, possibly float-rounded, positions).
static void run_case(const char *model, const ek_mesh *mesh, const ek_material *mat,
                     const double *R, ek_isa isa, int f32, ek_scatter s, int phases,
                     const double *x, const double *fref, const double *fscale) {
  size_t nv = ek_mesh_nverts(mesh), n3 = nv * 3;
  double *f = malloc(n3 * sizeof(double));
  ek_fvm_phase_times pt;
  ek_fvm_opts o = {.scatter = s, .isa = isa, .R = R, .phase_times = phases ? &pt : NULL};
  int rc;
  if (f32) {
    float *xf = malloc(n3 * sizeof(float)), *ff = malloc(n3 * sizeof(float));
    for (size_t i = 0; i < n3; i++) {
      xf[i] = (float)x[i];
      ff[i] = 1e30f; // must be overwritten
    }
    rc = ek_mesh_fvm_forces_ex_f32(mesh, mat, xf, ff, &o);
    for (size_t i = 0; i < n3; i++)
      f[i] = ff[i];
    free(xf);
    free(ff);
  } else {
    for (size_t i = 0; i < n3; i++)
      f[i] = 1e300;
    rc = ek_mesh_fvm_forces_ex_f64(mesh, mat, x, f, &o);
  }
  char label[200];
  snprintf(label, sizeof label, "%-17s %-6s %s %-14s%s", model, ek_isa_name(isa),
           f32 ? "f32" : "f64", ek_scatter_name(s), phases ? " phases" : "");
  if (rc != 0) {
    printf("%s: rc = %d (%s)\nFAIL\n", label, rc, ek_last_error());
    failures++;
    free(f);
    return;
  }
  size_t wi;
  double err = test_force_error(n3, f, fref, fscale, &wi);
  if (ek_check_report(label, err, f32 ? EK_FVM_TOL_F32 : EK_FVM_TOL_F64)) {
    failures++;
    printf("  vertex %zu component %zu: kernel %.9g reference %.17g (scale of that "
           "component %.3g)\n",
           wi / 3, wi % 3, f[wi], fref[wi], fscale[wi]);
  }
  if (phases && !(pt.deformation_gradient >= 0 && pt.svd >= 0 && pt.pk1 >= 0 && pt.scatter >= 0)) {
    printf("%s: negative phase time\nFAIL\n", label);
    failures++;
  }
  free(f);
}

// Same bits at 1, 2 and 3 threads for the deterministic strategies.
static void check_threads(const char *model, const ek_mesh *mesh, const ek_material *mat,
                          const double *R, const double *x) {
  size_t n3 = ek_mesh_nverts(mesh) * 3;
  float *xf = malloc(n3 * sizeof(float));
  for (size_t i = 0; i < n3; i++)
    xf[i] = (float)x[i];
  for (int si = 0; si < NSTRAT; si++) {
    ek_scatter s = strategies[si];
    if (s == EK_SCATTER_ATOMIC)
      continue;
    ek_fvm_opts o = {.scatter = s, .R = R};
    float *a32 = malloc(n3 * sizeof(float)), *b32 = malloc(n3 * sizeof(float));
    double *a64 = malloc(n3 * sizeof(double)), *b64 = malloc(n3 * sizeof(double));
    // Every output poisoned before its call (f is overwritten, fvm.h): a
    // chunk that did not run cannot keep the previous call's right values.
    omp_set_num_threads(1);
    ek_check_poison(a32, n3 * sizeof(float));
    ek_check_poison(a64, n3 * sizeof(double));
    int rc = ek_mesh_fvm_forces_ex_f32(mesh, mat, xf, a32, &o) |
             ek_mesh_fvm_forces_ex_f64(mesh, mat, x, a64, &o);
    int same32 = 1, same64 = 1;
    // 2 threads, and 3 (more than this machine's cores on the 2-core hosts:
    // the helper team's oversubscribed waits).
    for (int nt = 2; nt <= 3; nt++) {
      omp_set_num_threads(nt);
      ek_check_poison(b32, n3 * sizeof(float));
      ek_check_poison(b64, n3 * sizeof(double));
      rc |= ek_mesh_fvm_forces_ex_f32(mesh, mat, xf, b32, &o) |
            ek_mesh_fvm_forces_ex_f64(mesh, mat, x, b64, &o);
      same32 &= memcmp(a32, b32, n3 * sizeof(float)) == 0;
      same64 &= memcmp(a64, b64, n3 * sizeof(double)) == 0;
    }
    omp_set_num_threads(2);
    printf("%-17s %-14s 1 vs 2, 3 threads: f32 %s, f64 %s\n", model, ek_scatter_name(s),
           same32 ? "same bits" : "DIFFER", same64 ? "same bits" : "DIFFER");
    if (rc || !same32 || !same64) {
      printf("FAIL (rc %d)\n", rc);
      for (size_t i = 0; i < n3; i++)
        if (a32[i] != b32[i] || a64[i] != b64[i]) {
          printf("  first difference at component %zu: f32 %.9g vs %.9g, f64 %.17g vs %.17g\n", i,
                 a32[i], b32[i], a64[i], b64[i]);
          break;
        }
      failures++;
    }
    free(a32);
    free(b32);
    free(a64);
    free(b64);
  }
  free(xf);
}

// Per-tet fields and the energy against the reference (double).
static void check_fields(const char *model, const ek_mesh *mesh, const test_mesh *t,
                         const ek_material *mat, const double *R, const double *x) {
  size_t nt = t->ntets, n3 = t->nverts * 3;
  double *J = malloc(nt * sizeof(double)), *smin = malloc(nt * sizeof(double));
  double *psi = malloc(nt * sizeof(double)), *f = malloc(n3 * sizeof(double));
  ek_fvm_opts o = {.R = R, .J = J, .sigma_min = smin, .psi = psi};
  int rc = ek_mesh_fvm_forces_ex_f64(mesh, mat, x, f, &o);
  ek_material_ref m = test_ref_material(mat);
  double eJ = 0, es = 0, ep = 0, psi_scale = 0;
  for (size_t e = 0; e < nt; e++) {
    double F[9], Dmi[9], U[9], S[3], V[9];
    ek_fvm_tet_F_ref(t->X, x, t->T + e * 4, F, Dmi);
    ek_svd3_ref(F, U, S, V);
    double p = ek_psi_ref(&m, F, R ? R + e * 9 : NULL);
    eJ = fmax(eJ, fabs(J[e] - ek_det3(F)) / (S[0] * S[0] * S[0]));
    es = fmax(es, fabs(smin[e] - S[2]) / S[0]);
    ep = fmax(ep, fabs(psi[e] - p));
    psi_scale = fmax(psi_scale, (mat->mu + fabs(mat->lambda)) * S[0] * S[0] * S[0] * S[0]);
  }
  char label[160];
  snprintf(label, sizeof label, "%-17s per-tet J", model);
  failures += rc != 0;
  failures += ek_check_report(label, eJ, EK_FVM_TOL_F64);
  snprintf(label, sizeof label, "%-17s per-tet smallest singular value", model);
  failures += ek_check_report(label, es, EK_FVM_TOL_F64);
  snprintf(label, sizeof label, "%-17s per-tet energy density", model);
  failures += ek_check_report(label, ep / psi_scale, EK_FVM_TOL_F64);
  double El = ek_mesh_fvm_energy_ex_f64(mesh, mat, x, R);
  double Er = ek_fvm_energy_ref(t->nverts, t->X, nt, t->T, &m, R, x);
  snprintf(label, sizeof label, "%-17s ek_mesh_fvm_energy_f64", model);
  failures += ek_check_report(label, fabs(El - Er) / fabs(Er), EK_FVM_TOL_F64);
  free(J);
  free(smin);
  free(psi);
  free(f);
}

static void check_bad_arguments(const ek_mesh *mesh, const double *x) {
  size_t n3 = ek_mesh_nverts(mesh) * 3;
  double *f = malloc(n3 * sizeof(double));
  for (size_t i = 0; i < n3; i++)
    f[i] = 42;
  ek_material good = {EK_MODEL_FIXED_COROTATED, 1, 2, 0};
  ek_material bad_mu = {EK_MODEL_FIXED_COROTATED, 0, 2, 0};
  ek_material corot = {EK_MODEL_COROTATED_LINEAR, 1, 2, 0};
  ek_fvm_opts bad_scatter = {.scatter = (ek_scatter)99};
  ek_fvm_opts bad_sweeps = {.svd_sweeps = 12};
  struct {
    const char *what;
    int rc;
  } cases[] = {
      {"NULL mesh", ek_mesh_fvm_forces_f64(NULL, &good, x, f)},
      {"NULL material", ek_mesh_fvm_forces_f64(mesh, NULL, x, f)},
      {"NULL x", ek_mesh_fvm_forces_f64(mesh, &good, NULL, f)},
      {"mu = 0", ek_mesh_fvm_forces_f64(mesh, &bad_mu, x, f)},
      {"corotated linear without R", ek_mesh_fvm_forces_f64(mesh, &corot, x, f)},
      {"scatter = 99", ek_mesh_fvm_forces_ex_f64(mesh, &good, x, f, &bad_scatter)},
      {"svd_sweeps = 12", ek_mesh_fvm_forces_ex_f64(mesh, &good, x, f, &bad_sweeps)},
  };
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
    int ok = cases[k].rc < 0;
    printf("bad argument %-28s rc = %d: %s\n", cases[k].what, cases[k].rc, ok ? "PASS" : "FAIL");
    failures += !ok;
  }
  int untouched = 1;
  for (size_t i = 0; i < n3; i++)
    untouched &= f[i] == 42;
  printf("f untouched by the failed calls: %s\n", untouched ? "PASS" : "FAIL");
  failures += !untouched;
  double E = ek_mesh_fvm_energy_f64(mesh, &bad_mu, x);
  printf("ek_mesh_fvm_energy_f64 with mu = 0: %g (NaN expected): %s\n", E,
         isnan(E) ? "PASS" : "FAIL");
  failures += !isnan(E);
  free(f);
}

// Neo-Hookean without clamp: an inverted tet gives NaN forces at its own
// vertices only (material.h: P = NaN for J <= 0); a disconnected healthy tet
// keeps finite forces equal to the reference. Every strategy, both
// precisions.
static void check_inverted_nan(void) {
  double X[8 * 3] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 5, 0, 0, 6, 0, 0, 5, 1, 0, 5, 0, 1};
  int32_t T[8] = {0, 1, 2, 3, 4, 5, 6, 7};
  ek_mesh *m = ek_mesh_create(8, X, 2, T);
  double x[8 * 3];
  memcpy(x, X, sizeof x);
  x[3 * 3 + 2] = -0.5; // tet 0 inverted: vertex 3 through its base
  x[7 * 3 + 2] = 1.1;  // tet 1 stretched
  ek_material nh = {EK_MODEL_NEO_HOOKEAN, 1, 2, 0};
  ek_material_ref mref = test_ref_material(&nh);
  double fref[24], s[24];
  ek_fvm_forces_ref(8, X, 2, T, &mref, NULL, x, fref, s);
  for (int si = 0; si < NSTRAT; si++)
    for (int f32 = 0; f32 < 2; f32++) {
      double f[24];
      ek_fvm_opts o = {.scatter = strategies[si]};
      int rc;
      if (f32) {
        float xf[24], ff[24];
        for (int i = 0; i < 24; i++)
          xf[i] = (float)x[i];
        rc = ek_mesh_fvm_forces_ex_f32(m, &nh, xf, ff, &o);
        for (int i = 0; i < 24; i++)
          f[i] = ff[i];
      } else {
        rc = ek_mesh_fvm_forces_ex_f64(m, &nh, x, f, &o);
      }
      int ok = rc == 0;
      double e = 0, scale = 0;
      for (int i = 0; i < 12; i++)
        ok &= isnan(f[i]);
      for (int i = 12; i < 24; i++) {
        ok &= isfinite(f[i]);
        e = fmax(e, fabs(f[i] - fref[i]));
        scale = fmax(scale, s[i]);
      }
      double tol = f32 ? EK_FVM_TOL_F32 : EK_FVM_TOL_F64;
      ok &= e / scale <= tol;
      printf("nh inverted tet, %s %s: NaN at its vertices only, other tet ek_last_error() %.3g "
             "(budget %g): %s\n",
             ek_scatter_name(strategies[si]), f32 ? "f32" : "f64", e / scale, tol,
             ok ? "PASS" : "FAIL");
      if (!ok) {
        failures++;
        for (int v = 0; v < 8; v++)
          printf("  vertex %d: kernel (%g %g %g) reference (%g %g %g)\n", v, f[v * 3], f[v * 3 + 1],
                 f[v * 3 + 2], fref[v * 3], fref[v * 3 + 1], fref[v * 3 + 2]);
      }
    }
  ek_mesh_destroy(m);
}

static void check_R_state(const ek_mesh *mesh, const ek_material *mat, const double *R,
                          const double *x) {
  size_t n3 = ek_mesh_nverts(mesh) * 3;
  const ek_tets *el = ek_mesh_elements(mesh);
  ek_tet_state *st32 = ek_tet_state_create(el, 9, 0), *st64 = ek_tet_state_create(el, 9, 1);
  ek_tet_state_set_f64(st32, R);
  ek_tet_state_set_f64(st64, R);
  float *x32 = malloc(n3 * sizeof(float)), *fa32 = malloc(n3 * sizeof(float)),
        *fb32 = malloc(n3 * sizeof(float));
  double *fa = malloc(n3 * sizeof(double)), *fb = malloc(n3 * sizeof(double));
  for (size_t i = 0; i < n3; i++)
    x32[i] = (float)x[i];
  int same = 1, cases = 0;
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available((ek_isa)isa))
      continue;
    for (int si = 0; si < NSTRAT; si++) {
      if (strategies[si] == EK_SCATTER_ATOMIC)
        continue; // its sums are not reproducible from run to run
      ek_fvm_opts a = {.scatter = strategies[si], .isa = (ek_isa)isa, .R = R};
      ek_fvm_opts b = {.scatter = strategies[si], .isa = (ek_isa)isa, .R_state = st32};
      same &= ek_mesh_fvm_forces_ex_f32(mesh, mat, x32, fa32, &a) == 0 &&
              ek_mesh_fvm_forces_ex_f32(mesh, mat, x32, fb32, &b) == 0 &&
              memcmp(fa32, fb32, n3 * sizeof(float)) == 0;
      b.R_state = st64;
      same &= ek_mesh_fvm_forces_ex_f64(mesh, mat, x, fa, &a) == 0 &&
              ek_mesh_fvm_forces_ex_f64(mesh, mat, x, fb, &b) == 0 &&
              memcmp(fa, fb, n3 * sizeof(double)) == 0;
      cases += 2;
    }
  }
  printf("corot_linear: R as per-element state = R as array, bitwise, %d cases: %s\n", cases,
         same ? "PASS" : "FAIL");
  failures += !same;
  ek_fvm_opts wrong = {.R_state = st32};
  int rc = ek_mesh_fvm_forces_ex_f64(mesh, mat, x, fa, &wrong);
  printf("corot_linear: an f32 state in an f64 call refused (rc %d): %s\n", rc,
         rc == EK_EINVAL ? "PASS" : "FAIL");
  failures += rc != EK_EINVAL;
  ek_tet_state_destroy(st32);
  ek_tet_state_destroy(st64);
  free(x32);
  free(fa32);
  free(fb32);
  free(fa);
  free(fb);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 2026, NULL);
  printf("test_fvm: seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);

  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    if (!ek_isa_available((ek_isa)isa)) {
      ek_mesh *m = ek_mesh_box(1, 1, 1, 1, 1, 1);
      double x[24], f[24];
      memcpy(x, ek_mesh_rest_positions(m), sizeof x);
      ek_material mat = {EK_MODEL_STVK, 1, 1, 0};
      ek_fvm_opts o = {.isa = (ek_isa)isa};
      int rc = ek_mesh_fvm_forces_ex_f64(m, &mat, x, f, &o);
      printf("skipped %s: not available on this CPU/build (forced: rc = %d, %s)\n",
             ek_isa_name((ek_isa)isa), rc, rc == EK_EISA ? "PASS" : "FAIL");
      failures += rc != EK_EISA;
      ek_mesh_destroy(m);
    }

  check_inverted_nan();

  for (int mi = 0; mi < test_nmodels; mi++) {
    const test_model *tm = &test_models[mi];
    ek_material_ref mref = test_ref_material(&tm->mat);
    // 5 x 4 x 3 cells = 360 tets: several blocks per colour, partial last
    // blocks, every colour's tail padded.
    test_mesh t = test_mesh_random(&rng, 5, 4, 3, 0.2);
    ek_mesh *mesh = ek_mesh_create(t.nverts, t.X, t.ntets, t.T);
    if (!mesh) {
      printf("ek_mesh_create: %s\nFAIL\n", ek_last_error());
      return 1;
    }
    size_t n3 = t.nverts * 3;
    double *x = malloc(n3 * sizeof(double)), *x32 = malloc(n3 * sizeof(double));
    double *fref = malloc(n3 * sizeof(double)), *fref32 = malloc(n3 * sizeof(double));
    double *s = malloc(n3 * sizeof(double)), *s32 = malloc(n3 * sizeof(double));
    double *R = test_rotations(&rng, t.ntets);
    const double *Ruse = tm->mat.model == EK_MODEL_COROTATED_LINEAR ? R : NULL;
    test_deform(&rng, &t, 0.15, 0.15, x);
    for (size_t i = 0; i < n3; i++)
      x32[i] = (float)x[i];
    ek_fvm_forces_ref(t.nverts, t.X, t.ntets, t.T, &mref, Ruse, x, fref, s);
    ek_fvm_forces_ref(t.nverts, t.X, t.ntets, t.T, &mref, Ruse, x32, fref32, s32);

    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      for (int f32 = 1; f32 >= 0; f32--)
        for (int si = 0; si < NSTRAT; si++)
          run_case(tm->name, mesh, &tm->mat, Ruse, (ek_isa)isa, f32, strategies[si], 0,
                   f32 ? x32 : x, f32 ? fref32 : fref, f32 ? s32 : s);
      run_case(tm->name, mesh, &tm->mat, Ruse, (ek_isa)isa, 1, EK_SCATTER_COLORED, 1, x32, fref32,
               s32);
      run_case(tm->name, mesh, &tm->mat, Ruse, (ek_isa)isa, 0, EK_SCATTER_GATHER, 1, x, fref, s);
    }
    check_fields(tm->name, mesh, &t, &tm->mat, Ruse, x);
    if (tm->mat.model == EK_MODEL_COROTATED_LINEAR)
      check_R_state(mesh, &tm->mat, R, x);
    if (mi == 0)
      check_bad_arguments(mesh, x);
    ek_mesh_destroy(mesh);
    free(x);
    free(x32);
    free(fref);
    free(fref32);
    free(s);
    free(s32);
    free(R);
    test_mesh_free(&t);

    // Thread determinism on a mesh big enough for every thread to get
    // blocks of every colour (12^3 cells, 10368 tets).
    test_mesh big = test_mesh_random(&rng, 12, 12, 12, 0.2);
    ek_mesh *bm = ek_mesh_create(big.nverts, big.X, big.ntets, big.T);
    double *xb = malloc(big.nverts * 3 * sizeof(double));
    double *Rb = test_rotations(&rng, big.ntets);
    test_deform(&rng, &big, 0.15, 0.15, xb);
    check_threads(tm->name, bm, &tm->mat, tm->mat.model == EK_MODEL_COROTATED_LINEAR ? Rb : NULL,
                  xb);
    ek_mesh_destroy(bm);
    free(xb);
    free(Rb);
    test_mesh_free(&big);
  }
  printf("test_fvm: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
