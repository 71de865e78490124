// Invariant: for every ISA this machine runs and both precisions, ek_svd3_*
// returns A = U diag(S) V^T with U, V rotations, S ordered and signed by
// det A, within EK_SVD3_TOL_F32 / _F64 of the LAPACK reference (relative to
// s1) for the default options, on a random set and every extremes family;
// a matrix with a NaN or infinity gives NaN in its own outputs only; the
// result of a matrix does not depend on its position or on the batch size
// (AoS and AoSoA entry points agree bit for bit, tails included); ISAs agree
// within the budget and the f64 kernels agree with the scalar replica of the
// algorithm (ek_svd3_mcadams_ref, same knobs, exact 1/sqrt: the replica
// has no hardware estimate, whose angles can take another valid path, e.g.
// a sign pair, so the default approximate rsqrt is held to the LAPACK
// budget above) within EK_SVD3_REPLICA_TOL, at the default refine and at
// refine none, 1 and 3; U and V not wanted
// (NULL) leave S's bits as they are, and so does a NULL Ssym for R;
// ek_polar3_* gives a rotation R and a symmetric Ssym with R Ssym = A; an
// invalid option returns rc < 0 and writes nothing; 1, 2 and 3 threads give the
// same bits; the block kernel gives the same bits with 2 and 4 vectors in
// flight (ek_svd3_knobs.chains, the per-CPU tuning), AoS and AoSoA, SVD and
// polar, approximate and exact rsqrt. Non-default options (approximate rsqrt, other sweeps) are the
// speed/accuracy trade: their errors are printed, not judged, but they must
// still give finite outputs for finite inputs.
//
// Usage: test_svd3 [--seed N]
#include <ek/ek.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels/kernels.h" // ek_svd3_knobs: the driver's defaults
#include "check.h"
#include "cli.h"
#include "svd3/svd3_ref.h"

ek_svd3_knobs ek_svd3_default_knobs_f64(void);

enum { N_RANDOM = 20000, N_FAMILY = 500, N_TAIL = 1001, N_THREADS_TEST = 5000 };

static int failures;

static double budget_of(int bits) { return bits == 32 ? EK_SVD3_TOL_F32 : EK_SVD3_TOL_F64; }

// Lanes of one vector of the ISA (EK_W of its kernels).
static size_t vector_lanes(ek_isa isa, int bits) {
  switch (isa) {
  case EK_ISA_AVX2:
    return bits == 32 ? 8 : 4;
  case EK_ISA_AVX512:
    return bits == 32 ? 16 : 8;
  default:
    return 1;
  }
}

static size_t block_lanes(int bits) { return bits == 32 ? EK_LANES_F32 : EK_LANES_F64; }

static void print_svd_case(const double A[9], const double U[9], const double S[3],
                           const double V[9], const double S_ref[3]) {
  ek_print3("A", A);
  ek_print3("U", U);
  ek_print3("V", V);
  printf("  S actual   % .17g % .17g % .17g\n", S[0], S[1], S[2]);
  if (S_ref)
    printf("  S expected % .17g % .17g % .17g\n", S_ref[0], S_ref[1], S_ref[2]);
}

static int all_nan(const double *x, int n) {
  for (int i = 0; i < n; i++)
    if (!isnan(x[i]))
      return 0;
  return 1;
}

// ---- Accuracy against LAPACK ----
// Runs one option set on one input set; prints one line. Default options
// are judged against the budget; others (trade) only for finiteness and
// NaN isolation.
static void accuracy(int bits, ek_isa isa, const ek_svd3_set *s, const ek_svd3_opts *o,
                     const char *optname, int trade, int polar, double *U, double *S, double *V) {
  double budget = budget_of(bits);
  char label[128];
  snprintf(label, sizeof label, "%s %s f%d %s %s", polar ? "polar" : "svd", ek_isa_name(isa), bits,
           optname, s->name);
  int rc = ek_check_run_svd3(bits, polar, s->n, s->A, U, S, V, o);
  if (rc != 0) {
    printf("FAIL %s: rc %d (%s)\n", label, rc, ek_last_error());
    failures++;
    return;
  }
  double worst = 0;
  long nonfinite = 0, leaks = 0;
  int shown = 0;
  for (size_t i = 0; i < s->n; i++) {
    const double *A = s->A + 9 * i;
    if (s->bad[i]) {
      int nan_out =
          all_nan(U + 9 * i, 9) && all_nan(V + 9 * i, 9) && (polar || all_nan(S + 3 * i, 3));
      if (!nan_out && leaks++ < 2) {
        printf("FAIL %s #%zu: non-finite input, outputs not all NaN\n", label, i);
        print_svd_case(A, U + 9 * i, polar ? s->S_ref + 3 * i : S + 3 * i, V + 9 * i, NULL);
      }
      continue;
    }
    double w;
    int nf;
    if (polar) {
      ek_polar3_metrics m;
      ek_check_polar3(A, U + 9 * i, V + 9 * i, s->S_ref + 3 * i, s->R_ref + 9 * i, &m);
      w = ek_polar3_metrics_worst(&m), nf = m.nonfinite;
    } else {
      ek_svd3_metrics m;
      ek_check_svd3(A, U + 9 * i, S + 3 * i, V + 9 * i, s->S_ref + 3 * i, budget, &m);
      w = ek_svd3_metrics_worst(&m), nf = m.nonfinite;
    }
    if (nf) {
      if (nonfinite++ < 2) {
        printf("FAIL %s #%zu: non-finite output for a finite input\n", label, i);
        if (!polar)
          print_svd_case(A, U + 9 * i, S + 3 * i, V + 9 * i, s->S_ref + 3 * i);
        else
          ek_print3("A", A), ek_print3("R", U + 9 * i), ek_print3("Ssym", V + 9 * i);
      }
      continue;
    }
    if (!trade && w > budget && shown++ < 2) {
      printf("FAIL %s #%zu: error %.3g > budget %.3g\n", label, i, w, budget);
      if (!polar)
        print_svd_case(A, U + 9 * i, S + 3 * i, V + 9 * i, s->S_ref + 3 * i);
      else
        ek_print3("A", A), ek_print3("R", U + 9 * i), ek_print3("R expected", s->R_ref + 9 * i),
            ek_print3("Ssym", V + 9 * i);
    }
    worst = fmax(worst, w);
  }
  if (nonfinite || leaks) {
    printf("FAIL %s: %ld non-finite outputs for finite inputs, %ld NaN isolation errors\n", label,
           nonfinite, leaks);
    failures++;
  }
  if (trade)
    printf("%-58s err=%-11.4g budget=%-8.3g ratio=%-9.3g trade (not judged)\n", label, worst,
           budget, worst / budget);
  else
    failures += ek_check_report(label, worst, budget);
}

