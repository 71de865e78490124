// Per-element velocity gradient fields of the simulation state
// (ek_sim_rate_fields, sim.h): L = D + W from the cloth kernels
// (include/ek/cloth.h: tets L = Fdot F^-1, triangles L = Fdot F^+, seed 003
// eqs. 28-31) and the principal strain rates; and the per-vertex rotation
// field from Kabsch over each vertex's one-ring (ek_sim_vertex_rotations,
// seed 003 eqs. 21-27).
#include "sim_internal.h"

#include <ek/cloth.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

// Eigenvalues of a symmetric 3x3 A (row-major), descending, in closed
// form (Smith 1961, CACM 4(4): A = q I + p B, det B = 2 cos(3 phi)).
static void sym3_eigenvalues(const double *A, double e[3]) {
  double p1 = A[1] * A[1] + A[2] * A[2] + A[5] * A[5];
  double q = (A[0] + A[4] + A[8]) / 3;
  double p2 = (A[0] - q) * (A[0] - q) + (A[4] - q) * (A[4] - q) + (A[8] - q) * (A[8] - q) + 2 * p1;
  if (!(p2 > 0)) {
    e[0] = e[1] = e[2] = q;
    return;
  }
  double p = sqrt(p2 / 6), B[9];
  for (int k = 0; k < 9; ++k)
    B[k] = (A[k] - (k % 4 == 0 ? q : 0)) / p;
  double r = 0.5 * (B[0] * (B[4] * B[8] - B[5] * B[7]) - B[1] * (B[3] * B[8] - B[5] * B[6]) +
                    B[2] * (B[3] * B[7] - B[4] * B[6]));
  r = r < -1 ? -1 : r > 1 ? 1 : r;
  double phi = acos(r) / 3;
  e[0] = q + 2 * p * cos(phi);
  e[2] = q + 2 * p * cos(phi + 2.0943951023931955 /* 2 pi / 3 */);
  e[1] = 3 * q - e[0] - e[2];
}

int ek_sim_rate_fields(const ek_sim *s, double *D, double *W, double *rates) {
  size_t ne = s->nt;
  double *Dw = D ? D : malloc(9 * ne * sizeof(double));
  double *xc = NULL, *vc = NULL;
  int rc = Dw ? 0 : EK_ENOMEM;
  if (rc == 0 && s->cloth) {
    // Corners and their velocities, n x 9 (cloth.h's AoS layout).
    const int32_t *T = ek_cloth_tris(s->cloth);
    xc = malloc(9 * ne * sizeof(double));
    vc = malloc(9 * ne * sizeof(double));
    if (!xc || !vc)
      rc = EK_ENOMEM;
    for (size_t t = 0; rc == 0 && t < ne; ++t)
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k) {
          xc[9 * t + 3 * c + k] = s->x[3 * (size_t)T[3 * t + c] + k];
          vc[9 * t + 3 * c + k] = s->v[3 * (size_t)T[3 * t + c] + k];
        }
    if (rc == 0)
      rc = ek_tri_velocity_gradient_f64(ne, xc, vc, NULL, Dw, W, NULL);
  } else if (rc == 0) {
    rc = ek_mesh_velocity_gradient_f64(s->mesh, s->x, s->v, NULL, Dw, W);
  }
  for (size_t e = 0; rc == 0 && rates && e < ne; ++e) {
    const double *d = Dw + 9 * e;
    double *r = rates + 3 * e;
    if (!s->cloth) {
      sym3_eigenvalues(d, r);
      continue;
    }
    // In the deformed plane: t1 along the first edge, t2 = n x t1; the 2x2
    // form M = [t_a . D t_b] and its eigenvalues.
    const double *x0 = xc + 9 * e, *x1 = x0 + 3, *x2 = x0 + 6;
    double t1[3], e2[3], n[3], t2[3];
    for (int k = 0; k < 3; ++k)
      t1[k] = x1[k] - x0[k], e2[k] = x2[k] - x0[k];
    n[0] = t1[1] * e2[2] - t1[2] * e2[1];
    n[1] = t1[2] * e2[0] - t1[0] * e2[2];
    n[2] = t1[0] * e2[1] - t1[1] * e2[0];
    double l1 = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    double ln = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(l1 > 0) || !(ln > 0)) {
      r[0] = r[1] = r[2] = NAN; // a collapsed triangle has no plane
      continue;
    }
    for (int k = 0; k < 3; ++k)
      t1[k] /= l1, n[k] /= ln;
    t2[0] = n[1] * t1[2] - n[2] * t1[1];
    t2[1] = n[2] * t1[0] - n[0] * t1[2];
    t2[2] = n[0] * t1[1] - n[1] * t1[0];
    double M[3] = {0, 0, 0}; // M00, M01, M11
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        M[0] += t1[i] * d[3 * i + j] * t1[j];
        M[1] += t1[i] * d[3 * i + j] * t2[j];
        M[2] += t2[i] * d[3 * i + j] * t2[j];
      }
    double m = 0.5 * (M[0] + M[2]), h = hypot(0.5 * (M[0] - M[2]), M[1]);
    r[0] = m + h;
    r[1] = m - h;
    r[2] = 0;
  }
  if (!D)
    free(Dw);
  free(xc);
  free(vc);
  return rc;
}

