// Invariant: ek's kernels compute in their own floating-point mode
// (kernels/simd/fpmode.h), whatever the caller's. For every ISA this
// machine runs and both precisions, with the caller's MXCSR at the C
// default (FTZ/DAZ off) and with FTZ and DAZ on (plus a sticky exception
// flag the caller had raised):
//   - ek_svd3_* at the default options and at sweeps 2..8 (double: 3..8,
//     from its default) x rsqrt exact and approximate meets EK_SVD3_TOL_F32
//     / _F64 against LAPACK (relative to s1) on Gaussian matrices, Gaussian x 1e-30 and x 1e-36
//     (f64: x 1e-300 and x 1e-306), near-diagonal matrices (off-diagonal 1e-3..1e-30 of the
//     diagonal: their Jacobi sweeps reach subnormals first), the rank-1 and graded families of the
//     extremes catalogue (whose QR and refinement need gradual underflow) and subnormal inputs
//     (Gaussian x 1e-40 / 1e-310: svd3.h says they are decomposed like any other scale, whatever
//     the caller's DAZ);
//   - every output has the same bits in both caller modes;
//   - the caller's MXCSR (mode and flags) is the same after each call;
//   - the same two properties hold for ek_svd3_aosoa_*, ek_polar3_*,
//     ek_polar3_warm_* (the staged AoS driver) and the material kernels
//     (ek_pk1_*, ek_pk1_hessian_*, fixed corotated and stable neo-Hookean)
//     on the Gaussian x 1e-30 (1e-300), rank-1, graded and subnormal sets.
// The SVD's non-default options are judged against the budget here (in
// test_svd3 they are a printed trade-off): with two exact refinement sweeps
// after them, every sweep count from the default up meets it. One sweep
// (and two in double) is below the budget by design; those run for the
// bits and mode checks only.
// Where the target has no mode to set (not x86), the mode checks are
// skipped with a note and the budgets are still checked.
//
// Usage: test_fpmode [--seed N]
#include <ek/ek.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels/simd/fpmode.h" // the caller's side: ek_fpmode_get/set
#include "check.h"
#include "cli.h"

enum { N_SET = 1001 }; // not a multiple of any block

static int failures;

// ---- Caller modes ----
// The C default, and FTZ + DAZ; each with the precision-exception flag
// (PE, MXCSR bit 5) raised, as a caller's earlier arithmetic leaves it,
// so that the check also sees the flags come back.
#define CALLER_FLAG 0x20u
static const char *const mode_name[2] = {"FTZ/DAZ off", "FTZ/DAZ on"};
static ek_fpmode caller_mode(int k) {
  ek_fpmode m = ek_fpmode_get() & ~(EK_FPMODE_FTZ_DAZ | 0x3Fu);
  return (k ? m | EK_FPMODE_FTZ_DAZ : m) | CALLER_FLAG;
}

// Runs fn(ctx) with the caller's MXCSR set to mode k; returns 1 if the
// MXCSR after the call differs from the one set (printed).
static int in_mode(int k, const char *what, int (*fn)(void *), void *ctx, int *rc) {
  ek_fpmode saved = ek_fpmode_get(), set = caller_mode(k);
  ek_fpmode_set(set);
  *rc = fn(ctx);
  ek_fpmode after = ek_fpmode_get();
  ek_fpmode_set(saved);
  if (EK_FPMODE_HAS_FLUSH && after != set) {
    printf("FAIL %s (%s): caller's MXCSR %#x became %#x\n", what, mode_name[k], set, after);
    return 1;
  }
  return 0;
}

// ---- Input sets ----
static double g_scale; // of the scaled family being generated

static void gen_scaled(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < 9 * n; i++)
    A[i] = g_scale * ek_rng_gauss(rng);
}

// Diagonal (Gaussian entries) plus off-diagonal entries 10^-u of the
// largest diagonal entry, u uniform in [3, 30], random signs.
static void gen_near_diagonal(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double *M = A + 9 * i, d = 0;
    for (int k = 0; k < 3; k++)
      d = fmax(d, fabs(M[4 * k] = ek_rng_gauss(rng)));
    for (int k = 0; k < 9; k++)
      if (k % 4)
        M[k] = d * pow(10, -3 - 27 * ek_rng_uniform(rng)) * (ek_rng_uniform(rng) < 0.5 ? -1 : 1);
  }
}

static const ek_check_family *catalogue(const char *name) {
  for (int f = 0; f < ek_check_nfamilies; f++)
    if (!strcmp(ek_check_families[f].name, name))
      return &ek_check_families[f];
  fprintf(stderr, "test_fpmode: no family %s in the catalogue\n", name);
  exit(2);
}

