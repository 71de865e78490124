// XPBD for cloth (include/ek/cloth_force.h): the membrane as one energy
// constraint per triangle, in the form of the tets' (include/ek/xpbd.h,
// seed 001),
//   C_j = sqrt(2 W(F_j) / k),  alpha_j = 1 / (A_j k),
// so that C_j^2 / (2 alpha_j) = A_j W(F_j), the triangle's membrane energy
// (W = Psi of the membrane model per unit area, k the sheet's Young's
// modulus per unit area, E h); with F = (x1 - x0) d1^T + (x2 - x0) d2^T
// (d_k row k of Dm^-1), grad_k C = P d_k / (k C) for k = 1, 2 and
// grad_0 C = -(grad_1 C + grad_2 C), P = dW/dF. Bending: per hinge
// C_h = |s|, s = sum_i k_i x_i, alpha_h = 1 / k_b, so C_h^2 / (2 alpha_h)
// is the quadratic bending energy of Bergou et al. 2006;
// grad_i C_h = k_i s / |s|.
// The projection (Macklin, Mueller, Chentanez 2016 eqs. 17-18):
//   dlambda = (-C - alpha~ lambda) / (sum_i w_i |grad_i C|^2 + alpha~),
//   alpha~ = alpha / h^2, x_i += w_i grad_i C dlambda.
// A constraint with C <= EK_XPBD_C_MIN_F64-like EK_CLOTH_XPBD_C_MIN (its
// gradient is 0/0 at rest) is skipped.
// Gauss-Seidel by colours (greedy: no two constraints of one colour share
// a vertex; triangles first, then hinges), a colour's constraints in
// parallel: the same bits at any thread count. Scalar double (a plain
// path: the vector kernels are the explicit loop's forces).
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../elements/layer.h"
#include "../elements/tri_polar.h"
#include "../elements/tris.h"
#include "../kernels.h"
#include "../team.h"

struct ek_cloth_xpbd {
  const ek_cloth *cl;
  ek_cloth_params p;
  double k;          // membrane modulus per unit area
  size_t n;          // constraints: triangles then hinges
  int32_t *order;    // constraints by colour
  size_t *color_off; // colour c: order[color_off[c] .. color_off[c+1])
  int ncolors;
  double *lambda, *w;
  double h;
};

void ek_cloth_xpbd_destroy(ek_cloth_xpbd *x) {
  if (!x)
    return;
  free(x->order);
  free(x->color_off);
  free(x->lambda);
  free(x->w);
  free(x);
}

ek_cloth_xpbd *ek_cloth_xpbd_create(const ek_cloth *cl, const ek_cloth_params *p, double k) {
  if (!cl || !p || !(k > 0) || !isfinite(k) || !(p->mu > 0) || !(p->lambda >= 0) ||
      !(p->bending >= 0)) {
    ek_set_error("ek_cloth_xpbd_create: bad arguments (k %g)", k);
    return NULL;
  }
  ek_cloth_xpbd *x = calloc(1, sizeof *x);
  if (!x)
    return NULL;
  x->cl = cl;
  x->p = *p;
  x->k = k;
  size_t nh = p->bending > 0 ? cl->nh : 0;
  x->n = cl->nt + nh;
  int32_t *color = malloc((x->n ? x->n : 1) * sizeof *color);
  x->order = malloc(x->n * sizeof *x->order);
  x->lambda = calloc(x->n, sizeof *x->lambda);
  x->w = calloc(cl->nv, sizeof *x->w);
  if (!color || !x->order || !x->lambda || !x->w) {
    free(color);
    ek_cloth_xpbd_destroy(x);
    ek_set_error("ek_cloth_xpbd_create: out of memory");
    return NULL;
  }
  // Greedy colours in element order (kernels/elements/layer.h), the
  // triangles' first, the hinges' after them (no colour mixes the two).
  int nct = ek_layer_color(cl->nv, cl->nt, 0, 3, NULL, cl->tris, color);
  int nch = nct < 0 ? -1 : ek_layer_color(cl->nv, nh, 0, 4, NULL, cl->hinges, color + cl->nt);
  if (nct < 0 || nch < 0) {
    free(color);
    ek_cloth_xpbd_destroy(x);
    ek_set_error("ek_cloth_xpbd_create: out of memory (colouring)");
    return NULL;
  }
  for (size_t j = cl->nt; j < x->n; ++j)
    color[j] += nct;
  int ncol = nct + nch;
  x->ncolors = ncol;
  x->color_off = calloc((size_t)ncol + 1, sizeof *x->color_off);
  if (!x->color_off) {
    free(color);
    ek_cloth_xpbd_destroy(x);
    return NULL;
  }
  for (size_t j = 0; j < x->n; ++j)
    x->color_off[color[j] + 1]++;
  for (int c = 0; c < ncol; ++c)
    x->color_off[c + 1] += x->color_off[c];
  size_t *pos = malloc((size_t)ncol * sizeof *pos);
  if (!pos) {
    free(color);
    ek_cloth_xpbd_destroy(x);
    return NULL;
  }
  memcpy(pos, x->color_off, (size_t)ncol * sizeof *pos);
  for (size_t j = 0; j < x->n; ++j)
    x->order[pos[color[j]]++] = (int32_t)j;
  free(pos);
  free(color);
  return x;
}