// ---- Position and batch-size independence, AoS vs AoSoA ----
static int same_bits(const double *a, const double *b, size_t n) {
  return memcmp(a, b, n * sizeof *a) == 0 || n == 0;
}

// AoS entry points on double data with U, S, V (polar: R, -, Ssym) that
// may be NULL (f32 converted).
static int run_svd3_some(int bits, int polar, size_t n, const double *A, double *U, double *S,
                         double *V, const ek_svd3_opts *o) {
  if (bits == 64)
    return polar ? ek_polar3_f64(n, A, U, V, o) : ek_svd3_f64(n, A, U, S, V, o);
  float *a = ek_check_malloc(9 * n * sizeof(float) + 1);
  float *u = U ? ek_check_malloc(9 * n * sizeof(float) + 1) : NULL;
  float *s = S ? ek_check_malloc(3 * n * sizeof(float) + 1) : NULL;
  float *v = V ? ek_check_malloc(9 * n * sizeof(float) + 1) : NULL;
  ek_check_to_f32(9 * n, A, a);
  int rc = polar ? ek_polar3_f32(n, a, u, v, o) : ek_svd3_f32(n, a, u, s, v, o);
  if (rc == 0) {
    if (U)
      ek_check_from_f32(9 * n, u, U);
    if (S)
      ek_check_from_f32(3 * n, s, S);
    if (V)
      ek_check_from_f32(9 * n, v, V);
  }
  free(a), free(u), free(s), free(v);
  return rc;
}

// AoSoA entry point on double data: pack, run, unpack (f32 converted).
static int run_aosoa(int bits, size_t n, const double *A, double *U, double *S, double *V,
                     const ek_svd3_opts *o, double *pad_worst) {
  size_t L = block_lanes(bits), nb = (n + L - 1) / L, lanes = nb * L;
  int rc;
  *pad_worst = 0;
  if (bits == 64) {
    double *a = ek_aosoa_alloc_f64(n, 9), *u = ek_aosoa_alloc_f64(n, 9);
    double *s = ek_aosoa_alloc_f64(n, 3), *v = ek_aosoa_alloc_f64(n, 9);
    ek_aosoa_pack_f64(n, 9, A, a);
    // The outputs poisoned, padding lanes too (threads() compares calls).
    ek_check_poison(u, 9 * lanes * sizeof *u), ek_check_poison(s, 3 * lanes * sizeof *s);
    ek_check_poison(v, 9 * lanes * sizeof *v);
    rc = ek_svd3_aosoa_f64(nb, a, u, s, v, o);
    if (rc == 0) {
      ek_aosoa_unpack_f64(n, 9, u, U), ek_aosoa_unpack_f64(n, 3, s, S);
      ek_aosoa_unpack_f64(n, 9, v, V);
      // Padding lanes hold the identity: S = (1, 1, 1) there.
      for (size_t l = n; l < lanes; l++) {
        size_t b = l / L, k = l % L;
        for (int p = 0; p < 3; p++)
          *pad_worst = fmax(*pad_worst, fabs(s[(b * 3 + p) * L + k] - 1));
      }
    }
    ek_free(a), ek_free(u), ek_free(s), ek_free(v);
  } else {
    float *a32 = ek_check_malloc(9 * n * sizeof(float) + 1);
    ek_check_to_f32(9 * n, A, a32);
    float *a = ek_aosoa_alloc_f32(n, 9), *u = ek_aosoa_alloc_f32(n, 9);
    float *s = ek_aosoa_alloc_f32(n, 3), *v = ek_aosoa_alloc_f32(n, 9);
    float *U32 = ek_check_malloc(9 * n * sizeof(float) + 1);
    float *S32 = ek_check_malloc(3 * n * sizeof(float) + 1);
    float *V32 = ek_check_malloc(9 * n * sizeof(float) + 1);
    ek_aosoa_pack_f32(n, 9, a32, a);
    ek_check_poison(u, 9 * lanes * sizeof *u), ek_check_poison(s, 3 * lanes * sizeof *s);
    ek_check_poison(v, 9 * lanes * sizeof *v);
    rc = ek_svd3_aosoa_f32(nb, a, u, s, v, o);
    if (rc == 0) {
      ek_aosoa_unpack_f32(n, 9, u, U32), ek_aosoa_unpack_f32(n, 3, s, S32);
      ek_aosoa_unpack_f32(n, 9, v, V32);
      ek_check_from_f32(9 * n, U32, U), ek_check_from_f32(3 * n, S32, S);
      ek_check_from_f32(9 * n, V32, V);
      for (size_t l = n; l < lanes; l++) {
        size_t b = l / L, k = l % L;
        for (int p = 0; p < 3; p++)
          *pad_worst = fmax(*pad_worst, fabs(s[(b * 3 + p) * L + k] - 1));
      }
    }
    ek_free(a), ek_free(u), ek_free(s), ek_free(v);
    free(a32), free(U32), free(S32), free(V32);
  }
  return rc;
}

