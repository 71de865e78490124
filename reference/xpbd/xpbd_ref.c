// Reference XPBD with the Hookean constraint of seed 001, double, AoS.
// Macklin, Mueller, Chentanez 2016 ("XPBD") eqs. 17, 18 for the
// projection; seed 001 for the constraint and the shape-matching F.
#include "xpbd_ref.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fvm/fvm_ref.h"
#include "material/model_ref.h"

static int set_alloc(ek_xpbd_ref_set *s, size_t n, size_t nverts, size_t nmembers) {
  memset(s, 0, sizeof *s);
  s->n = n;
  s->nverts = nverts;
  s->start = malloc((n + 1) * sizeof(int32_t));
  s->members = malloc((nmembers ? nmembers : 1) * sizeof(int32_t));
  s->b = malloc((nmembers > n ? 3 * (nmembers - n) : 1) * sizeof(double));
  s->V = malloc((n ? n : 1) * sizeof(double));
  if (!s->start || !s->members || !s->b || !s->V) {
    ek_xpbd_ref_free(s);
    return -1;
  }
  return 0;
}

void ek_xpbd_ref_free(ek_xpbd_ref_set *s) {
  free(s->start);
  free(s->members);
  free(s->b);
  free(s->V);
  memset(s, 0, sizeof *s);
}

int ek_xpbd_ref_tets(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                     ek_xpbd_ref_set *s) {
  if (set_alloc(s, ntets, nverts, 4 * ntets))
    return -1;
  for (size_t e = 0; e < ntets; e++) {
    const int32_t *t = tets + 4 * e;
    double F[9], Di[9];
    const double V = ek_fvm_tet_F_ref(X, X, t, F, Di);
    if (!(V > 0) || !isfinite(V)) {
      ek_xpbd_ref_free(s);
      return -1;
    }
    s->start[e] = (int32_t)(4 * e);
    for (int k = 0; k < 4; k++)
      s->members[4 * e + k] = t[k];
    // F = Ds Dm^-1 = sum_k (x_k - x_0) (row k of Dm^-1) (Teran 2003 sec. 4):
    // column k of Ds times row k of Dm^-1.
    memcpy(s->b + 9 * e, Di, sizeof Di);
    s->V[e] = V;
  }
  s->start[ntets] = (int32_t)(4 * ntets);
  return 0;
}

static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

