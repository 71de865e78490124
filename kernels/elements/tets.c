// The tet element layer (include/ek/elements.h): rest-shape data (Dm^-1,
// V0; Teran et al. 2003 sec. 4, seed 004), the Morton order of the
// centroids, the coloured order (colours formed inside Morton chunks, the
// chunks coloured too), the AoSoA packing the kernels read, and the vertex
// incidence lists; the last three through the primitives triangles and
// XPBD share (layer.h). Built once per mesh, at baseline ISA.
#include "tets.h"

#include "layer.h"
#include "morton.h"

#include "../kernels.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void blocks_free(ek_tet_blocks *bl) {
  free(bl->slot_tet);
  ek_free(bl->idx_f32);
  ek_free(bl->idx_f64);
  ek_free(bl->dm_inv_f32);
  ek_free(bl->v0_f32);
  ek_free(bl->dm_inv_f64);
  ek_free(bl->v0_f64);
}

void ek_tets_destroy(ek_tets *el) {
  if (!el)
    return;
  free(el->tets);
  free(el->X);
  free(el->V0);
  free(el->Dm_inv);
  blocks_free(&el->morton);
  blocks_free(&el->colored);
  free(el->phase_chunk);
  free(el->chunk_slot);
  free(el->chunk_group);
  free(el->group_slot);
  free(el->morton_slot);
  free(el->vert_start);
  free(el->vert_entries);
  free(el);
}

// Pack one slot order (bl->slot_tet, bl->nslots set) into AoSoA blocks of
// both precisions (layer.h); padding slots get index -1, Dm^-1 = 0, V0 = 0.
static int blocks_pack(const ek_tets *el, ek_tet_blocks *bl) {
  const size_t W32 = EK_LANES_F32, W64 = EK_LANES_F64;
  size_t ns = bl->nslots, nb32 = ns / W32, nb64 = ns / W64;
  bl->idx_f32 = ek_alloc(nb32 * 4 * W32 * sizeof(int32_t));
  bl->idx_f64 = ek_alloc(nb64 * 4 * W64 * sizeof(int32_t));
  bl->dm_inv_f32 = ek_alloc(nb32 * 9 * W32 * sizeof(float));
  bl->dm_inv_f64 = ek_alloc(nb64 * 9 * W64 * sizeof(double));
  bl->v0_f32 = ek_alloc(nb32 * W32 * sizeof(float));
  bl->v0_f64 = ek_alloc(nb64 * W64 * sizeof(double));
  if (!bl->idx_f32 || !bl->idx_f64 || !bl->dm_inv_f32 || !bl->dm_inv_f64 || !bl->v0_f32 ||
      !bl->v0_f64)
    return -1;
  ek_layer_pack_index(ns, bl->slot_tet, 4, el->tets, W32, bl->idx_f32);
  ek_layer_pack_index(ns, bl->slot_tet, 4, el->tets, W64, bl->idx_f64);
  ek_layer_pack_values(ns, bl->slot_tet, 9, el->Dm_inv, NULL, W32, 0, bl->dm_inv_f32);
  ek_layer_pack_values(ns, bl->slot_tet, 9, el->Dm_inv, NULL, W64, 1, bl->dm_inv_f64);
  ek_layer_pack_values(ns, bl->slot_tet, 1, el->V0, NULL, W32, 0, bl->v0_f32);
  ek_layer_pack_values(ns, bl->slot_tet, 1, el->V0, NULL, W64, 1, bl->v0_f64);
  return 0;
}

// Dm = [X1-X0, X2-X0, X3-X0] as columns (Teran et al. 2003 sec. 4), its
// determinant (6 V0) and inverse by the adjugate.
static double rest_frame(const double *X, const int32_t *t, double Dm_inv[9]) {
  double A[9];
  for (int c = 0; c < 3; c++)
    for (int r = 0; r < 3; r++)
      A[r * 3 + c] = X[(size_t)t[c + 1] * 3 + r] - X[(size_t)t[0] * 3 + r];
  double det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
               A[2] * (A[3] * A[7] - A[4] * A[6]);
  double s = 1.0 / det;
  Dm_inv[0] = (A[4] * A[8] - A[5] * A[7]) * s;
  Dm_inv[1] = (A[2] * A[7] - A[1] * A[8]) * s;
  Dm_inv[2] = (A[1] * A[5] - A[2] * A[4]) * s;
  Dm_inv[3] = (A[5] * A[6] - A[3] * A[8]) * s;
  Dm_inv[4] = (A[0] * A[8] - A[2] * A[6]) * s;
  Dm_inv[5] = (A[2] * A[3] - A[0] * A[5]) * s;
  Dm_inv[6] = (A[3] * A[7] - A[4] * A[6]) * s;
  Dm_inv[7] = (A[1] * A[6] - A[0] * A[7]) * s;
  Dm_inv[8] = (A[0] * A[4] - A[1] * A[3]) * s;
  return det;
}