// ---- AoS at every start within a 64-byte line: the same bits ----
// The AoS driver takes the matrices before the first whole line of U on
// their own (ek_aos_head, kernels.h); where the arrays start must not
// change any matrix's U, S, V (reference: U0, S0, V0 of tails()).
static int aos_starts(int bits, ek_isa isa, const ek_svd3_set *random, const double *U0,
                      const double *S0, const double *V0) {
  enum { STARTS = EK_LANES_F32 + 2 };
  const size_t n = N_TAIL, es = bits == 32 ? sizeof(float) : sizeof(double);
  ek_svd3_opts o = {.isa = isa};
  unsigned char *a = ek_alloc((n + STARTS) * 9 * es), *u = ek_alloc((n + STARTS) * 9 * es);
  unsigned char *sv = ek_alloc((n + STARTS) * 3 * es), *v = ek_alloc((n + STARTS) * 9 * es);
  double *U = ek_check_malloc(9 * n * sizeof(double)), *S = ek_check_malloc(3 * n * sizeof(double)),
         *V = ek_check_malloc(9 * n * sizeof(double));
  int bad = -1;
  for (int k = 0; k < STARTS && bad < 0; k++) {
    void *ak = a + (size_t)k * 9 * es, *uk = u + (size_t)k * 9 * es;
    void *sk = sv + (size_t)k * 3 * es, *vk = v + (size_t)k * 9 * es;
    int rc;
    if (bits == 32) {
      ek_check_to_f32(9 * n, random->A, ak);
      rc = ek_svd3_f32(n, ak, uk, sk, vk, &o);
      ek_check_from_f32(9 * n, uk, U), ek_check_from_f32(3 * n, sk, S);
      ek_check_from_f32(9 * n, vk, V);
    } else {
      memcpy(ak, random->A, 9 * n * es);
      rc = ek_svd3_f64(n, ak, uk, sk, vk, &o);
      memcpy(U, uk, 9 * n * es), memcpy(S, sk, 3 * n * es), memcpy(V, vk, 9 * n * es);
    }
    if (rc != 0 || !same_bits(U, U0, 9 * n) || !same_bits(S, S0, 3 * n) || !same_bits(V, V0, 9 * n))
      bad = k;
  }
  if (bad >= 0)
    printf("FAIL tails %s f%d AoS: the results differ when the arrays start %d matrices into a "
           "64-byte line\n",
           ek_isa_name(isa), bits, bad);
  ek_free(a), ek_free(u), ek_free(sv), ek_free(v);
  free(U), free(S), free(V);
  return bad >= 0;
}

static void tails(int bits, ek_isa isa, const ek_svd3_set *random) {
  ek_svd3_opts o = {.isa = isa};
  size_t n_full = N_TAIL;
  double *U0 = ek_check_malloc(9 * n_full * sizeof(double));
  double *S0 = ek_check_malloc(3 * n_full * sizeof(double));
  double *V0 = ek_check_malloc(9 * n_full * sizeof(double));
  // Outputs one entry longer than asked, with a sentinel after the end.
  double *U = ek_check_malloc((9 * n_full + 1) * sizeof(double));
  double *S = ek_check_malloc((3 * n_full + 1) * sizeof(double));
  double *V = ek_check_malloc((9 * n_full + 1) * sizeof(double));
  if (ek_check_run_svd3(bits, 0, n_full, random->A, U0, S0, V0, &o) != 0) {
    printf("FAIL tails %s f%d: rc != 0 (%s)\n", ek_isa_name(isa), bits, ek_last_error());
    failures++;
    return;
  }
  size_t W = vector_lanes(isa, bits), L = block_lanes(bits);
  size_t sizes[] = {0, 1, W - 1, W + 1, L - 1, L + 1, 17, n_full};
  int bad = 0;
  double pad_worst_all = 0;
  for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
    size_t n = sizes[k];
    const double sentinel = 12345.0;
    U[9 * n] = S[3 * n] = V[9 * n] = sentinel;
    int rc = ek_check_run_svd3(bits, 0, n, random->A, U, S, V, &o);
    int ok = rc == 0 && same_bits(U, U0, 9 * n) && same_bits(S, S0, 3 * n) &&
             same_bits(V, V0, 9 * n) && U[9 * n] == sentinel && S[3 * n] == sentinel &&
             V[9 * n] == sentinel;
    if (!ok) {
      printf("FAIL tails %s f%d AoS n=%zu: rc %d, results differ from the n=%zu batch or write "
             "past the end\n",
             ek_isa_name(isa), bits, n, rc, n_full);
      bad++;
    }
    double pad_worst;
    U[9 * n] = S[3 * n] = V[9 * n] = sentinel;
    rc = run_aosoa(bits, n, random->A, U, S, V, &o, &pad_worst);
    ok = rc == 0 && same_bits(U, U0, 9 * n) && same_bits(S, S0, 3 * n) && same_bits(V, V0, 9 * n) &&
         U[9 * n] == sentinel;
    if (!ok) {
      printf("FAIL tails %s f%d AoSoA n=%zu: rc %d, results differ from the AoS batch\n",
             ek_isa_name(isa), bits, n, rc);
      bad++;
    }
    pad_worst_all = fmax(pad_worst_all, pad_worst);
  }
  bad += aos_starts(bits, isa, random, U0, S0, V0);
  // U and V not wanted (NULL): S the same bits; polar without Ssym: R the
  // same bits as with it.
  {
    size_t n = n_full;
    int ok =
        run_svd3_some(bits, 0, n, random->A, NULL, S, NULL, &o) == 0 && same_bits(S, S0, 3 * n);
    double *R0 = ek_check_malloc(9 * n * sizeof(double)),
           *P0 = ek_check_malloc(9 * n * sizeof(double));
    ok &= ek_check_run_svd3(bits, 1, n, random->A, R0, NULL, P0, &o) == 0 &&
          run_svd3_some(bits, 1, n, random->A, U, NULL, NULL, &o) == 0 && same_bits(U, R0, 9 * n);
    if (!ok) {
      printf("FAIL tails %s f%d: NULL outputs change the others\n", ek_isa_name(isa), bits);
      bad++;
    }
    free(R0), free(P0);
  }
  printf("tails %s f%d: sizes 0 1 %zu %zu %zu %zu 17 %zu, AoS and AoSoA (AoS at 18 starts in a "
         "line) bit-identical to one batch: %s\n",
         ek_isa_name(isa), bits, W - 1, W + 1, L - 1, L + 1, n_full, bad ? "FAIL" : "PASS");
  failures += bad != 0;
  char label[96];
  snprintf(label, sizeof label, "padding lanes (identity) %s f%d: |S - 1|", ek_isa_name(isa), bits);
  failures += ek_check_report(label, pad_worst_all, budget_of(bits));
  free(U0), free(S0), free(V0), free(U), free(S), free(V);
}