int ek_xpbd_ref_clusters(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                         const double *mass, ek_xpbd_ref_set *s, size_t *bad_vertex) {
  // Vertex -> incident tets (CSR), then each vertex's neighbours from them.
  size_t *inc_start = calloc(nverts + 1, sizeof(size_t));
  size_t *inc = malloc((ntets ? 4 * ntets : 1) * sizeof(size_t));
  size_t *fill = calloc(nverts + 1, sizeof(size_t));
  int32_t *scratch = NULL;
  int32_t *nb_start = malloc((nverts + 1) * sizeof(int32_t));
  int32_t *nb = NULL;
  int rc = -1;
  memset(s, 0, sizeof *s);
  if (!inc_start || !inc || !fill || !nb_start || !mass)
    goto done;
  for (size_t i = 0; i < 4 * ntets; i++)
    inc_start[tets[i] + 1]++;
  size_t maxinc = 0;
  for (size_t v = 0; v < nverts; v++) {
    maxinc = inc_start[v + 1] > maxinc ? inc_start[v + 1] : maxinc;
    inc_start[v + 1] += inc_start[v];
  }
  for (size_t e = 0; e < ntets; e++)
    for (int k = 0; k < 4; k++) {
      size_t v = (size_t)tets[4 * e + k];
      inc[inc_start[v] + fill[v]++] = e;
    }
  scratch = malloc((4 * maxinc + 1) * sizeof(int32_t));
  if (!scratch)
    goto done;
  // Two passes over the vertices: count the neighbours, then store them.
  size_t total = 0;
  for (int pass = 0; pass < 2; pass++) {
    total = 0;
    for (size_t v = 0; v < nverts; v++) {
      size_t cnt = 0;
      for (size_t q = inc_start[v]; q < inc_start[v + 1]; q++)
        for (int k = 0; k < 4; k++) {
          int32_t u = tets[4 * inc[q] + k];
          if ((size_t)u != v)
            scratch[cnt++] = u;
        }
      qsort(scratch, cnt, sizeof(int32_t), cmp_i32);
      size_t uniq = 0;
      for (size_t q = 0; q < cnt; q++)
        if (uniq == 0 || scratch[q] != scratch[uniq - 1])
          scratch[uniq++] = scratch[q];
      if (pass == 0) {
        nb_start[v] = (int32_t)total;
      } else {
        memcpy(nb + nb_start[v], scratch, uniq * sizeof(int32_t));
      }
      total += uniq;
    }
    if (pass == 0) {
      nb_start[nverts] = (int32_t)total;
      nb = malloc((total ? total : 1) * sizeof(int32_t));
      if (!nb)
        goto done;
    }
  }
  if (set_alloc(s, nverts, nverts, nverts + total))
    goto done;
  for (size_t v = 0; v < nverts; v++) {
    int32_t *mem = s->members + v + (size_t)nb_start[v];
    size_t K = 1 + (size_t)(nb_start[v + 1] - nb_start[v]);
    s->start[v] = (int32_t)(v + (size_t)nb_start[v]);
    mem[0] = (int32_t)v;
    memcpy(mem + 1, nb + nb_start[v], (K - 1) * sizeof(int32_t));
    // Rest centre of mass and Q = sum_k m_k rbar_k rbar_k^T (seed 001;
    // Mueller et al. 2005 eq. 7's A_qq^-1).
    double M = 0, c[3] = {0, 0, 0}, Q[9] = {0}, Qi[9];
    for (size_t k = 0; k < K; k++) {
      M += mass[mem[k]];
      for (int r = 0; r < 3; r++)
        c[r] += mass[mem[k]] * X[mem[k] * 3 + r];
    }
    if (!(M > 0)) {
      if (bad_vertex)
        *bad_vertex = v;
      ek_xpbd_ref_free(s);
      goto done;
    }
    for (int r = 0; r < 3; r++)
      c[r] /= M;
    for (size_t k = 0; k < K; k++) {
      double rb[3];
      for (int r = 0; r < 3; r++)
        rb[r] = X[mem[k] * 3 + r] - c[r];
      for (int r = 0; r < 3; r++)
        for (int q = 0; q < 3; q++)
          Q[3 * r + q] += mass[mem[k]] * rb[r] * rb[q];
    }
    double det = m3_inverse(Q, Qi), tr3 = (Q[0] + Q[4] + Q[8]) / 3;
    if (!(det > EK_XPBD_REF_Q_SINGULAR * tr3 * tr3 * tr3)) {
      if (bad_vertex)
        *bad_vertex = v;
      ek_xpbd_ref_free(s);
      goto done;
    }
    // F = (sum_k m_k r_k rbar_k^T) Q^-1 (seed 001): the x_cm terms cancel
    // because sum_k m_k rbar_k = 0, leaving F = sum_k x_k b_k^T with
    // b_k = m_k Q^-1 rbar_k (Q symmetric), and sum_k b_k = 0 turns that
    // into sum_{k>=1} (x_k - x_0) b_k^T.
    double *bv = s->b + 3 * (size_t)nb_start[v];
    for (size_t k = 1; k < K; k++) {
      double rb[3];
      for (int r = 0; r < 3; r++)
        rb[r] = X[mem[k] * 3 + r] - c[r];
      for (int r = 0; r < 3; r++)
        bv[3 * (k - 1) + r] =
            mass[mem[k]] * (Qi[3 * r] * rb[0] + Qi[3 * r + 1] * rb[1] + Qi[3 * r + 2] * rb[2]);
    }
    // The vertex's share of the mesh volume: a quarter of each incident
    // tet's (xpbd.h), so the V_j sum to the mesh volume.
    double V = 0;
    for (size_t q = inc_start[v]; q < inc_start[v + 1]; q++) {
      double F[9], Di[9];
      V += ek_fvm_tet_F_ref(X, X, tets + 4 * inc[q], F, Di) / 4;
    }
    s->V[v] = V;
  }
  s->start[nverts] = (int32_t)(nverts + total);
  rc = 0;
done:
  free(inc_start);
  free(inc);
  free(fill);
  free(scratch);
  free(nb_start);
  free(nb);
  return rc;
}

