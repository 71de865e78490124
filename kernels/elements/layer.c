// The element-layer primitives shared by every element kind (layer.h):
// incidence lists, greedy colouring, AoSoA packing.
#include "layer.h"

#include <stdlib.h>
#include <string.h>

int ek_layer_incidence(size_t nv, size_t n, const int32_t *vert, size_t **start_out,
                       size_t **entries_out) {
  size_t *start = calloc(nv + 1, sizeof *start);
  size_t *next = malloc((nv ? nv : 1) * sizeof *next);
  size_t *entries = NULL;
  if (!start || !next)
    goto oom;
  for (size_t i = 0; i < n; i++)
    if (vert[i] >= 0)
      start[vert[i] + 1]++;
  for (size_t v = 0; v < nv; v++)
    start[v + 1] += start[v];
  entries = malloc((start[nv] ? start[nv] : 1) * sizeof *entries);
  if (!entries)
    goto oom;
  memcpy(next, start, nv * sizeof *next);
  for (size_t i = 0; i < n; i++)
    if (vert[i] >= 0)
      entries[next[vert[i]]++] = i;
  free(next);
  *start_out = start;
  *entries_out = entries;
  return 0;
oom:
  free(start);
  free(next);
  free(entries);
  return -1;
}

// Vertices of element e (layer.h).
static void members(size_t e, int nc, const size_t *estart, size_t *m0, size_t *m1) {
  *m0 = estart ? estart[e] : e * (size_t)nc;
  *m1 = estart ? estart[e + 1] : (e + 1) * (size_t)nc;
}

int ek_layer_color(size_t nv, size_t n, size_t chunk, int nc, const size_t *estart,
                   const int32_t *vert, int32_t *color) {
  if (chunk == 0)
    chunk = n ? n : 1;
  // Greedy needs at most (elements sharing a vertex with one element) + 1
  // colours: members x (elements per vertex) + 1 bounds it.
  size_t *deg = calloc(nv ? nv : 1, sizeof *deg), maxdeg = 0, maxm = 0;
  if (!deg)
    return -1;
  for (size_t e = 0; e < n; e++) {
    size_t m0, m1;
    members(e, nc, estart, &m0, &m1);
    maxm = m1 - m0 > maxm ? m1 - m0 : maxm;
    for (size_t m = m0; m < m1; m++)
      if (++deg[vert[m]] > maxdeg)
        maxdeg = deg[vert[m]];
  }
  free(deg);
  // No more colours than elements either (chunks of tets have many members).
  size_t bound = maxm * maxdeg < n ? maxm * maxdeg : n;
  const size_t words = (bound + 1 + 63) / 64;
  uint64_t *used = calloc((nv ? nv : 1) * (words ? words : 1), sizeof *used);
  if (!used)
    return -1;
  int ncolors = 0;
  for (size_t e0 = 0; e0 < n; e0 += chunk) {
    size_t e1 = e0 + chunk < n ? e0 + chunk : n;
    for (size_t e = e0; e < e1; e++) {
      size_t m0, m1;
      members(e, nc, estart, &m0, &m1);
      if (m0 == m1) {
        color[e] = -1;
        continue;
      }
      int col = 0;
      for (size_t w = 0; w < words; w++) {
        uint64_t b = 0;
        for (size_t m = m0; m < m1; m++)
          b |= used[(size_t)vert[m] * words + w];
        if (~b) {
          col = (int)(w * 64) + __builtin_ctzll(~b);
          break;
        }
      }
      color[e] = col;
      for (size_t m = m0; m < m1; m++)
        used[(size_t)vert[m] * words + (size_t)col / 64] |= 1ULL << (col % 64);
      if (col + 1 > ncolors)
        ncolors = col + 1;
    }
    // Clear the chunk's vertices for the next chunk (its own graph).
    for (size_t e = e0; e < e1; e++) {
      size_t m0, m1;
      members(e, nc, estart, &m0, &m1);
      for (size_t m = m0; m < m1; m++)
        memset(used + (size_t)vert[m] * words, 0, words * sizeof *used);
    }
  }
  free(used);
  return ncolors;
}

void ek_layer_pack_index(size_t nslots, const int32_t *slot_elem, int planes, const int32_t *vert,
                         size_t L, int32_t *out) {
  for (size_t s = 0; s < nslots; s++) {
    int32_t e = slot_elem[s];
    size_t b = s / L, l = s % L;
    for (int k = 0; k < planes; k++)
      out[(b * (size_t)planes + (size_t)k) * L + l] =
          e >= 0 ? vert[(size_t)e * (size_t)planes + (size_t)k] : -1;
  }
}

void ek_layer_pack_values(size_t nslots, const int32_t *slot_elem, int planes, const double *val,
                          const double *pad, size_t L, int f64, void *out) {
  for (size_t s = 0; s < nslots; s++) {
    int32_t e = slot_elem[s];
    size_t b = s / L, l = s % L;
    for (int k = 0; k < planes; k++) {
      double v = e >= 0 ? val[(size_t)e * (size_t)planes + (size_t)k] : pad ? pad[k] : 0.0;
      size_t at = (b * (size_t)planes + (size_t)k) * L + l;
      if (f64)
        ((double *)out)[at] = v;
      else
        ((float *)out)[at] = (float)v;
    }
  }
}