// ---- NaN isolation ----
// NaN / inf put into a copy of the random batch: those matrices give NaN
// everywhere, every other matrix gives the same bits as without them.
static void nan_isolation(int bits, ek_isa isa, const ek_svd3_set *random) {
  size_t n = N_TAIL, W = vector_lanes(isa, bits);
  size_t where[] = {0, 1, W, W + 1, 500, n - 1};
  const double poison[] = {NAN, INFINITY, -INFINITY, NAN, -NAN, INFINITY};
  double *A = ek_check_malloc(9 * n * sizeof(double));
  memcpy(A, random->A, 9 * n * sizeof(double));
  char *bad = calloc(n, 1);
  for (size_t k = 0; k < sizeof where / sizeof where[0]; k++) {
    A[9 * where[k] + (k * 4) % 9] = poison[k];
    bad[where[k]] = 1;
  }
  double *U0 = ek_check_malloc(9 * n * sizeof(double)),
         *S0 = ek_check_malloc(3 * n * sizeof(double));
  double *V0 = ek_check_malloc(9 * n * sizeof(double)),
         *U = ek_check_malloc(9 * n * sizeof(double));
  double *S = ek_check_malloc(3 * n * sizeof(double)), *V = ek_check_malloc(9 * n * sizeof(double));
  ek_svd3_opts o = {.isa = isa};
  int rc0 = ek_check_run_svd3(bits, 0, n, random->A, U0, S0, V0, &o);
  int rc = ek_check_run_svd3(bits, 0, n, A, U, S, V, &o);
  long errors = rc0 != 0 || rc != 0;
  for (size_t i = 0; i < n && !errors; i++) {
    int ok = bad[i] ? all_nan(U + 9 * i, 9) && all_nan(S + 3 * i, 3) && all_nan(V + 9 * i, 9)
                    : same_bits(U + 9 * i, U0 + 9 * i, 9) && same_bits(S + 3 * i, S0 + 3 * i, 3) &&
                          same_bits(V + 9 * i, V0 + 9 * i, 9);
    if (!ok) {
      printf("FAIL NaN isolation %s f%d: matrix %zu (%s)\n", ek_isa_name(isa), bits, i,
             bad[i] ? "non-finite input, outputs not all NaN" : "neighbour changed");
      print_svd_case(A + 9 * i, U + 9 * i, S + 3 * i, V + 9 * i, S0 + 3 * i);
      errors++;
    }
  }
  printf("NaN isolation %s f%d (NaN/inf in matrices 0 1 %zu %zu 500 %zu of %zu): %s\n",
         ek_isa_name(isa), bits, W, W + 1, n - 1, n, errors ? "FAIL" : "PASS");
  failures += errors != 0;
  free(A), free(bad), free(U0), free(S0), free(V0), free(U), free(S), free(V);
}

// ---- ISA agreement, and f64 kernels vs the replica ----
// refine: the option (0 = default); S_scalar: NULL to skip the ISA check.
static void agreement(int bits, ek_isa isa, const ek_svd3_set *s, const double *S_scalar,
                      int refine, double *U, double *S, double *V) {
  ek_svd3_opts o = {.isa = isa, .refine = refine, .exact_rsqrt = bits == 64 ? 1 : 0};
  if (ek_check_run_svd3(bits, 0, s->n, s->A, U, S, V, &o) != 0) {
    failures++;
    return;
  }
  double worst = 0, worst_rep = 0;
  ek_svd3_knobs k = ek_svd3_default_knobs_f64();
  if (refine)
    k.refine = refine == EK_SVD3_REFINE_NONE ? 0 : refine;
  int shown = 0;
  for (size_t i = 0; i < s->n; i++) {
    if (s->bad[i])
      continue;
    double s1 = s->S_ref[3 * i] > 0 ? s->S_ref[3 * i] : 1;
    for (int j = 0; j < 3 && S_scalar; j++)
      worst = fmax(worst, fabs(S[3 * i + j] - S_scalar[3 * i + j]) / s1);
    if (bits != 64)
      continue;
    double Ur[9], Sr[3], Vr[9];
    ek_svd3_mcadams_ref(s->A + 9 * i, k.sweeps, k.refine, Ur, Sr, Vr);
    double e = 0;
    for (int j = 0; j < 3; j++)
      e = fmax(e, fabs(S[3 * i + j] - Sr[j]) / s1);
    const double *Sx = s->S_ref + 3 * i;
    double gap = fmin(Sx[0] - Sx[1], Sx[1] - fabs(Sx[2]));
    // Without refinement the kernel is Jacobi on A^T A alone: its S, U and V
    // carry the rounding differences times the squared condition number
    // (seen: 8e-11 on two_small, 1.6e-12 on ill_cond_1e3), so the replica
    // check holds there only for s3 >= 1e-2 s1 (kappa^2 eps <= 2e-12).
    if (k.refine == 0 && fabs(Sx[2]) < 1e-2 * s1)
      continue;
    if (gap > EK_SVD3_REPLICA_GAP * s1)
      for (int j = 0; j < 9; j++)
        e = fmax(e, fmax(fabs(U[9 * i + j] - Ur[j]), fabs(V[9 * i + j] - Vr[j])));
    if (!(e <= EK_SVD3_REPLICA_TOL) && shown++ < 2) {
      printf("FAIL replica agreement %s f64 %s #%zu: %.3g\n", ek_isa_name(isa), s->name, i, e);
      print_svd_case(s->A + 9 * i, U + 9 * i, S + 3 * i, V + 9 * i, Sr);
      ek_print3("U replica", Ur);
      ek_print3("V replica", Vr);
    }
    worst_rep = fmax(worst_rep, isnan(e) ? INFINITY : e);
  }
  char label[128];
  if (S_scalar) {
    snprintf(label, sizeof label, "S agreement %s vs scalar f%d %s", ek_isa_name(isa), bits,
             s->name);
    failures += ek_check_report(label, worst, budget_of(bits));
  }
  if (bits == 64) {
    char knob[32] = "";
    if (refine == EK_SVD3_REFINE_NONE)
      snprintf(knob, sizeof knob, " refine=none");
    else if (refine > 0)
      snprintf(knob, sizeof knob, " refine=%d", refine);
    snprintf(label, sizeof label, "replica agreement %s f64%s %s", ek_isa_name(isa), knob, s->name);
    failures += ek_check_report(label, worst_rep, EK_SVD3_REPLICA_TOL);
  }
}

