// SVD / polar decomposition of whole AoSoA blocks (layout in
// include/ek/batch.h). The blocks are a sequence of vectors of EK_W lanes
// (EK_VPB per block); SVD3_IL vectors go through the SVD side by side.
#include "simd/simd.h"
#include "svd3/svd3_core.h"

// Independent vectors in flight (see svd3_core_n).
#define SVD3_IL 2

// Offset of vector j's entry 0 in a batch of `planes`-plane blocks.
static inline size_t vec_offset(size_t j, int planes) {
  return (j / EK_VPB) * (size_t)planes * EK_LANES + (j % EK_VPB) * EK_W;
}

// n, exact and polar are compile-time constants at each call below, so
// every combination gets its own straight-line code.
EK_INLINE void svd3_vectors(int n, size_t j0, const real *A, real *U, real *S, real *V, int sweeps,
                            int refine, int exact, int polar) {
  vreal a[SVD3_MAX_N][9], u[SVD3_MAX_N][9], s[SVD3_MAX_N][3], w[SVD3_MAX_N][9], scale[SVD3_MAX_N];
  for (int j = 0; j < n; j++)
    for (int i = 0; i < 9; i++)
      a[j][i] = vload(A + vec_offset(j0 + j, 9) + (size_t)i * EK_LANES);
  svd3_core_n(n, (const vreal(*)[9])a, u, s, w, scale, sweeps, refine, exact);
  for (int j = 0; j < n; j++) {
    size_t m9 = vec_offset(j0 + j, 9), m3 = vec_offset(j0 + j, 3);
    if (polar) {
      vreal r[9], p[9];
      svd3_polar(u[j], s[j], w[j], scale[j], r, p);
      for (int i = 0; i < 9; i++) {
        vstore(U + m9 + (size_t)i * EK_LANES, r[i]);
        if (V)
          vstore(V + m9 + (size_t)i * EK_LANES, p[i]);
      }
    } else {
      for (int i = 0; i < 9; i++) {
        vstore(U + m9 + (size_t)i * EK_LANES, u[j][i]);
        vstore(V + m9 + (size_t)i * EK_LANES, w[j][i]);
      }
      for (int i = 0; i < 3; i++)
        vstore(S + m3 + (size_t)i * EK_LANES, vmul(s[j][i], scale[j]));
    }
  }
}

EK_INLINE void svd3_blocks(size_t nblocks, const real *A, real *U, real *S, real *V, int sweeps,
                           int refine, int exact, int polar) {
  size_t nvec = nblocks * EK_VPB, j = 0;
  for (; j + SVD3_IL <= nvec; j += SVD3_IL)
    svd3_vectors(SVD3_IL, j, A, U, S, V, sweeps, refine, exact, polar);
  for (; j < nvec; j++)
    svd3_vectors(1, j, A, U, S, V, sweeps, refine, exact, polar);
}

void EK_SYM(svd3_block)(size_t nblocks, const real *A, real *U, real *S, real *V,
                        const ek_svd3_knobs *k) {
  if (k->polar) {
    if (k->exact_rsqrt)
      svd3_blocks(nblocks, A, U, S, V, k->sweeps, k->refine, 1, 1);
    else
      svd3_blocks(nblocks, A, U, S, V, k->sweeps, k->refine, 0, 1);
  } else {
    if (k->exact_rsqrt)
      svd3_blocks(nblocks, A, U, S, V, k->sweeps, k->refine, 1, 0);
    else
      svd3_blocks(nblocks, A, U, S, V, k->sweeps, k->refine, 0, 0);
  }
}
