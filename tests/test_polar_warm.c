// Invariant: for every ISA this machine runs and both precisions, the
// warm-started polar ek_polar3_warm_* with its default iterations returns R
// within EK_POLAR_WARM_TOL_F32 / _F64 (max_ij |R - R_svd|) of the SVD polar
// (LAPACK, ek_polar3_ref) on A = R* S (s_i in [0.5, 2]) from a guess within
// 10 degrees of R*, and on the F of the cantilever and twist scenes over a
// running simulation (R chained from step to step as a loop keeps it); for
// 1..3 iterations it follows the plain double replica of its iteration
// (ek_polar_warm_ref) to the budget; R is a rotation (|R^T R - I|, |det R -
// 1| within the budget) for every input: guesses up to 180 degrees off,
// inverted, rank-deficient and zero A, A at 1e+-30; a NaN matrix gives NaN
// in its own R only; AoS and AoSoA entry points agree bit for bit (tails
// included; on the extremes too, where a NaN may differ in sign), as do 1,
// 2 and 3 threads (AoS and AoSoA); bad options and arguments give
// EK_EINVAL and write nothing; the scene key parses; the cantilever and
// twist with "polar": "warm" (fixed corotated, and corotated linear's R^n)
// stay within the EK_POLAR_WARM_LOOP_* bounds of "polar": "svd", and give
// the same bits at 1 and 2 threads; after ek_sim_set_state to a body turned
// rigidly by 150 degrees, both stay put and agree (kept rotations restart).
//
// Usage: test_polar_warm [--seed N] [--scenes DIR]
#include <ek/ek.h>
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "check_polar_warm.h"
#include "polar/polar_warm_ref.h"
#include "svd3/svd3_ref.h"
#include "test_sim_common.h"
#include "test_tolerances.h"

enum { N_RANDOM = 4000, N_TAIL = 1001, N_THREADS_TEST = 40000 };

static double budget_of(int bits) {
  return bits == 32 ? EK_POLAR_WARM_TOL_F32 : EK_POLAR_WARM_TOL_F64;
}

// Largest |R^T R - I| and |det R - 1| over n rotations (inf for a NaN).
static double rotation_error(size_t n, const double *R, const char *skip) {
  double worst = 0;
  for (size_t e = 0; e < n; e++) {
    if (skip && skip[e])
      continue;
    const double *r = R + e * 9;
    double RtR[9];
    double Rt[9] = {r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]};
    ek_mul3(Rt, r, RtR);
    double d = fabs(ek_det3(r) - 1);
    for (int i = 0; i < 9; i++)
      d = fmax(d, fabs(RtR[i] - (i % 4 == 0)));
    if (!(d == d))
      return INFINITY;
    worst = fmax(worst, d);
  }
  return worst;
}

// Largest |R - R_svd| over n matrices, with the LAPACK polar of A (rounded
// to the precision, as the kernel saw it), and where it is.
static double svd_error(int bits, size_t n, const double *A, const double *R, size_t *worst_at) {
  double worst = 0;
  for (size_t e = 0; e < n; e++) {
    double d = ek_check_polar_error(bits, A + e * 9, R + e * 9);
    if (!(d <= worst)) {
      worst = isnan(d) ? INFINITY : d;
      *worst_at = e;
    }
  }
  return worst;
}

static void judge(const char *label, double err, double budget) {
  if (ek_check_report(label, err, budget))
    failures++;
}

static void print_case(const double *A, const double *G, const double *R) {
  ek_print3("A", A);
  ek_print3("guess", G);
  ek_print3("R", R);
  double Rr[9];
  ek_polar3_ref(A, Rr, NULL);
  ek_print3("R_svd", Rr);
}

