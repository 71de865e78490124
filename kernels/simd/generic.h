// Derived vector ops, written once in terms of each target's primitives
// (Highway's habit: hwy/ops/generic_ops-inl.h, where a target that has a
// native sequence defines HWY_NATIVE_<OP> and the generic one steps aside).
// Included by simd.h after the target header, never directly.
//
// A target that maps one of these ops to a better instruction sequence
// defines the op itself and EK_HAVE_<OP> before this header. Each generic
// body is the operation sequence every target used before it moved here, so
// the kernels' bits did not change (the kernel-output hashes before and
// after are identical).
#ifndef EK_SIMD_GENERIC_H
#define EK_SIMD_GENERIC_H

// vmla(a, b, c) = a*b + c, fused where the target has FMA. The scalar target
// defines its own, unfused: baseline x86-64 has no FMA instruction and
// libm's fma is a slow software routine there (scalar.h).
#ifndef EK_HAVE_VMLA
static inline vreal vmla(vreal a, vreal b, vreal c) { return vfma(a, b, c); }
#endif

// vrsqrt(x) = 1/sqrt(x): the correctly rounded square root, then a
// correctly rounded divide (so every target gives the same bits).
static inline vreal vrsqrt(vreal a) { return vdiv(vset(1), vsqrt(a)); }

// vrsqrt_raw / vrsqrt_est. A target with a hardware estimate defines
// vrsqrt_raw (the instruction), EK_HAVE_VRSQRT_RAW, its documented relative
// error bound EK_RSQRT_RAW_TOL and the Newton steps EK_RSQRT_NEWTON that
// vrsqrt_est applies. Without an estimate both are the exact vrsqrt.
#ifdef EK_HAVE_VRSQRT_RAW
// Newton's step for 1/sqrt(a), y' = y (1.5 - (0.5 a y) y), with a fused
// 1.5 - (h y) y (vnmla is fused on every target that has an estimate). A
// step takes a relative error e to about 1.5 e^2, so one step on a 12- or
// 14-bit estimate reaches float precision and two on the 14-bit one reach
// double precision (the bound the test checks: tests/simd_ops.c).
static inline vreal vrsqrt_est(vreal a) {
  vreal y = vrsqrt_raw(a);
  vreal h = vmul(vset((real)0.5), a);
  for (int k = 0; k < EK_RSQRT_NEWTON; k++)
    y = vmul(y, vnmla(vmul(h, y), y, vset((real)1.5)));
  return y;
}
#else
#define EK_RSQRT_NEWTON 0
static inline vreal vrsqrt_raw(vreal a) { return vrsqrt(a); }
static inline vreal vrsqrt_est(vreal a) { return vrsqrt(a); }
#endif

// visfinite(x): x - x is 0 for finite x and NaN for inf or NaN.
static inline vmask visfinite(vreal a) { return veq(vsub(a, a), vzero()); }

// vsel_op(m, a, b) = vsel(m, a, b) where the target spells it otherwise
// (avx2.h says why).
#ifndef EK_HAVE_VSEL_OP
static inline vreal vsel_op(vmask m, vreal a, vreal b) { return vsel(m, a, b); }
#endif

// vsel_neg(m, a, b) = m ? -a : b. AVX-512 does it in one masked XOR.
#ifndef EK_HAVE_VSEL_NEG
static inline vreal vsel_neg(vmask m, vreal a, vreal b) { return vsel_op(m, vneg(a), b); }
#endif

// The record transposes, through a tile of np planes in L1: the records
// are copied field by field between p and the tile, the planes move as
// whole vectors. (Measured on Zen 4, AVX-512 float: 16-lane gathers for
// the loads cost as much as this; gathering the output runs from a
// just-stored tile cost 2x more: the gathers wait for the stores; README,
// "The AoS API".) The scalar target's path; the vector targets transpose in
// registers below.
static inline void vload_records_tile(const real *p, int np, vreal *planes) {
  real tile[EK_RECORD_MAX * EK_W] __attribute__((aligned(64)));
  for (int l = 0; l < EK_W; l++)
    for (int k = 0; k < np; k++)
      tile[k * EK_W + l] = p[l * np + k];
  for (int k = 0; k < np; k++)
    planes[k] = vload(tile + k * EK_W);
}
static inline void vstore_records_tile(real *p, int np, const vreal *planes) {
  real tile[EK_RECORD_MAX * EK_W] __attribute__((aligned(64)));
  for (int k = 0; k < np; k++)
    vstore(tile + k * EK_W, planes[k]);
  for (int l = 0; l < EK_W; l++)
    for (int k = 0; k < np; k++)
      p[l * np + k] = tile[k * EK_W + l];
}

