// Per-element velocity gradient fields of the simulation state
// (ek_sim_rate_fields, sim.h): L = D + W and the principal strain rates
// from the body (body.h: tets L = Fdot F^-1, triangles L = Fdot F^+, seed
// 003 eqs. 28-31, through include/ek/cloth.h); and the per-vertex rotation
// field from Kabsch over each vertex's one-ring (ek_sim_vertex_rotations,
// seed 003 eqs. 21-27).
#include "sim_internal.h"

#include <ek/cloth.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int ek_sim_rate_fields(const ek_sim *s, double *D, double *W, double *rates) {
  double *Dw = D ? D : malloc(9 * s->nt * sizeof(double));
  int rc = Dw ? s->body->ops->rate_fields(s, Dw, W, rates) : EK_ENOMEM;
  if (!D)
    free(Dw);
  return rc;
}

static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

// Vertex v's one-ring: itself first, then the other vertices of its
// elements, ascending, each once.
static int build_rings(ek_sim *s) {
  const int nc = s->body->corners;
  const int32_t *E = s->body->elems;
  const double *X = s->body->X;
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