// ---- Accuracy against the SVD polar, and the replica ----
static void accuracy(int bits, ek_isa isa, uint64_t seed) {
  const struct {
    const char *name;
    double s_min, s_max, deg_min, deg_max;
  } sets[] = {{"random (s in [0.5, 2], guess <= 10 deg)", 0.5, 2, 0, 10},
              {"near (s in [0.9, 1.1], guess <= 1 deg)", 0.9, 1.1, 0, 1}};
  size_t n = N_RANDOM;
  double *A = ek_check_malloc(n * 9 * sizeof(double)), *G = ek_check_malloc(n * 9 * sizeof(double));
  double *R = ek_check_malloc(n * 9 * sizeof(double));
  for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++) {
    ek_rng rng;
    ek_rng_seed(&rng, ek_check_stream_seed(seed, sets[k].name));
    ek_check_warm_cases(&rng, n, sets[k].s_min, sets[k].s_max, sets[k].deg_min, sets[k].deg_max, A,
                        G);
    memcpy(R, G, n * 9 * sizeof(double));
    char label[200];
    int rc = ek_check_run_polar_warm(bits, 1, n, A, R, isa, 0);
    snprintf(label, sizeof label, "warm %s f%d default vs SVD polar, %s", ek_isa_name(isa), bits,
             sets[k].name);
    if (rc != 0) {
      printf("FAIL %s: rc %d (%s)\n", label, rc, ek_last_error());
      failures++;
      continue;
    }
    size_t at = 0;
    double err = svd_error(bits, n, A, R, &at);
    judge(label, err, budget_of(bits));
    if (!(err <= budget_of(bits)))
      print_case(A + at * 9, G + at * 9, R + at * 9);
    snprintf(label, sizeof label, "warm %s f%d default: R a rotation, %s", ek_isa_name(isa), bits,
             sets[k].name);
    judge(label, rotation_error(n, R, NULL), budget_of(bits));
    // The iteration itself: 1..3 steps against the double replica.
    for (int it = 1; it <= 3; it++) {
      memcpy(R, G, n * 9 * sizeof(double));
      ek_check_run_polar_warm(bits, 1, n, A, R, isa, it);
      double worst = 0;
      for (size_t e = 0; e < n; e++) {
        double a[9], r[9];
        for (int i = 0; i < 9; i++) {
          a[i] = bits == 32 ? (double)(float)A[e * 9 + i] : A[e * 9 + i];
          r[i] = bits == 32 ? (double)(float)G[e * 9 + i] : G[e * 9 + i];
        }
        ek_polar_warm_ref(a, r, it);
        worst = fmax(worst, ek_check_rdiff9(R + e * 9, r));
      }
      snprintf(label, sizeof label, "warm %s f%d %d iteration(s) vs double replica, %s",
               ek_isa_name(isa), bits, it, sets[k].name);
      judge(label, worst, bits == 32 ? EK_POLAR_WARM_TOL_F32 : EK_POLAR_WARM_REPLICA_TOL);
    }
  }
  free(A), free(G), free(R);
}

// ---- Extremes: always a rotation; errors printed where they are not judged ----
// a and b hold the same bits, or both a NaN (of any sign or payload).
static int same_bits_or_nan(size_t n, const double *a, const double *b) {
  for (size_t i = 0; i < n; i++)
    if (memcmp(a + i, b + i, sizeof *a) != 0 && !(isnan(a[i]) && isnan(b[i])))
      return 0;
  return 1;
}