void ek_xpbd_ref_F(int K, const int32_t *members, const double *b, const double *x, double F[9]) {
  memset(F, 0, 9 * sizeof(double));
  const double *x0 = x + 3 * members[0];
  for (int k = 1; k < K; k++) {
    const double *xk = x + 3 * members[k], *bk = b + 3 * (k - 1);
    for (int r = 0; r < 3; r++) {
      double d = xk[r] - x0[r];
      for (int c = 0; c < 3; c++)
        F[3 * r + c] += d * bk[c];
    }
  }
}

// StVK (Sifakis & Barbic 2012 course notes, ch. 3; the seed's "Hookean"
// energy).
double ek_xpbd_ref_stvk(const ek_xpbd_ref_material *m, const double F[9], double P[9]) {
  double e[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      double s = F[i] * F[j] + F[3 + i] * F[3 + j] + F[6 + i] * F[6 + j]; // (F^T F)_ij
      e[3 * i + j] = 0.5 * (s - (i == j));
    }
  double tr = e[0] + e[4] + e[8], ee = 0;
  for (int k = 0; k < 9; k++)
    ee += e[k] * e[k];
  if (P) {
    double S[9];
    for (int k = 0; k < 9; k++)
      S[k] = 2 * m->mu * e[k] + (k % 4 == 0 ? m->lambda * tr : 0);
    // P = F S: dW/dF (the seed writes S F; see xpbd.h).
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++)
        P[3 * i + j] = F[3 * i] * S[j] + F[3 * i + 1] * S[3 + j] + F[3 * i + 2] * S[6 + j];
  }
  return m->mu * ee + 0.5 * m->lambda * tr * tr;
}

double ek_xpbd_ref_eval(const ek_xpbd_ref_material *m, int K, const int32_t *members,
                        const double *b, const double *x, double cmin, double *grad) {
  double F[9], P[9];
  ek_xpbd_ref_F(K, members, b, x, F);
  // C = sqrt(2 W / E): C^2 / (2 alpha) = V W with alpha = 1 / (V E) (seed
  // 001).
  double C = sqrt(2 * ek_xpbd_ref_stvk(m, F, P) / m->young);
  if (!(C > cmin) || !grad)
    return C;
  // grad_k C = (dW/dF : dF/dx_k) / (E C) = P b_k / (E C) (seed 001's chain
  // rule with F S for the derivative); grad_0 = -sum_{k>=1}.
  double s = 1 / (m->young * C);
  for (int r = 0; r < 3; r++)
    grad[r] = 0;
  for (int k = 1; k < K; k++) {
    const double *bk = b + 3 * (k - 1);
    for (int r = 0; r < 3; r++) {
      double g = (P[3 * r] * bk[0] + P[3 * r + 1] * bk[1] + P[3 * r + 2] * bk[2]) * s;
      grad[3 * k + r] = g;
      grad[r] -= g;
    }
  }
  return C;
}

double ek_xpbd_ref_snh_eval(const ek_xpbd_ref_material *m, int K, const int32_t *members,
                            const double *b, const double *x, double cmin, double *gD, double *gH,
                            double *ch) {
  double F[9], cof[9];
  ek_xpbd_ref_F(K, members, b, x, F);
  m3_cof(F, cof);
  const double Ic = m3_ddot(F, F);
  // Macklin & Mueller 2021's C_D = sqrt(I_C) with Smith et al. 2018's log
  // term, and C_H = J - a with ek's a (xpbd.h): the energy is ek's psi.
  const double cd = sqrt(fmax(Ic - log(1 + Ic), 0));
  *ch = m3_det(F) - (1 + 0.75 * m->mu / m->lambda);
  // d(I_C - log(1 + I_C))/dF = 2 F I_C / (1 + I_C), halved by the sqrt.
  const double sD = cd > cmin ? Ic / ((1 + Ic) * cd) : 0;
  for (int r = 0; r < 3; r++) {
    if (gD)
      gD[r] = 0;
    if (gH)
      gH[r] = 0;
  }
  for (int k = 1; k < K; k++) {
    const double *bk = b + 3 * (k - 1);
    for (int r = 0; r < 3; r++) {
      const double fb = F[3 * r] * bk[0] + F[3 * r + 1] * bk[1] + F[3 * r + 2] * bk[2];
      const double cb = cof[3 * r] * bk[0] + cof[3 * r + 1] * bk[1] + cof[3 * r + 2] * bk[2];
      if (gD) {
        gD[3 * k + r] = sD * fb;
        gD[r] -= sD * fb;
      }
      if (gH) {
        gH[3 * k + r] = cb;
        gH[r] -= cb;
      }
    }
  }
  return cd;
}