// ---- Invalid options ----
static void invalid_options(void) {
  const ek_svd3_opts bad_opts[] = {
      {.sweeps = 9},       {.sweeps = -1}, {.exact_rsqrt = 2}, {.exact_rsqrt = -2},
      {.isa = (ek_isa)99}, {.refine = 4},  {.refine = -2},
  };
  const char *names[] = {"sweeps 9", "sweeps -1", "exact_rsqrt 2", "exact_rsqrt -2",
                         "isa 99",   "refine 4",  "refine -2"};
  int nbad = 0;
  float a32[9 * 17], u32[9 * 17], s32[3 * 17], v32[9 * 17];
  double a64[9 * 17], u64[9 * 17], s64[3 * 17], v64[9 * 17];
  for (int i = 0; i < 9 * 17; i++)
    a32[i] = (float)(a64[i] = (i % 4 == 0) + 0.1 * (i % 7));
  float *pa32 = ek_aosoa_alloc_f32(17, 9), *pu32 = ek_aosoa_alloc_f32(17, 9);
  float *ps32 = ek_aosoa_alloc_f32(17, 3), *pv32 = ek_aosoa_alloc_f32(17, 9);
  double *pa64 = ek_aosoa_alloc_f64(17, 9), *pu64 = ek_aosoa_alloc_f64(17, 9);
  double *ps64 = ek_aosoa_alloc_f64(17, 3), *pv64 = ek_aosoa_alloc_f64(17, 9);
  ek_aosoa_pack_f32(17, 9, a32, pa32), ek_aosoa_pack_f64(17, 9, a64, pa64);
  size_t nb32 = ek_aosoa_blocks_f32(17), nb64 = ek_aosoa_blocks_f64(17);
  size_t n_opts = sizeof bad_opts / sizeof bad_opts[0];
  for (size_t k = 0; k <= n_opts; k++) {
    ek_svd3_opts o;
    const char *name;
    if (k < n_opts)
      o = bad_opts[k], name = names[k];
    else {
      // A real ISA this CPU cannot run, if there is one.
      int missing = -1;
      for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
        if (!ek_isa_available((ek_isa)isa))
          missing = isa;
      if (missing < 0)
        break;
      o = (ek_svd3_opts){.isa = (ek_isa)missing};
      name = ek_isa_name((ek_isa)missing);
    }
    // Fill every output with a sentinel byte pattern; it must survive.
    memset(u32, 0x5a, sizeof u32), memset(s32, 0x5a, sizeof s32), memset(v32, 0x5a, sizeof v32);
    memset(u64, 0x5a, sizeof u64), memset(s64, 0x5a, sizeof s64), memset(v64, 0x5a, sizeof v64);
    size_t b32 = ek_aosoa_size_f32(17, 9) * sizeof(float);
    size_t b64 = ek_aosoa_size_f64(17, 9) * sizeof(double);
    memset(pu32, 0x5a, b32), memset(pv32, 0x5a, b32);
    memset(ps32, 0x5a, ek_aosoa_size_f32(17, 3) * sizeof(float));
    memset(pu64, 0x5a, b64), memset(pv64, 0x5a, b64);
    memset(ps64, 0x5a, ek_aosoa_size_f64(17, 3) * sizeof(double));
    int rc[8] = {
        ek_svd3_f32(17, a32, u32, s32, v32, &o),
        ek_svd3_f64(17, a64, u64, s64, v64, &o),
        ek_polar3_f32(17, a32, u32, v32, &o),
        ek_polar3_f64(17, a64, u64, v64, &o),
        ek_svd3_aosoa_f32(nb32, pa32, pu32, ps32, pv32, &o),
        ek_svd3_aosoa_f64(nb64, pa64, pu64, ps64, pv64, &o),
        ek_polar3_aosoa_f32(nb32, pa32, pu32, pv32, &o),
        ek_polar3_aosoa_f64(nb64, pa64, pu64, pv64, &o),
    };
    int untouched = 1;
    const unsigned char *bufs[] = {(void *)u32,  (void *)s32,  (void *)v32,  (void *)u64,
                                   (void *)s64,  (void *)v64,  (void *)pu32, (void *)ps32,
                                   (void *)pv32, (void *)pu64, (void *)ps64, (void *)pv64};
    size_t sizes[] = {sizeof u32,
                      sizeof s32,
                      sizeof v32,
                      sizeof u64,
                      sizeof s64,
                      sizeof v64,
                      b32,
                      ek_aosoa_size_f32(17, 3) * sizeof(float),
                      b32,
                      b64,
                      ek_aosoa_size_f64(17, 3) * sizeof(double),
                      b64};
    for (int b = 0; b < 12; b++)
      for (size_t j = 0; j < sizes[b]; j++)
        untouched &= bufs[b][j] == 0x5a;
    int all_neg = 1;
    for (int j = 0; j < 8; j++)
      all_neg &= rc[j] < 0;
    int ok = all_neg && untouched;
    printf("invalid option %-16s rc = %d %d %d %d %d %d %d %d, outputs %s: %s\n", name, rc[0],
           rc[1], rc[2], rc[3], rc[4], rc[5], rc[6], rc[7], untouched ? "untouched" : "WRITTEN",
           ok ? "PASS" : "FAIL");
    nbad += !ok;
  }
  ek_free(pa32), ek_free(pu32), ek_free(ps32), ek_free(pv32);
  ek_free(pa64), ek_free(pu64), ek_free(ps64), ek_free(pv64);
  failures += nbad;
}

