// Scalar double replica of ek's SVD3 kernel algorithm, step for step
// (kernels/svd3/svd3_core.h): McAdams, Selle, Tamstorf, Teran,
// Sifakis, "Computing the Singular Value Decomposition of 3x3 matrices with
// minimal branching and elementary floating point operations", UW-Madison
// TR1690, 2011 (sec. 2 for the Jacobi part), plus a one-sided Jacobi refinement
// (Hestenes 1958) on B = A V. Exact 1/sqrt throughout. The step banners are
// the kernel's.
#include "svd3_ref.h"

#include <math.h>

// Spec constants of the double kernel: below TINY2 = 1e-300 (relative to
// the scaled matrix) a rotation is negligible; matrices below 2^-512 are
// prescaled by 2^512 (exact) so subnormal entries become normal. GAMMA,
// CSTAR, SSTAR: McAdams et al. 2011, sec. 2 (the angle test and the pi/4
// fallback rotation of the half-angle pi/8).
#define TINY2 1e-300
#define TINY_MATRIX 0x1p-512
#define PRESCALE 0x1p512
#define GAMMA 5.82842712474619009760   // 3 + 2 sqrt(2)
#define CSTAR 0.923879532511286756128  // cos(pi/8)
#define SSTAR 0.3826834323650897717284 // sin(pi/8)

static double rsq(double x) { return 1.0 / sqrt(x); }

// Rotation in plane (p,q) about e_k; pairs in sweep order.
static const int pairs[3][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}};

// Symmetric 3x3 stored in full; only the entries the spec names are
// updated, the mirror is kept in step.
static double *sym(double s[9], int i, int j) { return &s[3 * i + j]; }

static void set_sym(double s[9], int i, int j, double v) { s[3 * i + j] = s[3 * j + i] = v; }

