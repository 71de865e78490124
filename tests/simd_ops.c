// The vector API (kernels/simd/simd.h, vmath.h) op by op on one target and
// precision: compiled once per target x precision with that target's flags,
// as the kernels are (tests/CMakeLists.txt), and called by test_simd.c for
// each build the CPU runs.
//
// Invariant: every lane of every op equals the same operation written in
// plain C on that lane's inputs, bit for bit (an arithmetic op on a NaN may
// return any NaN), and the approximate ops (vrsqrt_raw, vrsqrt_est, vlog)
// stay within their documented relative error. The inputs differ in every
// lane and hold signed zeros, infinities, NaNs, subnormals and the extremes
// of the range, so a swapped, broadcast or dropped lane fails. Lanes are
// read and written through a union, not through vload / vstore, which are
// checked on their own.
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "simd/simd.h"
#include "simd/vmath.h"
#include "simd_ops.h"

#define STR2_(x) #x
#define STR_(x) STR2_(x)
#define TARGET STR_(EK_TARGET_TOKEN) " " STR_(EK_PREC_TOKEN)

#define NL 1024        // lanes per input set, a multiple of every EK_W
#define NV (NL / EK_W) // vectors per input set
#define NX 61          // points in the gather tables

#if defined(EK_REAL_F32)
typedef uint32_t ubits;
#define EPS FLT_EPSILON
#define REAL_MIN FLT_MIN
#define REAL_TRUE_MIN FLT_TRUE_MIN
#define REAL_MAX FLT_MAX
#define REAL_MIN_EXP FLT_MIN_EXP
#define REAL_MAX_EXP FLT_MAX_EXP
#define REAL_MANT_DIG FLT_MANT_DIG
#define rsqrt_c(x) (1 / sqrtf(x))
#define frexp_c frexpf
#else
typedef uint64_t ubits;
#define EPS DBL_EPSILON
#define REAL_MIN DBL_MIN
#define REAL_TRUE_MIN DBL_TRUE_MIN
#define REAL_MAX DBL_MAX
#define REAL_MIN_EXP DBL_MIN_EXP
#define REAL_MAX_EXP DBL_MAX_EXP
#define REAL_MANT_DIG DBL_MANT_DIG
#define rsqrt_c(x) (1 / sqrt(x))
#define frexp_c frexp
#endif
#define SIGN ((ubits)1 << (8 * sizeof(ubits) - 1))

// Error budgets (relative, max over lanes), from the bounds documented in
// kernels/simd/generic.h and vmath.h: u is the unit roundoff EPS / 2.
// vrsqrt_est: one Newton step takes a relative error e to
// 1.5 e^2 + 0.5 e^3 plus at most 2.5 u of rounding (h y, the fused
// 1.5 - h y y, y t); 3 u is charged per step. The steps are those simd.h
// promises (1 for float, 2 for double), not the target's EK_RSQRT_NEWTON,
// so a target that drops a step fails.
#if defined(EK_REAL_F32)
#define EST_STEPS 1
#else
#define EST_STEPS 2
#endif
#ifdef EK_HAVE_VRSQRT_RAW
static double rsqrt_est_budget(double raw, int steps) {
  double e = raw;
  for (int k = 0; k < steps; k++)
    e = 1.5 * e * e + 0.5 * e * e * e + 3 * (EPS / 2);
  return e;
}
#endif
// vlog: relative error <= EK_VLOG_TOL_EPS epsilons (vmath.h).
#define VLOG_BUDGET (EK_VLOG_TOL_EPS * EPS)

typedef union {
  vreal v;
  real r[EK_W];
} lanes;

static vreal get(const real *p) {
  lanes u;
  memcpy(u.r, p, sizeof u.r);
  return u.v;
}
static void put(real *p, vreal v) {
  lanes u;
  u.v = v;
  memcpy(p, u.r, sizeof u.r);
}
// A mask's lanes as 0 / 1, through vsel (checked against C below).
static void put_mask(int *p, vmask m) {
  real r[EK_W];
  put(r, vsel(m, vset(1), vzero()));
  for (int l = 0; l < EK_W; l++)
    p[l] = r[l] == 1;
}
static ubits bits(real x) {
  ubits b;
  memcpy(&b, &x, sizeof b);
  return b;
}
static real from_bits(ubits b) {
  real x;
  memcpy(&x, &b, sizeof x);
  return x;
}
// Same bits; or both NaN where nan_any (arithmetic on a NaN input: x86
// keeps the first NaN operand's payload, C leaves it unspecified).
static int same(real expect, real got, int nan_any) {
  if (nan_any && isnan(expect))
    return isnan(got);
  return bits(expect) == bits(got);
}

// ---- One op's verdict: lanes compared, the first mismatches printed ----
typedef struct {
  const char *op;
  int lanes, bad;
} op_check;

