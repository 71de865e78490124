// Invariant: a program that uses the kernel library only (<ek/ek.h>, linked
// with ek::ek or `pkg-config ek`: no libek_sim, HDF5 or cJSON) builds, links
// and runs against an installed ek: ek_svd3_f32 recovers known singular
// values, and the FVM force of a tet built from plain arrays
// (ek_tets_create, ek_fvm_tet_forces_ex_f64) is zero at rest and sums to
// zero when the tet is stretched (internal forces, fvm.h).
//
//   ek-consumer-kernels
#include <ek/ek.h>

#include <math.h>
#include <stdio.h>

// A = Rz(90 deg) diag(3, 2, 1): singular values 3, 2, 1 exactly.
static int check_svd(void) {
  const float A[9] = {0, -2, 0, 3, 0, 0, 0, 0, 1}, expected[3] = {3, 2, 1};
  float U[9], S[3], V[9];
  int rc = ek_svd3_f32(1, A, U, S, V, NULL);
  if (rc != 0) {
    fprintf(stderr, "ek_svd3_f32: returned %d: %s\n", rc, ek_last_error());
    return 1;
  }
  // Budget relative to the largest singular value (include/ek/svd3.h).
  double worst = 0;
  for (int i = 0; i < 3; ++i)
    worst = fmax(worst, fabs((double)S[i] - expected[i]) / expected[0]);
  printf("svd3 f32: S = %.7g %.7g %.7g, error %.3g (budget %g)\n", S[0], S[1], S[2], worst,
         EK_SVD3_TOL_F32);
  return !(worst <= EK_SVD3_TOL_F32);
}

// One unit corner tet, StVK: f = 0 at rest; stretched by 10% along x the
// four corner forces sum to zero, to the kernel's budget (EK_FVM_TOL_F64,
// relative to the largest force).
static int check_fvm(void) {
  const double X[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const int32_t tets[4] = {0, 1, 2, 3};
  ek_tets *el = ek_tets_create(4, X, 1, tets);
  if (!el) {
    fprintf(stderr, "ek_tets_create: %s\n", ek_last_error());
    return 1;
  }
  ek_material mat = {.model = EK_MODEL_STVK, .mu = 1, .lambda = 1};
  double x[12], f_rest[12], f[12];
  for (int i = 0; i < 12; ++i)
    x[i] = X[i] * (i % 3 == 0 ? 1.1 : 1.0);
  int failed = ek_fvm_tet_forces_ex_f64(el, &mat, X, f_rest, NULL) != 0 ||
               ek_fvm_tet_forces_ex_f64(el, &mat, x, f, NULL) != 0;
  ek_tets_destroy(el);
  if (failed) {
    fprintf(stderr, "ek_fvm_tet_forces_ex_f64: %s\n", ek_last_error());
    return 1;
  }
  double rest = 0, fmax_abs = 0, sum[3] = {0, 0, 0};
  for (int i = 0; i < 12; ++i) {
    rest = fmax(rest, fabs(f_rest[i]));
    fmax_abs = fmax(fmax_abs, fabs(f[i]));
    sum[i % 3] += f[i];
  }
  double net = fmax(fabs(sum[0]), fmax(fabs(sum[1]), fabs(sum[2]))) / fmax_abs;
  printf("fvm tet: |f| at rest %.3g, stretched max |f| %.6g, |sum f| / max |f| %.3g (budget %g)\n",
         rest, fmax_abs, net, EK_FVM_TOL_F64);
  return !(rest <= EK_FVM_TOL_F64 && fmax_abs > 0 && net <= EK_FVM_TOL_F64);
}

int main(void) {
  int failed = check_svd();
  failed |= check_fvm();
  printf("%s\n", failed ? "FAIL" : "PASS");
  return failed;
}