static void extremes(int bits, ek_isa isa, uint64_t seed) {
  size_t n = 512;
  double *A = ek_check_malloc(n * 9 * sizeof(double)), *G = ek_check_malloc(n * 9 * sizeof(double));
  double *R = ek_check_malloc(n * 9 * sizeof(double));
  char label[200];
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "extremes"));
  const struct {
    const char *name;
    double s_min, s_max, deg_min, deg_max;
  } sets[] = {{"guess 30..90 deg off", 0.5, 2, 30, 90},
              {"guess 90..150 deg off", 0.5, 2, 90, 150},
              {"guess 150..180 deg off", 0.5, 2, 150, 180},
              {"inverted (det < 0), guess <= 10 deg", -0.5, 2, 0, 10},
              {"inverted near-flat (s in [0.9,1.1], s3 < 0)", -0.9, 1.1, 0, 10},
              {"inverted, largest negated (SVD polar 180 deg off)", 0.5, -2, 0, 10}};
  for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++) {
    ek_check_warm_cases(&rng, n, sets[k].s_min, sets[k].s_max, sets[k].deg_min, sets[k].deg_max, A,
                        G);
    int its[] = {0, 4, 8, 16};
    for (int j = 0; j < 4; j++) {
      memcpy(R, G, n * 9 * sizeof(double));
      ek_check_run_polar_warm(bits, 1, n, A, R, isa, its[j]);
      snprintf(label, sizeof label, "warm %s f%d %s, %d it: R a rotation", ek_isa_name(isa), bits,
               sets[k].name, its[j]);
      judge(label, rotation_error(n, R, NULL), budget_of(bits));
      size_t at;
      double err = svd_error(bits, n, A, R, &at);
      size_t off = 0;
      for (size_t e = 0; e < n; e++)
        off += !(ek_check_polar_error(bits, A + e * 9, R + e * 9) <= budget_of(bits));
      printf("  info: %s: max |R - R_svd| %.3e, %zu of %zu beyond the budget\n", label, err, off,
             n);
    }
  }
  // Rank-deficient and zero A, scaled A, NaN lanes.
  for (size_t e = 0; e < n; e++) {
    double s[3] = {1, 0.5, 0};
    int kind = (int)(e % 4);
    if (kind == 1)
      s[1] = 0; // rank 1
    if (kind == 2)
      s[0] = s[1] = 0; // zero
    if (kind == 3)
      s[2] = 1e-7; // nearly flat
    ek_rng_with_sigma(&rng, s, A + e * 9);
    ek_rng_rotation(&rng, G + e * 9);
  }
  memcpy(R, G, n * 9 * sizeof(double));
  ek_check_run_polar_warm(bits, 1, n, A, R, isa, 0);
  snprintf(label, sizeof label, "warm %s f%d rank 0..2 A: R a rotation", ek_isa_name(isa), bits);
  judge(label, rotation_error(n, R, NULL), budget_of(bits));
  double zero_moved = 0;
  for (size_t e = 2; e < n; e += 4) {
    double g[9];
    for (int i = 0; i < 9; i++)
      g[i] = bits == 32 ? (double)(float)G[e * 9 + i] : G[e * 9 + i];
    zero_moved = fmax(zero_moved, ek_check_rdiff9(R + e * 9, g));
  }
  snprintf(label, sizeof label, "warm %s f%d A = 0 keeps the guess", ek_isa_name(isa), bits);
  judge(label, zero_moved, budget_of(bits));

  // Scale: A * 1e+-30 (f32: 1e+-30 is in range; f64 also 1e+-300) gives
  // the same R as A within the budget.
  ek_check_warm_cases(&rng, n, 0.5, 2, 0, 10, A, G);
  double *R1 = ek_check_malloc(n * 9 * sizeof(double)),
         *As = ek_check_malloc(n * 9 * sizeof(double));
  memcpy(R1, G, n * 9 * sizeof(double));
  ek_check_run_polar_warm(bits, 1, n, A, R1, isa, 0);
  double scales[] = {1e30, 1e-30, bits == 64 ? 1e300 : 1e35, bits == 64 ? 1e-300 : 1e-35};
  // The AoS entry point on the same extreme batches (Raos): the AoSoA
  // kernel's bits (a NaN compared as a NaN: the two may give it other
  // signs, docs/perf.md, "Memory-bound paths", eighth round).
  double *Raos = ek_check_malloc(n * 9 * sizeof(double));
  int aos_same = 1;
  for (int k = 0; k < 4; k++) {
    for (size_t i = 0; i < n * 9; i++)
      As[i] = A[i] * scales[k];
    memcpy(R, G, n * 9 * sizeof(double));
    ek_check_run_polar_warm(bits, 1, n, As, R, isa, 0);
    memcpy(Raos, G, n * 9 * sizeof(double));
    ek_check_run_polar_warm(bits, 0, n, As, Raos, isa, 0);
    aos_same &= same_bits_or_nan(n * 9, R, Raos);
    double d = 0;
    for (size_t e = 0; e < n; e++)
      d = fmax(d, ek_check_rdiff9(R + e * 9, R1 + e * 9));
    snprintf(label, sizeof label, "warm %s f%d A x %g: same R as A", ek_isa_name(isa), bits,
             scales[k]);
    judge(label, isnan(d) ? INFINITY : d, budget_of(bits));
  }
  // NaN / inf in A or in the guess: that matrix's R all NaN, the others
  // untouched (equal to the clean run's bits).
  memcpy(As, A, n * 9 * sizeof(double));
  memcpy(R, G, n * 9 * sizeof(double));
  As[5 * 9 + 3] = NAN, As[17 * 9] = INFINITY, R[40 * 9 + 8] = NAN;
  R[23 * 9 + 4] = INFINITY, R[29 * 9 + 1] = -INFINITY; // the guess's infinities
  memcpy(Raos, R, n * 9 * sizeof(double));
  ek_check_run_polar_warm(bits, 1, n, As, R, isa, 0);
  ek_check_run_polar_warm(bits, 0, n, As, Raos, isa, 0);
  aos_same &= same_bits_or_nan(n * 9, R, Raos);
  int ok = 1;
  for (size_t e = 0; e < n; e++) {
    int bad = e == 5 || e == 17 || e == 23 || e == 29 || e == 40;
    for (int i = 0; i < 9; i++)
      ok &= bad ? isnan(R[e * 9 + i]) : R[e * 9 + i] == R1[e * 9 + i];
  }
  snprintf(label, sizeof label, "warm %s f%d NaN / inf matrices: NaN in their own R only",
           ek_isa_name(isa), bits);
  check(label, ok, "");
  snprintf(label, sizeof label,
           "warm %s f%d extremes (A x 1e+-30 and beyond, NaN / inf): AoS = AoSoA bits",
           ek_isa_name(isa), bits);
  check(label, aos_same, "NaNs compared as NaNs");
  free(R1), free(As), free(A), free(G), free(R), free(Raos);
}