// Morton order of the centroids in the bounding box, 21 bits per axis.
static int morton_order(const ek_tets *el, const double *X, int32_t *order) {
  size_t nt = el->ntets, nv = el->nverts;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t v = 0; v < nv; v++)
    for (int k = 0; k < 3; k++) {
      lo[k] = fmin(lo[k], X[v * 3 + k]);
      hi[k] = fmax(hi[k], X[v * 3 + k]);
    }
  ek_morton_key *keyed = malloc(nt * sizeof *keyed);
  if (!keyed)
    return -1;
  for (size_t t = 0; t < nt; t++) {
    uint64_t key = 0;
    for (int k = 0; k < 3; k++) {
      // Halved coordinates: the centroid's sum and the box's span stay
      // finite for any finite coordinates (near DBL_MAX, X + X or hi - lo
      // would overflow), and u is clamped to [0, 1] (NaN -> 0) before the
      // conversion to an integer, which is undefined outside its range.
      double c = 0;
      for (int j = 0; j < 4; j++)
        c += X[(size_t)el->tets[t * 4 + j] * 3 + k] / 8;
      double span = hi[k] / 2 - lo[k] / 2;
      double u = span > 0 ? (c - lo[k] / 2) / span : 0;
      u = u >= 0 ? fmin(u, 1.0) : 0;
      key |= ek_morton_spread3((uint64_t)(u * 2097151.0)) << k;
    }
    keyed[t].key = key;
    keyed[t].index = (int32_t)t;
  }
  qsort(keyed, nt, sizeof *keyed, ek_morton_key_cmp);
  for (size_t t = 0; t < nt; t++)
    order[t] = keyed[t].index;
  free(keyed);
  return 0;
}

// The vertices of the Morton slots, slot-major (slot * 4 + corner; -1 in
// padding slots): the sequence the incidence lists and the colourings read.
static int32_t *morton_vertices(const ek_tets *el) {
  int32_t *seq = malloc(el->morton.nslots * 4 * sizeof(int32_t));
  if (seq)
    ek_layer_pack_index(el->morton.nslots, el->morton.slot_tet, 4, el->tets, 1, seq);
  return seq;
}

// The vertex range of each THREAD_BUFFERS part (tets.h), per precision:
// the parts are scatter_share's shares of nslots / lanes blocks.
static void part_ranges(ek_tets *el, const int32_t *seq) {
  for (int f64 = 0; f64 < 2; f64++) {
    const size_t lanes = f64 ? EK_LANES_F64 : EK_LANES_F32, nb = el->morton.nslots / lanes;
    for (int p = 0; p < EK_FVM_PARTS; p++) {
      const size_t b0 = nb * (size_t)p / EK_FVM_PARTS, b1 = nb * (size_t)(p + 1) / EK_FVM_PARTS;
      size_t lo = el->nverts, hi = 0;
      for (size_t e = b0 * lanes * 4; e < b1 * lanes * 4; e++)
        if (seq[e] >= 0) {
          lo = (size_t)seq[e] < lo ? (size_t)seq[e] : lo;
          hi = (size_t)seq[e] + 1 > hi ? (size_t)seq[e] + 1 : hi;
        }
      el->part_vlo[f64][p] = lo < hi ? lo : 0;
      el->part_vhi[f64][p] = lo < hi ? hi : 0;
    }
  }
}

// Vertex incidence (CSR) over the Morton slots (layer.h): entries
// slot * 4 + corner, ascending.
static int incidence(ek_tets *el, const int32_t *seq) {
  size_t nv = el->nverts, *start, *entries;
  if (ek_layer_incidence(nv, el->morton.nslots * 4, seq, &start, &entries))
    return -1;
  el->vert_start = malloc((nv + 1) * sizeof(int32_t));
  el->vert_entries = malloc((start[nv] ? start[nv] : 1) * sizeof(int32_t));
  if (el->vert_start && el->vert_entries) {
    for (size_t v = 0; v <= nv; v++)
      el->vert_start[v] = (int32_t)start[v];
    for (size_t e = 0; e < start[nv]; e++)
      el->vert_entries[e] = (int32_t)entries[e];
  }
  free(start);
  free(entries);
  return el->vert_start && el->vert_entries ? 0 : -1;
}

