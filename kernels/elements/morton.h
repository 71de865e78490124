// Internal: the Morton (Z-order) code's bit spreading and the sort key of
// a Morton order, for the tets' Morton order (tets.c) and the implicit
// loop's vertex order across MPI ranks (sim/implicit.c). Header-only (no
// symbol of libek), so libek_sim includes it by path as the tests include
// kernels' headers, and the public API stays without a Morton code.
#ifndef EK_KERNELS_ELEMENTS_MORTON_H
#define EK_KERNELS_ELEMENTS_MORTON_H

#include <stdint.h>

// Spread the low 21 bits of v so that there are two zero bits between
// consecutive bits (3D Morton interleave: Morton 1966; the bit spreading of
// Raman & Wise 2008, "Converting to and from dilated integers").
static inline uint64_t ek_morton_spread3(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

// An element's Morton code and its index; sorted by ek_morton_key_cmp
// (qsort), the code then the index: a total order, so the sort's result
// does not depend on qsort's algorithm.
typedef struct {
  uint64_t key;
  int32_t index;
} ek_morton_key;

static inline int ek_morton_key_cmp(const void *a, const void *b) {
  const ek_morton_key *x = a, *y = b;
  if (x->key != y->key)
    return x->key < y->key ? -1 : 1;
  return (x->index > y->index) - (x->index < y->index);
}

#endif
