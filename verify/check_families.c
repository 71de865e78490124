// The extremes catalogue: named families of 3x3 input matrices (a table, so
// a row is one line; FFTW CONVENTIONS "favor a table"). Every family covers
// a way a 3x3 SVD goes wrong: scale (overflow / underflow of A^T A),
// rank deficiency (vanishing rotations), repeated singular values (the
// Jacobi angle is undefined), inversion (the sign rule), and isolation of
// non-finite lanes.
#include <math.h>
#include <string.h>

#include "check.h"

// Signed singular values (s0, s1, s2) in any order, embedded by random
// rotations: A = U diag(s) V^T.
static void with_sigma(ek_rng *rng, double s0, double s1, double s2, double *A) {
  const double s[3] = {s0, s1, s2};
  ek_rng_with_sigma(rng, s, A);
}

// A log-uniform positive number in [lo, hi].
static double log_uniform(ek_rng *rng, double lo, double hi) {
  return exp(log(lo) + (log(hi) - log(lo)) * ek_rng_uniform(rng));
}

static double random_sign(ek_rng *rng) { return ek_rng_uniform(rng) < 0.5 ? -1.0 : 1.0; }

static void gen_gaussian(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++)
    ek_rng_gauss_matrix(rng, A + 9 * i);
}

static void gen_rotation(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++)
    ek_rng_rotation(rng, A + 9 * i);
}

// Rotations by pi - delta about random axes, delta in {0} U [1e-8, 1e-2]
// log-uniform (Rodrigues' formula): the quaternion's w goes to zero, where
// a quaternion-based method loses the axis.
static void gen_rotation_180(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double a[3], n2;
    do {
      a[0] = ek_rng_gauss(rng), a[1] = ek_rng_gauss(rng), a[2] = ek_rng_gauss(rng);
      n2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    } while (n2 < 1e-12);
    for (int k = 0; k < 3; k++)
      a[k] /= sqrt(n2);
    double delta = i % 4 == 0 ? 0.0 : log_uniform(rng, 1e-8, 1e-2);
    double th = 3.14159265358979323846 - delta, c = cos(th), s = sin(th);
    double *R = A + 9 * i;
    for (int r = 0; r < 3; r++)
      for (int k = 0; k < 3; k++)
        R[3 * r + k] = (r == k ? c : 0.0) + (1 - c) * a[r] * a[k];
    R[1] -= s * a[2], R[2] += s * a[1], R[3] += s * a[2];
    R[5] -= s * a[0], R[6] -= s * a[1], R[7] += s * a[0];
  }
}

// Improper orthogonal matrices (det -1): a rotation with a row negated.
static void gen_reflection(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    ek_rng_rotation(rng, A + 9 * i);
    int r = (int)(ek_rng_next(rng) % 3);
    for (int k = 0; k < 3; k++)
      A[9 * i + 3 * r + k] = -A[9 * i + 3 * r + k];
  }
}

// Gaussian with a column negated where needed so that det A < 0 (an
// inverted element).
static void gen_inverted(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double *M = A + 9 * i;
    ek_rng_gauss_matrix(rng, M);
    if (ek_det3(M) > 0) {
      int c = (int)(ek_rng_next(rng) % 3);
      for (int r = 0; r < 3; r++)
        M[3 * r + c] = -M[3 * r + c];
    }
  }
}

static void scaled_gaussian(ek_rng *rng, size_t n, double *A, double scale) {
  for (size_t i = 0; i < 9 * n; i++)
    A[i] = scale * ek_rng_gauss(rng);
}
static void gen_scale_1e30(ek_rng *rng, size_t n, double *A) { scaled_gaussian(rng, n, A, 1e30); }
static void gen_scale_1em30(ek_rng *rng, size_t n, double *A) { scaled_gaussian(rng, n, A, 1e-30); }
// Entries near float's smallest normal (1.2e-38): A^T A underflows in float
// without ek's scaling step.
static void gen_scale_1em37(ek_rng *rng, size_t n, double *A) { scaled_gaussian(rng, n, A, 1e-37); }
static void gen_scale_1e300(ek_rng *rng, size_t n, double *A) { scaled_gaussian(rng, n, A, 1e300); }
static void gen_scale_1em300(ek_rng *rng, size_t n, double *A) {
  scaled_gaussian(rng, n, A, 1e-300);
}
// Subnormal entries (float: below 1.2e-38, double: below 2.2e-308).
static void gen_subnormal_f32(ek_rng *rng, size_t n, double *A) {
  scaled_gaussian(rng, n, A, 1e-40);
}
static void gen_subnormal_f64(ek_rng *rng, size_t n, double *A) {
  scaled_gaussian(rng, n, A, 1e-310);
}

// Entries of wildly different magnitudes in one matrix, 1e-20..1e20.
static void gen_mixed_scale(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < 9 * n; i++)
    A[i] = random_sign(rng) * log_uniform(rng, 1e-20, 1e20);
}

static void gen_zero(ek_rng *rng, size_t n, double *A) {
  (void)rng;
  memset(A, 0, 9 * n * sizeof *A);
}

