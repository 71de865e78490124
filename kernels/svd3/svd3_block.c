// SVD / polar decomposition of whole AoSoA blocks (layout in
// include/ek/batch.h), or of AoS matrices (k->aos). The blocks are a
// sequence of vectors of EK_W lanes (EK_VPB per block); `il` vectors go
// through the SVD side by side. A lane's result depends on its matrix only,
// so both layouts, and every il, give the same bits.
#include "simd/simd.h"
#include "svd3/svd3_core.h"

// Independent vectors in flight (see svd3_core_n): 2, or 4 where the row's
// svd3_chains says so (k->chains; the CPU's choice, kernels/cpu_x86.c).
// Each SVD is a chain of dependent operations (a Jacobi pair's angle, its
// rsqrt, the rotation that the next pair reads), so the core overlaps
// independent vectors only. Two fill a core whose 512-bit FMAs run as two
// 256-bit halves (Zen 4, where this was tuned); a core with two full-width
// FMA pipes (Zen 5, Intel Xeons) has twice the throughput to fill and takes 4, even at
// the cost of spills (4 states do not fit 32 zmm registers; the stack
// traffic goes to the load/store pipes, not the FMA pipes). Measured on
// Zen 5 (EPYC, AVX-512 float, default knobs, 1 thread): 1 vector 15.5 ns,
// 2: 10.3, 3: 10.0, 4: 9.0-9.3 ns per matrix; but on a batch far bigger
// than the caches 4 took 31-39 ns against 22-27 with plain stores (the
// drivers keep 2 there unless they stream the outputs, svd3.c). On an
// Intel Xeon (Emerald Rapids, full width) 4 took 14.6 against 15.8 ns
// cache-resident (seventeenth round; kernels/cpu_x86.c).
#define SVD3_IL 2
#define SVD3_IL_WIDE 4

// Offset of vector j's entry 0 in a batch of `planes`-plane blocks.
static inline size_t vec_offset(size_t j, int planes) {
  return (j / EK_VPB) * (size_t)planes * EK_LANES + (j % EK_VPB) * EK_W;
}

// The SVD (polar: R and Ssym) of n vectors of matrices, outputs in
// registers: u = U or R, s = S scaled back, w = V or Ssym. n, exact and
// polar are compile-time constants at each call below, so every
// combination gets its own straight-line code.
EK_INLINE void svd3_solve(int n, const vreal (*a)[9], vreal (*u)[9], vreal (*s)[3], vreal (*w)[9],
                          int sweeps, int refine, int exact, int polar) {
  vreal scale[SVD3_MAX_N];
  svd3_core_n(n, a, u, s, w, scale, sweeps, refine, exact);
  for (int j = 0; j < n; j++) {
    if (polar) {
      vreal r[9], p[9];
      svd3_polar(u[j], s[j], w[j], scale[j], r, p);
      for (int i = 0; i < 9; i++)
        u[j][i] = r[i], w[j][i] = p[i];
    } else {
      for (int i = 0; i < 3; i++)
        s[j][i] = vmul(s[j][i], scale[j]);
    }
  }
}

// The remainder of a call (an odd last vector, an AoS tail) is at most one
// or two vectors per call, so one out-of-line copy with run-time knobs
// serves every variant: inlined per (n, rsqrt, polar, layout) as the main
// loop is, it made this file the longest of the build. The same operations,
// so the same bits.
__attribute__((noinline)) static void svd3_solve_one(const vreal a[9], vreal u[9], vreal s[3],
                                                     vreal w[9], int sweeps, int refine, int exact,
                                                     int polar) {
  svd3_solve(1, (const vreal(*)[9])a, (vreal(*)[9])u, (vreal(*)[3])s, (vreal(*)[9])w, sweeps,
             refine, exact, polar);
}

// n vectors: the main loop's n = SVD3_IL inline, a single one out of line.
EK_INLINE void svd3_solve_n(int n, const vreal (*a)[9], vreal (*u)[9], vreal (*s)[3], vreal (*w)[9],
                            int sweeps, int refine, int exact, int polar) {
  if (n == 1)
    svd3_solve_one(a[0], u[0], s[0], w[0], sweeps, refine, exact, polar);
  else
    svd3_solve(n, a, u, s, w, sweeps, refine, exact, polar);
}

// One AoSoA output of vectors j0 .. j0 + n - 1 (v[j * planes + i]: vector
// j's plane i) where k->nt is set: block by block, plane by plane, a
// block's EK_VPB vectors side by side, so each array's lines are written
// whole and in address order (AVX2's two half-line vectors of a line back
// to back). Streaming stores (`stream`) in the plain stores' order, U and
// V plane by plane with AVX2's halves 21 stores apart, took 48.5 ns per
// f32 matrix against 26.1 plain on a Zen 4 (partial lines leave the write
// combining buffers one half at a time); in this order 26.5 (2 chains).
EK_INLINE void svd3_put_lines(int n, size_t j0, real *P, int planes, const vreal *v, int stream) {
  for (int j = 0; j < n; j += EK_VPB)
    for (int i = 0; i < planes; i++)
      for (int l = j; l < j + EK_VPB && l < n; l++) {
        real *p = P + vec_offset(j0 + (size_t)l, planes) + (size_t)i * EK_LANES;
        if (stream)
          vstream(p, v[l * planes + i]);
        else
          vstore(p, v[l * planes + i]);
      }
}