// ---- One SVD call in one caller mode ----
// The kernel's arrays in its precision: A converted before, the outputs
// after the call, both in the default mode (a conversion under the caller's
// FTZ would flush the tiny inputs before ek sees them).
typedef struct {
  int bits;
  size_t n;
  void *A, *U, *S, *V;
  ek_svd3_opts o;
} svd_call;

static int run_svd(void *p) {
  svd_call *c = p;
  if (c->bits == 64)
    return ek_svd3_f64(c->n, c->A, c->U, c->S, c->V, &c->o);
  return ek_svd3_f32(c->n, c->A, c->U, c->S, c->V, &c->o);
}

static void to_double(int bits, size_t count, const void *in, double *out) {
  if (bits == 64)
    memcpy(out, in, count * sizeof *out);
  else
    ek_check_from_f32(count, in, out);
}

static int same(const double *a, const double *b, size_t n) {
  return memcmp(a, b, n * sizeof *a) == 0;
}

// Worst error of the SVD outputs over the set (finite inputs).
static double svd_error(const ek_svd3_set *s, const double *U, const double *S, const double *V,
                        double budget) {
  double worst = 0;
  for (size_t i = 0; i < s->n; i++) {
    if (s->bad[i])
      continue;
    ek_svd3_metrics m;
    ek_check_svd3(s->A + 9 * i, U + 9 * i, S + 3 * i, V + 9 * i, s->S_ref + 3 * i, budget, &m);
    double w = ek_svd3_metrics_worst(&m);
    if (!(w <= worst))
      worst = isnan(w) ? INFINITY : w;
  }
  return worst;
}

// One set, one ISA, one rsqrt mode: the default options and sweeps 2..8,
// each in both caller modes. Prints one line.
static void svd_set(int bits, ek_isa isa, const ek_svd3_set *s, int exact) {
  double budget = bits == 32 ? EK_SVD3_TOL_F32 : EK_SVD3_TOL_F64;
  size_t n = s->n;
  size_t rs = bits == 32 ? sizeof(float) : sizeof(double);
  void *A = ek_check_malloc(9 * n * rs), *u = ek_check_malloc(9 * n * rs);
  void *sv = ek_check_malloc(3 * n * rs), *v = ek_check_malloc(9 * n * rs);
  if (bits == 32)
    ek_check_to_f32(9 * n, s->A, A);
  else
    memcpy(A, s->A, 9 * n * sizeof(double));
  double *U[2], *S[2], *V[2];
  for (int k = 0; k < 2; k++) {
    U[k] = ek_check_malloc(9 * n * sizeof(double));
    S[k] = ek_check_malloc(3 * n * sizeof(double));
    V[k] = ek_check_malloc(9 * n * sizeof(double));
  }
  // Judged: the default options and every sweep count from the
  // precision's default up (2 for float, 3 for double); fewer sweeps are
  // the speed end of the trade-off, whose errors test_svd3 prints: here
  // they are checked for their bits and the caller's mode only.
  int first = bits == 32 ? ek_svd3_default_sweeps_f32() : ek_svd3_default_sweeps_f64();
  double worst = 0;
  int worst_sweeps = 0, differ = 0, bad = 0;
  for (int sweeps = 0; sweeps <= EK_SVD3_MAX_SWEEPS; sweeps++) {
    for (int k = 0; k < 2; k++) {
      svd_call c = {.bits = bits,
                    .n = n,
                    .A = A,
                    .U = u,
                    .S = sv,
                    .V = v,
                    .o = {.sweeps = sweeps, .exact_rsqrt = exact ? 1 : -1, .isa = isa}};
      if (sweeps == 0)
        c.o.exact_rsqrt = 0; // the defaults, once per rsqrt line
      int rc;
      bad += in_mode(k, "ek_svd3", run_svd, &c, &rc);
      if (rc != 0) {
        printf("FAIL ek_svd3 f%d %s sweeps %d: rc %d (%s)\n", bits, ek_isa_name(isa), sweeps, rc,
               ek_last_error());
        bad++;
        continue;
      }
      to_double(bits, 9 * n, u, U[k]), to_double(bits, 3 * n, sv, S[k]);
      to_double(bits, 9 * n, v, V[k]);
      double e = svd_error(s, U[k], S[k], V[k], budget);
      if ((sweeps == 0 || sweeps >= first) && !(e <= worst))
        worst = e, worst_sweeps = sweeps;
    }
    if (!(same(U[0], U[1], 9 * n) && same(S[0], S[1], 3 * n) && same(V[0], V[1], 9 * n))) {
      if (!differ)
        printf("FAIL ek_svd3 f%d %s %s sweeps %d: outputs differ between the caller's modes\n",
               bits, ek_isa_name(isa), s->name, sweeps);
      differ++;
    }
  }
  char label[160];
  snprintf(label, sizeof label, "svd f%d %s rsqrt=%s %.40s (sweeps %d..8, worst at %d%s)", bits,
           ek_isa_name(isa), exact ? "exact" : "approx", s->name, first, worst_sweeps,
           worst_sweeps ? "" : " = default");
  failures += ek_check_report(label, worst, budget);
  if (differ || bad)
    failures++;
  for (int k = 0; k < 2; k++)
    free(U[k]), free(S[k]), free(V[k]);
  free(A), free(u), free(sv), free(v);
}