static void lane_result(op_check *c, int ok, int i, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static void lane_result(op_check *c, int ok, int i, const char *fmt, ...) {
  c->lanes++;
  if (ok)
    return;
  if (c->bad++ < 4) {
    va_list ap;
    va_start(ap, fmt);
    printf("      %s %s: vector %d lane %d: ", TARGET, c->op, i / EK_W, i % EK_W);
    vprintf(fmt, ap);
    printf("\n");
    va_end(ap);
  }
}
static void op_done(op_check *c, ek_simd_tally *t, const char *what) {
  printf("%-5s %s %-15s %5d results, %d differ (%s)\n", c->bad ? "FAIL" : "PASS", TARGET, c->op,
         c->lanes, c->bad, what);
  t->ops++;
  t->lanes += c->lanes;
  t->failures += c->bad != 0;
}
// An approximate op: max relative error against its budget.
static void op_done_err(op_check *c, ek_simd_tally *t, double err, double budget) {
  ek_verdict v = c->bad ? EK_FAIL : ek_check_verdict(err, budget);
  printf("%-5s %s %-15s %5d results, max rel err %.3g, budget %.3g, ratio %.3f\n",
         ek_verdict_name(v), TARGET, c->op, c->lanes, err, budget, err / budget);
  t->ops++;
  t->lanes += c->lanes;
  t->failures += v == EK_FAIL;
}

// ---- Inputs ----
static real a[NL], b[NL], c[NL], pos[NL], logx[NL];
static int32_t idx[NL];

// s 2^e m, m uniform in [1, 2), e uniform in [emin, emax].
static real random_real(ek_rng *rng, int emin, int emax, int sign) {
  double m = 1 + ek_rng_uniform(rng);
  int e = emin + (int)(ek_rng_uniform(rng) * (emax - emin + 1));
  double s = sign && ek_rng_uniform(rng) < 0.5 ? -1 : 1;
  return (real)(s * ldexp(m, e));
}

static void make_inputs(uint64_t seed) {
  ek_rng rng;
  ek_rng_seed(&rng, ek_check_stream_seed(seed, "simd_ops"));
  const real special[] = {0,         -(real)0,   (real)INFINITY,   -(real)INFINITY,
                          (real)NAN, -(real)NAN, REAL_TRUE_MIN,    -REAL_TRUE_MIN,
                          REAL_MIN,  REAL_MAX,   -REAL_MAX,        1,
                          -1,        (real)0.5,  3 * REAL_TRUE_MIN};
  const int ns = (int)(sizeof special / sizeof special[0]);
  for (int i = 0; i < NL; i++) {
    a[i] = random_real(&rng, -20, 20, 1);
    b[i] = random_real(&rng, -20, 20, 1);
    c[i] = random_real(&rng, -20, 20, 1);
    // Positive normal numbers over the whole exponent range.
    pos[i] = random_real(&rng, REAL_MIN_EXP - 1, REAL_MAX_EXP - 2, 0);
    idx[i] = (int32_t)(ek_rng_uniform(&rng) * (NX + 4)) - 4; // -4 .. NX-1
  }
  for (int j = 0; j < ns; j++)
    a[(37 * j + 5) % NL] = special[j];
  for (int i = 0; i < NL; i++) {
    if (i % 13 == 0)
      b[i] = a[i]; // equal lanes for the comparisons
    else if (i % 17 == 0)
      b[i] = -a[i];
    if (i % 5 == 0)
      c[i] = -(a[i] * b[i]); // a b + c is the product's rounding error fused, 0 unfused
  }
  // Signed zeros against each other (min / max return the second operand).
  a[21] = 0, b[21] = -(real)0, a[22] = -(real)0, b[22] = 0;
  for (int j = 0; j < ns; j++) {
    b[(53 * j + 11) % NL] = special[j];
    c[(71 * j + 3) % NL] = special[j];
  }
  pos[7] = REAL_MIN, pos[8] = REAL_MAX, pos[9] = 1, pos[10] = 2, pos[11] = (real)0.5;
  pos[12] = 1 - EPS / 2, pos[13] = 1 + EPS;
  // vlog: every kind of input, subnormals, and arguments near 1 (small log).
  for (int i = 0; i < NL; i++) {
    switch (i % 4) {
    case 0:
      logx[i] = a[i];
      break;
    case 1:
      logx[i] = pos[i];
      break;
    case 2:
      logx[i] = random_real(&rng, 0, REAL_MANT_DIG - 2, 0) * REAL_TRUE_MIN;
      break;
    default:
      logx[i] = 1 + random_real(&rng, -REAL_MANT_DIG, -2, 1);
    }
  }
}

// ---- Loads and stores, set, zero ----
static void check_memory(ek_simd_tally *t) {
  static real buf[NL + 2 * EK_W] __attribute__((aligned(64)));
  const real guard = (real)-12345.5;
  op_check cs = {"vset", 0, 0}, cz = {"vzero", 0, 0};
  for (int v = 0; v < NV; v++) {
    real got[EK_W], x = a[v * EK_W + v % EK_W];
    put(got, vset(x));
    for (int l = 0; l < EK_W; l++)
      lane_result(&cs, same(x, got[l], 0), v * EK_W + l, "expected %a got %a", x, got[l]);
  }
  real zero[EK_W];
  put(zero, vzero());
  for (int l = 0; l < EK_W; l++)
    lane_result(&cz, bits(zero[l]) == 0, l, "expected +0 got %a", zero[l]);
  op_done(&cs, t, "every lane the scalar, bit for bit");
  op_done(&cz, t, "every lane +0");

  // Aligned (offset 0) and unaligned (offset 1 real: not a multiple of 16 bytes).
  op_check cl = {"vload", 0, 0}, cst = {"vstore", 0, 0};
  for (int off = 0; off <= 1; off++) {
    memcpy(buf + off, a, sizeof a);
    for (int v = 0; v < NV; v++) {
      real got[EK_W];
      put(got, vload(buf + off + v * EK_W));
      for (int l = 0; l < EK_W; l++) {
        int i = v * EK_W + l;
        lane_result(&cl, same(a[i], got[l], 0), i, "offset %d: expected %a got %a", off, a[i],
                    got[l]);
      }
    }
    for (int i = 0; i < NL + 2 * EK_W; i++)
      buf[i] = guard;
    for (int v = 0; v < NV; v++)
      vstore(buf + off + v * EK_W, get(a + v * EK_W));
    for (int i = 0; i < NL; i++)
      lane_result(&cst, same(a[i], buf[off + i], 0), i, "offset %d: expected %a got %a", off, a[i],
                  buf[off + i]);
    for (int i = 0; i < NL + 2 * EK_W; i++)
      if (i < off || i >= off + NL)
        lane_result(&cst, buf[i] == guard, i, "offset %d: wrote outside [%d, %d) at %d", off, off,
                    off + NL, i);
  }
  op_done(&cl, t, "aligned and unaligned, bit for bit");
  op_done(&cst, t, "aligned and unaligned, nothing outside written");
}

// ---- Arithmetic: each op and its plain-C twin, a table ----
static vreal v_add(vreal x, vreal y, vreal z) { return (void)z, vadd(x, y); }
static vreal v_sub(vreal x, vreal y, vreal z) { return (void)z, vsub(x, y); }
static vreal v_mul(vreal x, vreal y, vreal z) { return (void)z, vmul(x, y); }
static vreal v_div(vreal x, vreal y, vreal z) { return (void)z, vdiv(x, y); }
static vreal v_neg(vreal x, vreal y, vreal z) { return (void)y, (void)z, vneg(x); }
static vreal v_abs(vreal x, vreal y, vreal z) { return (void)y, (void)z, vabs(x); }
static vreal v_min(vreal x, vreal y, vreal z) { return (void)z, vmin(x, y); }
static vreal v_max(vreal x, vreal y, vreal z) { return (void)z, vmax(x, y); }
static vreal v_sqrt(vreal x, vreal y, vreal z) { return (void)y, (void)z, vsqrt(x); }
static vreal v_fma(vreal x, vreal y, vreal z) { return vfma(x, y, z); }
static vreal v_mla(vreal x, vreal y, vreal z) { return vmla(x, y, z); }
static vreal v_mls(vreal x, vreal y, vreal z) { return vmls(x, y, z); }
static vreal v_nmla(vreal x, vreal y, vreal z) { return vnmla(x, y, z); }
static vreal v_rsqrt(vreal x, vreal y, vreal z) { return (void)y, (void)z, vrsqrt(x); }
static vreal v_xorsign(vreal x, vreal y, vreal z) { return (void)z, vxorsign(x, y); }

#if defined(EK_REAL_F32)
static real c_fma(real x, real y, real z) { return fmaf(x, y, z); }
static real c_sqrt(real x) { return sqrtf(x); }
#else
static real c_fma(real x, real y, real z) { return fma(x, y, z); }
static real c_sqrt(real x) { return sqrt(x); }
#endif
static real c_add(real x, real y, real z) { return (void)z, x + y; }
static real c_sub(real x, real y, real z) { return (void)z, x - y; }
static real c_mul(real x, real y, real z) { return (void)z, x * y; }
static real c_div(real x, real y, real z) { return (void)z, x / y; }
static real c_neg(real x, real y, real z) { return (void)y, (void)z, from_bits(bits(x) ^ SIGN); }
static real c_abs(real x, real y, real z) { return (void)y, (void)z, from_bits(bits(x) & ~SIGN); }
// x86 MINPS / MAXPS: the second operand when either is NaN or both are zero.
static real c_min(real x, real y, real z) { return (void)z, x < y ? x : y; }
static real c_max(real x, real y, real z) { return (void)z, x > y ? x : y; }
static real c_sqrt3(real x, real y, real z) { return (void)y, (void)z, c_sqrt(x); }
static real c_rsqrt(real x, real y, real z) { return (void)y, (void)z, rsqrt_c(x); }
static real c_xorsign(real x, real y, real z) {
  return (void)z, signbit(y) ? from_bits(bits(x) ^ SIGN) : x;
}
// vmla / vmls / vnmla: fused where the target has FMA, a rounded product
// then a rounded sum on the scalar target (simd.h).
#if defined(EK_TARGET_SCALAR)
static real c_mla(real x, real y, real z) { return x * y + z; }
static real c_mls(real x, real y, real z) { return x * y - z; }
static real c_nmla(real x, real y, real z) { return z - x * y; }
#define MLA_KIND "unfused"
#else
static real c_mla(real x, real y, real z) { return c_fma(x, y, z); }
static real c_mls(real x, real y, real z) { return c_fma(x, y, -z); }
static real c_nmla(real x, real y, real z) { return c_fma(-x, y, z); }
#define MLA_KIND "fused"
#endif

typedef struct {
  const char *op;
  vreal (*v)(vreal, vreal, vreal);
  real (*c)(real, real, real);
  int nan_any; // 0: the op moves bits, NaNs included (neg, abs, min, max, xorsign)
  const char *what;
} arith_op;

static const arith_op arith[] = {
    {"vadd", v_add, c_add, 1, "a + b"},
    {"vsub", v_sub, c_sub, 1, "a - b"},
    {"vmul", v_mul, c_mul, 1, "a * b"},
    {"vdiv", v_div, c_div, 1, "a / b"},
    {"vneg", v_neg, c_neg, 0, "sign bit flipped"},
    {"vabs", v_abs, c_abs, 0, "sign bit cleared"},
    {"vmin", v_min, c_min, 0, "a < b ? a : b"},
    {"vmax", v_max, c_max, 0, "a > b ? a : b"},
    {"vsqrt", v_sqrt, c_sqrt3, 1, "sqrt(a)"},
    {"vfma", v_fma, c_fma, 1, "fma(a, b, c)"},
    {"vmla", v_mla, c_mla, 1, "a * b + c, " MLA_KIND},
    {"vmls", v_mls, c_mls, 1, "a * b - c, " MLA_KIND},
    {"vnmla", v_nmla, c_nmla, 1, "c - a * b, " MLA_KIND},
    {"vrsqrt", v_rsqrt, c_rsqrt, 1, "1 / sqrt(a)"},
    {"vxorsign", v_xorsign, c_xorsign, 0, "signbit(b) ? -a : a"},
};

static void check_arith(ek_simd_tally *t) {
  // The inputs must tell fused from unfused, or vfma / vmla prove nothing.
  int differ = 0;
  for (int i = 0; i < NL; i++)
    differ += isfinite(a[i] * b[i] + c[i]) && !same(c_fma(a[i], b[i], c[i]), a[i] * b[i] + c[i], 1);
  printf("%-5s %s %-15s %5d lanes where fused and unfused a * b + c differ\n",
         differ ? "PASS" : "FAIL", TARGET, "(inputs)", differ);
  t->failures += differ == 0;
  for (size_t k = 0; k < sizeof arith / sizeof arith[0]; k++) {
    const arith_op *op = &arith[k];
    op_check ck = {op->op, 0, 0};
    for (int v = 0; v < NV; v++) {
      real got[EK_W];
      put(got, op->v(get(a + v * EK_W), get(b + v * EK_W), get(c + v * EK_W)));
      for (int l = 0; l < EK_W; l++) {
        int i = v * EK_W + l;
        real e = op->c(a[i], b[i], c[i]);
        lane_result(&ck, same(e, got[l], op->nan_any), i, "a %a b %a c %a: expected %a got %a",
                    a[i], b[i], c[i], e, got[l]);
      }
    }
    op_done(&ck, t, op->what);
  }
}

// ---- The reciprocal square root's estimates ----
static void check_rsqrt_est(ek_simd_tally *t) {
  op_check cr = {"vrsqrt_raw", 0, 0}, ce = {"vrsqrt_est", 0, 0};
  double err_raw = 0, err_est = 0;
  for (int v = 0; v < NV; v++) {
    real raw[EK_W], est[EK_W];
    vreal x = get(pos + v * EK_W);
    put(raw, vrsqrt_raw(x));
    put(est, vrsqrt_est(x));
    for (int l = 0; l < EK_W; l++) {
      int i = v * EK_W + l;
#ifdef EK_HAVE_VRSQRT_RAW
      // Against 1/sqrt in long double (x87: 64-bit significand).
      long double r = 1.0L / sqrtl((long double)pos[i]);
      double er = (double)fabsl((raw[l] - r) / r), ee = (double)fabsl((est[l] - r) / r);
      err_raw = er > err_raw || isnan(er) ? er : err_raw;
      err_est = ee > err_est || isnan(ee) ? ee : err_est;
      lane_result(&cr, er <= EK_RSQRT_RAW_TOL, i, "x %a: 1/sqrt %La got %a (rel err %.3g)", pos[i],
                  r, raw[l], er);
      lane_result(&ce, ee <= rsqrt_est_budget(EK_RSQRT_RAW_TOL, EST_STEPS), i,
                  "x %a: 1/sqrt %La got %a (rel err %.3g)", pos[i], r, est[l], ee);
#else
      // No estimate on this target: both are the exact vrsqrt.
      real e = rsqrt_c(pos[i]);
      lane_result(&cr, same(e, raw[l], 0), i, "x %a: expected %a got %a", pos[i], e, raw[l]);
      lane_result(&ce, same(e, est[l], 0), i, "x %a: expected %a got %a", pos[i], e, est[l]);
#endif
    }
  }
#ifdef EK_HAVE_VRSQRT_RAW
  op_done_err(&cr, t, err_raw, EK_RSQRT_RAW_TOL);
  op_done_err(&ce, t, err_est, rsqrt_est_budget(EK_RSQRT_RAW_TOL, EST_STEPS));
#else
  (void)err_raw, (void)err_est;
  op_done(&cr, t, "no estimate here: 1 / sqrt(a), bit for bit");
  op_done(&ce, t, "no estimate here: 1 / sqrt(a), bit for bit");
#endif
}

// ---- Comparisons and masks ----
static vmask v_lt(vreal x, vreal y) { return vlt(x, y); }
static vmask v_le(vreal x, vreal y) { return vle(x, y); }
static vmask v_gt(vreal x, vreal y) { return vgt(x, y); }
static vmask v_ge(vreal x, vreal y) { return vge(x, y); }
static vmask v_eq(vreal x, vreal y) { return veq(x, y); }
static int c_lt(real x, real y) { return x < y; }
static int c_le(real x, real y) { return x <= y; }
static int c_gt(real x, real y) { return x > y; }
static int c_ge(real x, real y) { return x >= y; }
static int c_eq(real x, real y) { return x == y; }

static const struct {
  const char *op;
  vmask (*v)(vreal, vreal);
  int (*c)(real, real);
  const char *what;
} compares[] = {
    {"vlt", v_lt, c_lt, "a < b, false on NaN"},  {"vle", v_le, c_le, "a <= b, false on NaN"},
    {"vgt", v_gt, c_gt, "a > b, false on NaN"},  {"vge", v_ge, c_ge, "a >= b, false on NaN"},
    {"veq", v_eq, c_eq, "a == b, false on NaN"},
};

static void check_masks(ek_simd_tally *t) {
  for (size_t k = 0; k < sizeof compares / sizeof compares[0]; k++) {
    op_check ck = {compares[k].op, 0, 0};
    for (int v = 0; v < NV; v++) {
      int got[EK_W];
      put_mask(got, compares[k].v(get(a + v * EK_W), get(b + v * EK_W)));
      for (int l = 0; l < EK_W; l++) {
        int i = v * EK_W + l, e = compares[k].c(a[i], b[i]);
        lane_result(&ck, got[l] == e, i, "a %a b %a: expected %d got %d", a[i], b[i], e, got[l]);
      }
    }
    op_done(&ck, t, compares[k].what);
  }

  op_check cf = {"visfinite", 0, 0}, cand = {"vmand", 0, 0}, cor = {"vmor", 0, 0};
  op_check cnot = {"vmnot", 0, 0}, csel = {"vsel", 0, 0}, cneg = {"vsel_neg", 0, 0};
  for (int v = 0; v < NV; v++) {
    vreal x = get(a + v * EK_W), y = get(b + v * EK_W), z = get(c + v * EK_W);
    vmask m1 = vlt(x, y), m2 = vgt(z, x), m = vge(z, vzero());
    int fin[EK_W], mand[EK_W], mor[EK_W], mnot[EK_W];
    real sel[EK_W], sneg[EK_W];
    put_mask(fin, visfinite(x));
    put_mask(mand, vmand(m1, m2));
    put_mask(mor, vmor(m1, m2));
    put_mask(mnot, vmnot(m1));
    put(sel, vsel(m, x, y));
    put(sneg, vsel_neg(m, x, y));
    for (int l = 0; l < EK_W; l++) {
      int i = v * EK_W + l;
      int e1 = a[i] < b[i];
      int e2 = c[i] > a[i], em = c[i] >= 0;
      lane_result(&cf, fin[l] == !!isfinite(a[i]), i, "a %a: got %d", a[i], fin[l]);
      lane_result(&cand, mand[l] == (e1 && e2), i, "%d & %d: got %d", e1, e2, mand[l]);
      lane_result(&cor, mor[l] == (e1 || e2), i, "%d | %d: got %d", e1, e2, mor[l]);
      lane_result(&cnot, mnot[l] == !e1, i, "~%d: got %d", e1, mnot[l]);
      real es = em ? a[i] : b[i], en = em ? from_bits(bits(a[i]) ^ SIGN) : b[i];
      lane_result(&csel, same(es, sel[l], 0), i, "m %d a %a b %a: expected %a got %a", em, a[i],
                  b[i], es, sel[l]);
      lane_result(&cneg, same(en, sneg[l], 0), i, "m %d a %a b %a: expected %a got %a", em, a[i],
                  b[i], en, sneg[l]);
    }
  }
  op_done(&cf, t, "isfinite(a)");
  op_done(&cand, t, "lane-wise and");
  op_done(&cor, t, "lane-wise or");
  op_done(&cnot, t, "lane-wise not");
  op_done(&csel, t, "m ? a : b, bit for bit");
  op_done(&cneg, t, "m ? -a : b, bit for bit");

  // vany / vall on random masks, on each one-lane mask and its complement,
  // and on the all-true and all-false masks.
  op_check cany = {"vany", 0, 0}, call = {"vall", 0, 0};
  real iota[EK_W];
  for (int l = 0; l < EK_W; l++)
    iota[l] = (real)l;
  for (int v = 0; v < NV + 2 * EK_W + 2; v++) {
    vmask m;
    int e[EK_W];
    if (v < NV) {
      m = vlt(get(a + v * EK_W), get(b + v * EK_W));
      for (int l = 0; l < EK_W; l++)
        e[l] = a[v * EK_W + l] < b[v * EK_W + l];
    } else if (v < NV + 2 * EK_W) {
      int one = (v - NV) / 2, inv = (v - NV) % 2;
      m = veq(get(iota), vset((real)one));
      if (inv)
        m = vmnot(m);
      for (int l = 0; l < EK_W; l++)
        e[l] = (l == one) != inv;
    } else {
      int all = v == NV + 2 * EK_W;
      m = all ? veq(vzero(), vzero()) : vlt(vzero(), vzero());
      for (int l = 0; l < EK_W; l++)
        e[l] = all;
    }
    int any_e = 0, all_e = 1;
    for (int l = 0; l < EK_W; l++)
      any_e |= e[l], all_e &= e[l];
    int any_g = vany(m), all_g = vall(m);
    // The vector's verdict counts once, as its lane 0.
    lane_result(&cany, !!any_g == any_e, v * EK_W, "expected %d got %d", any_e, any_g);
    lane_result(&call, !!all_g == all_e, v * EK_W, "expected %d got %d", all_e, all_g);
  }
  op_done(&cany, t, "masks: random, one lane, all but one, all, none");
  op_done(&call, t, "masks: random, one lane, all but one, all, none");
}

// ---- Exponent extraction and the logarithm ----
static void check_vmath(ek_simd_tally *t) {
  op_check cm = {"vmant_exp", 0, 0}, cl = {"vlog", 0, 0};
  for (int v = 0; v < NV; v++) {
    real m[EK_W], e[EK_W];
    vreal ev;
    put(m, vmant_exp(get(pos + v * EK_W), &ev));
    put(e, ev);
    for (int l = 0; l < EK_W; l++) {
      int i = v * EK_W + l, k;
      real f = frexp_c(pos[i], &k); // f in [0.5, 1)
      real em = 2 * f, ee = (real)(k - 1);
      lane_result(&cm, same(em, m[l], 0) && same(ee, e[l], 0), i,
                  "x %a: expected m %a e %g got m %a e %g", pos[i], em, (double)ee, m[l],
                  (double)e[l]);
    }
  }
  op_done(&cm, t, "x = m 2^e, m in [1, 2), as frexp, bit for bit");

  double err = 0;
  for (int v = 0; v < NV; v++) {
    real got[EK_W];
    put(got, vlog(get(logx + v * EK_W)));
    for (int l = 0; l < EK_W; l++) {
      int i = v * EK_W + l;
      real x = logx[i];
      if (!(x > 0) || isinf(x) || x == 1) {
        // NaN for x < 0 and NaN, -inf for +-0, +inf for +inf, 0 for 1.
        real e = isnan(x) || x < 0 ? (real)NAN : x == 0 ? -(real)INFINITY : x == 1 ? 0 : x;
        lane_result(&cl, same(e, got[l], 1), i, "x %a: expected %a got %a", x, e, got[l]);
        continue;
      }
      long double r = logl((long double)x);
      double rel = (double)fabsl((got[l] - r) / r);
      err = rel > err || isnan(rel) ? rel : err;
      lane_result(&cl, rel <= VLOG_BUDGET, i, "x %a: log %La got %a (rel err %.3g)", x, r, got[l],
                  rel);
    }
  }
  op_done_err(&cl, t, err, VLOG_BUDGET);
}

// ---- Gathers ----
static void check_gathers(ek_simd_tally *t) {
  // Tables whose entries differ (a's first 3 NX values), so a lane that
  // reads the wrong index shows.
  op_check cg = {"vgather", 0, 0}, cp = {"vgather_points", 0, 0};
  for (int v = 0; v < NV; v++) {
    const int32_t *ix = idx + v * EK_W;
    real got[EK_W], p[3][EK_W];
    vreal pv[3];
    int mask[EK_W];
    put(got, vgather(a, ix));
    put_mask(mask, vgather_points(a, ix, pv));
    for (int k = 0; k < 3; k++)
      put(p[k], pv[k]);
    for (int l = 0; l < EK_W; l++) {
      int i = v * EK_W + l, j = ix[l] < 0 ? 0 : ix[l];
      lane_result(&cg, same(a[j], got[l], 0), i, "idx %d: expected %a got %a", (int)ix[l], a[j],
                  got[l]);
      int ok = mask[l] == (ix[l] < 0);
      for (int k = 0; k < 3; k++)
        ok &= same(a[3 * j + k], p[k][l], 0);
      lane_result(&cp, ok, i, "idx %d: expected (%a %a %a) mask %d got (%a %a %a) mask %d",
                  (int)ix[l], a[3 * j], a[3 * j + 1], a[3 * j + 2], ix[l] < 0, p[0][l], p[1][l],
                  p[2][l], mask[l]);
    }
  }
  op_done(&cg, t, "x[idx], x[0] where idx < 0");
  op_done(&cp, t, "points x[3 idx + k], mask where idx < 0");
#if defined(EK_HAVE_VLOAD_POINTS)
  op_check cl = {"vload_points", 0, 0};
  for (int v = 0; v < NV; v++) {
    const int32_t *ix = idx + v * EK_W;
    real p[3][EK_W];
    vreal pv[3];
    int mask[EK_W];
    put_mask(mask, vload_points(a, ix, pv));
    for (int k = 0; k < 3; k++)
      put(p[k], pv[k]);
    for (int l = 0; l < EK_W; l++) {
      int i = v * EK_W + l, j = ix[l] < 0 ? 0 : ix[l];
      int ok = mask[l] == (ix[l] < 0);
      for (int k = 0; k < 3; k++)
        ok &= same(a[3 * j + k], p[k][l], 0);
      lane_result(&cl, ok, i, "idx %d: expected (%a %a %a) mask %d got (%a %a %a) mask %d",
                  (int)ix[l], a[3 * j], a[3 * j + 1], a[3 * j + 2], ix[l] < 0, p[0][l], p[1][l],
                  p[2][l], mask[l]);
    }
  }
  op_done(&cl, t, "vgather_points' values by loads and a transpose");
#endif
#if defined(EK_HAVE_VSCATTER_ADD_ROWS4) || defined(EK_HAVE_VROWS4)
  // Random rows (repeats in a vector included) against the scalar adds in
  // lane order, corners inner; lanes whose corner 0 is negative skipped:
  // vscatter_add_rows4 (AVX2), or the rows of 4 the AVX-512 force makes
  // (vstore_rows4) and adds (vadd_rows4).
#if defined(EK_HAVE_VROWS4)
  op_check cs = {"vstore_rows4+vadd_rows4", 0, 0};
#else
  op_check cs = {"vscatter_add_rows4", 0, 0};
#endif
  static real rows[NX * 4], ref[NX * 4];
  for (int i = 0; i < NX * 4; i++)
    rows[i] = ref[i] = a[(7 * i + 3) % NL];
  for (int v = 0; v + 4 <= NV; v += 4) {
    int32_t ci[4 * EK_W];
    for (int k = 0; k < 4 * EK_W; k++)
      ci[k] = k < EK_W || idx[v * EK_W + k] >= 0 ? idx[v * EK_W + k] : -idx[v * EK_W + k];
    vreal h[12];
    real hs[12][EK_W];
    for (int k = 0; k < 12; k++) {
      h[k] = vload(b + ((v + k) % NV) * EK_W);
      put(hs[k], h[k]);
    }
#if defined(EK_HAVE_VROWS4)
    _Alignas(64) real r4[16 * EK_W];
    vstore_rows4(r4, h);
    vadd_rows4(rows, ci, EK_W, r4);
#else
    vscatter_add_rows4(rows, ci, EK_W, h);
#endif
    for (int l = 0; l < EK_W; l++) {
      if (ci[l] < 0)
        continue;
      for (int c = 0; c < 4; c++)
        for (int k = 0; k < 3; k++)
          ref[ci[c * EK_W + l] * 4 + k] += hs[3 * c + k][l];
    }
  }
  for (int i = 0; i < NX; i++)
    for (int k = 0; k < 3; k++)
      lane_result(&cs, same(ref[4 * i + k], rows[4 * i + k], 1), 3 * i + k,
                  "row %d component %d: expected %a got %a", i, k, ref[4 * i + k], rows[4 * i + k]);
  op_done(&cs, t, "rows of 4 += corner values, lane order, corners inner");
#endif
}

// ---- The record transposes, for every np the API allows ----
// Inlined into each call so that np is a constant there, as in the kernels
// (avx512.h's register transpose relies on it).
EK_INLINE void check_records_np(int np, op_check *cl, op_check *cs, op_check *cn) {
  // 64-byte aligned, as vstore_records_nt's streaming stores need.
  real out[EK_RECORD_MAX * EK_W + EK_W] __attribute__((aligned(64)));
  const real guard = (real)-12345.5;
  for (int base = 0; base + np * EK_W <= NL; base += 7 * np * EK_W + 3) {
    const real *p = a + base;
    vreal planes[EK_RECORD_MAX];
    vload_records(p, np, planes);
    for (int k = 0; k < np; k++) {
      real got[EK_W];
      put(got, planes[k]);
      for (int l = 0; l < EK_W; l++)
        lane_result(cl, same(p[l * np + k], got[l], 0), l, "np %d field %d: expected %a got %a", np,
                    k, p[l * np + k], got[l]);
    }
    // Store planes from c (independent of the load) and read the records.
    for (int k = 0; k < np; k++)
      planes[k] = get(c + base + k * EK_W);
    for (int i = 0; i < np * EK_W + EK_W; i++)
      out[i] = guard;
    vstore_records(out, np, planes);
    for (int l = 0; l < EK_W; l++)
      for (int k = 0; k < np; k++) {
        real e = c[base + k * EK_W + l];
        lane_result(cs, same(e, out[l * np + k], 0), l, "np %d record field %d: expected %a got %a",
                    np, k, e, out[l * np + k]);
      }
    for (int i = np * EK_W; i < np * EK_W + EK_W; i++)
      lane_result(cs, out[i] == guard, 0, "np %d: wrote past the records at %d", np, i);
    // The same through the streaming stores.
    for (int i = 0; i < np * EK_W + EK_W; i++)
      out[i] = guard;
    vstore_records_nt(out, np, planes);
    vstream_fence();
    for (int l = 0; l < EK_W; l++)
      for (int k = 0; k < np; k++) {
        real e = c[base + k * EK_W + l];
        lane_result(cn, same(e, out[l * np + k], 0), l, "np %d record field %d: expected %a got %a",
                    np, k, e, out[l * np + k]);
      }
    for (int i = np * EK_W; i < np * EK_W + EK_W; i++)
      lane_result(cn, out[i] == guard, 0, "np %d: wrote past the records at %d", np, i);
  }
}

static void check_records(ek_simd_tally *t) {
  op_check cl = {"vload_records", 0, 0}, cs = {"vstore_records", 0, 0},
           cn = {"vstore_records_nt", 0, 0};
  check_records_np(1, &cl, &cs, &cn);
  check_records_np(2, &cl, &cs, &cn);
  check_records_np(3, &cl, &cs, &cn);
  check_records_np(4, &cl, &cs, &cn);
  check_records_np(5, &cl, &cs, &cn);
  check_records_np(6, &cl, &cs, &cn);
  check_records_np(7, &cl, &cs, &cn);
  check_records_np(8, &cl, &cs, &cn);
  check_records_np(9, &cl, &cs, &cn);
  op_done(&cl, t, "np = 1..9: plane k lane l = record l field k");
  op_done(&cs, t, "np = 1..9: the inverse, nothing past the records");
  op_done(&cn, t, "np = 1..9: vstore_records with streaming stores (64-byte aligned), the same");
}

// vsum_run3: a 3x3 block of doubles (rows rs apart, a guard after each
// row's 3 values) plus n element blocks of 9 reals a plane stride 16 apart,
// against the sums written out in plain C: the partial sum's bits kept
// (quieted) once it is NaN, else acc + e. Inputs from a[] (NaNs,
// infinities, signed zeros, subnormals) as the element values and b[] as
// K's old values; first and n = 1..4 each tried.
static void check_sum_run(ek_simd_tally *t) {
  op_check cr = {"vsum_run3", 0, 0};
  enum { RS = 7, ES = 16 };
  const double guard = 1234.5;
  int tried = 0;
  for (int base = 0; base + 4 * 9 * ES <= NL * 4 && tried < 48; base += 97, tried++) {
    const int n = 1 + tried % 4, first = tried / 4 % 2;
    real e[4 * 9 * ES];
    uint16_t off[4];
    for (int k = 0; k < 4 * 9 * ES; k++)
      e[k] = a[(base + k) % NL];
    for (int j = 0; j < n; j++)
      off[j] = (uint16_t)(j * 9 * ES + (tried + j) % ES);
    double o[3 * RS], want[3 * RS];
    for (int k = 0; k < 3 * RS; k++)
      o[k] = want[k] = k % RS < 3 ? (double)b[(base + k) % NL] : guard;
    for (int i = 0; i < 3; i++)
      for (int m = 0; m < 3; m++) {
        double acc = first ? 0 : want[i * RS + m];
        for (int j = 0; j < n; j++) {
          const double x = (double)e[off[j] + (3 * i + m) * ES];
          if (isnan(acc)) {
            uint64_t u;
            memcpy(&u, &acc, 8);
            u |= (uint64_t)1 << 51; // quieted
            memcpy(&acc, &u, 8);
          } else
            acc = acc + x;
        }
        want[i * RS + m] = acc;
      }
    vsum_run3(o, RS, e, ES, off, n, first);
    for (int k = 0; k < 3 * RS; k++) {
      uint64_t g, w;
      memcpy(&g, &o[k], 8);
      memcpy(&w, &want[k], 8);
      lane_result(&cr, g == w, k, "run %d (n %d, first %d): expected %a got %a", tried, n, first,
                  want[k], o[k]);
    }
  }
  op_done(&cr, t, "n = 1..4, first or not: the plain sums' bits, first NaN kept, guards intact");
}

void EK_SYM(simd_ops)(uint64_t seed, ek_simd_tally *t) {
  make_inputs(seed);
  check_memory(t);
  check_arith(t);
  check_rsqrt_est(t);
  check_masks(t);
  check_vmath(t);
  check_gathers(t);
  check_records(t);
  check_sum_run(t);
}
