// Tetrahedral meshes: validation, rest-shape precompute (Dm^-1, V0, lumped
// volumes; Teran et al. 2003 sec. 4, seed 004), locality reordering (Morton
// order of centroids), greedy colouring and the AoSoA packing the FVM
// kernels read. Readers live in mesh_io.c and call mesh_build().
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh_build.h"
#include "mesh_internal.h"

void mesh_error(char *err, size_t errlen, const char *fmt, ...) {
  if (!err || errlen == 0)
    return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(err, errlen, fmt, ap);
  va_end(ap);
}

static void blocks_free(ek_mesh_blocks *bl) {
  free(bl->slot_tet);
  ek_free(bl->idx_f32);
  ek_free(bl->idx_f64);
  ek_free(bl->dm_inv_f32);
  ek_free(bl->v0_f32);
  ek_free(bl->dm_inv_f64);
  ek_free(bl->v0_f64);
}

// Pack one slot order (bl->slot_tet, bl->nslots set) into AoSoA blocks of
// both precisions; padding slots get index -1, Dm^-1 = 0, V0 = 0.
static int blocks_pack(const ek_mesh *m, ek_mesh_blocks *bl) {
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
  for (size_t s = 0; s < ns; s++) {
    int32_t t = bl->slot_tet[s];
    size_t b32 = s / W32, l32 = s % W32, b64 = s / W64, l64 = s % W64;
    for (int c = 0; c < 4; c++) {
      int32_t vi = t >= 0 ? m->tets[t * 4 + c] : -1;
      bl->idx_f32[(b32 * 4 + c) * W32 + l32] = vi;
      bl->idx_f64[(b64 * 4 + c) * W64 + l64] = vi;
    }
    for (int k = 0; k < 9; k++) {
      double d = t >= 0 ? m->Dm_inv[t * 9 + k] : 0.0;
      bl->dm_inv_f32[(b32 * 9 + k) * W32 + l32] = (float)d;
      bl->dm_inv_f64[(b64 * 9 + k) * W64 + l64] = d;
    }
    double v0 = t >= 0 ? m->V0[t] : 0.0;
    bl->v0_f32[b32 * W32 + l32] = (float)v0;
    bl->v0_f64[b64 * W64 + l64] = v0;
  }
  return 0;
}

void ek_mesh_destroy(ek_mesh *m) {
  if (!m)
    return;
  free(m->X);
  free(m->tets);
  free(m->V0);
  free(m->Dm_inv);
  free(m->lumped);
  free(m->color_slot_start);
  blocks_free(&m->colored);
  blocks_free(&m->morton);
  free(m->vert_start);
  free(m->vert_entries);
  free(m);
}

// Where an element came from, for messages: "file:line" when read from a
// file, "ek_mesh_create: tet i" otherwise.
static void where_tet(char *buf, size_t len, const mesh_origin *o, size_t t) {
  if (o && o->file && o->tet_line)
    snprintf(buf, len, "%s:%ld: tet %zu", o->file, o->tet_line[t], t);
  else
    snprintf(buf, len, "%s: tet %zu", o && o->file ? o->file : "ek_mesh_create", t);
}

static void where_vert(char *buf, size_t len, const mesh_origin *o, size_t v) {
  if (o && o->file && o->vert_line)
    snprintf(buf, len, "%s:%ld: vertex %zu", o->file, o->vert_line[v], v);
  else
    snprintf(buf, len, "%s: vertex %zu", o && o->file ? o->file : "ek_mesh_create", v);
}

// 3x3 helpers on row-major arrays.
static double det3(const double A[9]) {
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
         A[2] * (A[3] * A[7] - A[4] * A[6]);
}