// ---- Other entry points: same bits in both modes, MXCSR kept ----
typedef struct {
  int which, bits;
  ek_isa isa;
  size_t n;
  const double *A;
  const float *a32;
  void *out;
} other_call;

enum {
  OTHER_SVD_AOSOA,
  OTHER_POLAR,
  OTHER_WARM,
  OTHER_PK1_FC,
  OTHER_PK1_SNH,
  OTHER_HESS_SNH,
  OTHER_N
};
static const char *const other_name[OTHER_N] = {
    "ek_svd3_aosoa",        "ek_polar3",
    "ek_polar3_warm",       "ek_pk1 fixed_corot.",
    "ek_pk1 stable_neo_h.", "ek_pk1_hessian stable_neo_h."};

static int run_other(void *p) {
  other_call *c = p;
  size_t n = c->n;
  const ek_material fc = {.model = EK_MODEL_FIXED_COROTATED, .mu = 1, .lambda = 10};
  const ek_material snh = {.model = EK_MODEL_STABLE_NEO_HOOKEAN, .mu = 1, .lambda = 10};
  if (c->bits == 64) {
    double *o = c->out;
    ek_svd3_opts so = {.isa = c->isa};
    ek_polar_warm_opts wo = {.isa = c->isa};
    switch (c->which) {
    case OTHER_SVD_AOSOA: { // A packed: U, S, V follow in out
      size_t nb = ek_aosoa_blocks_f64(n), sz = ek_aosoa_size_f64(n, 9);
      double *a = ek_aosoa_alloc_f64(n, 9);
      ek_aosoa_pack_f64(n, 9, c->A, a);
      int rc = ek_svd3_aosoa_f64(nb, a, o, o + sz, o + sz + ek_aosoa_size_f64(n, 3), &so);
      ek_free(a);
      return rc;
    }
    case OTHER_POLAR:
      return ek_polar3_f64(n, c->A, o, o + 9 * n, &so);
    case OTHER_WARM: // guess: the identity
      for (size_t i = 0; i < 9 * n; i++)
        o[i] = i % 9 % 4 == 0;
      return ek_polar3_warm_f64(n, c->A, o, &wo);
    case OTHER_PK1_FC:
      return ek_material_eval_f64(&fc, EK_MAT_PK1, c->isa, n, c->A, NULL, NULL, o, 0);
    case OTHER_PK1_SNH:
      return ek_material_eval_f64(&snh, EK_MAT_PK1, c->isa, n, c->A, NULL, NULL, o, 0);
    default:
      return ek_material_eval_f64(&snh, EK_MAT_HESSIAN, c->isa, n, c->A, NULL, NULL, o, 1);
    }
  }
  float *o = c->out;
  ek_svd3_opts so = {.isa = c->isa};
  ek_polar_warm_opts wo = {.isa = c->isa};
  switch (c->which) {
  case OTHER_SVD_AOSOA: {
    size_t nb = ek_aosoa_blocks_f32(n), sz = ek_aosoa_size_f32(n, 9);
    float *a = ek_aosoa_alloc_f32(n, 9);
    ek_aosoa_pack_f32(n, 9, c->a32, a);
    int rc = ek_svd3_aosoa_f32(nb, a, o, o + sz, o + sz + ek_aosoa_size_f32(n, 3), &so);
    ek_free(a);
    return rc;
  }
  case OTHER_POLAR:
    return ek_polar3_f32(n, c->a32, o, o + 9 * n, &so);
  case OTHER_WARM:
    for (size_t i = 0; i < 9 * n; i++)
      o[i] = i % 9 % 4 == 0;
    return ek_polar3_warm_f32(n, c->a32, o, &wo);
  case OTHER_PK1_FC:
    return ek_material_eval_f32(&fc, EK_MAT_PK1, c->isa, n, c->a32, NULL, NULL, o, 0);
  case OTHER_PK1_SNH:
    return ek_material_eval_f32(&snh, EK_MAT_PK1, c->isa, n, c->a32, NULL, NULL, o, 0);
  default:
    return ek_material_eval_f32(&snh, EK_MAT_HESSIAN, c->isa, n, c->a32, NULL, NULL, o, 1);
  }
}

