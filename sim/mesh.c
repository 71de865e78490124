// Tetrahedral meshes: validation (with the file, line and value in every
// message), orientation fixes, lumped volumes and the CFL edge length; the
// rest-shape data, orders and AoSoA blocks the kernels read are the element
// layer's (kernels/elements/, built from the validated arrays). Readers
// live in mesh_io.c and call mesh_build().
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "errbuf.h"
#include "mesh_box.h"
#include "mesh_build.h"

void mesh_error(char *err, size_t errlen, const char *fmt, ...) {
  if (!err || errlen == 0)
    return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(err, errlen, fmt, ap);
  va_end(ap);
}

void ek_mesh_destroy(ek_mesh *m) {
  if (!m)
    return;
  free(m->X);
  free(m->lumped);
  ek_tets_destroy(m->el);
  free(m);
}

// An element's vertex set, sorted, and its index: sorted records put
// duplicates side by side.
typedef struct {
  int32_t v[4];
  size_t index;
} elem_key;

static int cmp_elem_key(const void *pa, const void *pb) {
  const elem_key *a = pa, *b = pb;
  for (int k = 0; k < 4; k++)
    if (a->v[k] != b->v[k])
      return a->v[k] < b->v[k] ? -1 : 1;
  return (a->index > b->index) - (a->index < b->index);
}

int mesh_find_duplicate(const int32_t *elems, size_t n, int nodes, size_t *first, size_t *second) {
  elem_key *keys = malloc((n ? n : 1) * sizeof *keys);
  if (!keys)
    return -1;
  for (size_t e = 0; e < n; e++) {
    elem_key *k = keys + e;
    k->v[3] = -1; // triangles: the fourth slot is the same for all
    for (int c = 0; c < nodes; c++) {
      int32_t x = elems[e * (size_t)nodes + c];
      int j = c;
      for (; j > 0 && k->v[j - 1] > x; j--) // insertion sort of <= 4 indices
        k->v[j] = k->v[j - 1];
      k->v[j] = x;
    }
    k->index = e;
  }
  qsort(keys, n, sizeof *keys, cmp_elem_key);
  int found = 0;
  for (size_t i = 1; i < n; i++)
    if (memcmp(keys[i].v, keys[i - 1].v, sizeof keys[i].v) == 0 &&
        (i < 2 || memcmp(keys[i - 2].v, keys[i].v, sizeof keys[i].v) != 0) &&
        (!found || keys[i].index < *second)) {
      // keys[i - 1] and keys[i]: the two lowest indices of this set.
      *first = keys[i - 1].index;
      *second = keys[i].index;
      found = 1;
    }
  free(keys);
  return found;
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
    snprintf(buf, len, "%s:%ld: vertex %zu", o->vert_file ? o->vert_file : o->file, o->vert_line[v],
             v);
  else
    snprintf(buf, len, "%s: vertex %zu", o && o->file ? o->file : "ek_mesh_create", v);
}

// 3x3 helpers on row-major arrays.
static double det3(const double A[9]) {
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
         A[2] * (A[3] * A[7] - A[4] * A[6]);
}

// Dm = [X1-X0, X2-X0, X3-X0] as columns (Teran et al. 2003 sec. 4).
static void rest_edges(const double *X, const int32_t *t, double Dm[9]) {
  for (int c = 0; c < 3; c++)
    for (int r = 0; r < 3; r++)
      Dm[r * 3 + c] = X[t[c + 1] * 3 + r] - X[t[0] * 3 + r];
}

static double maxabs9(const double A[9]) {
  double s = 0;
  for (int k = 0; k < 9; k++)
    s = fmax(s, fabs(A[k]));
  return s;
}