size_t ek_cloth_xpbd_count(const ek_cloth_xpbd *x) { return x ? x->n : 0; }
int ek_cloth_xpbd_colors(const ek_cloth_xpbd *x) { return x ? x->ncolors : 0; }

int ek_cloth_xpbd_begin(ek_cloth_xpbd *x, const double *w, double h) {
  if (!x || !w || !(h > 0)) {
    ek_set_error("ek_cloth_xpbd_begin: bad arguments");
    return EK_EINVAL;
  }
  memcpy(x->w, w, x->cl->nv * sizeof(double));
  memset(x->lambda, 0, x->n * sizeof(double));
  x->h = h;
  return 0;
}

// Membrane W and P of one triangle's F (P may be NULL).
static double membrane_W(const ek_cloth_params *p, const double F[6], double P[6]) {
  if (p->model == EK_MEMBRANE_STVK) {
    double C00 = F[0] * F[0] + F[2] * F[2] + F[4] * F[4];
    double C01 = F[0] * F[1] + F[2] * F[3] + F[4] * F[5];
    double C11 = F[1] * F[1] + F[3] * F[3] + F[5] * F[5];
    double E00 = 0.5 * (C00 - 1), E11 = 0.5 * (C11 - 1), E01 = 0.5 * C01, tr = E00 + E11;
    if (P) {
      double S00 = 2 * p->mu * E00 + p->lambda * tr, S11 = 2 * p->mu * E11 + p->lambda * tr,
             S01 = 2 * p->mu * E01;
      for (int i = 0; i < 3; ++i) {
        P[2 * i] = F[2 * i] * S00 + F[2 * i + 1] * S01;
        P[2 * i + 1] = F[2 * i] * S01 + F[2 * i + 1] * S11;
      }
    }
    return p->mu * (E00 * E00 + E11 * E11 + 2 * E01 * E01) + 0.5 * p->lambda * tr * tr;
  }
  cloth_svd32 d;
  cloth_svd32_of(F, &d);
  if (P)
    for (int k = 0; k < 6; ++k)
      P[k] = 2 * p->mu * (F[k] - d.R[k]);
  return p->mu * ((d.sigma[0] - 1) * (d.sigma[0] - 1) + (d.sigma[1] - 1) * (d.sigma[1] - 1));
}

// C and its gradient (nc members, grad nc x 3) of constraint j at x;
// alpha its compliance. Returns the member count.
static int constraint(const ek_cloth_xpbd *x, size_t j, const double *pos, const int32_t **mem,
                      double *C, double grad[12], double *alpha) {
  const ek_cloth *cl = x->cl;
  if (j < cl->nt) {
    const int32_t *q = cl->tris + 3 * j;
    const double *D = cl->dm_inv + 4 * j;
    double F[6], P[6];
    for (int i = 0; i < 3; ++i) {
      double e1 = pos[3 * (size_t)q[1] + i] - pos[3 * (size_t)q[0] + i];
      double e2 = pos[3 * (size_t)q[2] + i] - pos[3 * (size_t)q[0] + i];
      F[2 * i] = e1 * D[0] + e2 * D[2];
      F[2 * i + 1] = e1 * D[1] + e2 * D[3];
    }
    double W = membrane_W(&x->p, F, P);
    *C = sqrt(2 * fmax(W, 0) / x->k);
    *alpha = 1 / (cl->area[j] * x->k);
    *mem = q;
    if (*C > 0)
      for (int i = 0; i < 3; ++i) {
        double g1 = (P[2 * i] * D[0] + P[2 * i + 1] * D[1]) / (x->k * *C);
        double g2 = (P[2 * i] * D[2] + P[2 * i + 1] * D[3]) / (x->k * *C);
        grad[3 + i] = g1;
        grad[6 + i] = g2;
        grad[i] = -(g1 + g2);
      }
    return 3;
  }
  size_t h = j - cl->nt;
  const int32_t *q = cl->hinges + 4 * h;
  const double *k = cl->hinge_k + 4 * h;
  double s[3] = {0, 0, 0};
  for (int c = 0; c < 4; ++c)
    for (int i = 0; i < 3; ++i)
      s[i] += k[c] * pos[3 * (size_t)q[c] + i];
  *C = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  *alpha = 1 / x->p.bending;
  *mem = q;
  if (*C > 0)
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i)
        grad[3 * c + i] = k[c] * s[i] / *C;
  return 4;
}