// ---- AoS = AoSoA bits (tails), 1 = 2 = 3 threads bits (AoS and AoSoA) ----
static void layouts_and_threads(int bits, uint64_t seed) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "threads"));
  size_t n = N_THREADS_TEST;
  double *A = ek_check_malloc(n * 9 * sizeof(double)), *G = ek_check_malloc(n * 9 * sizeof(double));
  double *R1 = ek_check_malloc(n * 9 * sizeof(double)),
         *R2 = ek_check_malloc(n * 9 * sizeof(double));
  ek_check_warm_cases(&rng, n, 0.5, 2, 0, 30, A, G);
  char label[200];
  memcpy(R1, G, N_TAIL * 9 * sizeof(double));
  memcpy(R2, G, N_TAIL * 9 * sizeof(double));
  ek_check_run_polar_warm(bits, 0, N_TAIL, A, R1, EK_ISA_AUTO, 0);
  ek_check_run_polar_warm(bits, 1, N_TAIL, A, R2, EK_ISA_AUTO, 0);
  snprintf(label, sizeof label, "warm f%d AoS = AoSoA bits, n = %d", bits, N_TAIL);
  check(label, memcmp(R1, R2, N_TAIL * 9 * sizeof(double)) == 0, "");
  int threads = omp_get_max_threads();
  for (int aosoa = 0; aosoa < 2; aosoa++) {
    // R is in and out (the guesses, then the rotations: polar.h), so not
    // poisoned: the same guesses G before every call, which a chunk that
    // did not run would leave (G is 0 to 30 degrees off the result).
    omp_set_num_threads(1);
    memcpy(R1, G, n * 9 * sizeof(double));
    ek_check_run_polar_warm(bits, aosoa, n, A, R1, EK_ISA_AUTO, 0);
    // Chunks go to whichever thread claims them first (kernels/team.h): a
    // few calls per count, so that the helpers take some in most.
    int same = 1;
    for (int t = 2; t <= 3; t++)
      for (int rep = 0; rep < 3; rep++) {
        omp_set_num_threads(t);
        memcpy(R2, G, n * 9 * sizeof(double));
        ek_check_run_polar_warm(bits, aosoa, n, A, R2, EK_ISA_AUTO, 0);
        same &= memcmp(R1, R2, n * 9 * sizeof(double)) == 0;
      }
    omp_set_num_threads(threads);
    snprintf(label, sizeof label, "warm f%d %s 1 thread = 2 and 3 threads bits, n = %d", bits,
             aosoa ? "AoSoA" : "AoS", N_THREADS_TEST);
    check(label, same, "");
  }
  free(A), free(G), free(R1), free(R2);
}