// Longest and shortest of the 6 edges of a tet whose edge vectors from
// vertex 0 are the columns of D (the other three edges are differences of
// columns).
static void edge_range(const double D[9], double *lmin, double *lmax) {
  static const int ends[6][2] = {{-1, 0}, {-1, 1}, {-1, 2}, {0, 1}, {0, 2}, {1, 2}};
  double lo = INFINITY, hi = 0;
  for (int e = 0; e < 6; e++) {
    double d2 = 0;
    for (int r = 0; r < 3; r++) {
      double a = ends[e][0] < 0 ? 0 : D[r * 3 + ends[e][0]], b = D[r * 3 + ends[e][1]];
      d2 += (b - a) * (b - a);
    }
    lo = fmin(lo, d2);
    hi = fmax(hi, d2);
  }
  *lmin = sqrt(lo);
  *lmax = sqrt(hi);
}

// m * 2^e2 as text, also where that value is beyond the range of a double
// (a rest frame measured in scaled units, see mesh_build).
void mesh_fmt_scaled(char *buf, size_t len, double m, int e2) {
  double v = ldexp(m, e2);
  if (m == 0 || (isfinite(v) && fabs(v) >= DBL_MIN)) {
    snprintf(buf, len, "%.6g", v);
    return;
  }
  double l = log10(fabs(m)) + e2 * log10(2.0), d = floor(l), mant = pow(10, l - d);
  if (mant >= 9.999995) { // would print as "10" with 6 digits
    mant /= 10;
    d += 1;
  }
  snprintf(buf, len, "%s%.6ge%+d", m < 0 ? "-" : "", mant, (int)d);
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
  int32_t *T = malloc(ntets * 4 * sizeof(int32_t)); // orientation fixes applied
  unsigned char *used = calloc(nverts, 1);
  if (m) {
    m->X = malloc(nverts * 3 * sizeof(double));
    m->lumped = calloc(nverts, sizeof(double));
  }
  if (!m || !T || !used || !m->X || !m->lumped) {
    mesh_error(err, errlen, "%s: out of memory", src);
    goto fail;
  }
  memcpy(m->X, X, nverts * 3 * sizeof(double));
  memcpy(T, tets_in, ntets * 4 * sizeof(int32_t));

  // Fewer than 4 distinct vertices cannot span a volume: reported before
  // the per-tet checks, which would only name one symptom of it.
  size_t ndistinct = 0;
  for (size_t i = 0; i < ntets * 4; i++)
    if (!used[T[i]]) {
      used[T[i]] = 1;
      ndistinct++;
    }
  if (ndistinct < 4) {
    mesh_error(err, errlen, "%s: only %zu distinct vertices used (need at least 4)", src,
               ndistinct);
    goto fail;
  }
  m->min_edge = INFINITY;
  for (size_t t = 0; t < ntets; t++) {
    int32_t *tv = T + t * 4;
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
    for (int k = 0; k < 9; k++)
      if (!isfinite(Dm[k])) {
        // Two finite coordinates whose difference is beyond DBL_MAX.
        where_tet(where, sizeof where, origin, t);
        int c = k % 3, r = k / 3;
        long base = origin ? origin->index_base : 0;
        mesh_error(err, errlen,
                   "%s: edge from vertex %ld to vertex %ld overflows: %c = %.17g - %.17g is "
                   "beyond the range of a double (supported: 6V in [DBL_MIN, DBL_MAX], see "
                   "mesh.h)",
                   where, (long)tv[0] + base, (long)tv[c + 1] + base, "xyz"[r],
                   m -> X[tv[c + 1] * 3 + r], m -> X[tv[0] * 3 + r]);
        goto fail;
      }
    // Shape tests in scaled units, so that they hold at any scale: Dm
    // divided by the power of two 2^e nearest above its largest entry
    // (exact), so 6V and edge^3 are computed without overflow or underflow
    // and the degeneracy test does not depend on the mesh's units.
    int e = 0;
    frexp(maxabs9(Dm), &e);
    double Ds[9];
    for (int k = 0; k < 9; k++)
      Ds[k] = ldexp(Dm[k], -e);
    double six_v_s = det3(Ds), lmin_s, lmax_s;
    edge_range(Ds, &lmin_s, &lmax_s);
    // Degenerate: 6|V| <= 1e-12 * (longest edge)^3 (DESIGN.md, "Meshes").
    if (fabs(six_v_s) <= EK_MESH_DEGENERATE_REL * lmax_s * lmax_s * lmax_s) {
      char v6[48], lm[48];
      mesh_fmt_scaled(v6, sizeof v6, six_v_s, 3 * e);
      mesh_fmt_scaled(lm, sizeof lm, lmax_s, e);
      where_tet(where, sizeof where, origin, t);
      mesh_error(err, errlen, "%s: degenerate: 6V = %s <= %g * (longest edge %s)^3 (zero volume)",
                 where, v6, EK_MESH_DEGENERATE_REL, lm);
      goto fail;
    }
    // The supported range: 6V = det(Dm), computed in the mesh's units as
    // the element layer computes it, must be a finite, normal double
    // (mesh.h). A cube of edge 1e120 is a valid shape whose volume (1e360)
    // no double holds.
    double six_v = det3(Dm);
    if (!isfinite(six_v) || fabs(six_v) < DBL_MIN) {
      char v6[48];
      mesh_fmt_scaled(v6, sizeof v6, six_v_s, 3 * e);
      where_tet(where, sizeof where, origin, t);
      mesh_error(err, errlen,
                 "%s: 6V = %s is outside the supported range [%g, %g] of rest volumes (a "
                 "double; edges from about 1e-102 to 1e102): rescale the mesh",
                 where, v6, DBL_MIN, DBL_MAX);
      goto fail;
    }
    if (six_v_s < 0) {
      if (!fix) {
        char v[48];
        mesh_fmt_scaled(v, sizeof v, six_v_s / 6, 3 * e);
        where_tet(where, sizeof where, origin, t);
        mesh_error(err, errlen,
                   "%s: inverted: rest volume %s < 0 (refused; set fix_orientation to swap "
                   "its vertices 1 and 2)",
                   where, v);
        goto fail;
      }
      int32_t tmp = tv[1];
      tv[1] = tv[2];
      tv[2] = tmp;
      m->nfixed++;
    }
    double lmin = ldexp(lmin_s, e);
    if (lmin < m->min_edge)
      m->min_edge = lmin;
  }
  {
    // The same tet twice (in any vertex order) doubles its mass and
    // stiffness without a word (issue 28: a TetGen file listing a tet twice
    // loaded). Checked after the shape tests (an odd reordering is
    // reported as inverted first).
    size_t first = 0, second = 0;
    int dup = mesh_find_duplicate(tets_in, ntets, 4, &first, &second);
    if (dup < 0) {
      mesh_error(err, errlen, "%s: out of memory", src);
      goto fail;
    }
    if (dup) {
      char where1[512];
      where_tet(where, sizeof where, origin, second);
      where_tet(where1, sizeof where1, origin, first);
      const int32_t *tv = tets_in + 4 * second;
      long base = origin ? origin->index_base : 0;
      mesh_error(err, errlen, "%s: duplicate element: vertices %ld %ld %ld %ld, the same set as %s",
                 where, (long)tv[0] + base, (long)tv[1] + base, (long)tv[2] + base,
                 (long)tv[3] + base, where1);
      goto fail;
    }
  }
  {
    m->el = ek_tets_create(nverts, X, ntets, T);
    if (!m->el) {
      mesh_error(err, errlen, "%s: %s", src, ek_last_error());
      goto fail;
    }
  }
  // Lumped volumes: a quarter of each tet's V0 to each of its corners
  // (Teran et al. 2003 sec. 4). Each V0 is finite, their sum at a vertex
  // may not be.
  const double *V0 = ek_tets_rest_volumes(m->el);
  for (size_t t = 0; t < ntets; t++)
    for (int c = 0; c < 4; c++)
      m->lumped[T[t * 4 + c]] += V0[t] / 4;
  for (size_t v = 0; v < nverts; v++)
    if (!isfinite(m->lumped[v])) {
      where_vert(where, sizeof where, origin, v);
      mesh_error(err, errlen,
                 "%s: lumped volume (sum of V0 / 4 over its tets) overflows to %g: outside the "
                 "supported range, rescale the mesh",
                 where, m->lumped[v]);
      goto fail;
    }
  free(T);
  free(used);
  return m;
fail:
  free(T);
  free(used);
  ek_mesh_destroy(m);
  return NULL;
}