// Inverse by the adjugate; det != 0 is checked by the caller.
static void inv3(const double A[9], double det, double Ai[9]) {
  double s = 1.0 / det;
  Ai[0] = (A[4] * A[8] - A[5] * A[7]) * s;
  Ai[1] = (A[2] * A[7] - A[1] * A[8]) * s;
  Ai[2] = (A[1] * A[5] - A[2] * A[4]) * s;
  Ai[3] = (A[5] * A[6] - A[3] * A[8]) * s;
  Ai[4] = (A[0] * A[8] - A[2] * A[6]) * s;
  Ai[5] = (A[2] * A[3] - A[0] * A[5]) * s;
  Ai[6] = (A[3] * A[7] - A[4] * A[6]) * s;
  Ai[7] = (A[1] * A[6] - A[0] * A[7]) * s;
  Ai[8] = (A[0] * A[4] - A[1] * A[3]) * s;
}

// Dm = [X1-X0, X2-X0, X3-X0] as columns (Teran et al. 2003 sec. 4).
static void rest_edges(const double *X, const int32_t *t, double Dm[9]) {
  for (int c = 0; c < 3; c++)
    for (int r = 0; r < 3; r++)
      Dm[r * 3 + c] = X[t[c + 1] * 3 + r] - X[t[0] * 3 + r];
}

static double longest_edge(const double *X, const int32_t *t) {
  double best = 0;
  for (int a = 0; a < 4; a++)
    for (int b = a + 1; b < 4; b++) {
      double d2 = 0;
      for (int k = 0; k < 3; k++) {
        double d = X[t[a] * 3 + k] - X[t[b] * 3 + k];
        d2 += d * d;
      }
      if (d2 > best)
        best = d2;
    }
  return sqrt(best);
}

static double shortest_edge(const double *X, const int32_t *t) {
  double best = INFINITY;
  for (int a = 0; a < 4; a++)
    for (int b = a + 1; b < 4; b++) {
      double d2 = 0;
      for (int k = 0; k < 3; k++) {
        double d = X[t[a] * 3 + k] - X[t[b] * 3 + k];
        d2 += d * d;
      }
      if (d2 < best)
        best = d2;
    }
  return sqrt(best);
}