// ---- AoS at every start within a 64-byte line: the same bits ----
// The AoS driver takes the records before the first whole line on their
// own (ek_aos_head, kernels.h), so the rest's vectors span whole lines;
// where the array starts must not change any record's result. Reference:
// the AoSoA path on the same records.
static void aos_starts(int bits, ek_isa isa, uint64_t seed) {
  enum { STARTS = EK_LANES_F32 + 2 };
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "aos_starts"));
  const size_t n = N_TAIL, es = bits == 32 ? sizeof(float) : sizeof(double);
  double *A = ek_check_malloc(n * 9 * sizeof(double)), *G = ek_check_malloc(n * 9 * sizeof(double));
  double *Rref = ek_check_malloc(n * 9 * sizeof(double)),
         *R = ek_check_malloc(n * 9 * sizeof(double));
  ek_check_warm_cases(&rng, n, 0.5, 2, 0, 30, A, G);
  memcpy(Rref, G, n * 9 * sizeof(double));
  ek_check_run_polar_warm(bits, 1, n, A, Rref, isa, 0);
  unsigned char *a = ek_alloc((n + STARTS) * 9 * es), *r = ek_alloc((n + STARTS) * 9 * es);
  int bad = -1;
  for (int k = 0; k < STARTS && bad < 0; k++) {
    // Start k records into the line: k 36 (f32) or 72 (f64) bytes.
    void *ak = a + (size_t)k * 9 * es, *rk = r + (size_t)k * 9 * es;
    ek_polar_warm_opts o = {.isa = isa};
    int rc;
    if (bits == 32) {
      ek_check_to_f32(n * 9, A, ak), ek_check_to_f32(n * 9, G, rk);
      rc = ek_polar3_warm_f32(n, ak, rk, &o);
      ek_check_from_f32(n * 9, rk, R);
    } else {
      memcpy(ak, A, n * 9 * es), memcpy(rk, G, n * 9 * es);
      rc = ek_polar3_warm_f64(n, ak, rk, &o);
      memcpy(R, rk, n * 9 * es);
    }
    if (rc != 0 || memcmp(R, Rref, n * 9 * sizeof(double)) != 0)
      bad = k;
  }
  char label[200];
  snprintf(label, sizeof label, "%s f%d AoS = AoSoA bits at %d starts (n = %d)", ek_isa_name(isa),
           bits, STARTS, N_TAIL);
  char detail[80] = "";
  if (bad >= 0)
    snprintf(detail, sizeof detail, "differs when the array starts %d records into a line", bad);
  check(label, bad < 0, detail);
  ek_free(a), ek_free(r);
  free(A), free(G), free(Rref), free(R);
}

// ---- Bad options and arguments: EK_EINVAL, nothing written ----
static void bad_input(void) {
  _Alignas(64) float A[9 * 16], R[9 * 16], R0[9 * 16];
  for (int i = 0; i < 9 * 16; i++)
    A[i] = (float)(i % 7), R[i] = R0[i] = (float)(i % 4 == 0);
  const struct {
    const char *what;
    int iterations;
  } opts[] = {{"iterations = -1", -1}, {"iterations = 17", EK_POLAR_WARM_MAX_ITERATIONS + 1}};
  for (int k = 0; k < 2; k++) {
    ek_polar_warm_opts o = {.iterations = opts[k].iterations};
    int rc1 = ek_polar3_warm_f32(16, A, R, &o), rc2 = ek_polar3_warm_aosoa_f32(1, A, R, &o);
    char label[160];
    snprintf(label, sizeof label, "bad option %s -> EK_EINVAL, R untouched", opts[k].what);
    check(label, rc1 == EK_EINVAL && rc2 == EK_EINVAL && !memcmp(R, R0, sizeof R), ek_last_error());
  }
  check("NULL A -> EK_EINVAL", ek_polar3_warm_f32(16, NULL, R, NULL) == EK_EINVAL, ek_last_error());
  check("NULL R -> EK_EINVAL", ek_polar3_warm_aosoa_f32(1, A, NULL, NULL) == EK_EINVAL,
        ek_last_error());
  double Ad[10], Rd[10];
  check("misaligned double R -> EK_EINVAL",
        ek_polar3_warm_f64(1, Ad, (double *)((char *)Rd + 4), NULL) == EK_EINVAL, ek_last_error());
  check("n = SIZE_MAX -> EK_EINVAL", ek_polar3_warm_f32(SIZE_MAX, A, R, NULL) == EK_EINVAL,
        ek_last_error());
  check("n = 0 -> EK_OK", ek_polar3_warm_f32(0, NULL, NULL, NULL) == EK_OK, "");
}

// ---- Over a running simulation ----
static void simulation(int bits, ek_isa isa) {
  const char *scenes[] = {"cantilever", "twist"};
  // Steps and stride: every 5th step of the first 400 (cantilever: the
  // beam's first fall; twist: 0.08 s of the twist), so the guess is 5
  // steps old.
  for (int k = 0; k < 2; k++) {
    char path[1200], err[1024], label[200];
    snprintf(path, sizeof path, "%s/%s.json", scenes_dir, scenes[k]);
    ek_check_warm_run w;
    if (ek_check_polar_warm_sim(path, 400, 5, bits, isa, 0, &w, err, sizeof err) != 0) {
      printf("FAIL %s: %s\n", path, err);
      failures++;
      continue;
    }
    snprintf(label, sizeof label, "warm %s f%d over %s (%zu tets x %zu samples), max",
             ek_isa_name(isa), bits, scenes[k], w.tets, w.samples);
    judge(label, w.max, budget_of(bits));
    printf("  info: p99 %.3e, largest rotation between samples %.3g deg\n", w.p99, w.max_angle_deg);
  }
}