#ifdef EK_HAVE_VREC_PERM
// The record transposes in registers, from the target's vrec_blend (a
// constant lane mask), vrec_perm and vrec_perm2 (constant lane indices).
// The W records are np vectors in memory; element e = np l + k is field k of
// record l, at lane e mod W of vector e / W. With np = q s (q odd):
//  1. split by e mod q, with blends alone: in a group of q vectors (q W
//     elements, a multiple of q), the q elements at one lane j are
//     W t + j, t < q, and W is coprime with q, so they lie in q different
//     classes mod q: one blend chain of the q vectors per class c puts the
//     whole class in one vector, W of its elements p = (e - c) / q (a
//     "stream": p = s l + r for field k = q r + c), lane j holding
//     p = (W t + j - c) / q, a fixed lane order;
//  2. split each stream by p mod s the same way (s odd: its s vectors hold
//     at lane j the positions W g + p_j, g < s, in s different classes mod
//     s) and put the lanes in record order with one permute; s = 2 (both in
//     one class) takes one two-source permute, s = 1 one permute.
// For np = 9 (q = s = 3): 36 selects (vrec_blend: vblendmps on AVX-512,
// vblendps on AVX2) and 9 permutes per 9 planes, against 81 masked
// permutes in vload_records_masked (avx512.h) or AVX2's tile through L1;
// the store is the mirror image. Zen 5, the warm polar's AoS API, f32,
// 4096 matrices, 1 thread: 3.6 ns per matrix against 5.8 (AVX-512) and
// 6.9 against 8.9 (AVX2); the AoSoA kernel 3.0 / 5.8 (docs/perf.md).
// q = 3 where 3 divides np, else q = np for odd np; np = 2 is q = 1,
// s = 2; np = 4 is q = 2, s = 2, where stage 1 takes a two-source permute
// per stream (even W: selects cannot split by parity) and leaves the lanes
// in order; np = 8 takes the target's other path. The loops are unrolled
// fully so that, np being a literal at every call, the masks and indices
// fold to constants.
EK_INLINE int vrec_factored(int np) { return np % 3 == 0 || np % 2 == 1 || np == 2 || np == 4; }
EK_INLINE int vrec_q(int np) { return np % 3 == 0 ? 3 : np % 2 == 1 ? np : np / 2; }
// Stage 1: lane j of class c's vector holds stream position vrec_pos (of
// W in the group); position p (< W) is at lane vrec_lane_at.
EK_INLINE int vrec_pos(int q, int c, int j) {
  if (q == 2)
    return j;
  int t = 0;
#pragma GCC unroll 16
  for (int u = 0; u < q; u++)
    if ((EK_W * u + j) % q == c)
      t = u;
  return (EK_W * t + j - c) / q;
}
EK_INLINE int vrec_lane_at(int q, int c, int p) { return q == 2 ? p : (q * p + c) % EK_W; }
// Lanes j of group vector t whose element is in class c (mod q).
EK_INLINE unsigned vrec_class_mask(int q, int t, int c) {
  unsigned m = 0;
#pragma GCC unroll 16
  for (int j = 0; j < EK_W; j++)
    m |= (unsigned)((EK_W * t + j) % q == c) << j;
  return m;
}
// Lanes j of stream c's group-g vector whose position is in class r (mod s).
EK_INLINE unsigned vrec_stream_mask(int q, int s, int c, int g, int r) {
  unsigned m = 0;
#pragma GCC unroll 16
  for (int j = 0; j < EK_W; j++)
    m |= (unsigned)((EK_W * g + vrec_pos(q, c, j)) % s == r) << j;
  return m;
}