// ---- Streamed outputs ----
// A batch whose arrays pass 32 MiB takes streaming stores for its outputs
// (kernels/svd3/svd3.c, nt_for: AoS; AoSoA where the row takes more than 2
// chains), with the row's chains where all of them are streamed: its
// results must have the bits of the same matrices in calls of 4096 (plain
// stores). Three layouts: every array on 64 bytes (all streamed), the
// outputs one record past it (AoS: a head, S then off its line: U and V
// alone streamed; AoSoA: S one value past it, nothing streamed), and the
// polar (R, Ssym).
// The inputs: the random set, repeated (read as blocks by the AoSoA entry
// points: other matrices, as valid as any); n leaves a partial last vector
// (AoS).
static int run_streamed(int bits, int aosoa, int polar, size_t n, const char *a, char *u, char *s,
                        char *v, const ek_svd3_opts *o) {
  if (aosoa) {
    size_t nb = n / block_lanes(bits);
    return bits == 32
               ? (polar ? ek_polar3_aosoa_f32(nb, (const float *)a, (float *)u, (float *)v, o)
                        : ek_svd3_aosoa_f32(nb, (const float *)a, (float *)u, (float *)s,
                                            (float *)v, o))
               : (polar ? ek_polar3_aosoa_f64(nb, (const double *)a, (double *)u, (double *)v, o)
                        : ek_svd3_aosoa_f64(nb, (const double *)a, (double *)u, (double *)s,
                                            (double *)v, o));
  }
  return bits == 32
             ? (polar ? ek_polar3_f32(n, (const float *)a, (float *)u, (float *)v, o)
                      : ek_svd3_f32(n, (const float *)a, (float *)u, (float *)s, (float *)v, o))
             : (polar
                    ? ek_polar3_f64(n, (const double *)a, (double *)u, (double *)v, o)
                    : ek_svd3_f64(n, (const double *)a, (double *)u, (double *)s, (double *)v, o));
}

static void streamed(int bits, ek_isa isa, const ek_svd3_set *s) {
  const size_t n = (bits == 32 ? 300000 : 150000) + 5, es = bits == 32 ? 4 : 8, piece = 4096;
  char *A = ek_alloc(9 * n * es), *o[2][3];
  int ok = A != NULL;
  for (int c = 0; c < 2; c++)
    for (int k = 0; k < 3; k++)
      ok &= (o[c][k] = ek_alloc(((k == 1 ? 3 : 9) * n + 9) * es)) != NULL;
  if (!ok) {
    printf("streamed: out of memory\n");
    exit(1);
  }
  for (size_t i = 0; i < 9 * n; i++)
    if (bits == 32)
      ((float *)A)[i] = (float)s->A[i % (9 * s->n)];
    else
      ((double *)A)[i] = s->A[i % (9 * s->n)];
  ek_svd3_opts opt = {.isa = isa};
  // AoSoA: whole blocks only (piece is a multiple of the block).
  const size_t nblk = n / block_lanes(bits) * block_lanes(bits);
  for (int aosoa = 0; aosoa < 2; aosoa++)
    for (int layout = 0; layout < 3; layout++) {
      int polar = layout == 2;
      size_t off = layout == 1 ? 1 : 0, m_all = aosoa ? nblk : n;
      for (int c = 0; c < 2; c++) {
        char *u = o[c][0] + (aosoa ? 0 : 9 * off * es), *sv = o[c][1] + (aosoa ? 1 : 3) * off * es,
             *v = o[c][2] + (aosoa ? 0 : 9 * off * es);
        for (int k = 0; k < 3; k++)
          memset(o[c][k], 0, ((k == 1 ? 3 : 9) * n + 9) * es);
        for (size_t i0 = 0; i0 < m_all; i0 += c ? piece : m_all) {
          size_t m = c ? (m_all - i0 < piece ? m_all - i0 : piece) : m_all;
          ok &= run_streamed(bits, aosoa, polar, m, A + 9 * i0 * es, u + 9 * i0 * es,
                             sv + 3 * i0 * es, v + 9 * i0 * es, &opt) == 0;
        }
      }
      for (int k = 0; k < 3; k++)
        if (memcmp(o[0][k], o[1][k], ((k == 1 ? 3 : 9) * n + 9) * es) != 0) {
          printf("streamed %s f%d: %s layout %d output %d differs from calls of %zu\n",
                 ek_isa_name(isa), bits, aosoa ? "AoSoA" : "AoS", layout, k, piece);
          ok = 0;
        }
    }
  printf("streamed %s f%d: n=%zu (arrays past 32 MiB, streamed stores) bit-identical to calls of "
         "%zu (AoS and AoSoA; aligned, one record off, polar): %s\n",
         ek_isa_name(isa), bits, n, piece, ok ? "PASS" : "FAIL");
  failures += !ok;
  for (int c = 0; c < 2; c++)
    for (int k = 0; k < 3; k++)
      ek_free(o[c][k]);
  ek_free(A);
}