double ek_xpbd_ref_snh_energy(const ek_xpbd_ref_material *m, const double F[9]) {
  const double Ic = m3_ddot(F, F), ch = m3_det(F) - (1 + 0.75 * m->mu / m->lambda);
  return 0.5 * m->mu * (Ic - log(1 + Ic)) + 0.5 * m->lambda * ch * ch;
}

void ek_xpbd_ref_snh_solve(double add, double adh, double ahh, double kD, double kH, double cd,
                           double ch, double lD, double lH, double dl[2]) {
  // Rows multiplied by k = 1 / alpha~ (as the StVK projection below).
  const double m11 = kD * add + 1, m12 = kD * adh, m21 = kH * adh, m22 = kH * ahh + 1;
  const double r1 = -(kD * cd + lD), r2 = -(kH * ch + lH);
  const double det = m11 * m22 - m12 * m21;
  dl[0] = (r1 * m22 - m12 * r2) / det;
  dl[1] = (m11 * r2 - m21 * r1) / det;
}

// Project element j's stable neo-Hookean pair (weights w_i n_i, n NULL:
// 1), multipliers lambda[2 j], lambda[2 j + 1], corrections added to out.
static void project_snh(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m, const double *w,
                        const double *n, double h, size_t j, int K, const int32_t *mem,
                        const double *gD, const double *gH, double cd, double ch, double *lambda,
                        double *out) {
  double add = 0, adh = 0, ahh = 0, dl[2];
  for (int k = 0; k < K; k++) {
    const double wk = (n ? n[mem[k]] : 1) * w[mem[k]];
    for (int r = 0; r < 3; r++) {
      add += wk * gD[3 * k + r] * gD[3 * k + r];
      adh += wk * gD[3 * k + r] * gH[3 * k + r];
      ahh += wk * gH[3 * k + r] * gH[3 * k + r];
    }
  }
  const double V = s->V[j], h2 = h * h;
  ek_xpbd_ref_snh_solve(add, adh, ahh, V * m->mu * h2, V * m->lambda * h2, cd, ch, lambda[2 * j],
                        lambda[2 * j + 1], dl);
  lambda[2 * j] += dl[0];
  lambda[2 * j + 1] += dl[1];
  for (int k = 0; k < K; k++)
    for (int r = 0; r < 3; r++)
      out[3 * mem[k] + r] += w[mem[k]] * (gD[3 * k + r] * dl[0] + gH[3 * k + r] * dl[1]);
}

static int max_members(const ek_xpbd_ref_set *s) {
  int K = 1;
  for (size_t j = 0; j < s->n; j++)
    if (s->start[j + 1] - s->start[j] > K)
      K = s->start[j + 1] - s->start[j];
  return K;
}

// Element j's members, K and b.
static int element(const ek_xpbd_ref_set *s, size_t j, const int32_t **mem, const double **b) {
  *mem = s->members + s->start[j];
  *b = s->b + 3 * ((size_t)s->start[j] - j);
  return s->start[j + 1] - s->start[j];
}

// Project constraint j (C > cmin, grad_k C in g): Macklin 2016 eq. 18
// multiplied through by k = 1 / alpha~ = V E h^2 (as the library does: no
// 1/k to underflow for stiff constraints), vertex i weighted w_i n_i (n
// NULL: 1); lambda_j += dlambda and eq. 17, dx_i = w_i grad_i C dlambda,
// added into out.
static void project(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m, const double *w,
                    const double *n, double h, size_t j, int K, const int32_t *mem, const double *g,
                    double C, double *lambda, double *out) {
  double sum = 0;
  for (int k = 0; k < K; k++)
    sum += (n ? n[mem[k]] : 1) * w[mem[k]] *
           (g[3 * k] * g[3 * k] + g[3 * k + 1] * g[3 * k + 1] + g[3 * k + 2] * g[3 * k + 2]);
  const double kk = s->V[j] * m->young * h * h;
  const double dl = -(C * kk + lambda[j]) / (kk * sum + 1);
  lambda[j] += dl;
  for (int k = 0; k < K; k++)
    for (int r = 0; r < 3; r++)
      out[3 * mem[k] + r] += w[mem[k]] * g[3 * k + r] * dl;
}

