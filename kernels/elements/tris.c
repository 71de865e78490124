// The triangle element layer (include/ek/cloth_force.h): rest frames (the
// one triangle rest frame and degeneracy check of ek, also behind
// ek_tri_rest_f64), bending hinges with the coefficients of Bergou et al.
// 2006, AoSoA blocks in both precisions and the vertex incidence the
// deterministic gather walks, through the primitives tets share
// (layer.h). Built once, at baseline ISA (integer and setup work).
#include <ek/cloth.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <ek/batch.h>

#include "../kernels.h"
#include "layer.h"
#include "tris.h"

static double dot3(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static void cross3(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}
static void sub3(const double *a, const double *b, double *c) {
  for (int i = 0; i < 3; ++i)
    c[i] = a[i] - b[i];
}

double ek_tri_rest_frame(const double *X0, const double *X1, const double *X2, int rounding,
                         double dm_inv[4]) {
  double e1[3], e2[3], n[3], t2[3];
  sub3(X1, X0, e1);
  sub3(X2, X0, e2);
  cross3(e1, e2, n);
  double l1 = sqrt(dot3(e1, e1)), ln = sqrt(dot3(n, n));
  double area = 0.5 * ln;
  if (!(area > 0))
    return area;
  // t1 = e1 / |e1|, t2 = n x t1 / |n|: Dm = [[|e1|, e2.t1], [0, e2.t2]].
  double a = l1, b = dot3(e2, e1) / l1, d;
  if (rounding == EK_TRI_REST_VIA_T2) {
    cross3(n, e1, t2);
    d = dot3(e2, t2) / (ln * l1);
  } else {
    d = ln / l1;
  }
  // Dm^-1 of the upper-triangular [[a, b], [0, d]].
  dm_inv[0] = 1 / a;
  dm_inv[1] = -b / (a * d);
  dm_inv[2] = 0;
  dm_inv[3] = 1 / d;
  return area;
}

// The degeneracy rule (cloth.h), on the edges scaled by 2^-e (the largest
// component in [0.5, 1), exact), so that it decides at any scale as the
// unscaled test does wherever that one is in range (the scaling of
// sim/mesh_tri.c, issue 28).
int ek_tri_degenerate(const double X0[3], const double X1[3], const double X2[3], double *two_area,
                      double *longest2) {
  double e1[3], e2[3], e3[3], n[3], emax = 0;
  sub3(X1, X0, e1);
  sub3(X2, X0, e2);
  sub3(X2, X1, e3);
  for (int k = 0; k < 3; ++k)
    emax = fmax(emax, fmax(fabs(e1[k]), fmax(fabs(e2[k]), fabs(e3[k]))));
  if (!isfinite(emax)) {
    if (two_area)
      *two_area = NAN;
    if (longest2)
      *longest2 = INFINITY;
    return 1;
  }
  int e = 0;
  frexp(emax, &e);
  for (int k = 0; k < 3; ++k)
    e1[k] = ldexp(e1[k], -e), e2[k] = ldexp(e2[k], -e), e3[k] = ldexp(e3[k], -e);
  cross3(e1, e2, n);
  double a2 = sqrt(dot3(n, n));
  double l2 = fmax(dot3(e1, e1), fmax(dot3(e2, e2), dot3(e3, e3)));
  if (two_area)
    *two_area = ldexp(a2, 2 * e);
  if (longest2)
    *longest2 = ldexp(l2, 2 * e);
  return !(a2 > EK_TRI_DEGENERATE_REL * l2);
}

// cot of the angle between u and v.
static double cot_angle(const double *u, const double *v) {
  double c[3];
  cross3(u, v, c);
  return dot3(u, v) / sqrt(dot3(c, c));
}

typedef struct {
  int32_t a, b; // edge vertices, a < b
  int32_t t;    // triangle
  int8_t c;     // local edge: vertices c, c+1 (mod 3)
} half_edge;

static int half_edge_cmp(const void *pa, const void *pb) {
  const half_edge *x = pa, *y = pb;
  if (x->a != y->a)
    return x->a < y->a ? -1 : 1;
  if (x->b != y->b)
    return x->b < y->b ? -1 : 1;
  return x->t < y->t ? -1 : x->t > y->t;
}

void ek_cloth_destroy(ek_cloth *cl) {
  if (!cl)
    return;
  free(cl->X);
  free(cl->tris);
  free(cl->dm_inv);
  free(cl->area);
  free(cl->hinges);
  free(cl->hinge_k);
  free(cl->lumped);
  ek_free(cl->tri_idx_f32);
  ek_free(cl->tri_idx_f64);
  ek_free(cl->hinge_idx_f32);
  ek_free(cl->hinge_idx_f64);
  ek_free(cl->dm_f32);
  ek_free(cl->area_f32);
  ek_free(cl->hk_f32);
  ek_free(cl->dm_f64);
  ek_free(cl->area_f64);
  ek_free(cl->hk_f64);
  free(cl->tri_off);
  free(cl->hinge_off);
  free(cl->tri_ref);
  free(cl->hinge_ref);
  ek_free(cl->tri_corner_f32);
  ek_free(cl->hinge_corner_f32);
  ek_free(cl->tri_corner_f64);
  ek_free(cl->hinge_corner_f64);
  ek_free(cl->energy_buf);
  free((void *)cl->energy_ready);
  free(cl);
}

// Hinges: edges shared by exactly two triangles, in the order of their
// sorted vertex pairs. x0, x1 the edge as the first triangle walks it, x2
// its opposite vertex there, x3 the second triangle's.
static int build_hinges(ek_cloth *cl) {
  size_t n = 3 * cl->nt;
  half_edge *he = malloc((n ? n : 1) * sizeof *he);
  if (!he)
    return EK_ENOMEM;
  for (size_t t = 0; t < cl->nt; ++t)
    for (int c = 0; c < 3; ++c) {
      int32_t u = cl->tris[3 * t + c], v = cl->tris[3 * t + (c + 1) % 3];
      he[3 * t + c] = (half_edge){u < v ? u : v, u < v ? v : u, (int32_t)t, (int8_t)c};
    }
  qsort(he, n, sizeof *he, half_edge_cmp);
  size_t nh = 0;
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && he[j].a == he[i].a && he[j].b == he[i].b)
      j++;
    nh += j - i == 2;
    i = j;
  }
  cl->nh = nh;
  cl->hinges = malloc((nh ? nh : 1) * 4 * sizeof(int32_t));
  cl->hinge_k = malloc((nh ? nh : 1) * 4 * sizeof(double));
  if (!cl->hinges || !cl->hinge_k) {
    free(he);
    return EK_ENOMEM;
  }
  size_t h = 0;
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && he[j].a == he[i].a && he[j].b == he[i].b)
      j++;
    if (j - i == 2) {
      const int32_t *t0 = cl->tris + 3 * (size_t)he[i].t, *t1 = cl->tris + 3 * (size_t)he[i + 1].t;
      int c0 = he[i].c, c1 = he[i + 1].c;
      int32_t *q = cl->hinges + 4 * h;
      q[0] = t0[c0];
      q[1] = t0[(c0 + 1) % 3];
      q[2] = t0[(c0 + 2) % 3];
      q[3] = t1[(c1 + 2) % 3];
      // Bergou et al. 2006 sec. 4: K from the cotangents of the rest angles
      // at the edge's ends, Q = 3 / (A0 + A1) K K^T.
      const double *X0 = cl->X + 3 * (size_t)q[0], *X1 = cl->X + 3 * (size_t)q[1],
                   *X2 = cl->X + 3 * (size_t)q[2], *X3 = cl->X + 3 * (size_t)q[3];
      double e0[3], e1[3], e2[3], e3[3], e4[3], me0[3];
      sub3(X1, X0, e0);
      sub3(X2, X0, e1);
      sub3(X3, X0, e2);
      sub3(X2, X1, e3);
      sub3(X3, X1, e4);
      for (int k = 0; k < 3; ++k)
        me0[k] = -e0[k];
      double c01 = cot_angle(e0, e1), c02 = cot_angle(e0, e2), c03 = cot_angle(me0, e3),
             c04 = cot_angle(me0, e4);
      double A = cl->area[he[i].t] + cl->area[he[i + 1].t], w = sqrt(3.0 / A);
      double *k = cl->hinge_k + 4 * h;
      k[0] = w * (c03 + c04);
      k[1] = w * (c01 + c02);
      k[2] = -w * (c01 + c03);
      k[3] = -w * (c02 + c04);
      h++;
    }
    i = j;
  }
  free(he);
  return 0;
}

