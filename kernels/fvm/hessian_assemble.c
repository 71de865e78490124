// Assembly of the projected Hessian K (include/ek/hessian.h:
// ek_fvm_hessian_pattern, ek_fvm_hessian_assemble): the pattern and an
// element-to-nonzero map built once from the element incidence, and per
// call the element Hessians of the cache's precision (HESS_ELEMENT
// kernels) added straight into the values through the map, block of
// lanes by block of lanes (hessian.c, ek_fvm_hessian_assemble_f32/f64).
// Each nonzero is summed on one thread, the thread that owns its row, in
// ascending slot order from 0: the assembled matrix has the same bits for
// any thread count (no colouring, no atomics) and the same bits as a
// gather of each block's contributions in slot order. Built once, at
// baseline ISA: the map is index work; the arithmetic is in the kernels.
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

static void plan_free(ek_fvm_hessian *h) {
  free(h->slot_own);
  free(h->row_own);
  h->row_own = NULL;
  free(h->tptr);
  free(h->tblk);
  free(h->tgrp);
  free(h->krun);
  free(h->kcon);
  free(h->runs);
  free(h->run_e);
  free(h->run_up);
  h->run_up = NULL;
  free(h->abuf);
  h->abuf = NULL;
  free(h->xptr);
  free(h->xlow);
  h->xptr = h->xlow = NULL;
  h->slot_own = NULL;
  h->tptr = h->tblk = h->tgrp = h->krun = h->kcon = NULL;
  h->runs = NULL;
  h->run_e = NULL;
  h->plan_threads = 0;
}

