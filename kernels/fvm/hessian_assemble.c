// Assembly of the projected Hessian K (include/ek/hessian.h:
// ek_fvm_hessian_pattern, ek_fvm_hessian_assemble): the element Hessians
// of the cache's precision (hessian.c, HESS_ELEMENT kernels), then per
// nonzero 3x3 block a gather of its contributions through a map built
// once from the element incidence. Each block sums its contributions in
// ascending slot order on one thread: the assembled matrix has the same
// bits for any thread count (no colouring, no atomics), as the GATHER
// scatter of the forces (scatter.h). Built once, at baseline ISA: the
// gather is index work; the arithmetic is in the element kernels.
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <ek/hessian.h>

#include "../elements/tets.h"
#include "hessian_kernel.h"

// The cache's slot order (scatter.h's scatter_blocks; that header is per
// precision).
static const ek_tet_blocks *cache_blocks(const ek_fvm_hessian *h) {
  return h->scatter == EK_SCATTER_COLORED ? &h->el->colored : &h->el->morton;
}

void ek_hessian_assembly_free(ek_fvm_hessian *h) {
  free(h->bptr);
  free(h->bcol);
  free(h->row_ptr);
  free(h->col);
  free(h->cptr);
  free(h->contrib);
  ek_free(h->ebuf);
  h->bptr = h->bcol = h->row_ptr = h->col = h->cptr = h->contrib = NULL;
  h->ebuf = NULL;
}

typedef struct {
  int32_t col, code; // column vertex; slot * 16 + d * 4 + c (-1: the diagonal's placeholder)
} entry;

static int entry_cmp(const void *a, const void *b) {
  const entry *x = a, *y = b;
  if (x->col != y->col)
    return x->col < y->col ? -1 : 1;
  return (x->code > y->code) - (x->code < y->code);
}

// The pattern and the map, from the slot order of the cache.
static int build_pattern(ek_fvm_hessian *h) {
  static const char *fn = "ek_fvm_hessian_pattern";
  const ek_tets *el = h->el;
  const ek_tet_blocks *bl = cache_blocks(h);
  const size_t nv = el->nverts, ns = bl->nslots;
  if (ns * 16 > INT32_MAX || nv * 3 > INT32_MAX) {
    ek_set_error("%s: %zu slots: the map's 32-bit codes overflow", fn, ns);
    return EK_EINVAL;
  }
  int32_t *rstart = calloc(nv + 1, sizeof(int32_t));
  entry *e = NULL;
  if (!rstart)
    goto oom;
  // Per row: one placeholder for the diagonal block (a vertex in no tet
  // still gets one: the solver holds it there), 4 entries per incident tet.
  for (size_t v = 0; v < nv; v++)
    rstart[v + 1] = 1;
  for (size_t s = 0; s < ns; s++)
    if (bl->slot_tet[s] >= 0)
      for (int d = 0; d < 4; d++)
        rstart[el->tets[4 * (size_t)bl->slot_tet[s] + d] + 1] += 4;
  for (size_t v = 0; v < nv; v++)
    rstart[v + 1] += rstart[v];
  const size_t ne = (size_t)rstart[nv];
  e = malloc(ne * sizeof *e);
  int32_t *fill = malloc(nv * sizeof(int32_t));
  if (!e || !fill) {
    free(fill);
    goto oom;
  }
  for (size_t v = 0; v < nv; v++) {
    e[rstart[v]] = (entry){(int32_t)v, -1};
    fill[v] = rstart[v] + 1;
  }
  for (size_t s = 0; s < ns; s++) {
    const int32_t t = bl->slot_tet[s];
    if (t < 0)
      continue;
    const int32_t *tv = el->tets + 4 * (size_t)t;
    for (int d = 0; d < 4; d++)
      for (int c = 0; c < 4; c++)
        e[fill[tv[d]]++] = (entry){tv[c], (int32_t)(s * 16 + (size_t)d * 4 + (size_t)c)};
  }
  free(fill);
  // Sort each row by (column, code): the codes are unique, so the order is
  // the mesh's alone. Count the blocks.
  size_t nblocks = 0;
  for (size_t v = 0; v < nv; v++) {
    qsort(e + rstart[v], (size_t)(rstart[v + 1] - rstart[v]), sizeof *e, entry_cmp);
    for (int32_t k = rstart[v]; k < rstart[v + 1]; k++)
      nblocks += k == rstart[v] || e[k].col != e[k - 1].col;
  }
  if (nblocks * 9 > INT32_MAX) {
    free(rstart);
    free(e);
    ek_set_error("%s: %zu nonzero blocks: more than 32-bit CSR indices hold", fn, nblocks);
    return EK_EINVAL;
  }
  h->nblocks = nblocks;
  h->bptr = malloc((nv + 1) * sizeof(int32_t));
  h->bcol = malloc(nblocks * sizeof(int32_t));
  h->cptr = malloc((nblocks + 1) * sizeof(int32_t));
  h->contrib = malloc((ne - nv + 1) * sizeof(int32_t));
  h->row_ptr = malloc((3 * nv + 1) * sizeof(int32_t));
  h->col = malloc((9 * nblocks + 1) * sizeof(int32_t));
  if (!h->bptr || !h->bcol || !h->cptr || !h->contrib || !h->row_ptr || !h->col) {
    ek_hessian_assembly_free(h);
    goto oom;
  }
  size_t q = 0, nc = 0;
  for (size_t v = 0; v < nv; v++) {
    h->bptr[v] = (int32_t)q;
    for (int32_t k = rstart[v]; k < rstart[v + 1]; k++) {
      if (k == rstart[v] || e[k].col != e[k - 1].col) {
        h->bcol[q] = e[k].col;
        h->cptr[q++] = (int32_t)nc;
      }
      if (e[k].code >= 0)
        h->contrib[nc++] = e[k].code;
    }
  }
  h->bptr[nv] = (int32_t)q;
  h->cptr[q] = (int32_t)nc;
  // Scalar CSR: row 3 v + k holds, per block (v, w) in column order, the
  // columns 3 w .. 3 w + 2.
  for (size_t v = 0; v < nv; v++) {
    const int32_t b0 = h->bptr[v], nb = h->bptr[v + 1] - b0;
    for (int k = 0; k < 3; k++) {
      const int32_t r0 = 9 * b0 + k * 3 * nb;
      h->row_ptr[3 * v + (size_t)k] = r0;
      for (int32_t j = 0; j < nb; j++)
        for (int m = 0; m < 3; m++)
          h->col[r0 + 3 * j + m] = 3 * h->bcol[b0 + j] + m;
    }
  }
  h->row_ptr[3 * nv] = (int32_t)(9 * nblocks);
  free(rstart);
  free(e);
  return EK_OK;
oom:
  free(rstart);
  free(e);
  ek_set_error("%s: out of memory for the pattern of %zu vertices", fn, nv);
  return EK_ENOMEM;
}