// Tets per Morton chunk of the coloured order: small enough that a chunk's
// vertices stay in L1/L2 across its colours and that a phase has several
// chunks to share between threads, large enough that the padding of its
// colour groups (each a whole block) stays small. A multiple of the f32
// block; depends on the mesh size only.
static size_t chunk_tets(size_t ntets) {
  size_t c = ntets / 64;
  c = c < 512 ? 512 : c > 4096 ? 4096 : c;
  return c / EK_LANES_F32 * EK_LANES_F32;
}

// The coloured order. Chunks are consecutive ranges of the Morton order.
// Chunk colours: greedy over the chunks in Morton order, each taking the
// smallest colour no chunk sharing a vertex with it has (a chunk's members:
// its tets' distinct vertices). Tet colours: greedy inside each chunk in
// Morton order, each tet taking the smallest colour no tet of its chunk
// sharing a vertex has. Both through the one greedy colouring of layer.h.
static int colored_order(ek_tets *el, const int32_t *seq) {
  const size_t W = EK_LANES_F32, nt = el->ntets, nv = el->nverts;
  const int32_t *morton = el->morton.slot_tet;
  const size_t ct = chunk_tets(nt), nchunks = (nt + ct - 1) / ct;
  el->nchunks = nchunks;
  int rc = -1;
  int32_t *chunk_color = malloc(nchunks * sizeof(int32_t));
  int32_t *tet_color = malloc(nt * sizeof(int32_t)); // by Morton position
  // Chunk members: each chunk's distinct vertices, in first-seen order.
  size_t *cstart = malloc((nchunks + 1) * sizeof(size_t));
  int32_t *cvert = malloc(nt * 4 * sizeof(int32_t));
  size_t *seen = malloc((nv ? nv : 1) * sizeof(size_t));
  size_t *count = NULL, *fill = NULL;
  if (!chunk_color || !tet_color || !cstart || !cvert || !seen)
    goto done;
  for (size_t v = 0; v < nv; v++)
    seen[v] = (size_t)-1;
  size_t nm = 0;
  for (size_t k = 0; k < nchunks; k++) {
    cstart[k] = nm;
    for (size_t i = k * ct * 4; i < (k * ct + ct < nt ? k * ct + ct : nt) * 4; i++)
      if (seen[seq[i]] != k) {
        seen[seq[i]] = k;
        cvert[nm++] = seq[i];
      }
  }
  cstart[nchunks] = nm;
  // Chunk colours (the phases) and tet colours inside each chunk, both
  // greedy in Morton order (layer.h).
  el->nphases = ek_layer_color(nv, nchunks, 0, 0, cstart, cvert, chunk_color);
  el->ncolors = el->nphases < 0 ? -1 : ek_layer_color(nv, nt, ct, 4, NULL, seq, tet_color);
  if (el->nphases < 0 || el->ncolors < 0)
    goto done;

  // Lay out: phase by phase, its chunks in Morton order, each chunk colour
  // group by colour group, every group padded to a whole f32 block.
  const size_t nc = (size_t)el->ncolors;
  count = calloc(nchunks * nc, sizeof(size_t));
  el->phase_chunk = calloc((size_t)el->nphases + 1, sizeof(size_t));
  el->chunk_slot = malloc((nchunks + 1) * sizeof(size_t));
  el->chunk_group = malloc((nchunks + 1) * sizeof(size_t));
  if (!count || !el->phase_chunk || !el->chunk_slot || !el->chunk_group)
    goto done;
  for (size_t i = 0; i < nt; i++)
    count[(i / ct) * nc + (size_t)tet_color[i]]++;
  size_t ngroups = 0, nslots = 0;
  for (size_t k = 0; k < nchunks; k++)
    for (size_t c = 0; c < nc; c++)
      if (count[k * nc + c]) {
        ngroups++;
        nslots += (count[k * nc + c] + W - 1) / W * W;
      }
  el->ngroups = ngroups;
  el->group_slot = malloc((ngroups + 1) * sizeof(size_t));
  el->colored.nslots = nslots;
  el->colored.slot_tet = malloc((nslots ? nslots : 1) * sizeof(int32_t));
  fill = malloc(nc * sizeof(size_t));
  if (!el->group_slot || !el->colored.slot_tet || !fill)
    goto done;
  size_t slot = 0, g = 0, ck = 0;
  for (int p = 0; p < el->nphases; p++) {
    el->phase_chunk[p] = ck;
    for (size_t k = 0; k < nchunks; k++) {
      if (chunk_color[k] != p)
        continue;
      el->chunk_slot[ck] = slot;
      el->chunk_group[ck] = g;
      ck++;
      size_t t0 = k * ct, t1 = t0 + ct < nt ? t0 + ct : nt;
      for (size_t c = 0; c < nc; c++) {
        fill[c] = slot;
        if (!count[k * nc + c])
          continue;
        el->group_slot[g++] = slot;
        size_t padded = (count[k * nc + c] + W - 1) / W * W;
        for (size_t s = slot; s < slot + padded; s++)
          el->colored.slot_tet[s] = -1;
        slot += padded;
      }
      for (size_t i = t0; i < t1; i++)
        el->colored.slot_tet[fill[tet_color[i]]++] = morton[i];
    }
  }
  el->phase_chunk[el->nphases] = ck;
  el->chunk_slot[ck] = slot;
  el->chunk_group[ck] = g;
  el->group_slot[g] = slot;
  rc = blocks_pack(el, &el->colored);
done:
  free(chunk_color);
  free(tet_color);
  free(cstart);
  free(cvert);
  free(seen);
  free(count);
  free(fill);
  return rc;
}