ek_mesh *ek_mesh_create_ex_errbuf(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                                  const ek_mesh_opts *opts, char *err, size_t errlen) {
  return mesh_build(nverts, X, ntets, tets, opts, NULL, err, errlen);
}

ek_mesh *ek_mesh_create_errbuf(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                               char *err, size_t errlen) {
  return mesh_build(nverts, X, ntets, tets, NULL, NULL, err, errlen);
}

// A box of nx x ny x nz cubes, 6 tets each (mesh_box.h).
ek_mesh *ek_mesh_box_errbuf(int nx, int ny, int nz, double lx, double ly, double lz, char *err,
                            size_t errlen) {
  if (nx < 1 || ny < 1 || nz < 1) {
    mesh_error(err, errlen, "ek_mesh_box: cell counts %d x %d x %d must be >= 1", nx, ny, nz);
    return NULL;
  }
  if (!(lx > 0 && isfinite(lx)) || !(ly > 0 && isfinite(ly)) || !(lz > 0 && isfinite(lz))) {
    mesh_error(err, errlen, "ek_mesh_box: sizes %g x %g x %g must be finite and > 0", lx, ly, lz);
    return NULL;
  }
  double *X;
  int32_t *T;
  size_t nverts, ntets;
  int rc = mesh_box_arrays(nx, ny, nz, lx, ly, lz, &X, &T, &nverts, &ntets);
  if (rc == EK_ENOMEM)
    mesh_error(err, errlen, "ek_mesh_box: out of memory");
  else if (rc)
    mesh_error(err, errlen, "ek_mesh_box: %d x %d x %d cells is too large", nx, ny, nz);
  if (rc)
    return NULL;
  mesh_origin o = {.file = "ek_mesh_box", .index_base = 0};
  ek_mesh *m = mesh_build(nverts, X, ntets, T, NULL, &o, err, errlen);
  free(X);
  free(T);
  return m;
}