// Caller-order slots of ne elements in blocks of L lanes (-1 padding; at
// least one block, so an empty set still has valid planes).
static int32_t *caller_slots(size_t ne, size_t L, size_t *nslots) {
  size_t nb = (ne + L - 1) / L;
  *nslots = (nb ? nb : 1) * L;
  int32_t *s = malloc(*nslots * sizeof *s);
  if (s)
    for (size_t i = 0; i < *nslots; ++i)
      s[i] = i < ne ? (int32_t)i : -1;
  return s;
}

// Both precisions' AoSoA blocks (layer.h): triangles 3 index planes,
// Dm^-1 4 (padding I), area 1 (padding 0); hinges 4 index planes, k 4
// (padding 0).
static int pack_layer(ek_cloth *cl) {
  static const double dm_pad[4] = {1, 0, 0, 1};
  for (int f64 = 0; f64 < 2; ++f64) {
    size_t L = f64 ? EK_LANES_F64 : EK_LANES_F32, es = f64 ? sizeof(double) : sizeof(float);
    size_t nts, nhs;
    int32_t *ts = caller_slots(cl->nt, L, &nts), *hs = caller_slots(cl->nh, L, &nhs);
    int32_t *tidx = ek_alloc(nts * 3 * sizeof(int32_t)),
            *hidx = ek_alloc(nhs * 4 * sizeof(int32_t));
    void *dm = ek_alloc(nts * 4 * es), *ar = ek_alloc(nts * es), *hk = ek_alloc(nhs * 4 * es);
    if (f64) {
      cl->ntb_f64 = (cl->nt + L - 1) / L, cl->nhb_f64 = (cl->nh + L - 1) / L;
      cl->tri_idx_f64 = tidx, cl->hinge_idx_f64 = hidx, cl->dm_f64 = dm, cl->area_f64 = ar,
      cl->hk_f64 = hk;
    } else {
      cl->ntb_f32 = (cl->nt + L - 1) / L, cl->nhb_f32 = (cl->nh + L - 1) / L;
      cl->tri_idx_f32 = tidx, cl->hinge_idx_f32 = hidx, cl->dm_f32 = dm, cl->area_f32 = ar,
      cl->hk_f32 = hk;
    }
    int ok = ts && hs && tidx && hidx && dm && ar && hk;
    if (ok) {
      ek_layer_pack_index(nts, ts, 3, cl->tris, L, tidx);
      ek_layer_pack_values(nts, ts, 4, cl->dm_inv, dm_pad, L, f64, dm);
      ek_layer_pack_values(nts, ts, 1, cl->area, NULL, L, f64, ar);
      ek_layer_pack_index(nhs, hs, 4, cl->hinges, L, hidx);
      ek_layer_pack_values(nhs, hs, 4, cl->hinge_k, NULL, L, f64, hk);
    }
    free(ts);
    free(hs);
    if (!ok)
      return EK_ENOMEM;
  }
  return 0;
}