ek_tets *ek_tets_create(size_t nverts, const double *X, size_t ntets, const int32_t *tets) {
  static const char fn[] = "ek_tets_create";
  if ((nverts && !X) || !tets) {
    ek_set_error("%s: NULL vertex or tet array", fn);
    return NULL;
  }
  if (ntets == 0) {
    ek_set_error("%s: no tetrahedra", fn);
    return NULL;
  }
  // Kernels gather coordinates at int32 offsets 3 v + k (vgather_points).
  if (nverts > INT32_MAX / 3 || ntets > (size_t)INT32_MAX / 4) {
    ek_set_error("%s: too large (%zu vertices, %zu tets; limits 2^31 / 3 vertices, 2^31 / 4 tets)",
                 fn, nverts, ntets);
    return NULL;
  }
  for (size_t i = 0; i < nverts * 3; i++)
    if (!isfinite(X[i])) {
      ek_set_error("%s: vertex %zu: coordinate %c = %g is not finite", fn, i / 3, "xyz"[i % 3],
                   X[i]);
      return NULL;
    }
  for (size_t i = 0; i < ntets * 4; i++)
    if (tets[i] < 0 || (size_t)tets[i] >= nverts) {
      ek_set_error("%s: tet %zu: vertex index %d out of range [0, %zu)", fn, i / 4, (int)tets[i],
                   nverts);
      return NULL;
    }
  ek_tets *el = calloc(1, sizeof *el);
  if (!el) {
    ek_set_error("%s: out of memory", fn);
    return NULL;
  }
  el->nverts = nverts;
  el->ntets = ntets;
  el->tets = malloc(ntets * 4 * sizeof(int32_t));
  el->V0 = malloc(ntets * sizeof(double));
  el->Dm_inv = malloc(ntets * 9 * sizeof(double));
  el->X = malloc(nverts * 3 * sizeof(double));
  const size_t W = EK_LANES_F32;
  el->morton.nslots = (ntets + W - 1) / W * W;
  el->morton.slot_tet = malloc(el->morton.nslots * sizeof(int32_t));
  if (!el->tets || !el->V0 || !el->Dm_inv || !el->X || !el->morton.slot_tet)
    goto oom;
  memcpy(el->tets, tets, ntets * 4 * sizeof(int32_t));
  memcpy(el->X, X, nverts * 3 * sizeof(double));
  for (size_t t = 0; t < ntets; t++) {
    double six_v = rest_frame(X, el->tets + t * 4, el->Dm_inv + t * 9);
    if (!(six_v > 0) || !isfinite(six_v)) {
      ek_set_error("%s: tet %zu: det(Dm) = 6V = %g, must be finite and > 0", fn, t, six_v);
      ek_tets_destroy(el);
      return NULL;
    }
    el->V0[t] = six_v / 6;
  }
  for (size_t s = ntets; s < el->morton.nslots; s++)
    el->morton.slot_tet[s] = -1;
  if (morton_order(el, X, el->morton.slot_tet) || blocks_pack(el, &el->morton))
    goto oom;
  int32_t *seq = morton_vertices(el);
  if (seq)
    part_ranges(el, seq);
  int bad = !seq || incidence(el, seq) || colored_order(el, seq);
  free(seq);
  if (bad)
    goto oom;
  el->morton_slot = malloc(ntets * sizeof(int32_t));
  if (!el->morton_slot)
    goto oom;
  for (size_t s = 0; s < ntets; s++)
    el->morton_slot[el->morton.slot_tet[s]] = (int32_t)s;
  return el;
oom:
  ek_tets_destroy(el);
  ek_set_error("%s: out of memory (%zu vertices, %zu tets)", fn, nverts, ntets);
  return NULL;
}