void ek_hessian_assembly_free(ek_fvm_hessian *h) {
  plan_free(h);
  free(h->bptr);
  free(h->bcol);
  free(h->row_ptr);
  free(h->col);
  free(h->slot_p);
  free(h->slot_rs);
  free(h->slot_first);
  free(h->slot_lower);
  free(h->mirror);
  free(h->isolated);
  free(h->ubptr);
  free(h->ubcol);
  free(h->udiag);
  h->ubptr = h->ubcol = h->udiag = NULL;
  h->bptr = h->bcol = h->row_ptr = h->col = h->slot_p = h->slot_rs = h->mirror = h->isolated = NULL;
  h->slot_first = h->slot_lower = NULL;
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
  h->slot_p = calloc(ns * 16, sizeof(int32_t));
  h->slot_rs = calloc(ns * 4, sizeof(int32_t));
  h->slot_first = calloc(ns, sizeof(uint16_t));
  h->slot_lower = calloc(ns, sizeof(uint16_t));
  h->mirror = malloc((nblocks + 1) * sizeof(int32_t));
  h->row_ptr = malloc((3 * nv + 1) * sizeof(int32_t));
  h->col = malloc((9 * nblocks + 1) * sizeof(int32_t));
  if (!h->bptr || !h->bcol || !h->slot_p || !h->slot_rs || !h->slot_first || !h->slot_lower ||
      !h->mirror || !h->row_ptr || !h->col) {
    ek_hessian_assembly_free(h);
    goto oom;
  }
  // Per row v: block j (column order) at value offset 9 bptr[v] + 3 j,
  // rows 3 nb apart; its first slot (the lowest code after the
  // diagonal's placeholder) writes, the later ones add.
  size_t q = 0, niso = 0;
  for (size_t v = 0; v < nv; v++) {
    h->bptr[v] = (int32_t)q;
    for (int32_t k = rstart[v]; k < rstart[v + 1]; k++)
      if (k == rstart[v] || e[k].col != e[k - 1].col)
        h->bcol[q++] = e[k].col;
    niso += rstart[v + 1] - rstart[v] == 1;
  }
  h->bptr[nv] = (int32_t)q;
  h->nisolated = niso;
  h->isolated = malloc((niso + 1) * sizeof(int32_t));
  if (!h->isolated) {
    ek_hessian_assembly_free(h);
    goto oom;
  }
  niso = 0;
  for (size_t v = 0; v < nv; v++) {
    const int32_t b0 = h->bptr[v], nb = h->bptr[v + 1] - b0;
    if (rstart[v + 1] - rstart[v] == 1)
      h->isolated[niso++] = (int32_t)v;
    int32_t j = -1;
    for (int32_t k = rstart[v]; k < rstart[v + 1]; k++) {
      const int fresh = k == rstart[v] || e[k].col != e[k - 1].col;
      j += fresh;
      if (e[k].code < 0)
        continue;
      const size_t s = (size_t)e[k].code >> 4, dc = (size_t)e[k].code & 15;
      h->slot_p[16 * s + dc] = 9 * b0 + 3 * j;
      h->slot_rs[4 * s + (dc >> 2)] = 3 * nb;
      if (fresh || e[k - 1].code < 0)
        h->slot_first[s] |= (uint16_t)(1u << dc);
      if (e[k].col < (int32_t)v)
        h->slot_lower[s] |= (uint16_t)(1u << dc);
    }
  }
  // Block (v, w)'s mirror (w, v): the pattern is symmetric (a tet couples
  // both ways), found by bisection in row w's ascending columns.
  for (size_t v = 0; v < nv; v++)
    for (int32_t q = h->bptr[v]; q < h->bptr[v + 1]; q++) {
      const int32_t w = h->bcol[q];
      int32_t lo = h->bptr[w], hi = h->bptr[w + 1] - 1;
      while (lo < hi) {
        const int32_t mid = lo + (hi - lo) / 2;
        if (h->bcol[mid] < (int32_t)v)
          lo = mid + 1;
        else
          hi = mid;
      }
      h->mirror[q] = lo;
    }
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
  // The upper block triangle: row v's blocks from its diagonal on (the
  // pattern holds every diagonal block).
  h->ubptr = malloc((nv + 1) * sizeof(int32_t));
  h->udiag = malloc((nv + 1) * sizeof(int32_t));
  size_t nu = 0;
  for (size_t v = 0; v < nv; v++) {
    int32_t q = h->bptr[v];
    while (h->bcol[q] < (int32_t)v)
      q++;
    nu += (size_t)(h->bptr[v + 1] - q);
  }
  h->ubcol = malloc((nu + 1) * sizeof(int32_t));
  if (!h->ubptr || !h->udiag || !h->ubcol) {
    ek_hessian_assembly_free(h);
    free(rstart);
    free(e);
    ek_set_error("%s: out of memory for the pattern of %zu vertices", fn, nv);
    return EK_ENOMEM;
  }
  nu = 0;
  for (size_t v = 0; v < nv; v++) {
    int32_t q = h->bptr[v];
    while (h->bcol[q] < (int32_t)v)
      q++;
    h->udiag[v] = q;
    h->ubptr[v] = (int32_t)nu;
    for (; q < h->bptr[v + 1]; q++)
      h->ubcol[nu++] = h->bcol[q];
  }
  h->ubptr[nv] = (int32_t)nu;
  h->nublocks = nu;
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

typedef struct {
  int32_t p;   // the K block's offset in the values
  uint16_t l;  // lane: the slot order within the slot block
  uint16_t dc; // element block d * 4 + c
} run_entry;

static int run_entry_cmp(const void *a, const void *b) {
  const run_entry *x = a, *y = b;
  if (x->p != y->p)
    return x->p < y->p ? -1 : 1;
  return (x->l > y->l) - (x->l < y->l);
}

// The element blocks of slot block b that thread t sums: its slots' blocks
// (d, c) on or above the block diagonal whose row d t owns, in (slot, d, c)
// order; written to out (lane index base + the slot's lane) unless out is
// NULL; returns how many.
static size_t block_entries(const ek_fvm_hessian *h, const int32_t *slot_tet, int t, size_t b,
                            size_t lanes, size_t base, run_entry *out) {
  size_t ne = 0;
  for (size_t s = b * lanes; s < (b + 1) * lanes; s++)
    if (slot_tet[s] >= 0)
      for (int d = 0; d < 4; d++)
        if (h->slot_own[4 * s + (size_t)d] == t)
          for (int c = 0; c < 4; c++)
            if (!(h->slot_lower[s] >> (d * 4 + c) & 1)) {
              if (out)
                out[ne] = (run_entry){h->slot_p[16 * s + (size_t)(d * 4 + c)],
                                      (uint16_t)(base + s - b * lanes), (uint16_t)(d * 4 + c)};
              ne++;
            }
  return ne;
}

// The runs of each plan group (hessian_kernel.h, ek_hess_run): the
// element blocks of group g's slot blocks that its thread sums (rows it
// owns, on or above the block diagonal), grouped by their K block, each
// group in ascending (entry, lane) order, i.e. ascending slot order (a
// thread's entries ascend), so a K block is loaded and stored once per
// group of slot blocks, and its sum has the plain assembly's order.
_Static_assert(144 * HESS_GROUP * EK_LANES_F32 <= 65536 && 144 * HESS_GROUP * EK_LANES_F64 <= 65536,
               "run_e's 16-bit element offsets: a group's element Hessians too large");
static int build_runs(ek_fvm_hessian *h, int nt, size_t lanes) {
  const size_t ng = (size_t)h->tgrp[nt];
  const int32_t *slot_tet = cache_blocks(h)->slot_tet;
  size_t ncon = 0;
  // Count: every owned upper element block of every entry is one element
  // of run_e; runs at most as many.
  for (int t = 0; t < nt; t++)
    for (int32_t k = h->tptr[t]; k < h->tptr[t + 1]; k++)
      ncon += block_entries(h, slot_tet, t, (size_t)h->tblk[k], lanes, 0, NULL);
  h->krun = malloc((ng + 1) * sizeof(int32_t));
  h->kcon = malloc((ng + 1) * sizeof(int32_t));
  h->runs = malloc((ncon + 1) * sizeof(ek_hess_run));
  h->run_e = malloc((ncon + 1) * sizeof(uint16_t));
  h->run_up = malloc((ncon + 1) * sizeof(int32_t));
  run_entry *ent = malloc(HESS_GROUP * lanes * 16 * sizeof *ent);
  if (!h->krun || !h->kcon || !h->runs || !h->run_e || !h->run_up || !ent || ncon > INT32_MAX) {
    free(ent);
    return EK_ENOMEM;
  }
  size_t nr = 0, nc = 0;
  for (int t = 0; t < nt; t++)
    for (int32_t g = h->tgrp[t]; g < h->tgrp[t + 1]; g++) {
      h->krun[g] = (int32_t)nr;
      h->kcon[g] = (int32_t)nc;
      const int32_t k0 = h->tptr[t] + (g - h->tgrp[t]) * HESS_GROUP;
      const int32_t k1 = k0 + HESS_GROUP < h->tptr[t + 1] ? k0 + HESS_GROUP : h->tptr[t + 1];
      size_t ne = 0;
      for (int32_t k = k0; k < k1; k++)
        ne += block_entries(h, slot_tet, t, (size_t)h->tblk[k], lanes, (size_t)(k - k0) * lanes,
                            ent + ne);
      qsort(ent, ne, sizeof *ent, run_entry_cmp);
      for (size_t i = 0; i < ne; i++) {
        const size_t j = ent[i].l / lanes, l = ent[i].l % lanes;
        const size_t s = (size_t)h->tblk[k0 + (int32_t)j] * lanes + l;
        const int dc = ent[i].dc;
        if (i == 0 || ent[i].p != ent[i - 1].p) {
          // The block's row v (corner dc >> 2's vertex) and its index q in
          // the block pattern; in the upper triangle: ubptr[v] + q - udiag[v].
          const int32_t v = h->el->tets[4 * (size_t)slot_tet[s] + (size_t)(dc >> 2)];
          const int32_t q = h->bptr[v] + (ent[i].p - 9 * h->bptr[v]) / 3;
          h->run_up[nr] = 9 * (h->ubptr[v] + q - h->udiag[v]);
          h->runs[nr++] = (ek_hess_run){ent[i].p, h->slot_rs[4 * s + (size_t)(dc >> 2)], 0,
                                        (uint16_t)(h->slot_first[s] >> dc & 1)};
        }
        h->runs[nr - 1].n++;
        h->run_e[nc++] = (uint16_t)((144 * j + (size_t)dc * 9) * lanes + l);
      }
    }
  h->krun[ng] = (int32_t)nr;
  h->kcon[ng] = (int32_t)nc;
  free(ent);
  return EK_OK;
}

// The CSR's lower blocks whose mirror row another thread owns (xptr,
// xlow: hessian_kernel.h), per thread in ascending row order.
static int build_cross(ek_fvm_hessian *h, int nt) {
  h->xptr = calloc((size_t)nt + 1, sizeof(int32_t));
  if (!h->xptr)
    return EK_ENOMEM;
  for (int pass = 0; pass < 2; pass++) {
    for (size_t v = 0; v < h->el->nverts; v++) {
      const int t = h->row_own[v];
      if (t >= nt) // a vertex in no tet: its diagonal block only
        continue;
      for (int32_t q = h->bptr[v]; q < h->bptr[v + 1] && h->bcol[q] < (int32_t)v; q++)
        if (h->row_own[h->bcol[q]] != t) {
          if (pass) {
            h->xlow[2 * (size_t)h->xptr[t]] = (int32_t)v;
            h->xlow[2 * (size_t)h->xptr[t]++ + 1] = q;
          } else
            h->xptr[t + 1]++;
        }
    }
    if (pass == 0) {
      for (int t = 0; t < nt; t++)
        h->xptr[t + 1] += h->xptr[t];
      h->xlow = malloc((2 * (size_t)h->xptr[nt] + 1) * sizeof(int32_t));
      if (!h->xlow)
        return EK_ENOMEM;
    }
  }
  // The fill advanced xptr[t] to thread t's end: shift back.
  for (int t = nt; t > 0; t--)
    h->xptr[t] = h->xptr[t - 1];
  h->xptr[0] = 0;
  return EK_OK;
}

// The threads' plan for nt threads (hessian_kernel.h): the slot blocks cut
// into nt runs (of about equal work, below); a vertex row belongs to the
// thread whose run holds the first block touching it; thread t computes, in
// ascending order, every block touching one of its rows (its run's, and the
// few later ones across the Morton cut). Which thread sums a nonzero
// changes with nt, the order of its sum does not.
static int build_plan(ek_fvm_hessian *h, int nt) {
  const ek_tets *el = h->el;
  const ek_tet_blocks *bl = cache_blocks(h);
  const size_t nv = el->nverts, ns = bl->nslots;
  const size_t lanes = h->precision == 32 ? EK_LANES_F32 : EK_LANES_F64, nb = ns / lanes;
  plan_free(h);
  uint8_t *vown = h->row_own = malloc(nv ? nv : 1);
  int32_t *seen = malloc((size_t)nt * sizeof(int32_t));
  size_t cut[257];
  h->slot_own = malloc(ns * 4);
  h->tptr = calloc((size_t)nt + 1, sizeof(int32_t));
  if (!vown || !seen || !h->slot_own || !h->tptr) {
    free(seen);
    plan_free(h);
    ek_set_error("ek_fvm_hessian_assemble: out of memory for the threads' plan");
    return EK_ENOMEM;
  }
  // Pass 0 cuts the slot blocks into nt equal runs; a thread then also
  // computes the later blocks touching its rows (across the cut), so passes
  // 1 and 2 shorten each run by that excess: every thread computes about as
  // many blocks (2 threads, the bench's box: equal runs gave thread 0 3592
  // blocks, thread 1 3169, and the barrier waited on thread 0; now 3436 and
  // 3422).
  for (int t = 0; t <= nt; t++)
    cut[t] = (size_t)t * nb / (size_t)nt;
  for (int pass = 0; pass < 3; pass++) {
    memset(vown, 0xff, nv);
    memset(h->tptr, 0, ((size_t)nt + 1) * sizeof(int32_t));
    for (size_t b = 0, t = 0; b < nb; b++) {
      while (cut[t + 1] <= b)
        t++;
      for (size_t s = b * lanes; s < (b + 1) * lanes; s++)
        if (bl->slot_tet[s] >= 0)
          for (int d = 0; d < 4; d++) {
            const int32_t v = el->tets[4 * (size_t)bl->slot_tet[s] + d];
            if (vown[v] == 0xff)
              vown[v] = (uint8_t)t;
          }
    }
    for (int t = 0; t < nt; t++)
      seen[t] = -1;
    for (size_t b = 0; b < nb; b++)
      for (size_t s = b * lanes; s < (b + 1) * lanes; s++)
        for (int d = 0; d < 4; d++) {
          const uint8_t o =
              bl->slot_tet[s] < 0 ? 0xff : vown[el->tets[4 * (size_t)bl->slot_tet[s] + d]];
          h->slot_own[4 * s + (size_t)d] = o;
          if (o != 0xff && seen[o] != (int32_t)b) {
            seen[o] = (int32_t)b;
            h->tptr[o + 1]++;
          }
        }
    if (pass < 2) {
      // Thread t's excess: its blocks beyond its run's; the runs' new
      // lengths give each thread (total blocks) / nt.
      size_t total = 0, len[256];
      for (int t = 0; t < nt; t++)
        total += (size_t)h->tptr[t + 1];
      for (int t = 0; t < nt; t++) {
        const size_t run = cut[t + 1] - cut[t], n = (size_t)h->tptr[t + 1];
        const size_t excess = n > run ? n - run : 0;
        const size_t want = (total + (size_t)t) / (size_t)nt;
        len[t] = want > excess ? want - excess : 0;
      }
      for (int t = 0; t < nt; t++) {
        const size_t c = cut[t] + len[t];
        cut[t + 1] = t + 1 == nt || c > nb ? nb : c;
      }
    }
  }
  for (int t = 0; t < nt; t++)
    h->tptr[t + 1] += h->tptr[t];
  h->tblk = malloc(((size_t)h->tptr[nt] + 1) * sizeof(int32_t));
  if (!h->tblk) {
    free(seen);
    plan_free(h);
    ek_set_error("ek_fvm_hessian_assemble: out of memory for the threads' plan");
    return EK_ENOMEM;
  }
  int32_t *fill = seen; // reused: the next free entry per thread
  for (int t = 0; t < nt; t++)
    fill[t] = h->tptr[t];
  for (size_t b = 0; b < nb; b++) {
    for (size_t s = b * lanes; s < (b + 1) * lanes; s++)
      for (int d = 0; d < 4; d++) {
        const uint8_t o = h->slot_own[4 * s + (size_t)d];
        if (o != 0xff && (fill[o] == h->tptr[o] || h->tblk[fill[o] - 1] != (int32_t)b))
          h->tblk[fill[o]++] = (int32_t)b;
      }
  }
  free(seen);
  h->tgrp = malloc(((size_t)nt + 1) * sizeof(int32_t));
  if (!h->tgrp) {
    plan_free(h);
    ek_set_error("ek_fvm_hessian_assemble: out of memory for the threads' plan");
    return EK_ENOMEM;
  }
  h->tgrp[0] = 0;
  for (int t = 0; t < nt; t++)
    h->tgrp[t + 1] = h->tgrp[t] + (h->tptr[t + 1] - h->tptr[t] + HESS_GROUP - 1) / HESS_GROUP;
  // Page-aligned (HESS_ABUF_BYTES is a multiple of 4096), a buffer's
  // length apart (HESS_ABUF_STRIDE; the gaps are never touched, so never
  // backed by memory): no thread's buffer shares or adjoins a page of
  // another's, and its placement is the same from run to run.
  h->abuf = aligned_alloc(4096, (size_t)nt * HESS_ABUF_STRIDE);
  if (!h->abuf || build_cross(h, nt) < 0 || build_runs(h, nt, lanes) < 0) {
    plan_free(h);
    ek_set_error("ek_fvm_hessian_assemble: out of memory for the threads' plan");
    return EK_ENOMEM;
  }
  h->plan_threads = nt;
  return EK_OK;
}

// The pattern and the plan for the threads a parallel region would get.
static int prepare(ek_fvm_hessian *h, const void *values, const char *fn) {
  if (!h || !values) {
    ek_set_error("%s: NULL argument", fn);
    return EK_EINVAL;
  }
  if (!h->bptr) {
    int rc = build_pattern(h);
    if (rc < 0)
      return rc;
  }
  // The threads a parallel region would get (at most 255: the plan's owner
  // bytes); one below the parallel grain (an element Hessian is about 9
  // products' arithmetic: the product's grain / 8).
  int nt = h->el->ntets >= EK_FVM_PARALLEL_MIN_TETS / 8 ? omp_get_max_threads() : 1;
  nt = nt < 1 ? 1 : nt > 255 ? 255 : nt;
  if (h->plan_threads != nt) {
    int rc = build_plan(h, nt);
    if (rc < 0)
      return rc;
  }
  return EK_OK;
}

int ek_fvm_hessian_assemble(ek_fvm_hessian *h, double *values) {
  int rc = prepare(h, values, "ek_fvm_hessian_assemble");
  if (rc < 0)
    return rc;
  rc = h->precision == 32 ? ek_fvm_hessian_assemble_f32(h, values)
                          : ek_fvm_hessian_assemble_f64(h, values);
  if (rc < 0)
    return rc;
  // A vertex in no tet: its diagonal block (the pattern holds it) is 0.
  for (size_t i = 0; i < h->nisolated; i++) {
    const int32_t v = h->isolated[i], nb = h->bptr[v + 1] - h->bptr[v];
    for (int r = 0; r < 3; r++)
      for (int m = 0; m < 3; m++)
        values[9 * h->bptr[v] + r * 3 * nb + m] = 0;
  }
  return EK_OK;
}

int ek_fvm_hessian_pattern_upper(ek_fvm_hessian *h, ek_bsr_pattern *p) {
  if (!h || !p) {
    ek_set_error("ek_fvm_hessian_pattern_upper: NULL argument");
    return EK_EINVAL;
  }
  if (!h->bptr) {
    int rc = build_pattern(h);
    if (rc < 0)
      return rc;
  }
  p->nbrows = h->el->nverts;
  p->nblocks = h->nublocks;
  p->bptr = h->ubptr;
  p->bcol = h->ubcol;
  return EK_OK;
}

// A vertex in no tet: its diagonal block (the pattern holds it, the first
// of its row) is 0; f or d, the values of the cache's precision.
static void zero_isolated_upper(const ek_fvm_hessian *h, float *f, double *d) {
  for (size_t i = 0; i < h->nisolated; i++)
    for (size_t m = 0; m < 9; m++) {
      const size_t k = 9 * (size_t)h->ubptr[h->isolated[i]] + m;
      if (f)
        f[k] = 0;
      else
        d[k] = 0;
    }
}

int ek_fvm_hessian_assemble_upper_f32(ek_fvm_hessian *h, float *values) {
  int rc = prepare(h, values, "ek_fvm_hessian_assemble_upper_f32");
  if (rc < 0 || (rc = ek_fvm_hessian_assemble_upper_run_f32(h, values)) < 0)
    return rc;
  zero_isolated_upper(h, values, NULL);
  return EK_OK;
}

int ek_fvm_hessian_assemble_upper_f64(ek_fvm_hessian *h, double *values) {
  int rc = prepare(h, values, "ek_fvm_hessian_assemble_upper_f64");
  if (rc < 0 || (rc = ek_fvm_hessian_assemble_upper_run_f64(h, values)) < 0)
    return rc;
  zero_isolated_upper(h, NULL, values);
  return EK_OK;
}