ek_cloth *ek_cloth_create(size_t nverts, const double *X, size_t ntris, const int32_t *tris) {
  if (!X || !tris || nverts < 3 || ntris == 0 || ntris > (size_t)INT32_MAX / 4 ||
      nverts > (size_t)INT32_MAX / 3) {
    ek_set_error("ek_cloth_create: need >= 3 vertices and >= 1 triangle (got %zu, %zu)", nverts,
                 ntris);
    return NULL;
  }
  for (size_t i = 0; i < 3 * nverts; ++i)
    if (!isfinite(X[i])) {
      ek_set_error("ek_cloth_create: vertex %zu: coordinate %g is not finite", i / 3, X[i]);
      return NULL;
    }
  for (size_t t = 0; t < ntris; ++t) {
    const int32_t *q = tris + 3 * t;
    for (int c = 0; c < 3; ++c)
      if (q[c] < 0 || (size_t)q[c] >= nverts) {
        ek_set_error("ek_cloth_create: triangle %zu: vertex index %d out of range [0, %zu)", t,
                     q[c], nverts);
        return NULL;
      }
    if (q[0] == q[1] || q[1] == q[2] || q[0] == q[2]) {
      ek_set_error("ek_cloth_create: triangle %zu: repeated vertex (%d %d %d)", t, q[0], q[1],
                   q[2]);
      return NULL;
    }
  }
  ek_cloth *cl = calloc(1, sizeof *cl);
  if (!cl)
    return NULL;
  cl->nv = nverts;
  cl->nt = ntris;
  cl->X = malloc(3 * nverts * sizeof(double));
  cl->tris = malloc(3 * ntris * sizeof(int32_t));
  cl->dm_inv = malloc(4 * ntris * sizeof(double));
  cl->area = malloc(ntris * sizeof(double));
  cl->lumped = calloc(nverts, sizeof(double));
  if (!cl->X || !cl->tris || !cl->dm_inv || !cl->area || !cl->lumped)
    goto oom;
  memcpy(cl->X, X, 3 * nverts * sizeof(double));
  memcpy(cl->tris, tris, 3 * ntris * sizeof(int32_t));
  for (size_t t = 0; t < ntris; ++t) {
    const int32_t *q = tris + 3 * t;
    const double *X0 = X + 3 * (size_t)q[0], *X1 = X + 3 * (size_t)q[1], *X2 = X + 3 * (size_t)q[2];
    double twoA, longest;
    if (ek_tri_degenerate(X0, X1, X2, &twoA, &longest)) {
      ek_set_error("ek_cloth_create: triangle %zu (%d %d %d): twice the rest area %g <= %g "
                   "(longest edge squared %g): degenerate (zero-area) triangle",
                   t, q[0], q[1], q[2], twoA, EK_CLOTH_DEGENERATE_REL * longest, longest);
      ek_cloth_destroy(cl);
      return NULL;
    }
    double A = ek_tri_rest_frame(X0, X1, X2, EK_TRI_REST_VIA_T2, cl->dm_inv + 4 * t);
    cl->area[t] = A;
    for (int c = 0; c < 3; ++c)
      cl->lumped[q[c]] += A / 3;
  }
  if (build_hinges(cl) != 0 ||
      ek_layer_incidence(nverts, 3 * ntris, cl->tris, &cl->tri_off, &cl->tri_ref) != 0 ||
      ek_layer_incidence(nverts, 4 * cl->nh, cl->hinges, &cl->hinge_off, &cl->hinge_ref) != 0 ||
      pack_layer(cl) != 0)
    goto oom;
  cl->tri_corner_f32 = ek_alloc((cl->ntb_f32 ? cl->ntb_f32 : 1) * 9 * EK_LANES_F32 * sizeof(float));
  cl->tri_corner_f64 =
      ek_alloc((cl->ntb_f64 ? cl->ntb_f64 : 1) * 9 * EK_LANES_F64 * sizeof(double));
  cl->hinge_corner_f32 =
      ek_alloc((cl->nhb_f32 ? cl->nhb_f32 : 1) * 12 * EK_LANES_F32 * sizeof(float));
  cl->hinge_corner_f64 =
      ek_alloc((cl->nhb_f64 ? cl->nhb_f64 : 1) * 12 * EK_LANES_F64 * sizeof(double));
  size_t neb = (ntris + cl->nh) / EK_CLOTH_ENERGY_BLOCK_F32 + 2; // f32 block sums
  cl->energy_buf = ek_alloc((cl->nh + 3 * nverts + neb) * sizeof(double));
  cl->energy_ready = calloc(ntris / EK_CLOTH_ENERGY_TRIS + cl->nh / EK_CLOTH_ENERGY_CHUNK + 2,
                            sizeof(atomic_uchar));
  if (!cl->tri_corner_f32 || !cl->tri_corner_f64 || !cl->hinge_corner_f32 ||
      !cl->hinge_corner_f64 || !cl->energy_buf || !cl->energy_ready)
    goto oom;
  return cl;
oom:
  ek_set_error("ek_cloth_create: out of memory for %zu vertices, %zu triangles", nverts, ntris);
  ek_cloth_destroy(cl);
  return NULL;
}

size_t ek_cloth_nverts(const ek_cloth *cl) { return cl->nv; }
size_t ek_cloth_ntris(const ek_cloth *cl) { return cl->nt; }
size_t ek_cloth_nhinges(const ek_cloth *cl) { return cl->nh; }
const int32_t *ek_cloth_tris(const ek_cloth *cl) { return cl->tris; }
const double *ek_cloth_rest_areas(const ek_cloth *cl) { return cl->area; }
const double *ek_cloth_dm_inv(const ek_cloth *cl) { return cl->dm_inv; }
const int32_t *ek_cloth_hinges(const ek_cloth *cl) { return cl->hinges; }
const double *ek_cloth_hinge_k(const ek_cloth *cl) { return cl->hinge_k; }
const double *ek_cloth_lumped_area(const ek_cloth *cl) { return cl->lumped; }
