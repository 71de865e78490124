// Warm-started polar decomposition of whole AoSoA blocks (layout in
// include/ek/batch.h; algorithm in polar_warm_core.h): A read, R read as
// the guess and overwritten with the rotation, vector by vector.
#include "../simd/simd.h"

#include "polar_warm_core.h"

// iters is a compile-time constant at each call below (the common counts
// get their own unrolled code; others take the loop).
EK_INLINE void polar_warm_blocks(size_t nblocks, const real *A, real *R, int iters) {
  for (size_t b = 0; b < nblocks; b++)
    for (int o = 0; o < EK_LANES; o += EK_W) {
      const real *a = A + b * 9 * EK_LANES + o;
      real *r = R + b * 9 * EK_LANES + o;
      vreal Av[9], Rv[9];
      for (int i = 0; i < 9; i++)
        Av[i] = vload(a + (size_t)i * EK_LANES), Rv[i] = vload(r + (size_t)i * EK_LANES);
      polar_warm_core(Av, Rv, iters);
      for (int i = 0; i < 9; i++)
        vstore(r + (size_t)i * EK_LANES, Rv[i]);
    }
}

void EK_SYM(polar_warm_block)(size_t nblocks, const real *A, real *R, int iters) {
  switch (iters) {
  case 1:
    polar_warm_blocks(nblocks, A, R, 1);
    break;
  case 2:
    polar_warm_blocks(nblocks, A, R, 2);
    break;
  case 3:
    polar_warm_blocks(nblocks, A, R, 3);
    break;
  default:
    polar_warm_blocks(nblocks, A, R, iters);
    break;
  }
}