static void gen_rank1(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++)
    with_sigma(rng, log_uniform(rng, 0.1, 10), 0, 0, A + 9 * i);
}

static void gen_rank2(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double s0 = log_uniform(rng, 0.1, 10);
    with_sigma(rng, s0, s0 * ek_rng_uniform(rng), 0, A + 9 * i);
  }
}

// (s, s, s') with s' anywhere in [-s, s]: the Jacobi angle of the repeated
// pair is undefined.
static void gen_repeated(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double s = log_uniform(rng, 0.1, 10), s2 = s * (2 * ek_rng_uniform(rng) - 1);
    if (i % 2)
      with_sigma(rng, s, s, s2, A + 9 * i);
    else
      with_sigma(rng, s2, s, s, A + 9 * i); // the repeated pair largest or smallest
  }
}

// (s, s (1 + 1e-6), s''): nearly repeated, the angle is ill-conditioned.
static void gen_nearly_repeated(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double s = log_uniform(rng, 0.1, 10), s2 = s * (2 * ek_rng_uniform(rng) - 1);
    with_sigma(rng, s, s * (1 + 1e-6), s2, A + 9 * i);
  }
}

// (s, s, +-s): a scaled rotation or scaled reflection.
static void gen_all_equal(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double s = log_uniform(rng, 0.1, 10);
    with_sigma(rng, s, s, random_sign(rng) * s, A + 9 * i);
  }
}

static void ill_conditioned(ek_rng *rng, size_t n, double *A, double kappa) {
  for (size_t i = 0; i < n; i++) {
    double s0 = log_uniform(rng, 0.1, 10);
    double s1 = s0 * log_uniform(rng, 1 / kappa, 1);
    with_sigma(rng, s0, s1, random_sign(rng) * s0 / kappa, A + 9 * i);
  }
}
static void gen_ill_1e3(ek_rng *rng, size_t n, double *A) { ill_conditioned(rng, n, A, 1e3); }
static void gen_ill_1e6(ek_rng *rng, size_t n, double *A) { ill_conditioned(rng, n, A, 1e6); }
// s1/s2 = 1e3 and 1e6 with s2 = s3: two small values (the case DESIGN.md
// says Jacobi on A^T A alone cannot resolve in float).
static void gen_two_small(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double s0 = log_uniform(rng, 0.1, 10), k = i % 2 ? 1e3 : 1e6;
    with_sigma(rng, s0, s0 / k, random_sign(rng) * s0 / k * ek_rng_uniform(rng), A + 9 * i);
  }
}

// Diagonal, with signs, ties and zeros; the first one is the identity.
static void gen_diagonal(ek_rng *rng, size_t n, double *A) {
  static const double pool[] = {0, 1, -1, 2, -2, 0.5, 3, 1e-3};
  for (size_t i = 0; i < n; i++) {
    double *M = A + 9 * i;
    memset(M, 0, 9 * sizeof *M);
    for (int k = 0; k < 3; k++)
      M[4 * k] = i == 0 ? 1.0 : i % 3 ? pool[ek_rng_next(rng) % 8] : ek_rng_gauss(rng);
  }
}

// Signed permutation matrices times a positive scale: exact answers with
// column swaps and reflections.
static void gen_permutation(ek_rng *rng, size_t n, double *A) {
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (size_t i = 0; i < n; i++) {
    double *M = A + 9 * i;
    memset(M, 0, 9 * sizeof *M);
    const int *p = perms[ek_rng_next(rng) % 6];
    double s = log_uniform(rng, 0.1, 10);
    for (int r = 0; r < 3; r++)
      M[3 * r + p[r]] = s * random_sign(rng);
  }
}

// A nearly flat tet: one tiny singular value, either sign, 1e-8..1e-4 of s0.
static void gen_near_flat(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++) {
    double s0 = log_uniform(rng, 0.1, 10), s1 = s0 * log_uniform(rng, 0.1, 1);
    with_sigma(rng, s0, s1, random_sign(rng) * s0 * log_uniform(rng, 1e-8, 1e-4), A + 9 * i);
  }
}

// Graded: 1 (+) a 2x2 block of sizes 10^-x, 10^-y, x, y in [0, 30], under
// a random signed permutation. Tiny singular values survive rounding to
// float exactly (no rotation mixes them into the large one), so this checks
// thresholds that treat a small but representable value as zero.
static void gen_graded(ek_rng *rng, size_t n, double *A) {
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (size_t i = 0; i < n; i++) {
    double x = 30 * ek_rng_uniform(rng), y = 30 * ek_rng_uniform(rng);
    double t = 6.283185307179586 * ek_rng_uniform(rng), a = pow(10, -x), b = pow(10, -y);
    double G[9] = {1, 0, 0, 0, a * cos(t), a * sin(t), 0, -0.5 * b * sin(t), b * cos(t)};
    const int *pr = perms[ek_rng_next(rng) % 6], *pc = perms[ek_rng_next(rng) % 6];
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++)
        A[9 * i + 3 * pr[r] + pc[c]] = G[3 * r + c] * (r == 0 ? random_sign(rng) : 1.0);
  }
}