void ek_xpbd_ref_gauss_seidel(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m,
                              const double *w, double h, double cmin, size_t norder,
                              const int32_t *order, double *x, double *lambda) {
  double *g = malloc((size_t)max_members(s) * 6 * sizeof(double));
  if (!order)
    norder = s->n;
  for (size_t q = 0; q < norder; q++) {
    size_t j = order ? (size_t)order[q] : q;
    const int32_t *mem;
    const double *b;
    int K = element(s, j, &mem, &b);
    if (m->snh) {
      double *gH = g + 3 * (size_t)K, ch;
      double cd = ek_xpbd_ref_snh_eval(m, K, mem, b, x, cmin, g, gH, &ch);
      project_snh(s, m, w, NULL, h, j, K, mem, g, gH, cd, ch, lambda, x);
      continue;
    }
    double C = ek_xpbd_ref_eval(m, K, mem, b, x, cmin, g);
    if (C > cmin) // else at the rounding level of F: grad C is 0/0 (xpbd.h)
      project(s, m, w, NULL, h, j, K, mem, g, C, lambda, x);
  }
  free(g);
}

void ek_xpbd_ref_jacobi(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m, const double *w,
                        double h, double cmin, double *x, double *lambda) {
  double *g = malloc((size_t)max_members(s) * 6 * sizeof(double));
  double *dx = calloc(3 * s->nverts, sizeof(double));
  double *cnt = calloc(s->nverts, sizeof(double));
  // n_i: every constraint on vertex i, skipped or not (a static count).
  for (size_t q = 0; q < (size_t)s->start[s->n]; q++)
    cnt[s->members[q]] += 1;
  for (size_t j = 0; j < s->n; j++) {
    const int32_t *mem;
    const double *b;
    int K = element(s, j, &mem, &b);
    if (m->snh) {
      double *gH = g + 3 * (size_t)K, ch;
      double cd = ek_xpbd_ref_snh_eval(m, K, mem, b, x, cmin, g, gH, &ch);
      project_snh(s, m, w, cnt, h, j, K, mem, g, gH, cd, ch, lambda, dx);
      continue;
    }
    double C = ek_xpbd_ref_eval(m, K, mem, b, x, cmin, g);
    // Consistent averaging (xpbd.h; Macklin et al. 2014): vertex i's
    // weight counts n_i times, so the fixed point is Gauss-Seidel's.
    if (C > cmin)
      project(s, m, w, cnt, h, j, K, mem, g, C, lambda, dx);
  }
  for (size_t i = 0; i < 3 * s->nverts; i++)
    x[i] += dx[i];
  free(g);
  free(dx);
  free(cnt);
}

double ek_xpbd_ref_residual(const ek_xpbd_ref_set *s, const ek_xpbd_ref_material *m, double h,
                            double cmin, const double *x, const double *lambda, double *cmax) {
  double res = 0, cm = 0;
  for (size_t j = 0; j < s->n; j++) {
    const int32_t *mem;
    const double *b;
    int K = element(s, j, &mem, &b);
    if (m->snh) {
      // The larger of the pair's |C + alpha~ lambda|; cmax: max |C_H|.
      double ch, cd = ek_xpbd_ref_snh_eval(m, K, mem, b, x, cmin, NULL, NULL, &ch);
      const double V = s->V[j], h2 = h * h;
      const double rD = fabs(cd + lambda[2 * j] / (V * m->mu * h2));
      const double rH = fabs(ch + lambda[2 * j + 1] / (V * m->lambda * h2));
      const double r = rD > rH ? rD : rH, ac = fabs(ch);
      if (!(r <= res))
        res = r;
      if (!(ac <= cm))
        cm = ac;
      continue;
    }
    double C = ek_xpbd_ref_eval(m, K, mem, b, x, cmin, NULL);
    // Maxima that keep a NaN (fmax would drop it).
    if (!(C <= cm))
      cm = C;
    if (!(C > cmin))
      continue;
    // alpha~ lambda = lambda / (V E h^2).
    double r = fabs(C + lambda[j] / (s->V[j] * m->young * h * h));
    if (!(r <= res))
      res = r;
  }
  if (cmax)
    *cmax = cm;
  return res;
}