// AoSoA: vectors j0 .. j0 + n - 1 of the batch. nt (k->nt): the outputs
// written by streaming stores (svd3_put_lines); 0 keeps the plain stores'
// order below.
EK_INLINE void svd3_vectors(int n, size_t j0, const real *A, real *U, real *S, real *V, int sweeps,
                            int refine, int exact, int polar, int nt) {
  vreal a[SVD3_MAX_N][9], u[SVD3_MAX_N][9], s[SVD3_MAX_N][3], w[SVD3_MAX_N][9];
  for (int j = 0; j < n; j++)
    for (int i = 0; i < 9; i++)
      a[j][i] = vload(A + vec_offset(j0 + j, 9) + (size_t)i * EK_LANES);
  svd3_solve_n(n, (const vreal(*)[9])a, u, s, w, sweeps, refine, exact, polar);
  if (nt) {
    svd3_put_lines(n, j0, U, 9, u[0], nt & EK_SVD3_NT_U);
    if (V)
      svd3_put_lines(n, j0, V, 9, w[0], nt & EK_SVD3_NT_V);
    if (!polar)
      svd3_put_lines(n, j0, S, 3, s[0], nt & EK_SVD3_NT_S);
    return;
  }
  for (int j = 0; j < n; j++) {
    size_t m9 = vec_offset(j0 + j, 9), m3 = vec_offset(j0 + j, 3);
    for (int i = 0; i < 9; i++) {
      vstore(U + m9 + (size_t)i * EK_LANES, u[j][i]);
      if (V)
        vstore(V + m9 + (size_t)i * EK_LANES, w[j][i]);
    }
    if (!polar)
      for (int i = 0; i < 3; i++)
        vstore(S + m3 + (size_t)i * EK_LANES, s[j][i]);
  }
}

EK_INLINE void svd3_blocks(int il, size_t nblocks, const real *A, real *U, real *S, real *V,
                           int sweeps, int refine, int exact, int polar, int nt) {
  size_t nvec = nblocks * EK_VPB, j = 0;
  for (; j + (size_t)il <= nvec; j += (size_t)il)
    svd3_vectors(il, j, A, U, S, V, sweeps, refine, exact, polar, nt);
  for (; j < nvec; j++)
    svd3_vectors(1, j, A, U, S, V, sweeps, refine, exact, polar, nt);
}

// AoS: the n * EK_W matrices from m0 on, transposed to and from registers
// on the way in and out (vload_records, vstore_records). U, V (R, Ssym) may
// be NULL; S is written in SVD mode only.
// nt (k->nt): which outputs take streaming stores (EK_SVD3_NT_*), a
// run-time flag: only the stores are duplicated, not the SVD.
EK_INLINE void svd3_aos_put(real *p, int np, const vreal *planes, int nt) {
  if (nt)
    vstore_records_nt(p, np, planes);
  else
    vstore_records(p, np, planes);
}

EK_INLINE void svd3_aos_vectors(int n, size_t m0, const real *A, real *U, real *S, real *V,
                                int sweeps, int refine, int exact, int polar, int nt) {
  vreal a[SVD3_MAX_N][9], u[SVD3_MAX_N][9], s[SVD3_MAX_N][3], w[SVD3_MAX_N][9];
  for (int j = 0; j < n; j++)
    vload_records(A + 9 * (m0 + (size_t)j * EK_W), 9, a[j]);
  svd3_solve_n(n, (const vreal(*)[9])a, u, s, w, sweeps, refine, exact, polar);
  for (int j = 0; j < n; j++) {
    size_t m = m0 + (size_t)j * EK_W;
    if (U)
      svd3_aos_put(U + 9 * m, 9, u[j], nt & EK_SVD3_NT_U);
    if (V)
      svd3_aos_put(V + 9 * m, 9, w[j], nt & EK_SVD3_NT_V);
    if (!polar)
      svd3_aos_put(S + 3 * m, 3, s[j], nt & EK_SVD3_NT_S);
  }
}

// AoS: n matrices; a last partial vector goes through a local copy padded
// with the identity (so no lane reads or writes past the arrays).
EK_INLINE void svd3_aos(int il, size_t n, const real *A, real *U, real *S, real *V, int sweeps,
                        int refine, int exact, int polar, int nt) {
  size_t m = 0, step = (size_t)il * EK_W;
  for (; m + step <= n; m += step)
    svd3_aos_vectors(il, m, A, U, S, V, sweeps, refine, exact, polar, nt);
  for (; m + EK_W <= n; m += EK_W)
    svd3_aos_vectors(1, m, A, U, S, V, sweeps, refine, exact, polar, nt);
  if (m == n)
    return;
  size_t tail = n - m;
  real a[9 * EK_W], u[9 * EK_W], s[3 * EK_W], v[9 * EK_W];
  for (size_t l = 0; l < EK_W; l++)
    for (int i = 0; i < 9; i++)
      a[9 * l + i] = l < tail ? A[9 * (m + l) + i] : (real)(i % 4 == 0);
  svd3_aos_vectors(1, 0, a, u, s, v, sweeps, refine, exact, polar, 0);
  for (size_t l = 0; l < tail; l++) {
    for (int i = 0; i < 9; i++) {
      if (U)
        U[9 * (m + l) + i] = u[9 * l + i];
      if (V)
        V[9 * (m + l) + i] = v[9 * l + i];
    }
    if (!polar)
      for (int i = 0; i < 3; i++)
        S[3 * (m + l) + i] = s[3 * l + i];
  }
}