// Small integer entries in [-4, 4]: many exactly singular or repeated cases.
static void gen_integer(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < 9 * n; i++)
    A[i] = (double)((int)(ek_rng_next(rng) % 9) - 4);
}

// I + E with |E| ~ 1e-4: deformation gradients of a stiff simulation.
static void gen_near_identity(ek_rng *rng, size_t n, double *A) {
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 9; k++)
      A[9 * i + k] = (k % 4 == 0 ? 1.0 : 0.0) + 1e-4 * ek_rng_gauss(rng);
}

// Gaussian batch where every 5th matrix has one entry replaced by NaN, +inf
// or -inf: only those matrices may come out NaN.
static void gen_nonfinite(ek_rng *rng, size_t n, double *A) {
  gen_gaussian(rng, n, A);
  for (size_t i = 3; i < n; i += 5) {
    int k = (int)(ek_rng_next(rng) % 9);
    A[9 * i + k] = i % 3 == 0 ? NAN : i % 3 == 1 ? INFINITY : -INFINITY;
  }
}

const ek_check_family ek_check_families[] = {
    {"gaussian", gen_gaussian, EK_FAMILY_BOTH, "iid N(0,1) entries"},
    {"rotation", gen_rotation, EK_FAMILY_BOTH, "uniform random rotations"},
    {"rotation_180", gen_rotation_180, EK_FAMILY_BOTH, "rotations by pi - [0, 1e-2]"},
    {"reflection", gen_reflection, EK_FAMILY_BOTH, "orthogonal, det -1"},
    {"inverted", gen_inverted, EK_FAMILY_BOTH, "gaussian with det < 0"},
    {"scale_1e30", gen_scale_1e30, EK_FAMILY_BOTH, "gaussian * 1e30"},
    {"scale_1e-30", gen_scale_1em30, EK_FAMILY_BOTH, "gaussian * 1e-30"},
    {"scale_1e-37", gen_scale_1em37, EK_FAMILY_BOTH, "gaussian * 1e-37 (near FLT_MIN)"},
    {"scale_1e300", gen_scale_1e300, EK_FAMILY_F64, "gaussian * 1e300"},
    {"scale_1e-300", gen_scale_1em300, EK_FAMILY_F64, "gaussian * 1e-300"},
    {"subnormal_f32", gen_subnormal_f32, EK_FAMILY_F32, "gaussian * 1e-40 (float subnormals)"},
    {"subnormal_f64", gen_subnormal_f64, EK_FAMILY_F64, "gaussian * 1e-310 (double subnormals)"},
    {"mixed_scale", gen_mixed_scale, EK_FAMILY_BOTH, "entries +-1e-20..1e20 log-uniform"},
    {"zero", gen_zero, EK_FAMILY_BOTH, "exact zero matrix"},
    {"rank1", gen_rank1, EK_FAMILY_BOTH, "sigma (s, 0, 0)"},
    {"rank2", gen_rank2, EK_FAMILY_BOTH, "sigma (s, t, 0)"},
    {"repeated", gen_repeated, EK_FAMILY_BOTH, "sigma (s, s, s'), |s'| <= s"},
    {"nearly_repeated", gen_nearly_repeated, EK_FAMILY_BOTH, "sigma (s, s(1+1e-6), s')"},
    {"all_equal", gen_all_equal, EK_FAMILY_BOTH, "sigma (s, s, +-s)"},
    {"ill_cond_1e3", gen_ill_1e3, EK_FAMILY_BOTH, "s0/|s2| = 1e3"},
    {"ill_cond_1e6", gen_ill_1e6, EK_FAMILY_BOTH, "s0/|s2| = 1e6"},
    {"two_small", gen_two_small, EK_FAMILY_BOTH, "s0/s1 = 1e3 or 1e6, |s2| <= s1"},
    {"diagonal", gen_diagonal, EK_FAMILY_BOTH, "diagonal with signs, ties, zeros"},
    {"permutation", gen_permutation, EK_FAMILY_BOTH, "scaled signed permutations"},
    {"near_flat", gen_near_flat, EK_FAMILY_BOTH, "|s2|/s0 in 1e-8..1e-4, either sign"},
    {"graded", gen_graded, EK_FAMILY_BOTH, "1 (+) 2x2 block of sizes 1e-30..1, permuted"},
    {"integer", gen_integer, EK_FAMILY_BOTH, "integer entries in [-4, 4]"},
    {"near_identity", gen_near_identity, EK_FAMILY_BOTH, "I + 1e-4 N(0,1)"},
    {"nonfinite", gen_nonfinite, EK_FAMILY_BOTH | EK_FAMILY_NONFINITE,
     "gaussian, every 5th matrix has a NaN or +-inf entry"},
};
const int ek_check_nfamilies = (int)(sizeof ek_check_families / sizeof ek_check_families[0]);

int ek_check_family_for(const ek_check_family *f, int bits) {
  return (f->flags & (bits == 32 ? EK_FAMILY_F32 : EK_FAMILY_F64)) != 0;
}