// A scene with "polar": "warm" against the same with "polar": "svd": the
// positions after N steps. f32: no further apart than
// EK_POLAR_WARM_LOOP_F32_FACTOR x the f32 and f64 SVD runs are (the f32
// force's own rounding); f64: EK_POLAR_WARM_LOOP_TOL_F64 x the body size.
static int loop_start_model(run *r, const char *scene, int prec, ek_polar_method polar,
                            ek_model model) {
  char path[1200];
  snprintf(path, sizeof path, "%s/%s.json", scenes_dir, scene);
  memset(r, 0, sizeof *r);
  if (ek_scene_load(path, &r->scene) != 0) {
    printf("FAIL %s\n", ek_last_error());
    failures++;
    return -1;
  }
  r->scene.output_file[0] = '\0';
  r->scene.precision = prec;
  r->scene.material.model = model;
  r->scene.polar = polar;
  r->mesh = ek_scene_mesh(&r->scene);
  r->sim = r->mesh ? ek_sim_create(&r->scene, r->mesh) : NULL;
  if (!r->sim) {
    printf("FAIL %s: %s\n", path, ek_last_error());
    failures++;
    ek_mesh_destroy(r->mesh);
    return -1;
  }
  return 0;
}

static int loop_start(run *r, const char *scene, int prec, ek_polar_method polar) {
  return loop_start_model(r, scene, prec, polar, EK_MODEL_FIXED_COROTATED);
}

static double max_diff(size_t n, const double *a, const double *b) {
  double d = 0;
  for (size_t i = 0; i < n; i++)
    d = fmax(d, fabs(a[i] - b[i]));
  return d == d ? d : INFINITY;
}

// The scene key: "warm" parses to EK_POLAR_WARM, absent means "svd".
static void scene_key(void) {
  const char *base = "{\"mesh\": {\"box\": [1, 1, 1], \"size\": [1, 1, 1]}, \"material\": "
                     "{\"model\": \"arap\", \"mu\": 1, \"lambda\": 0, \"density\": 1}, "
                     "\"dt\": 0.001, \"steps\": 1%s}";
  const struct {
    const char *key;
    ek_polar_method want;
  } cases[] = {{", \"polar\": \"warm\"", EK_POLAR_WARM},
               {", \"polar\": \"svd\"", EK_POLAR_SVD},
               {"", EK_POLAR_SVD}};
  for (int k = 0; k < 3; k++) {
    char text[512], label[160];
    snprintf(text, sizeof text, base, cases[k].key);
    ek_scene sc;
    int rc = ek_scene_parse(text, "polar.json", ".", &sc);
    snprintf(label, sizeof label, "scene key '%s' -> polar %d", cases[k].key, (int)cases[k].want);
    check(label, rc == 0 && sc.polar == cases[k].want, rc ? ek_last_error() : "");
  }
}