// Spread the low 21 bits of v so that there are two zero bits between
// consecutive bits (3D Morton interleave).
static uint64_t spread3(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

typedef struct {
  uint64_t key;
  int32_t tet;
} keyed_tet;

static int cmp_keyed(const void *a, const void *b) {
  const keyed_tet *x = a, *y = b;
  if (x->key != y->key)
    return x->key < y->key ? -1 : 1;
  return (x->tet > y->tet) - (x->tet < y->tet); // stable: ties by index
}

// Validate, precompute and pack. Takes ownership of nothing; copies X and
// tets. On error returns NULL with the message in err.
ek_mesh *mesh_build(size_t nverts, const double *X, size_t ntets, const int32_t *tets_in,
                    const ek_mesh_opts *opts, const mesh_origin *origin, char *err, size_t errlen) {
  char where[512];
  const char *src = origin && origin->file ? origin->file : "ek_mesh_create";
  int fix = opts ? opts->fix_orientation : 0;
  if ((nverts && !X) || (ntets && !tets_in)) {
    mesh_error(err, errlen, "%s: NULL vertex or tet array", src);
    return NULL;
  }
  if (nverts > INT32_MAX || ntets > (size_t)INT32_MAX / 4) {
    mesh_error(err, errlen, "%s: too large (%zu vertices, %zu tets; limit 2^31)", src, nverts,
               ntets);
    return NULL;
  }
  if (ntets == 0) {
    mesh_error(err, errlen, "%s: no tetrahedra", src);
    return NULL;
  }
  for (size_t v = 0; v < nverts; v++)
    for (int k = 0; k < 3; k++)
      if (!isfinite(X[v * 3 + k])) {
        where_vert(where, sizeof where, origin, v);
        mesh_error(err, errlen, "%s: coordinate %c = %g is not finite", where, "xyz"[k],
                   X[v * 3 + k]);
        return NULL;
      }
  for (size_t t = 0; t < ntets; t++)
    for (int c = 0; c < 4; c++) {
      int32_t i = tets_in[t * 4 + c];
      if (i < 0 || (size_t)i >= nverts) {
        where_tet(where, sizeof where, origin, t);
        // Files are reported in their own numbering (base), memory 0-based.
        long base = origin ? origin->index_base : 0;
        mesh_error(err, errlen, "%s: vertex index %ld out of range [%ld, %ld]", where,
                   (long)i + base, base, (long)nverts - 1 + base);
        return NULL;
      }
    }

  ek_mesh *m = calloc(1, sizeof *m);
  if (!m) {
    mesh_error(err, errlen, "%s: out of memory", src);
    return NULL;
  }
  m->nverts = nverts;
  m->ntets = ntets;
  m->X = malloc(nverts * 3 * sizeof(double));
  m->tets = malloc(ntets * 4 * sizeof(int32_t));
  m->V0 = malloc(ntets * sizeof(double));
  m->Dm_inv = malloc(ntets * 9 * sizeof(double));
  m->lumped = calloc(nverts, sizeof(double));
  unsigned char *used = calloc(nverts, 1);
  if (!m->X || !m->tets || !m->V0 || !m->Dm_inv || !m->lumped || !used) {
    free(used);
    ek_mesh_destroy(m);
    mesh_error(err, errlen, "%s: out of memory", src);
    return NULL;
  }
  memcpy(m->X, X, nverts * 3 * sizeof(double));
  memcpy(m->tets, tets_in, ntets * 4 * sizeof(int32_t));

  // Fewer than 4 distinct vertices cannot span a volume: reported before
  // the per-tet checks, which would only name one symptom of it.
  size_t ndistinct = 0;
  for (size_t i = 0; i < ntets * 4; i++)
    if (!used[m->tets[i]]) {
      used[m->tets[i]] = 1;
      ndistinct++;
    }
  if (ndistinct < 4) {
    mesh_error(err, errlen, "%s: only %zu distinct vertices used (need at least 4)", src,
               ndistinct);
    goto fail;
  }
  m->min_edge = INFINITY;
  for (size_t t = 0; t < ntets; t++) {
    int32_t *tv = m->tets + t * 4;
    for (int a = 0; a < 4; a++)
      for (int b = a + 1; b < 4; b++)
        if (tv[a] == tv[b]) {
          where_tet(where, sizeof where, origin, t);
          long base = origin ? origin->index_base : 0;
          mesh_error(err, errlen,
                     "%s: degenerate: vertex %ld appears twice (vertices %ld %ld %ld %ld)", where,
                     (long)tv[a] + base, (long)tv[0] + base, (long)tv[1] + base, (long)tv[2] + base,
                     (long)tv[3] + base);
          goto fail;
        }
    double Dm[9];
    rest_edges(m->X, tv, Dm);
    double six_v = det3(Dm);
    double lmax = longest_edge(m->X, tv);
    // Degenerate: 6|V| <= 1e-12 * (longest edge)^3 (DESIGN.md, "Meshes").
    if (fabs(six_v) <= EK_MESH_DEGENERATE_REL * lmax * lmax * lmax) {
      where_tet(where, sizeof where, origin, t);
      mesh_error(err, errlen,
                 "%s: degenerate: 6V = %.6g <= %g * (longest edge %.6g)^3 (zero volume)", where,
                 six_v, EK_MESH_DEGENERATE_REL, lmax);
      goto fail;
    }
    if (six_v < 0) {
      if (!fix) {
        where_tet(where, sizeof where, origin, t);
        mesh_error(err, errlen,
                   "%s: inverted: rest volume %.6g < 0 (refused; set fix_orientation to swap "
                   "its vertices 1 and 2)",
                   where, six_v / 6);
        goto fail;
      }
      int32_t tmp = tv[1];
      tv[1] = tv[2];
      tv[2] = tmp;
      m->nfixed++;
      rest_edges(m->X, tv, Dm);
      six_v = det3(Dm);
    }
    m->V0[t] = six_v / 6;
    inv3(Dm, six_v, m->Dm_inv + t * 9);
    double lmin = shortest_edge(m->X, tv);
    if (lmin < m->min_edge)
      m->min_edge = lmin;
    for (int c = 0; c < 4; c++)
      m->lumped[tv[c]] += m->V0[t] / 4;
  }
  free(used);
  used = NULL;
  if (mesh_layout(m) != 0) {
    mesh_error(err, errlen, "%s: out of memory", src);
    goto fail;
  }
  return m;
fail:
  free(used);
  ek_mesh_destroy(m);
  return NULL;
}

// Morton order, greedy colouring, slots, AoSoA packing, vertex lists.
int mesh_layout(ek_mesh *m) {
  size_t nt = m->ntets, nv = m->nverts;
  const int32_t *T = m->tets;

  // Morton order of centroids in the bounding box, 21 bits per axis.
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t v = 0; v < nv; v++)
    for (int k = 0; k < 3; k++) {
      if (m->X[v * 3 + k] < lo[k])
        lo[k] = m->X[v * 3 + k];
      if (m->X[v * 3 + k] > hi[k])
        hi[k] = m->X[v * 3 + k];
    }
  keyed_tet *order = malloc(nt * sizeof *order);
  if (!order)
    return -1;
  for (size_t t = 0; t < nt; t++) {
    uint64_t key = 0;
    for (int k = 0; k < 3; k++) {
      double c = 0;
      for (int j = 0; j < 4; j++)
        c += m->X[T[t * 4 + j] * 3 + k];
      c /= 4;
      double span = hi[k] - lo[k];
      double u = span > 0 ? (c - lo[k]) / span : 0;
      uint64_t q = (uint64_t)(u * 2097151.0);
      key |= spread3(q) << k;
    }
    order[t].key = key;
    order[t].tet = (int32_t)t;
  }
  qsort(order, nt, sizeof *order, cmp_keyed);

  // Greedy colouring in Morton order: each tet takes the smallest colour
  // no tet sharing one of its vertices has. Per-vertex bit sets of used
  // colours; greedy needs at most (tets touching the neighbourhood) + 1
  // colours, bounded by 4 * max vertex degree + 1.
  size_t *deg = calloc(nv, sizeof *deg);
  int32_t *color = malloc(nt * sizeof *color);
  if (!deg || !color) {
    free(order);
    free(deg);
    free(color);
    return -1;
  }
  for (size_t i = 0; i < nt * 4; i++)
    deg[T[i]]++;
  size_t maxdeg = 0;
  for (size_t v = 0; v < nv; v++)
    if (deg[v] > maxdeg)
      maxdeg = deg[v];
  size_t words = (4 * maxdeg + 1 + 63) / 64;
  uint64_t *usedc = calloc(nv * words, sizeof *usedc);
  if (!usedc) {
    free(order);
    free(deg);
    free(color);
    return -1;
  }
  int ncolors = 0;
  for (size_t i = 0; i < nt; i++) {
    int32_t t = order[i].tet;
    int c = 0;
    for (size_t w = 0; w < words; w++) {
      uint64_t busy = 0;
      for (int j = 0; j < 4; j++)
        busy |= usedc[(size_t)T[t * 4 + j] * words + w];
      if (~busy) {
        c = (int)(w * 64) + __builtin_ctzll(~busy);
        break;
      }
    }
    color[t] = c;
    for (int j = 0; j < 4; j++)
      usedc[(size_t)T[t * 4 + j] * words + c / 64] |= 1ULL << (c % 64);
    if (c + 1 > ncolors)
      ncolors = c + 1;
  }
  free(usedc);

  // Morton order: the tets as sorted, padded at the end.
  const size_t W32 = EK_LANES_F32;
  m->morton.nslots = (nt + W32 - 1) / W32 * W32;
  m->morton.slot_tet = malloc(m->morton.nslots * sizeof(int32_t));
  // Colour-major order: Morton order inside a colour, each colour padded
  // to a multiple of the f32 block width.
  size_t *count = calloc((size_t)ncolors + 1, sizeof *count);
  m->color_slot_start = calloc((size_t)ncolors + 1, sizeof(size_t));
  if (!count || !m->color_slot_start || !m->morton.slot_tet) {
    free(order);
    free(deg);
    free(color);
    free(count);
    return -1;
  }
  for (size_t s = 0; s < m->morton.nslots; s++)
    m->morton.slot_tet[s] = s < nt ? order[s].tet : -1;
  for (size_t t = 0; t < nt; t++)
    count[color[t]]++;
  for (int c = 0; c < ncolors; c++)
    m->color_slot_start[c + 1] = m->color_slot_start[c] + (count[c] + W32 - 1) / W32 * W32;
  m->ncolors = ncolors;
  m->colored.nslots = m->color_slot_start[ncolors];
  m->colored.slot_tet = malloc(m->colored.nslots * sizeof(int32_t));
  if (!m->colored.slot_tet) {
    free(order);
    free(deg);
    free(color);
    free(count);
    return -1;
  }
  for (size_t s = 0; s < m->colored.nslots; s++)
    m->colored.slot_tet[s] = -1;
  for (int c = 0; c < ncolors; c++)
    count[c] = m->color_slot_start[c];
  for (size_t i = 0; i < nt; i++) {
    int32_t t = order[i].tet;
    m->colored.slot_tet[count[color[t]]++] = t;
  }
  free(order);
  free(color);
  free(count);
  if (blocks_pack(m, &m->colored) || blocks_pack(m, &m->morton)) {
    free(deg);
    return -1;
  }

  // Vertex-centric lists (CSR) over the Morton order, entries ascending by
  // slot then corner because slots are visited in order.
  m->vert_start = calloc(nv + 1, sizeof(int32_t));
  m->vert_entries = malloc(nt * 4 * sizeof(int32_t));
  if (!m->vert_start || !m->vert_entries) {
    free(deg);
    return -1;
  }
  for (size_t v = 0; v < nv; v++)
    m->vert_start[v + 1] = m->vert_start[v] + (int32_t)deg[v];
  for (size_t v = 0; v < nv; v++)
    deg[v] = (size_t)m->vert_start[v];
  for (size_t s = 0; s < m->morton.nslots; s++) {
    int32_t t = m->morton.slot_tet[s];
    if (t < 0)
      continue;
    for (int c = 0; c < 4; c++)
      m->vert_entries[deg[T[t * 4 + c]]++] = (int32_t)(s * 4 + (size_t)c);
  }
  free(deg);
  return 0;
}

