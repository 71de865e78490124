// Warm-started polar decomposition of whole AoSoA blocks (layout in
// include/ek/batch.h; algorithm in polar_warm_core.h): A read, R read as
// the guess and overwritten with the rotation, vector by vector.
#include "../simd/simd.h"

#include "polar_warm_core.h"

// Offset of vector j's entry 0 in a batch of 9-plane blocks.
static inline size_t vec_offset(size_t j) {
  return (j / EK_VPB) * 9 * (size_t)EK_LANES + (j % EK_VPB) * EK_W;
}

// nv (a compile-time constant at the calls below) vectors from vector j0,
// side by side.
EK_INLINE void polar_warm_vectors(int nv, size_t j0, const real *A, real *R, int iters) {
  vreal Av[POLAR_WARM_MAX_N][9], Rv[POLAR_WARM_MAX_N][9];
  for (int j = 0; j < nv; j++)
    for (int i = 0; i < 9; i++) {
      Av[j][i] = vload(A + vec_offset(j0 + (size_t)j) + (size_t)i * EK_LANES);
      Rv[j][i] = vload(R + vec_offset(j0 + (size_t)j) + (size_t)i * EK_LANES);
    }
  polar_warm_core_n(nv, (const vreal(*)[9])Av, Rv, iters);
  for (int j = 0; j < nv; j++)
    for (int i = 0; i < 9; i++)
      vstore(R + vec_offset(j0 + (size_t)j) + (size_t)i * EK_LANES, Rv[j][i]);
}

// iters is a compile-time constant at each call below (the common counts
// get their own unrolled code; others take the loop).
EK_INLINE void polar_warm_blocks(size_t nblocks, const real *A, real *R, int iters) {
  size_t nvec = nblocks * EK_VPB, j = 0;
  // One iteration is short enough that a second chain only adds register
  // pressure (measured: 3.2 vs 3.4 ns per f32 matrix on Zen 4).
  const int nv = iters == 1 ? 1 : POLAR_WARM_MAX_N;
  for (; j + (size_t)nv <= nvec; j += (size_t)nv)
    polar_warm_vectors(nv, j, A, R, iters);
  for (; j < nvec; j++)
    polar_warm_vectors(1, j, A, R, iters);
}

void EK_SYM(polar_warm_block)(size_t nblocks, const real *A, real *R, int iters) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
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
  ek_fpmode_leave(mode);
}

#if !defined(EK_TARGET_SCALAR) // the scalar target stages instead (below)
// AoS: nv vectors of EK_W matrices from m0 on, transposed to and from
// registers (vload_records, vstore_records; in-register permutes on
// AVX-512) instead of packed into staging blocks and unpacked, as
// svd3_block.c does for the SVD. Each lane's operations are the AoSoA
// path's, so each matrix gets the same bits.
EK_INLINE void polar_warm_aos_vectors(int nv, size_t m0, const real *A, real *R, int iters) {
  vreal Av[POLAR_WARM_MAX_N][9], Rv[POLAR_WARM_MAX_N][9];
  for (int j = 0; j < nv; j++) {
    vload_records(A + 9 * (m0 + (size_t)j * EK_W), 9, Av[j]);
    vload_records(R + 9 * (m0 + (size_t)j * EK_W), 9, Rv[j]);
  }
  polar_warm_core_n(nv, (const vreal(*)[9])Av, Rv, iters);
  for (int j = 0; j < nv; j++)
    vstore_records(R + 9 * (m0 + (size_t)j * EK_W), 9, Rv[j]);
}

// n AoS matrices; a last partial vector goes through a local copy padded
// with the identity (A and guess), so no lane reads or writes past the
// arrays.
EK_INLINE void polar_warm_aos(size_t n, const real *A, real *R, int iters) {
  const int nv = iters == 1 ? 1 : POLAR_WARM_MAX_N; // as polar_warm_blocks
  size_t m = 0;
  for (; m + (size_t)nv * EK_W <= n; m += (size_t)nv * EK_W)
    polar_warm_aos_vectors(nv, m, A, R, iters);
  for (; m + EK_W <= n; m += EK_W)
    polar_warm_aos_vectors(1, m, A, R, iters);
  if (m == n)
    return;
  size_t tail = n - m;
  real a[9 * EK_W], r[9 * EK_W];
  for (size_t l = 0; l < EK_W; l++)
    for (int i = 0; i < 9; i++) {
      a[9 * l + i] = l < tail ? A[9 * (m + l) + i] : (real)(i % 4 == 0);
      r[9 * l + i] = l < tail ? R[9 * (m + l) + i] : (real)(i % 4 == 0);
    }
  polar_warm_aos_vectors(1, 0, a, r, iters);
  for (size_t l = 0; l < tail; l++)
    for (int i = 0; i < 9; i++)
      R[9 * (m + l) + i] = r[9 * l + i];
}
#endif

void EK_SYM(polar_warm_aos)(size_t n, const real *A, real *R, int iters);
#if defined(EK_TARGET_SCALAR)
// The scalar target stages instead, one block at a time through its own
// block kernel: its in-register AoS copy gave the same numbers but other
// NaN payloads on ek-hash's extreme inputs (the compiler orders the
// operands of the two inlined copies differently), and the default results
// keep their bits. One vector is one matrix here, so staging is a copy.
void EK_SYM(polar_warm_aos)(size_t n, const real *A, real *R, int iters) {
  real a[9 * EK_LANES], r[9 * EK_LANES];
  for (size_t m0 = 0; m0 < n; m0 += EK_LANES) {
    size_t m = n - m0 < EK_LANES ? n - m0 : EK_LANES;
    for (size_t l = 0; l < EK_LANES; l++)
      for (int i = 0; i < 9; i++) {
        a[(size_t)i * EK_LANES + l] = l < m ? A[9 * (m0 + l) + i] : (real)(i % 4 == 0);
        r[(size_t)i * EK_LANES + l] = l < m ? R[9 * (m0 + l) + i] : (real)(i % 4 == 0);
      }
    EK_SYM(polar_warm_block)(1, a, r, iters);
    for (size_t l = 0; l < m; l++)
      for (int i = 0; i < 9; i++)
        R[9 * (m0 + l) + i] = r[(size_t)i * EK_LANES + l];
  }
}
#else
void EK_SYM(polar_warm_aos)(size_t n, const real *A, real *R, int iters) {
  ek_fpmode mode = ek_fpmode_enter();
  switch (iters) {
  case 1:
    polar_warm_aos(n, A, R, 1);
    break;
  case 2:
    polar_warm_aos(n, A, R, 2);
    break;
  case 3:
    polar_warm_aos(n, A, R, 3);
    break;
  default:
    polar_warm_aos(n, A, R, iters);
    break;
  }
  ek_fpmode_leave(mode);
}
#endif

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(polar_warm_block_fill)(ek_kernel_table *t);
void EK_SYM(polar_warm_block_fill)(ek_kernel_table *t) {
  t->EK_FIELD(polar_warm_block) = EK_SYM(polar_warm_block);
  t->EK_FIELD(polar_warm_aos) = EK_SYM(polar_warm_aos);
}