static void loop(void) {
  const char *scenes[] = {"cantilever", "twist"};
  const long steps = 300;
  for (int k = 0; k < 2; k++) {
    // f32 svd, f32 warm, f64 svd, f64 warm.
    run r[4];
    int started = 0, ok = 1;
    for (; started < 4; started++)
      if (loop_start(&r[started], scenes[k], started < 2 ? 32 : 64,
                     started % 2 ? EK_POLAR_WARM : EK_POLAR_SVD) != 0)
        break;
    for (long s = 0; started == 4 && s < steps && ok; s++)
      for (int w = 0; w < 4; w++)
        ok &= ek_sim_step(r[w].sim) == 0;
    if (started == 4) {
      size_t n3 = 3 * ek_mesh_nverts(r[0].mesh);
      const double *x[4];
      for (int w = 0; w < 4; w++)
        x[w] = ek_sim_positions(r[w].sim);
      double lo = INFINITY, hi = -INFINITY;
      for (size_t i = 0; i < n3; i += 3)
        lo = fmin(lo, x[2][i]), hi = fmax(hi, x[2][i]);
      char label[200], detail[200];
      if (!ok) {
        printf("FAIL loop %s: a step failed\n", scenes[k]);
        failures++;
      } else {
        double d32 = max_diff(n3, x[0], x[1]), rounding = max_diff(n3, x[0], x[2]);
        snprintf(label, sizeof label, "loop %s f32 fixed corotated warm vs svd, %ld steps",
                 scenes[k], steps);
        snprintf(detail, sizeof detail,
                 "max |x_warm - x_svd| (m); budget %g x max |x_svd,f32 - x_svd,f64| = %.3e",
                 (double)EK_POLAR_WARM_LOOP_F32_FACTOR, rounding);
        report(label, d32, EK_POLAR_WARM_LOOP_F32_FACTOR * rounding, detail);
        snprintf(label, sizeof label, "loop %s f64 fixed corotated warm vs svd, %ld steps",
                 scenes[k], steps);
        report(label, max_diff(n3, x[2], x[3]) / (hi - lo), EK_POLAR_WARM_LOOP_TOL_F64,
               "max |x_warm - x_svd| / length along x");
      }
    }
    for (int w = 0; w < started; w++) {
      ek_sim_destroy(r[w].sim);
      ek_mesh_destroy(r[w].mesh);
    }
  }
}

// Corotated linear's R^n refresh by the warm polar (double, from R^(n-1))
// against the SVD's: twist, f64, 300 steps, EK_POLAR_WARM_LOOP_TOL_F64 x
// the body's length.
static void loop_corot_linear(void) {
  run r[2];
  int started = 0, ok = 1;
  for (; started < 2; started++)
    if (loop_start_model(&r[started], "twist", 64, started ? EK_POLAR_WARM : EK_POLAR_SVD,
                         EK_MODEL_COROTATED_LINEAR) != 0)
      break;
  for (long s = 0; started == 2 && s < 300 && ok; s++)
    for (int w = 0; w < 2; w++)
      ok &= ek_sim_step(r[w].sim) == 0;
  if (started == 2) {
    size_t n3 = 3 * ek_mesh_nverts(r[0].mesh);
    const double *x0 = ek_sim_positions(r[0].sim), *x1 = ek_sim_positions(r[1].sim);
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n3; i += 3)
      lo = fmin(lo, x0[i]), hi = fmax(hi, x0[i]);
    if (!ok) {
      printf("FAIL loop twist corotated linear: a step failed\n");
      failures++;
    } else {
      report("loop twist f64 corotated linear R^n warm vs svd, 300 steps",
             max_diff(n3, x0, x1) / (hi - lo), EK_POLAR_WARM_LOOP_TOL_F64,
             "max |x_warm - x_svd| / length along x");
    }
  }
  for (int w = 0; w < started; w++) {
    ek_sim_destroy(r[w].sim);
    ek_mesh_destroy(r[w].mesh);
  }
}

// The warm path of the force at 1 and 2 threads: the same bits (cantilever,
// f32 and f64, 50 steps; its 6000 tets run on both threads).
static void loop_threads(void) {
  for (int prec = 32; prec <= 64; prec += 32) {
    run r[2];
    int started = 0, ok = 1, threads = omp_get_max_threads();
    for (; started < 2; started++) {
      omp_set_num_threads(started + 1);
      if (loop_start(&r[started], "cantilever", prec, EK_POLAR_WARM) != 0)
        break;
      for (long s = 0; s < 50 && ok; s++)
        ok &= ek_sim_step(r[started].sim) == 0;
    }
    omp_set_num_threads(threads);
    if (started == 2) {
      size_t n3 = 3 * ek_mesh_nverts(r[0].mesh);
      char label[160];
      snprintf(label, sizeof label, "loop cantilever f%d warm: 1 thread = 2 threads bits", prec);
      check(label,
            ok && !memcmp(ek_sim_positions(r[0].sim), ek_sim_positions(r[1].sim),
                          n3 * sizeof(double)),
            ok ? "" : "a step failed");
    }
    for (int w = 0; w < started; w++) {
      ek_sim_destroy(r[w].sim);
      ek_mesh_destroy(r[w].mesh);
    }
  }
}