// Constraints per chunk of a colour's job on the helper team.
#define COLOR_CHUNK 256

typedef struct {
  ek_cloth_xpbd *x;
  double *pos, ih2;
  size_t a, b; // the colour's range of x->order
} colour_job;

// Constraints [a + i COLOR_CHUNK, ...) of the colour: no two share a
// vertex, so the chunks may run in any order, on any thread.
static void colour_chunk(void *ctx, size_t i) {
  const colour_job *cj = ctx;
  ek_cloth_xpbd *x = cj->x;
  double *pos = cj->pos;
  const size_t o0 = cj->a + i * COLOR_CHUNK,
               o1 = o0 + COLOR_CHUNK < cj->b ? o0 + COLOR_CHUNK : cj->b;
  for (size_t o = o0; o < o1; ++o) {
    size_t j = (size_t)x->order[o];
    const int32_t *mem;
    double C, grad[12], alpha;
    int nm = constraint(x, j, pos, &mem, &C, grad, &alpha);
    if (!(C > EK_CLOTH_XPBD_C_MIN))
      continue;
    double at = alpha * cj->ih2, den = at;
    for (int m = 0; m < nm; ++m)
      den += x->w[mem[m]] * (grad[3 * m] * grad[3 * m] + grad[3 * m + 1] * grad[3 * m + 1] +
                             grad[3 * m + 2] * grad[3 * m + 2]);
    double dl = (-C - at * x->lambda[j]) / den;
    x->lambda[j] += dl;
    for (int m = 0; m < nm; ++m)
      for (int k = 0; k < 3; ++k)
        pos[3 * (size_t)mem[m] + k] += x->w[mem[m]] * grad[3 * m + k] * dl;
  }
}

// Each colour is a job of the helper team (kernels/team.h): the next colour
// starts once this one's chunks are done, but never waits for a thread that
// has not started (the barrier per colour of an OpenMP loop did).
int ek_cloth_xpbd_iterate(ek_cloth_xpbd *x, double *pos, int sweeps) {
  if (!x || !pos || sweeps < 0) {
    ek_set_error("ek_cloth_xpbd_iterate: bad arguments");
    return EK_EINVAL;
  }
  const int par = x->cl->nt >= EK_CLOTH_PARALLEL_MIN_TRIS;
  colour_job cj = {x, pos, 1 / (x->h * x->h), 0, 0};
  for (int it = 0; it < sweeps; ++it)
    for (int c = 0; c < x->ncolors; ++c) {
      cj.a = x->color_off[c];
      cj.b = x->color_off[c + 1];
      const size_t n = (cj.b - cj.a + COLOR_CHUNK - 1) / COLOR_CHUNK;
      if (par)
        ek_team_run(n, colour_chunk, &cj);
      else
        for (size_t i = 0; i < n; i++)
          colour_chunk(&cj, i);
    }
  return 0;
}

int ek_cloth_xpbd_residual(const ek_cloth_xpbd *x, const double *pos, double *residual,
                           double *cmax) {
  if (!x || !pos) {
    ek_set_error("ek_cloth_xpbd_residual: bad arguments");
    return EK_EINVAL;
  }
  const double ih2 = 1 / (x->h * x->h);
  double r = 0, cm = 0;
  for (size_t j = 0; j < x->n; ++j) {
    const int32_t *mem;
    double C, grad[12], alpha;
    constraint(x, j, pos, &mem, &C, grad, &alpha);
    r = fmax(r, fabs(C + alpha * ih2 * x->lambda[j]));
    cm = fmax(cm, C);
  }
  if (residual)
    *residual = r;
  if (cmax)
    *cmax = cm;
  return 0;
}