// ---- Thread count ----
static void threads(int bits, ek_isa isa, const ek_svd3_set *s) {
  size_t n = N_THREADS_TEST < s->n ? N_THREADS_TEST : s->n;
  double *U1 = ek_check_malloc(9 * n * sizeof(double)),
         *S1 = ek_check_malloc(3 * n * sizeof(double));
  double *V1 = ek_check_malloc(9 * n * sizeof(double)),
         *U2 = ek_check_malloc(9 * n * sizeof(double));
  double *S2 = ek_check_malloc(3 * n * sizeof(double)),
         *V2 = ek_check_malloc(9 * n * sizeof(double));
  ek_svd3_opts o = {.isa = isa};
  double pad;
  int saved = omp_get_max_threads(), ok = 1;
  for (int api = 0; api < 2; api++) {
    // Every output poisoned before its call (all overwritten, svd3.h), here
    // and inside run_aosoa and ek_check_run_svd3 (their staging): U2, S2,
    // V2 hold the previous call's results, which a chunk that did not run
    // would leave.
    omp_set_num_threads(1);
    ek_check_poison(U1, 9 * n * sizeof *U1), ek_check_poison(S1, 3 * n * sizeof *S1);
    ek_check_poison(V1, 9 * n * sizeof *V1);
    int rc1 = api ? run_aosoa(bits, n, s->A, U1, S1, V1, &o, &pad)
                  : ek_check_run_svd3(bits, 0, n, s->A, U1, S1, V1, &o);
    ok &= rc1 == 0;
    // Chunks go to whichever thread claims them first (kernels/team.h):
    // a few calls per count, so that the helpers take some in most.
    for (int t = 2; t <= 3; t++)
      for (int rep = 0; rep < 3; rep++) {
        omp_set_num_threads(t);
        ek_check_poison(U2, 9 * n * sizeof *U2), ek_check_poison(S2, 3 * n * sizeof *S2);
        ek_check_poison(V2, 9 * n * sizeof *V2);
        int rc2 = api ? run_aosoa(bits, n, s->A, U2, S2, V2, &o, &pad)
                      : ek_check_run_svd3(bits, 0, n, s->A, U2, S2, V2, &o);
        ok &= rc2 == 0 && same_bits(U1, U2, 9 * n) && same_bits(S1, S2, 3 * n) &&
              same_bits(V1, V2, 9 * n);
      }
  }
  omp_set_num_threads(saved);
  printf("threads %s f%d: 1, 2 and 3 threads bit-identical (n=%zu, AoS and AoSoA): %s\n",
         ek_isa_name(isa), bits, n, ok ? "PASS" : "FAIL");
  failures += !ok;
  free(U1), free(S1), free(V1), free(U2), free(S2), free(V2);
}