int ek_svd3_mcadams_ref(const double A_in[9], int sweeps, int refine, double U[9], double S[3],
                        double V[9]) {
  // ---- 0. Bad lanes ----
  int bad = sweeps < 0 || refine < 0;
  for (int i = 0; i < 9; i++)
    bad |= !isfinite(A_in[i]);
  if (bad) {
    for (int i = 0; i < 9; i++)
      U[i] = V[i] = NAN;
    S[0] = S[1] = S[2] = NAN;
    return -1;
  }

  // ---- 1. Scale ----
  // A' = sc pre A with sc = 1/max|pre a_ij|: entries of A' are <= 1, so
  // the Gram matrix neither overflows nor underflows; the zero matrix keeps
  // sc = 1. S is scaled back by m = max|a_ij| at the end.
  double m = 0;
  for (int i = 0; i < 9; i++)
    m = fmax(m, fabs(A_in[i]));
  double pre = m < TINY_MATRIX ? PRESCALE : 1;
  double sc = m > 0 ? 1.0 / (m * pre) : 1;
  double A[9];
  for (int i = 0; i < 9; i++)
    A[i] = A_in[i] * pre * sc;

  // ---- 2. Gram matrix ----
  double s[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      double acc = 0;
      for (int r = 0; r < 3; r++)
        acc += A[3 * r + i] * A[3 * r + j];
      s[3 * i + j] = acc;
    }

  // ---- 3. Jacobi eigenanalysis ----
  // McAdams et al. 2011 sec. 2: approximate Givens half-angle, the
  // conjugation S <- Q^T S Q written out, Q accumulated in q.
  double qw = 1, qv[3] = {0, 0, 0};
  for (int sweep = 0; sweep < sweeps; sweep++)
    for (int t = 0; t < 3; t++) {
      int p = pairs[t][0], q = pairs[t][1], k = pairs[t][2];
      double a = *sym(s, p, p), d = *sym(s, q, q), b = *sym(s, p, q);
      double e = *sym(s, p, k), f = *sym(s, q, k);
      // Compute the Givens angle.
      double ch = 2 * (a - d), sh = b;
      int ok = GAMMA * sh * sh < ch * ch;
      double n2 = ch * ch + sh * sh;
      double om = rsq(fmax(n2, TINY2));
      if (n2 <= TINY2) // negligible block: no rotation
        ch = 1, sh = 0;
      else if (ok)
        ch = om * ch, sh = om * sh;
      else
        ch = CSTAR, sh = SSTAR;
      double c = ch * ch - sh * sh, sn = 2 * ch * sh;
      // Conjugate the Gram matrix.
      set_sym(s, p, p, c * c * a + 2 * c * sn * b + sn * sn * d);
      set_sym(s, q, q, sn * sn * a - 2 * c * sn * b + c * c * d);
      set_sym(s, p, q, (d - a) * c * sn + b * (c * c - sn * sn));
      set_sym(s, p, k, c * e + sn * f);
      set_sym(s, q, k, -sn * e + c * f);
      // Accumulate: q <- q (x) (ch, sh e_k), Hamilton product.
      double rw = qw * ch - qv[k] * sh;
      double rv[3];
      for (int i = 0; i < 3; i++)
        rv[i] = ch * qv[i];
      rv[k] += qw * sh;
      // v x (sh e_k): component i gets sh * (v_j [k==l] - v_l [k==j]) for
      // (i,j,l) cyclic, i.e. +sh v_q on axis p and -sh v_p on axis q.
      rv[p] += sh * qv[q];
      rv[q] -= sh * qv[p];
      qw = rw, qv[0] = rv[0], qv[1] = rv[1], qv[2] = rv[2];
    }

  // ---- 4. V from the quaternion, B = A' V ----
  double qn = rsq(qw * qw + qv[0] * qv[0] + qv[1] * qv[1] + qv[2] * qv[2]);
  double w = qw * qn, x = qv[0] * qn, y = qv[1] * qn, z = qv[2] * qn;
  double Vm[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                  2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                  2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
  double B[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      B[3 * i + j] = A[3 * i] * Vm[j] + A[3 * i + 1] * Vm[3 + j] + A[3 * i + 2] * Vm[6 + j];

  // ---- 5. Refinement: one-sided Jacobi on the columns of B ----
  // Hestenes' rotation, the half-angle form of tan(2 theta) = 2 gamma /
  // (alpha - beta), taking the root with |theta| <= pi/4.
  for (int sweep = 0; sweep < refine; sweep++)
    for (int t = 0; t < 3; t++) {
      int p = pairs[t][0], q = pairs[t][1];
      double alpha = 0, beta = 0, gamma = 0;
      for (int r = 0; r < 3; r++) {
        alpha += B[3 * r + p] * B[3 * r + p];
        beta += B[3 * r + q] * B[3 * r + q];
        gamma += B[3 * r + p] * B[3 * r + q];
      }
      double xx = alpha - beta, yy = 2 * gamma, rr = sqrt(xx * xx + yy * yy);
      double tt = fabs(xx) + rr, uu = xx >= 0 ? yy : -yy;
      double n2 = tt * tt + uu * uu;
      double om = rsq(fmax(n2, TINY2));
      double c = n2 < TINY2 ? 1 : tt * om, sn = n2 < TINY2 ? 0 : uu * om;
      for (int r = 0; r < 3; r++) {
        double bp = B[3 * r + p], bq = B[3 * r + q];
        B[3 * r + p] = c * bp + sn * bq, B[3 * r + q] = -sn * bp + c * bq;
        double vp = Vm[3 * r + p], vq = Vm[3 * r + q];
        Vm[3 * r + p] = c * vp + sn * vq, Vm[3 * r + q] = -sn * vp + c * vq;
      }
    }

  // ---- 6. Sort singular values ----
  // As in McAdams et al. 2011: conditional swaps by column norm; negating
  // the new column j keeps det V = +1.
  double rho[3];
  for (int j = 0; j < 3; j++)
    rho[j] = B[j] * B[j] + B[3 + j] * B[3 + j] + B[6 + j] * B[6 + j];
  static const int swaps[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int t = 0; t < 3; t++) {
    int i = swaps[t][0], j = swaps[t][1];
    if (rho[i] < rho[j]) {
      for (int r = 0; r < 3; r++) {
        double bi = B[3 * r + i], vi = Vm[3 * r + i];
        B[3 * r + i] = B[3 * r + j], B[3 * r + j] = -bi;
        Vm[3 * r + i] = Vm[3 * r + j], Vm[3 * r + j] = -vi;
      }
      double tr = rho[i];
      rho[i] = rho[j], rho[j] = tr;
    }
  }

  // ---- 7. QR by Givens rotations ----
  // As in McAdams et al. 2011: G3 G2 G1 B = R upper triangular, with
  // U = G1^T G2^T G3^T.
  double Um[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  static const int qr_rows[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int t = 0; t < 3; t++) {
    int i = qr_rows[t][0], j = qr_rows[t][1];
    int col = t == 2 ? 1 : 0;
    double a1 = B[3 * i + col], a2 = B[3 * j + col];
    double n2 = a1 * a1 + a2 * a2;
    int ok = n2 > TINY2;
    double om = rsq(fmax(n2, TINY2));
    double c = ok ? a1 * om : 1, sn = ok ? a2 * om : 0;
    for (int l = 0; l < 3; l++) {
      double bi = B[3 * i + l], bj = B[3 * j + l];
      B[3 * i + l] = c * bi + sn * bj, B[3 * j + l] = -sn * bi + c * bj;
      // U <- U G^T: columns i, j of U rotate like rows i, j of B.
      double ui = Um[3 * l + i], uj = Um[3 * l + j];
      Um[3 * l + i] = c * ui + sn * uj, Um[3 * l + j] = -sn * ui + c * uj;
    }
  }

  // ---- 8. Output ----
  for (int i = 0; i < 9; i++)
    U[i] = Um[i], V[i] = Vm[i];
  S[0] = B[0] * m, S[1] = B[4] * m, S[2] = B[8] * m;
  return 0;
}