static void other_entry_points(int bits, ek_isa isa, const ek_svd3_set *s) {
  size_t n = s->n, rs = bits == 32 ? sizeof(float) : sizeof(double);
  // Room for the AoSoA outputs (padded to whole blocks) too.
  size_t count = 21 * (n + 64) + 81 * n;
  float *a32 = ek_check_malloc(9 * n * sizeof(float) + 1);
  ek_check_to_f32(9 * n, s->A, a32);
  void *out[2] = {ek_alloc(count * rs), ek_alloc(count * rs)};
  int bad = 0;
  for (int w = 0; w < OTHER_N; w++) {
    int rcs[2];
    for (int k = 0; k < 2; k++) {
      memset(out[k], 0x5a, count * rs);
      other_call c = {
          .which = w, .bits = bits, .isa = isa, .n = n, .A = s->A, .a32 = a32, .out = out[k]};
      bad += in_mode(k, other_name[w], run_other, &c, &rcs[k]);
    }
    if (rcs[0] < 0 || rcs[0] != rcs[1] || memcmp(out[0], out[1], count * rs) != 0) {
      printf("FAIL %s f%d %s %s: rc %d / %d, outputs differ between the caller's modes\n",
             other_name[w], bits, ek_isa_name(isa), s->name, rcs[0], rcs[1]);
      bad++;
    }
  }
  printf("other entry points f%d %s %s: same bits in both caller modes, MXCSR kept: %s\n", bits,
         ek_isa_name(isa), s->name, bad ? "FAIL" : "PASS");
  failures += bad != 0;
  free(a32), ek_free(out[0]), ek_free(out[1]);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_fpmode: seed %llu; caller modes: %s (MXCSR %#x), %s (%#x)\n",
         (unsigned long long)seed, mode_name[0], caller_mode(0), mode_name[1], caller_mode(1));
  if (!EK_FPMODE_HAS_FLUSH)
    printf("note: this target has no floating-point mode to set; mode checks skipped\n");
  const ek_check_family scaled = {"scaled", gen_scaled, EK_FAMILY_BOTH, "gaussian x scale"};
  const ek_check_family near_diag = {"near_diagonal", gen_near_diagonal, EK_FAMILY_BOTH,
                                     "diagonal + 1e-3..1e-30 off-diagonal"};
  for (int bits = 32; bits <= 64; bits += 32) {
    const double scales[3] = {1, bits == 32 ? 1e-30 : 1e-300, bits == 32 ? 1e-36 : 1e-306};
    ek_svd3_set sets[8];
    int nsets = 0;
    for (int k = 0; k < 3; k++) {
      char name[32];
      snprintf(name, sizeof name, "gaussian x %g", scales[k]);
      g_scale = scales[k];
      ek_svd3_set_init(&sets[nsets++], &scaled, name, seed + (uint64_t)k, N_SET, bits);
    }
    ek_svd3_set_init(&sets[nsets++], &near_diag, near_diag.name, seed, N_SET, bits);
    const char *fams[3] = {"rank1", "graded", bits == 32 ? "subnormal_f32" : "subnormal_f64"};
    for (int k = 0; k < 3; k++)
      ek_svd3_set_init(&sets[nsets++], catalogue(fams[k]), fams[k], seed, N_SET, bits);
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      printf("\n== %s f%d\n", ek_isa_name((ek_isa)isa), bits);
      for (int k = 0; k < nsets; k++)
        for (int exact = 1; exact >= 0; exact--)
          svd_set(bits, (ek_isa)isa, &sets[k], exact);
      for (int k = 0; k < nsets; k++)
        if (k == 1 || k >= 4)
          other_entry_points(bits, (ek_isa)isa, &sets[k]);
    }
    for (int k = 0; k < nsets; k++)
      ek_svd3_set_free(&sets[k]);
  }
  printf("\ntest_fpmode: %s (%d failing checks)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