// The chains knob (kernels.h, svd3_block.c) schedules independent vectors
// side by side; every lane's operations stay the same, so 2 and 4 chains
// must agree bit for bit. n is no multiple of 4 vectors, so the odd
// vectors after the 4-wide loop are covered; the AoSoA pass reads the same
// numbers as blocks (other matrices, as valid as any). A third pass takes 4
// chains with the outputs streamed (k.nt, the drivers' choice for batches
// beyond the caches, AoS and AoSoA; the arrays from ek_alloc, 64-byte
// aligned): the same bits again.
static void chains(int bits, ek_isa isa, const ek_svd3_set *s) {
  const ek_kernel_table *t = ek_kernels_for(isa);
  size_t lanes = block_lanes(bits), n = s->n < 3 * 4 * lanes + 37 ? s->n : 3 * 4 * lanes + 37;
  size_t nb = n / lanes, es = bits == 32 ? sizeof(float) : sizeof(double);
  char *A = ek_check_malloc(9 * n * es), *out[3][3];
  for (size_t i = 0; i < 9 * n; i++)
    if (bits == 32)
      ((float *)A)[i] = (float)s->A[i];
    else
      ((double *)A)[i] = s->A[i];
  int ok = 1;
  for (int c = 0; c < 3; c++)
    for (int k = 0; k < 3; k++)
      if (!(out[c][k] = ek_alloc((k == 1 ? 3 : 9) * n * es))) {
        printf("chains: out of memory\n");
        exit(1);
      }
  for (int variant = 0; variant < 8; variant++) {
    int aos = variant & 1, polar = (variant >> 1) & 1, exact = (variant >> 2) & 1;
    ek_svd3_knobs k = bits == 32 ? ek_svd3_default_knobs_f32() : ek_svd3_default_knobs_f64();
    k.aos = aos, k.polar = polar, k.exact_rsqrt = exact;
    size_t count = aos ? n : nb;
    for (int c = 0; c < 3; c++) {
      k.chains = c ? 4 : 2;
      k.nt = c == 2 ? EK_SVD3_NT_U | EK_SVD3_NT_V | EK_SVD3_NT_S : 0;
      for (int j = 0; j < 3; j++)
        memset(out[c][j], 0, (j == 1 ? 3 : 9) * n * es);
      if (bits == 32)
        t->svd3_block_f32(count, (const float *)A, (float *)out[c][0], (float *)out[c][1],
                          (float *)out[c][2], &k);
      else
        t->svd3_block_f64(count, (const double *)A, (double *)out[c][0], (double *)out[c][1],
                          (double *)out[c][2], &k);
    }
    for (int c = 1; c < 3; c++)
      for (int j = 0; j < 3; j++)
        if (memcmp(out[0][j], out[c][j], (j == 1 ? 3 : 9) * n * es) != 0) {
          printf("chains %s f%d: %s %s rsqrt %s: output %d differs between 2 and 4 chains%s\n",
                 ek_isa_name(isa), bits, aos ? "AoS" : "AoSoA", polar ? "polar" : "SVD",
                 exact ? "exact" : "approx", j, c == 2 ? " (streamed stores)" : "");
          ok = 0;
        }
  }
  printf("chains %s f%d: 2 and 4 vectors in flight, and 4 with streamed stores, "
         "bit-identical (n=%zu; AoS, AoSoA, SVD, polar, both rsqrt; this CPU's row takes %d): "
         "%s\n",
         ek_isa_name(isa), bits, n, t->svd3_chains, ok ? "PASS" : "FAIL");
  failures += !ok;
  for (int c = 0; c < 3; c++)
    for (int k = 0; k < 3; k++)
      ek_free(out[c][k]);
  free(A);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_svd3: seed %llu; default sweeps f32 %d, f64 %d\n", (unsigned long long)seed,
         ek_svd3_default_sweeps_f32(), ek_svd3_default_sweeps_f64());
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    if (!ek_isa_available((ek_isa)isa))
      printf("note: ISA %s skipped: not built or not supported by this CPU\n",
             ek_isa_name((ek_isa)isa));
  invalid_options();

  static const struct {
    const char *name;
    ek_svd3_opts o;
  } trades[] = {
      {"rsqrt=approx", {.exact_rsqrt = -1}},
      {"sweeps=1", {.sweeps = 1}},
      {"sweeps=2", {.sweeps = 2}},
      {"sweeps=4", {.sweeps = 4}},
      {"sweeps=8 rsqrt=approx", {.sweeps = 8, .exact_rsqrt = -1}},
      {"McAdams (sweeps=4 refine=none)",
       {.sweeps = 4, .exact_rsqrt = -1, .refine = EK_SVD3_REFINE_NONE}},
      {"refine=1", {.refine = 1}},
      {"refine=3", {.refine = 3}},
  };
  for (int bits = 32; bits <= 64; bits += 32) {
    int nsets = 0;
    ek_svd3_set *sets = ek_check_malloc((size_t)(ek_check_nfamilies + 1) * sizeof *sets);
    ek_svd3_set_init(&sets[nsets++], &ek_check_families[0], "random", seed, N_RANDOM, bits);
    for (int f = 0; f < ek_check_nfamilies; f++)
      if (ek_check_family_for(&ek_check_families[f], bits))
        ek_svd3_set_init(&sets[nsets++], &ek_check_families[f], ek_check_families[f].name, seed,
                         N_FAMILY, bits);
    double *U = ek_check_malloc(9 * N_RANDOM * sizeof(double));
    double *S = ek_check_malloc(3 * N_RANDOM * sizeof(double));
    double *V = ek_check_malloc(9 * N_RANDOM * sizeof(double));
    // S of the scalar ISA per set, for the agreement check.
    double **S_scalar = ek_check_malloc((size_t)nsets * sizeof *S_scalar);
    for (int k = 0; k < nsets; k++) {
      S_scalar[k] = ek_check_malloc(3 * sets[k].n * sizeof(double));
      ek_svd3_opts o = {.isa = EK_ISA_SCALAR};
      double *Ut = ek_check_malloc(9 * sets[k].n * sizeof(double)),
             *Vt = ek_check_malloc(9 * sets[k].n * sizeof(double));
      if (ek_check_run_svd3(bits, 0, sets[k].n, sets[k].A, Ut, S_scalar[k], Vt, &o) != 0)
        failures++;
      free(Ut), free(Vt);
    }
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      printf("\n== %s f%d\n", ek_isa_name((ek_isa)isa), bits);
      ek_svd3_opts def = {.isa = (ek_isa)isa};
      for (int k = 0; k < nsets; k++)
        accuracy(bits, (ek_isa)isa, &sets[k], &def, "default", 0, 0, U, S, V);
      for (int k = 0; k < nsets; k++)
        accuracy(bits, (ek_isa)isa, &sets[k], &def, "default", 0, 1, U, S, V);
      for (size_t t = 0; t < sizeof trades / sizeof trades[0]; t++)
        for (int k = 0; k < nsets; k++) {
          ek_svd3_opts o = trades[t].o;
          o.isa = (ek_isa)isa;
          accuracy(bits, (ek_isa)isa, &sets[k], &o, trades[t].name, 1, 0, U, S, V);
        }
      for (int k = 0; k < nsets; k++)
        agreement(bits, (ek_isa)isa, &sets[k], S_scalar[k], 0, U, S, V);
      // The refine knob against the replica run with the same knobs (f64:
      // the replica is exact to ~1e-12 only in double).
      static const int refine_knobs[] = {EK_SVD3_REFINE_NONE, 1, 3};
      for (size_t r = 0; bits == 64 && r < sizeof refine_knobs / sizeof refine_knobs[0]; r++)
        for (int k = 0; k < nsets; k++)
          agreement(bits, (ek_isa)isa, &sets[k], NULL, refine_knobs[r], U, S, V);
      tails(bits, (ek_isa)isa, &sets[0]);
      nan_isolation(bits, (ek_isa)isa, &sets[0]);
      threads(bits, (ek_isa)isa, &sets[0]);
      chains(bits, (ek_isa)isa, &sets[0]);
      streamed(bits, (ek_isa)isa, &sets[0]);
    }
    for (int k = 0; k < nsets; k++)
      ek_svd3_set_free(&sets[k]), free(S_scalar[k]);
    free(sets), free(S_scalar), free(U), free(S), free(V);
  }
  printf("\ntest_svd3: %s (%d failing checks)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