size_t ek_tets_nverts(const ek_tets *el) { return el ? el->nverts : 0; }
size_t ek_tets_count(const ek_tets *el) { return el ? el->ntets : 0; }
const int32_t *ek_tets_vertices(const ek_tets *el) { return el ? el->tets : NULL; }
const double *ek_tets_rest_volumes(const ek_tets *el) { return el ? el->V0 : NULL; }
const double *ek_tets_dm_inv(const ek_tets *el) { return el ? el->Dm_inv : NULL; }
int ek_tets_ncolors(const ek_tets *el) { return el ? el->ncolors : 0; }
int ek_tets_nphases(const ek_tets *el) { return el ? el->nphases : 0; }
size_t ek_tets_nchunks(const ek_tets *el) { return el ? el->nchunks : 0; }
size_t ek_tets_colored_slots(const ek_tets *el) { return el ? el->colored.nslots : 0; }

// ---- Per-element state ----

ek_tet_state *ek_tet_state_create(const ek_tets *el, int planes, int f64) {
  if (!el || planes < 1 || planes > 81 || (f64 != 0 && f64 != 1)) {
    ek_set_error("ek_tet_state_create: elements %p, planes = %d (1..81), f64 = %d (0 or 1)",
                 (const void *)el, planes, f64);
    return NULL;
  }
  ek_tet_state *st = calloc(1, sizeof *st);
  size_t lanes = f64 ? EK_LANES_F64 : EK_LANES_F32, n = el->morton.nslots * (size_t)planes;
  if (st)
    st->data = ek_alloc(n * (f64 ? sizeof(double) : sizeof(float)));
  if (!st || !st->data) {
    free(st);
    ek_set_error("ek_tet_state_create: out of memory (%zu values)", n);
    return NULL;
  }
  st->el = el;
  st->planes = planes;
  st->f64 = f64;
  for (size_t i = 0; i < n; i++) {
    size_t k = i / lanes % (size_t)planes; // plane of value i
    double v = planes == 9 && k % 4 == 0 ? 1 : 0;
    if (f64)
      ((double *)st->data)[i] = v;
    else
      ((float *)st->data)[i] = (float)v;
  }
  return st;
}

void ek_tet_state_destroy(ek_tet_state *st) {
  if (!st)
    return;
  ek_free(st->data);
  free(st);
}

int ek_tet_state_planes(const ek_tet_state *st) { return st ? st->planes : 0; }

// Index of (slot, plane k) in the state's AoSoA data.
static size_t state_index(const ek_tet_state *st, size_t slot, int k) {
  size_t lanes = st->f64 ? EK_LANES_F64 : EK_LANES_F32;
  return ((slot / lanes) * (size_t)st->planes + (size_t)k) * lanes + slot % lanes;
}

int ek_tet_state_set_f64(ek_tet_state *st, const double *values) {
  if (!st || !values) {
    ek_set_error("ek_tet_state_set_f64: NULL argument");
    return EK_EINVAL;
  }
  for (size_t t = 0; t < st->el->ntets; t++)
    for (int k = 0; k < st->planes; k++) {
      size_t i = state_index(st, (size_t)st->el->morton_slot[t], k);
      double v = values[t * (size_t)st->planes + (size_t)k];
      if (st->f64)
        ((double *)st->data)[i] = v;
      else
        ((float *)st->data)[i] = (float)v;
    }
  return EK_OK;
}

int ek_tet_state_get_f64(const ek_tet_state *st, double *values) {
  if (!st || !values) {
    ek_set_error("ek_tet_state_get_f64: NULL argument");
    return EK_EINVAL;
  }
  for (size_t t = 0; t < st->el->ntets; t++)
    for (int k = 0; k < st->planes; k++) {
      size_t i = state_index(st, (size_t)st->el->morton_slot[t], k);
      values[t * (size_t)st->planes + (size_t)k] =
          st->f64 ? ((const double *)st->data)[i] : (double)((const float *)st->data)[i];
    }
  return EK_OK;
}