static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

// Vertex v's one-ring: itself first, then the other vertices of its
// elements, ascending, each once.
static int build_rings(ek_sim *s) {
  const int nc = s->cloth ? 3 : 4;
  const int32_t *E = s->cloth ? ek_cloth_tris(s->cloth) : ek_mesh_tets(s->mesh);
  const double *X =
      s->cloth ? ek_trimesh_rest_positions(s->trimesh) : ek_mesh_rest_positions(s->mesh);
  size_t nv = s->nv, ne = s->nt;
  size_t *cnt = calloc(nv + 1, sizeof *cnt);
  if (!cnt)
    return EK_ENOMEM;
  for (size_t e = 0; e < ne * (size_t)nc; ++e)
    cnt[E[e] + 1] += (size_t)nc - 1;
  for (size_t v = 0; v < nv; ++v)
    cnt[v + 1] += cnt[v] + 1; // room for v itself
  int32_t *tmp = malloc((cnt[nv] ? cnt[nv] : 1) * sizeof *tmp);
  size_t *pos = malloc((nv ? nv : 1) * sizeof *pos);
  s->ring_off = calloc(nv + 1, sizeof *s->ring_off);
  if (!tmp || !pos || !s->ring_off) {
    free(tmp);
    free(pos);
    free(cnt);
    return EK_ENOMEM;
  }
  for (size_t v = 0; v < nv; ++v)
    pos[v] = cnt[v] + 1;
  for (size_t e = 0; e < ne; ++e)
    for (int a = 0; a < nc; ++a)
      for (int b = 0; b < nc; ++b)
        if (a != b) {
          int32_t v = E[e * (size_t)nc + (size_t)a];
          tmp[pos[v]++] = E[e * (size_t)nc + (size_t)b];
        }
  int32_t *out = malloc((cnt[nv] ? cnt[nv] : 1) * sizeof *out);
  if (!out) {
    free(tmp);
    free(pos);
    free(cnt);
    return EK_ENOMEM;
  }
  size_t n = 0;
  for (size_t v = 0; v < nv; ++v) {
    int32_t *nb = tmp + cnt[v] + 1;
    size_t k = pos[v] - cnt[v] - 1;
    qsort(nb, k, sizeof *nb, cmp_i32);
    out[n++] = (int32_t)v;
    for (size_t i = 0; i < k; ++i)
      if (i == 0 || nb[i] != nb[i - 1])
        out[n++] = nb[i];
    s->ring_off[v + 1] = n;
  }
  free(tmp);
  free(pos);
  free(cnt);
  s->ring = out;
  s->ring_P = malloc((n ? n : 1) * 3 * sizeof(double));
  s->ring_Q = malloc((n ? n : 1) * 3 * sizeof(double));
  if (!s->ring_P || !s->ring_Q)
    return EK_ENOMEM;
  for (size_t i = 0; i < n; ++i)
    memcpy(s->ring_P + 3 * i, X + 3 * (size_t)s->ring[i], 3 * sizeof(double));
  return 0;
}

int ek_sim_vertex_rotations(const ek_sim *cs, double *R) {
  ek_sim *s = (ek_sim *)cs; // the one-rings are built once, on first use
  if (!R)
    return EK_EINVAL;
  if (!s->ring && build_rings(s) != 0)
    return EK_ENOMEM;
  size_t n = s->ring_off[s->nv];
  for (size_t i = 0; i < n; ++i)
    memcpy(s->ring_Q + 3 * i, s->x + 3 * (size_t)s->ring[i], 3 * sizeof(double));
  return ek_kabsch_f64(s->nv, s->ring_off, s->ring_P, s->ring_Q, NULL, R);
}