const ek_tets *ek_mesh_elements(const ek_mesh *m) { return m ? m->el : NULL; }
size_t ek_mesh_nverts(const ek_mesh *m) { return m ? ek_tets_nverts(m->el) : 0; }
size_t ek_mesh_ntets(const ek_mesh *m) { return m ? ek_tets_count(m->el) : 0; }
const double *ek_mesh_rest_positions(const ek_mesh *m) { return m ? m->X : NULL; }
const int32_t *ek_mesh_tets(const ek_mesh *m) { return m ? ek_tets_vertices(m->el) : NULL; }
const double *ek_mesh_rest_volumes(const ek_mesh *m) {
  return m ? ek_tets_rest_volumes(m->el) : NULL;
}
const double *ek_mesh_dm_inv(const ek_mesh *m) { return m ? ek_tets_dm_inv(m->el) : NULL; }
const double *ek_mesh_lumped_volume(const ek_mesh *m) { return m ? m->lumped : NULL; }
int ek_mesh_ncolors(const ek_mesh *m) { return m ? ek_tets_ncolors(m->el) : 0; }
size_t ek_mesh_nfixed(const ek_mesh *m) { return m ? m->nfixed : 0; }
double ek_mesh_min_edge(const ek_mesh *m) { return m ? m->min_edge : 0; }
