// The cloth element layer (include/ek/cloth_force.h): rest frames, bending
// hinges with the coefficients of Bergou et al. 2006, AoSoA blocks in both
// precisions and the vertex incidence the deterministic gather walks.
// Built once, at baseline ISA (integer and setup work).
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <ek/batch.h>

#include "../kernels.h"
#include "cloth_layer.h"

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

double ek_cloth_rest_frame(const double *X0, const double *X1, const double *X2, double dm_inv[4]) {
  double e1[3], e2[3], n[3], t2[3];
  sub3(X1, X0, e1);
  sub3(X2, X0, e2);
  cross3(e1, e2, n);
  double l1 = sqrt(dot3(e1, e1)), ln = sqrt(dot3(n, n));
  double area = 0.5 * ln;
  if (!(area > 0))
    return area;
  // t1 = e1 / |e1|, t2 = n x t1 / |n|: Dm = [[|e1|, e2.t1], [0, e2.t2]].
  cross3(n, e1, t2);
  double a = l1, b = dot3(e2, e1) / l1, d = dot3(e2, t2) / (ln * l1);
  // Dm^-1 of the upper-triangular [[a, b], [0, d]].
  dm_inv[0] = 1 / a;
  dm_inv[1] = -b / (a * d);
  dm_inv[2] = 0;
  dm_inv[3] = 1 / d;
  return area;
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

// Vertex -> element corners, in element order (counting sort).
static int build_incidence(size_t nv, size_t ne, int nc, const int32_t *el, size_t **off_out,
                           int32_t **ref_out) {
  size_t *off = calloc(nv + 1, sizeof *off);
  int32_t *ref = malloc((ne ? ne : 1) * (size_t)nc * sizeof *ref);
  size_t *pos = malloc((nv ? nv : 1) * sizeof *pos);
  if (!off || !ref || !pos) {
    free(off);
    free(ref);
    free(pos);
    return EK_ENOMEM;
  }
  for (size_t e = 0; e < ne * (size_t)nc; ++e)
    off[el[e] + 1]++;
  for (size_t v = 0; v < nv; ++v)
    off[v + 1] += off[v];
  memcpy(pos, off, nv * sizeof *pos);
  for (size_t e = 0; e < ne * (size_t)nc; ++e)
    ref[pos[el[e]]++] = (int32_t)e;
  free(pos);
  *off_out = off;
  *ref_out = ref;
  return 0;
}

// AoSoA planes of one precision: idx (nc planes), values (nval planes, the
// padding value pad[k] for plane k).
static int pack_blocks(size_t ne, int nc, const int32_t *el, int nval, const double *val,
                       const double *pad, size_t L, int f64, size_t *nblocks, int32_t **idx,
                       void **vals) {
  size_t nb = (ne + L - 1) / L;
  *nblocks = nb;
  size_t slots = (nb ? nb : 1) * L;
  *idx = ek_alloc(slots * (size_t)nc * sizeof(int32_t));
  *vals = ek_alloc(slots * (size_t)nval * (f64 ? sizeof(double) : sizeof(float)));
  if (!*idx || !*vals)
    return EK_ENOMEM;
  for (size_t s = 0; s < slots; ++s) {
    size_t b = s / L, l = s % L;
    for (int c = 0; c < nc; ++c)
      (*idx)[(b * (size_t)nc + (size_t)c) * L + l] = s < ne ? el[s * (size_t)nc + (size_t)c] : -1;
    for (int k = 0; k < nval; ++k) {
      double v = s < ne ? val[s * (size_t)nval + (size_t)k] : pad[k];
      size_t at = (b * (size_t)nval + (size_t)k) * L + l;
      if (f64)
        ((double *)*vals)[at] = v;
      else
        ((float *)*vals)[at] = (float)v;
    }
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
    double longest = 0, e[3];
    for (int c = 0; c < 3; ++c) {
      sub3(X + 3 * (size_t)q[(c + 1) % 3], X + 3 * (size_t)q[c], e);
      longest = fmax(longest, dot3(e, e));
    }
    double A = ek_cloth_rest_frame(X0, X1, X2, cl->dm_inv + 4 * t);
    if (!(2 * A > EK_CLOTH_DEGENERATE_REL * longest)) {
      ek_set_error("ek_cloth_create: triangle %zu (%d %d %d): twice the rest area %g <= %g "
                   "(longest edge squared %g): degenerate (zero-area) triangle",
                   t, q[0], q[1], q[2], 2 * A, EK_CLOTH_DEGENERATE_REL * longest, longest);
      ek_cloth_destroy(cl);
      return NULL;
    }
    cl->area[t] = A;
    for (int c = 0; c < 3; ++c)
      cl->lumped[q[c]] += A / 3;
  }
  if (build_hinges(cl) != 0 ||
      build_incidence(nverts, ntris, 3, cl->tris, &cl->tri_off, &cl->tri_ref) != 0 ||
      build_incidence(nverts, cl->nh, 4, cl->hinges, &cl->hinge_off, &cl->hinge_ref) != 0)
    goto oom;
  // Tri planes: Dm^-1 (4) then the area (1), split after packing.
  double *tv = malloc(5 * ntris * sizeof(double));
  if (!tv)
    goto oom;
  for (size_t t = 0; t < ntris; ++t) {
    memcpy(tv + 5 * t, cl->dm_inv + 4 * t, 4 * sizeof(double));
    tv[5 * t + 4] = cl->area[t];
  }
  const double tri_pad[5] = {1, 0, 0, 1, 0}, hinge_pad[4] = {0, 0, 0, 0};
  int rc = 0;
  for (int f64 = 0; f64 < 2 && rc == 0; ++f64) {
    size_t L = f64 ? EK_LANES_F64 : EK_LANES_F32, nb;
    int32_t *idx;
    void *vals;
    rc = pack_blocks(ntris, 3, cl->tris, 5, tv, tri_pad, L, f64, &nb, &idx, &vals);
    void *dm = ek_alloc((nb ? nb : 1) * L * 4 * (f64 ? 8 : 4)),
         *ar = ek_alloc((nb ? nb : 1) * L * (f64 ? 8 : 4));
    if (rc == 0 && dm && ar) {
      size_t es = f64 ? 8 : 4;
      for (size_t b = 0; b < nb; ++b) {
        memcpy((char *)dm + b * 4 * L * es, (char *)vals + b * 5 * L * es, 4 * L * es);
        memcpy((char *)ar + b * L * es, (char *)vals + (b * 5 + 4) * L * es, L * es);
      }
    } else {
      rc = EK_ENOMEM;
    }
    ek_free(vals);
    if (f64) {
      cl->ntb_f64 = nb, cl->tri_idx_f64 = idx, cl->dm_f64 = dm, cl->area_f64 = ar;
    } else {
      cl->ntb_f32 = nb, cl->tri_idx_f32 = idx, cl->dm_f32 = dm, cl->area_f32 = ar;
    }
    if (rc == 0) {
      rc = pack_blocks(cl->nh, 4, cl->hinges, 4, cl->hinge_k, hinge_pad, L, f64, &nb, &idx, &vals);
      if (f64)
        cl->nhb_f64 = nb, cl->hinge_idx_f64 = idx, cl->hk_f64 = vals;
      else
        cl->nhb_f32 = nb, cl->hinge_idx_f32 = idx, cl->hk_f32 = vals;
    }
  }
  free(tv);
  if (rc)
    goto oom;
  cl->tri_corner_f32 = ek_alloc((cl->ntb_f32 ? cl->ntb_f32 : 1) * 9 * EK_LANES_F32 * sizeof(float));
  cl->tri_corner_f64 =
      ek_alloc((cl->ntb_f64 ? cl->ntb_f64 : 1) * 9 * EK_LANES_F64 * sizeof(double));
  cl->hinge_corner_f32 =
      ek_alloc((cl->nhb_f32 ? cl->nhb_f32 : 1) * 12 * EK_LANES_F32 * sizeof(float));
  cl->hinge_corner_f64 =
      ek_alloc((cl->nhb_f64 ? cl->nhb_f64 : 1) * 12 * EK_LANES_F64 * sizeof(double));
  if (!cl->tri_corner_f32 || !cl->tri_corner_f64 || !cl->hinge_corner_f32 || !cl->hinge_corner_f64)
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