EK_INLINE void vrec_load_factored(const real *p, int np, vreal *planes) {
  const int q = vrec_q(np), s = np / q;
  vreal in[EK_RECORD_MAX], b[EK_RECORD_MAX]; // b[g q + c]: class c of group g
  // Each record vector loaded once, into a register (the empty asm): else
  // the compiler reloads it for each blend that reads it, folded into
  // AVX-512's masked blends as masked memory operands (avx512.h).
#pragma GCC unroll 16
  for (int v = 0; v < np; v++) {
    in[v] = vload(p + v * EK_W);
    __asm__("" : "+v"(in[v]));
  }
#pragma GCC unroll 16
  for (int g = 0; g < s; g++)
#pragma GCC unroll 16
    for (int c = 0; c < q; c++) {
      if (q == 2) {
        int idx[EK_W];
#pragma GCC unroll 16
        for (int j = 0; j < EK_W; j++)
          idx[j] = 2 * j + c;
        b[g * q + c] = vrec_perm2(in[2 * g], in[2 * g + 1], idx);
        continue;
      }
      vreal acc = in[q * g];
#pragma GCC unroll 16
      for (int t = 1; t < q; t++)
        acc = vrec_blend(vrec_class_mask(q, t, c), acc, in[q * g + t]);
      b[g * q + c] = acc;
    }
#pragma GCC unroll 16
  for (int c = 0; c < q; c++)
#pragma GCC unroll 16
    for (int r = 0; r < s; r++) {
      // Field q r + c of record l: stream position s l + r.
      int idx[EK_W];
#pragma GCC unroll 16
      for (int l = 0; l < EK_W; l++) {
        int pos = s * l + r;
        idx[l] = (s == 2 ? pos / EK_W * EK_W : 0) + vrec_lane_at(q, c, pos % EK_W);
      }
      if (s == 2) {
        planes[q * r + c] = vrec_perm2(b[c], b[q + c], idx);
        continue;
      }
      vreal acc = b[c];
#pragma GCC unroll 16
      for (int g = 1; g < s; g++)
        acc = vrec_blend(vrec_stream_mask(q, s, c, g, r), acc, b[g * q + c]);
      planes[q * r + c] = vrec_perm(acc, idx);
    }
}

// The stores of the transposes, plain or non-temporal (nt a constant).
EK_INLINE void vrec_put(real *p, vreal v, int nt) {
  if (nt)
    vstream(p, v);
  else
    vstore(p, v);
}

EK_INLINE void vrec_store_factored(real *p, int np, const vreal *planes, int nt) {
  const int q = vrec_q(np), s = np / q;
  vreal b[EK_RECORD_MAX];
#pragma GCC unroll 16
  for (int c = 0; c < q; c++) {
    if (s == 2) {
#pragma GCC unroll 16
      for (int g = 0; g < 2; g++) {
        int idx[EK_W];
#pragma GCC unroll 16
        for (int j = 0; j < EK_W; j++) {
          int pos = EK_W * g + vrec_pos(q, c, j);
          idx[j] = pos % 2 * EK_W + pos / 2;
        }
        b[g * q + c] = vrec_perm2(planes[c], planes[q + c], idx);
      }
      continue;
    }
    // Field q r + c in the lane order of stage 1: lane j of group g holds
    // stream position W g + p_j, of record (W g + p_j) / s, for the one g
    // whose position is in class r.
    vreal rq[EK_RECORD_MAX];
#pragma GCC unroll 16
    for (int r = 0; r < s; r++) {
      int idx[EK_W];
#pragma GCC unroll 16
      for (int j = 0; j < EK_W; j++) {
        int l = 0;
#pragma GCC unroll 16
        for (int g = 0; g < s; g++)
          if ((EK_W * g + vrec_pos(q, c, j)) % s == r)
            l = (EK_W * g + vrec_pos(q, c, j)) / s;
        idx[j] = l;
      }
      rq[r] = vrec_perm(planes[q * r + c], idx);
    }
#pragma GCC unroll 16
    for (int g = 0; g < s; g++) {
      vreal acc = rq[0];
#pragma GCC unroll 16
      for (int r = 1; r < s; r++)
        acc = vrec_blend(vrec_stream_mask(q, s, c, g, r), acc, rq[r]);
      b[g * q + c] = acc;
    }
  }
#pragma GCC unroll 16
  for (int g = 0; g < s; g++)
#pragma GCC unroll 16
    for (int t = 0; t < q; t++) {
      if (q == 2) {
        int idx[EK_W];
#pragma GCC unroll 16
        for (int j = 0; j < EK_W; j++)
          idx[j] = (EK_W * t + j) % 2 * EK_W + (EK_W * t + j) / 2;
        vrec_put(p + (2 * g + t) * EK_W, vrec_perm2(b[2 * g], b[2 * g + 1], idx), nt);
        continue;
      }
      vreal acc = b[g * q];
#pragma GCC unroll 16
      for (int c = 1; c < q; c++)
        acc = vrec_blend(vrec_class_mask(q, t, c), acc, b[g * q + c]);
      vrec_put(p + (q * g + t) * EK_W, acc, nt);
    }
}
#endif