int ek_fvm_hessian_pattern(ek_fvm_hessian *h, ek_csr_pattern *p) {
  if (!h || !p) {
    ek_set_error("ek_fvm_hessian_pattern: NULL argument");
    return EK_EINVAL;
  }
  if (!h->bptr) {
    int rc = build_pattern(h);
    if (rc < 0)
      return rc;
  }
  p->nrows = 3 * h->el->nverts;
  p->nnz = 9 * h->nblocks;
  p->row_ptr = h->row_ptr;
  p->col = h->col;
  return EK_OK;
}

// Block row v of the matrix from the element Hessians (E: float or double).
#define GATHER_ROW(E)                                                                              \
  do {                                                                                             \
    const int32_t b0 = h->bptr[v], nb = h->bptr[v + 1] - b0;                                       \
    for (int32_t j = 0; j < nb; j++) {                                                             \
      double acc[9] = {0};                                                                         \
      for (int32_t k = h->cptr[b0 + j]; k < h->cptr[b0 + j + 1]; k++) {                            \
        const size_t code = (size_t)h->contrib[k], s = code >> 4;                                  \
        const int d = (int)(code >> 2 & 3), c = (int)(code & 3);                                   \
        const size_t base = s * 144 + (size_t)(d * 4 + c) * 9;                                     \
        for (int q = 0; q < 9; q++)                                                                \
          acc[q] += (double)(E)[base + (size_t)q];                                                 \
      }                                                                                            \
      for (int r = 0; r < 3; r++)                                                                  \
        for (int m = 0; m < 3; m++)                                                                \
          values[9 * b0 + r * 3 * nb + 3 * j + m] = acc[3 * r + m];                                \
    }                                                                                              \
  } while (0)

int ek_fvm_hessian_assemble(ek_fvm_hessian *h, double *values) {
  static const char *fn = "ek_fvm_hessian_assemble";
  if (!h || !values) {
    ek_set_error("%s: NULL argument", fn);
    return EK_EINVAL;
  }
  if (!h->bptr) {
    int rc = build_pattern(h);
    if (rc < 0)
      return rc;
  }
  const int f32 = h->precision == 32;
  const size_t ns = cache_blocks(h)->nslots;
  if (!h->ebuf && !(h->ebuf = ek_alloc(ns * 144 * (f32 ? sizeof(float) : sizeof(double))))) {
    ek_set_error("%s: out of memory for the element Hessians (%zu tets)", fn, h->el->ntets);
    return EK_ENOMEM;
  }
  int rc = f32 ? ek_fvm_hessian_elements_f32(h, h->ebuf) : ek_fvm_hessian_elements_f64(h, h->ebuf);
  if (rc < 0)
    return rc;
  const long nv = (long)h->el->nverts;
  const int parallel = h->el->ntets >= EK_FVM_PARALLEL_MIN_TETS / 8;
  if (f32) {
    const float *E = h->ebuf;
#pragma omp parallel for schedule(static) if (parallel)
    for (long v = 0; v < nv; v++)
      GATHER_ROW(E);
  } else {
    const double *E = h->ebuf;
#pragma omp parallel for schedule(static) if (parallel)
    for (long v = 0; v < nv; v++)
      GATHER_ROW(E);
  }
  return EK_OK;
}
