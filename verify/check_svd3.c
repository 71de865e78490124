// SVD3 input sets with their LAPACK reference, and a precision-generic way
// to call ek_svd3_* / ek_polar3_* on double data.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "svd3/svd3_ref.h"

void *ek_check_malloc(size_t bytes) {
  void *p = malloc(bytes ? bytes : 1);
  if (!p) {
    fprintf(stderr, "ek_check: out of memory (%zu bytes)\n", bytes);
    exit(1);
  }
  return p;
}

void ek_svd3_set_init(ek_svd3_set *s, const ek_check_family *f, const char *name, uint64_t seed,
                      size_t n, int bits) {
  snprintf(s->name, sizeof s->name, "%s", name);
  s->nonfinite_family = (f->flags & EK_FAMILY_NONFINITE) != 0;
  s->n = n;
  s->A = ek_check_malloc(9 * n * sizeof(double));
  s->S_ref = ek_check_malloc(3 * n * sizeof(double));
  s->R_ref = ek_check_malloc(9 * n * sizeof(double));
  s->bad = ek_check_malloc(n);
  // The stream is named by the set, not the family: the random set is the
  // gaussian generator on its own stream ("random").
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, name));
  f->generate(&rng, n, s->A);
  // A float kernel sees the rounded matrix; so does its reference.
  if (bits == 32)
    for (size_t i = 0; i < 9 * n; i++)
      s->A[i] = (float)s->A[i];
  for (size_t i = 0; i < n; i++) {
    double U[9], V[9];
    s->bad[i] = ek_svd3_ref(s->A + 9 * i, U, s->S_ref + 3 * i, V) != 0;
    ek_mul3_bt(U, V, s->R_ref + 9 * i);
  }
}

void ek_svd3_set_free(ek_svd3_set *s) {
  free(s->A), free(s->S_ref), free(s->R_ref), free(s->bad);
  s->A = s->S_ref = s->R_ref = NULL;
  s->bad = NULL;
}

int ek_check_run_svd3(int bits, int polar, size_t n, const double *A, double *U, double *S,
                      double *V, const ek_svd3_opts *o) {
  if (bits == 64)
    return polar ? ek_polar3_f64(n, A, U, V, o) : ek_svd3_f64(n, A, U, S, V, o);
  float *a = ek_check_malloc(9 * n * sizeof(float)), *u = ek_check_malloc(9 * n * sizeof(float));
  float *s = ek_check_malloc(3 * n * sizeof(float)), *v = ek_check_malloc(9 * n * sizeof(float));
  ek_check_to_f32(9 * n, A, a);
  // The outputs poisoned (tests/test_svd3.c compares calls at 1, 2 and 3
  // threads: a freed buffer of the previous call may come back here).
  ek_check_poison(u, 9 * n * sizeof *u), ek_check_poison(s, 3 * n * sizeof *s);
  ek_check_poison(v, 9 * n * sizeof *v);
  int rc = polar ? ek_polar3_f32(n, a, u, v, o) : ek_svd3_f32(n, a, u, s, v, o);
  if (rc == 0) {
    ek_check_from_f32(9 * n, u, U), ek_check_from_f32(9 * n, v, V);
    if (!polar)
      ek_check_from_f32(3 * n, s, S);
  }
  free(a), free(u), free(s), free(v);
  return rc;
}