// ek_sim_set_state restarts the kept rotations: a body turned rigidly by
// 150 degrees (about its centre, around (1, 1, 1)) feels no force, so one
// step later it has not moved, and the warm scenes (fixed corotated's force
// rotations, corotated linear's R^n) are where the SVD ones are. Kept rotations from the old
// state would be 150 degrees off, beyond what the default iterations
// recover (polar.h), and would push the body.
static void set_state_restarts(void) {
  const char *base =
      "{\"mesh\": {\"box\": [3, 3, 3], \"size\": [1, 1, 1]}, \"material\": "
      "{\"model\": \"%s\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000}, "
      "\"gravity\": [0, 0, 0], \"dt\": 0.0001, \"steps\": 1, \"precision\": \"f64\", "
      "\"polar\": \"%s\"}";
  const char *models[] = {"fixed_corotated", "corotated_linear"};
  for (int m = 0; m < 2; m++) {
    double *x[2] = {NULL, NULL}, moved = 0;
    size_t n3 = 0;
    int ok = 1;
    for (int warm = 0; warm < 2 && ok; warm++) {
      char text[600];
      snprintf(text, sizeof text, base, models[m], warm ? "warm" : "svd");
      ek_scene sc;
      ek_mesh *mesh = NULL;
      ek_sim *sim = NULL;
      ok = ek_scene_parse(text, "set_state.json", ".", &sc) == 0 &&
           (mesh = ek_scene_mesh(&sc)) != NULL && (sim = ek_sim_create(&sc, mesh)) != NULL;
      if (ok) {
        size_t nv = ek_mesh_nverts(mesh);
        n3 = 3 * nv;
        x[warm] = malloc(n3 * sizeof(double));
        const double *x0 = ek_sim_positions(sim), c = 0.5, a = 150 * 3.14159265358979323846 / 180;
        for (size_t i = 0; i < nv; i++) { // turn by a about (1, 1, 1) / sqrt(3) through c
          double p[3] = {x0[3 * i] - c, x0[3 * i + 1] - c, x0[3 * i + 2] - c}, k = 1 / sqrt(3.0);
          double kp = k * (p[0] + p[1] + p[2]);
          double kxp[3] = {k * (p[2] - p[1]), k * (p[0] - p[2]), k * (p[1] - p[0])};
          for (int d = 0; d < 3; d++)
            x[warm][3 * i + d] = c + p[d] * cos(a) + kxp[d] * sin(a) + k * kp * (1 - cos(a));
        }
        ok = ek_sim_set_state(sim, x[warm], NULL) == 0 && ek_sim_step(sim) == 0;
        if (ok) {
          moved = fmax(moved, max_diff(n3, x[warm], ek_sim_positions(sim)));
          memcpy(x[warm], ek_sim_positions(sim), n3 * sizeof(double));
        }
      }
      if (!ok) {
        printf("FAIL set_state %s %s: %s\n", models[m], warm ? "warm" : "svd", ek_last_error());
        failures++;
      }
      ek_sim_destroy(sim);
      ek_mesh_destroy(mesh);
    }
    if (ok) {
      char label[160];
      snprintf(label, sizeof label, "set_state: %s turned 150 deg, warm vs svd after a step",
               models[m]);
      report(label, max_diff(n3, x[0], x[1]), EK_POLAR_WARM_LOOP_TOL_F64,
             "max |x_warm - x_svd| (m), body size 1 m");
      snprintf(label, sizeof label, "set_state: %s turned 150 deg stays after a step", models[m]);
      report(label, moved, EK_POLAR_WARM_LOOP_TOL_F64, "max |x_1 - x_0| (m), svd and warm");
    }
    free(x[0]), free(x[1]);
  }
}

int main(int argc, char **argv) {
  unsigned long long seed = scenes_dir_init(argc, argv);
  printf("test_polar_warm: seed %llu\n", seed);
  for (ek_isa isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available(isa)) {
      printf("  %s: not available on this machine, skipped\n", ek_isa_name(isa));
      continue;
    }
    for (int bits = 32; bits <= 64; bits += 32) {
      accuracy(bits, isa, seed);
      extremes(bits, isa, seed);
      aos_starts(bits, isa, seed);
    }
  }
  for (int bits = 32; bits <= 64; bits += 32) {
    layouts_and_threads(bits, seed);
    simulation(bits, EK_ISA_AUTO);
  }
  bad_input();
  scene_key();
  loop();
  loop_corot_linear();
  loop_threads();
  set_state_restarts();
  printf("%s\n", failures ? "FAIL" : "PASS");
  return failures ? 1 : 0;
}