// vsum_run3(o, rs, e, off, n, first): one 3x3 block of an assembled
// matrix (rows rs apart) plus n element blocks in order, each 9 values a
// plane stride es apart from e + off[j], summed in double:
//   o[i rs + m] = (((o[i rs + m] + e_0) + e_1) + ... + e_{n-1})
// (o's old value taken as 0 where first). A sum keeps its first NaN: once
// the partial sum is NaN it stays (quieted), as x86's add returns its first
// operand's NaN, whichever way the compiler orders the add's operands
// (kernels/fvm/hessian.c, the assembly, says why the order matters).
#ifndef EK_HAVE_VSUM_RUN3
static inline double vsum_nan_first_(double a, double b) { return a != a ? a + 0.0 : a + b; }
static inline void vsum_run3(double *o, size_t rs, const real *e, size_t es, const uint16_t *off,
                             int n, int first) {
  for (int i = 0; i < 3; i++)
    for (int m = 0; m < 3; m++) {
      double acc = first ? 0 : o[(size_t)i * rs + (size_t)m];
      for (int j = 0; j < n; j++)
        acc = vsum_nan_first_(acc, (double)e[off[j] + (size_t)(3 * i + m) * es]);
      o[(size_t)i * rs + (size_t)m] = acc;
    }
}
#endif

// vadd_rows4(out, idx, stride, rows): one vector's rows of 4 (vstore_rows4,
// vadd_row4: avx512.h) added into out: for lane l = 0..W-1 in order,
// skipping lanes with idx[l] < 0, and corner c = 0..3 in order, out[4 i +
// k] += rows[vrow4_at(l, c) + k] (k < 3), i = idx[c stride + l], o's NaN
// first: the scalar scatter's adds in its order. Four lanes per turn of a
// loop that is not unrolled (vrow4_at(j + q, c) = vrow4_at(j, 0) +
// vrow4_at(q, c) for j a multiple of 4, q < 4, on every target): fully
// unrolled, 16 lanes were 64 load-add-stores of code per vector beside
// the SVD's (the fixed corotated force on Zen 5, docs/perf.md: smaller
// code was faster). The FVM force makes the rows where it makes the corner
// values and adds them later (kernels/fvm/fvm_tet.h); targets without rows
// of 4 may have vscatter_add_rows4 (avx2.h), the same adds from the corner
// planes in registers.
#ifdef EK_HAVE_VROWS4
EK_INLINE void vadd_rows4(real *out, const int32_t *idx, int stride, const real *rows) {
#pragma GCC unroll 1
  for (unsigned j = 0; j < EK_W; j += 4) {
    const int32_t *ix = idx + j;
    const real *r = rows + vrow4_at(j, 0);
#pragma GCC unroll 4
    for (unsigned q = 0; q < 4; q++) {
      if (ix[q] < 0)
        continue;
#pragma GCC unroll 4
      for (unsigned c = 0; c < 4; c++)
        vadd_row4(out + (size_t)ix[(size_t)c * (size_t)stride + q] * 4, r + vrow4_at(q, c));
    }
  }
}
#endif

EK_INLINE void vload_records(const real *p, int np, vreal *planes) {
#ifdef EK_HAVE_VREC_PERM
  if (np == 1) {
    planes[0] = vload(p);
    return;
  }
  if (vrec_factored(np)) {
    vrec_load_factored(p, np, planes);
    return;
  }
#endif
#ifdef EK_HAVE_VRECORDS_MASKED
  vload_records_masked(p, np, planes);
#else
  vload_records_tile(p, np, planes);
#endif
}
// nt (a constant): streaming stores for the factored sizes; the others
// (np 4, 8: the masked permutes, and the scalar target's tile) store
// plainly.
EK_INLINE void vstore_records_as(real *p, int np, const vreal *planes, int nt) {
  (void)nt; // no streaming store without the permutes
#ifdef EK_HAVE_VREC_PERM
  if (np == 1) {
    vrec_put(p, planes[0], nt);
    return;
  }
  if (vrec_factored(np)) {
    vrec_store_factored(p, np, planes, nt);
    return;
  }
#endif
#ifdef EK_HAVE_VRECORDS_MASKED
  vstore_records_masked(p, np, planes);
#else
  vstore_records_tile(p, np, planes);
#endif
}
EK_INLINE void vstore_records(real *p, int np, const vreal *planes) {
  vstore_records_as(p, np, planes, 0);
}
EK_INLINE void vstore_records_nt(real *p, int np, const vreal *planes) {
  vstore_records_as(p, np, planes, 1);
}
// Orders the streaming stores before what follows (an OpenMP barrier's
// plain stores and loads do not order them).
static inline void vstream_fence(void) {
#ifndef EK_NO_VSTREAM
  _mm_sfence();
#endif
}

#endif