ek_mesh *ek_mesh_create_ex(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                           const ek_mesh_opts *opts, char *err, size_t errlen) {
  return mesh_build(nverts, X, ntets, tets, opts, NULL, err, errlen);
}

ek_mesh *ek_mesh_create(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                        char *err, size_t errlen) {
  return mesh_build(nverts, X, ntets, tets, NULL, NULL, err, errlen);
}

// Kuhn (Freudenthal) split of each cube into 6 tets around the diagonal
// from corner 0 to corner 7: one tet per permutation of the axes, the path
// 0 -> e_a -> e_a+e_b -> 7. All cubes use the same split, so shared faces
// are cut along the same diagonal and the mesh is conforming. Odd
// permutations are listed with vertices 1 and 2 swapped so all volumes are
// positive.
ek_mesh *ek_mesh_box(int nx, int ny, int nz, double lx, double ly, double lz, char *err,
                     size_t errlen) {
  if (nx < 1 || ny < 1 || nz < 1) {
    mesh_error(err, errlen, "ek_mesh_box: cell counts %d x %d x %d must be >= 1", nx, ny, nz);
    return NULL;
  }
  if (!(lx > 0 && isfinite(lx)) || !(ly > 0 && isfinite(ly)) || !(lz > 0 && isfinite(lz))) {
    mesh_error(err, errlen, "ek_mesh_box: sizes %g x %g x %g must be finite and > 0", lx, ly, lz);
    return NULL;
  }
  size_t px = (size_t)nx + 1, py = (size_t)ny + 1, pz = (size_t)nz + 1;
  size_t nverts = px * py * pz, ncubes = (size_t)nx * ny * nz;
  if (nverts > INT32_MAX || ncubes > (size_t)INT32_MAX / 24) {
    mesh_error(err, errlen, "ek_mesh_box: %d x %d x %d cells is too large", nx, ny, nz);
    return NULL;
  }
  double *X = malloc(nverts * 3 * sizeof(double));
  int32_t *T = malloc(ncubes * 6 * 4 * sizeof(int32_t));
  if (!X || !T) {
    free(X);
    free(T);
    mesh_error(err, errlen, "ek_mesh_box: out of memory");
    return NULL;
  }
  for (size_t k = 0; k < pz; k++)
    for (size_t j = 0; j < py; j++)
      for (size_t i = 0; i < px; i++) {
        size_t v = (k * py + j) * px + i;
        X[v * 3 + 0] = lx * (double)i / nx;
        X[v * 3 + 1] = ly * (double)j / ny;
        X[v * 3 + 2] = lz * (double)k / nz;
      }
  // Corner c of a cube: bit 0 = +x, bit 1 = +y, bit 2 = +z. The tet of
  // the axis permutation (a, b, c) has Dm = [e_a, e_a+e_b, 7] whose
  // determinant is the permutation's sign, so odd permutations get
  // corners 1 and 2 swapped to keep det Dm > 0.
  // Path corners for each axis permutation (a, b, c): 0, e_a, e_a + e_b, 7.
  static const int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {1, 0, 2}, {2, 1, 0}};
  size_t t = 0;
  for (size_t k = 0; k < (size_t)nz; k++)
    for (size_t j = 0; j < (size_t)ny; j++)
      for (size_t i = 0; i < (size_t)nx; i++) {
        int32_t corner[8];
        for (int c = 0; c < 8; c++)
          corner[c] =
              (int32_t)(((k + (c >> 2 & 1)) * py + (j + (c >> 1 & 1))) * px + (i + (c & 1)));
        for (int p = 0; p < 6; p++) {
          int a = 1 << perms[p][0], ab = a | 1 << perms[p][1];
          int32_t *tv = T + t * 4;
          tv[0] = corner[0];
          tv[1] = corner[a];
          tv[2] = corner[ab];
          tv[3] = corner[7];
          if (p >= 3) { // odd permutation: negative orientation, swap 1 and 2
            int32_t tmp = tv[1];
            tv[1] = tv[2];
            tv[2] = tmp;
          }
          t++;
        }
      }
  mesh_origin o = {.file = "ek_mesh_box", .index_base = 0};
  ek_mesh *m = mesh_build(nverts, X, ncubes * 6, T, NULL, &o, err, errlen);
  free(X);
  free(T);
  return m;
}

size_t ek_mesh_nverts(const ek_mesh *m) { return m ? m->nverts : 0; }
size_t ek_mesh_ntets(const ek_mesh *m) { return m ? m->ntets : 0; }
const double *ek_mesh_rest_positions(const ek_mesh *m) { return m ? m->X : NULL; }
const int32_t *ek_mesh_tets(const ek_mesh *m) { return m ? m->tets : NULL; }
const double *ek_mesh_rest_volumes(const ek_mesh *m) { return m ? m->V0 : NULL; }
const double *ek_mesh_dm_inv(const ek_mesh *m) { return m ? m->Dm_inv : NULL; }
const double *ek_mesh_lumped_volume(const ek_mesh *m) { return m ? m->lumped : NULL; }
int ek_mesh_ncolors(const ek_mesh *m) { return m ? m->ncolors : 0; }
size_t ek_mesh_nfixed(const ek_mesh *m) { return m ? m->nfixed : 0; }
double ek_mesh_min_edge(const ek_mesh *m) { return m ? m->min_edge : 0; }