EK_INLINE void svd3_any(int il, size_t count, const real *A, real *U, real *S, real *V, int sweeps,
                        int refine, int exact, int polar, int aos, int nt) {
  if (aos)
    svd3_aos(il, count, A, U, S, V, sweeps, refine, exact, polar, nt);
  else
    svd3_blocks(il, count, A, U, S, V, sweeps, refine, exact, polar, nt);
}

// The wide copies (SVD3_IL_WIDE vectors in flight) in a function of their
// own, so that the compiler's choices in them (register allocation, loop
// structure: svd3_core_n keeps the wide Jacobi and one-sided sweeps as
// loops over the vectors) leave the 2-vector copies' code as it was.
__attribute__((noinline)) static void svd3_any_wide(size_t count, const real *A, real *U, real *S,
                                                    real *V, const ek_svd3_knobs *k) {
  if (k->polar)
    svd3_any(SVD3_IL_WIDE, count, A, U, S, V, k->sweeps, k->refine, 0, 1, k->aos, k->nt);
  else
    svd3_any(SVD3_IL_WIDE, count, A, U, S, V, k->sweeps, k->refine, 0, 0, k->aos, k->nt);
}

void EK_SYM(svd3_block)(size_t count, const real *A, real *U, real *S, real *V,
                        const ek_svd3_knobs *k) {
  ek_fpmode mode = ek_fpmode_enter(); // fpmode.h: ek's own mode, whatever the caller's
  // The wide copy exists for the approximate rsqrt only (the default of
  // both precisions): each copy inlines whole SVDs, and the exact one is an
  // accuracy knob whose time matters less.
  if (k->chains == SVD3_IL_WIDE && !k->exact_rsqrt) {
    svd3_any_wide(count, A, U, S, V, k);
  } else if (k->polar) {
    if (k->exact_rsqrt)
      svd3_any(SVD3_IL, count, A, U, S, V, k->sweeps, k->refine, 1, 1, k->aos, k->nt);
    else
      svd3_any(SVD3_IL, count, A, U, S, V, k->sweeps, k->refine, 0, 1, k->aos, k->nt);
  } else {
    if (k->exact_rsqrt)
      svd3_any(SVD3_IL, count, A, U, S, V, k->sweeps, k->refine, 1, 0, k->aos, k->nt);
    else
      svd3_any(SVD3_IL, count, A, U, S, V, k->sweeps, k->refine, 0, 0, k->aos, k->nt);
  }
  if (k->nt)
    vstream_fence();
  ek_fpmode_leave(mode);
}

// The out-of-line pair of svd3_core.h (svd3_pair), one per rsqrt mode.
__attribute__((noinline)) void EK_SYM(svd3_pair_exact)(int nv, const vreal A[2][9], vreal U[2][9],
                                                       vreal S[2][3], vreal V[2][9], int sweeps,
                                                       int refine) {
  if (nv == 1)
    svd3_solve_one(A[0], U[0], S[0], V[0], sweeps, refine, 1, 0);
  else
    svd3_core_pair(2, A, U, S, V, sweeps, refine, 1);
}

__attribute__((noinline)) void EK_SYM(svd3_pair_est)(int nv, const vreal A[2][9], vreal U[2][9],
                                                     vreal S[2][3], vreal V[2][9], int sweeps,
                                                     int refine) {
  if (nv == 1)
    svd3_solve_one(A[0], U[0], S[0], V[0], sweeps, refine, 0, 0);
  else
    svd3_core_pair(2, A, U, S, V, sweeps, refine, 0);
}

__attribute__((noinline)) void EK_SYM(svd3_quad_est)(int nv, const vreal A[4][9], vreal U[4][9],
                                                     vreal S[4][3], vreal V[4][9], int sweeps,
                                                     int refine) {
  if (nv == 4) {
    vreal scale[4];
    svd3_core_n(4, A, U, S, V, scale, sweeps, refine, 0);
    for (int j = 0; j < 4; j++)
      for (int i = 0; i < 3; i++)
        S[j][i] = vmul(S[j][i], scale[j]);
  } else {
    for (int j = 0; j < nv; j += 2)
      EK_SYM(svd3_pair_est)(nv - j < 2 ? 1 : 2, A + j, U + j, S + j, V + j, sweeps, refine);
  }
}

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(svd3_block_fill)(ek_kernel_table *t);
void EK_SYM(svd3_block_fill)(ek_kernel_table *t) { t->EK_FIELD(svd3_block) = EK_SYM(svd3_block); }
