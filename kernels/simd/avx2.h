// AVX2 + FMA target. Included through simd.h only; needs -mavx2 -mfma.
#ifndef EK_SIMD_AVX2_H
#define EK_SIMD_AVX2_H

#if !defined(__AVX2__) || !defined(__FMA__)
#error "the avx2 target needs -mavx2 -mfma"
#endif
#include <immintrin.h>
#include <stdint.h>

#if defined(EK_REAL_F32)
#define EK_W 8
typedef __m256 vreal;
typedef __m256 vmask; // all-ones / all-zeros lanes

static inline vreal vset(real x) { return _mm256_set1_ps(x); }
static inline vreal vzero(void) { return _mm256_setzero_ps(); }
static inline vreal vload(const real *p) { return _mm256_loadu_ps(p); }
static inline void vstore(real *p, vreal v) { _mm256_storeu_ps(p, v); }
static inline void vstream(real *p, vreal v) { _mm256_stream_ps(p, v); }
static inline vreal vadd(vreal a, vreal b) { return _mm256_add_ps(a, b); }
static inline vreal vsub(vreal a, vreal b) { return _mm256_sub_ps(a, b); }
static inline vreal vmul(vreal a, vreal b) { return _mm256_mul_ps(a, b); }
static inline vreal vdiv(vreal a, vreal b) { return _mm256_div_ps(a, b); }
static inline vreal vneg(vreal a) { return _mm256_xor_ps(a, _mm256_set1_ps(-0.0f)); }
static inline vreal vabs(vreal a) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a); }
static inline vreal vmin(vreal a, vreal b) { return _mm256_min_ps(a, b); }
static inline vreal vmax(vreal a, vreal b) { return _mm256_max_ps(a, b); }
static inline vreal vsqrt(vreal a) { return _mm256_sqrt_ps(a); }
static inline vreal vfma(vreal a, vreal b, vreal c) { return _mm256_fmadd_ps(a, b, c); }
// The 12-bit estimate, relative error <= 1.5 2^-12 (Intel SDM, RSQRTPS);
// vrsqrt_est adds one Newton step (generic.h).
#define EK_HAVE_VRSQRT_RAW
#define EK_RSQRT_RAW_TOL 0x1.8p-12
#define EK_RSQRT_NEWTON 1
static inline vreal vrsqrt_raw(vreal a) { return _mm256_rsqrt_ps(a); }
static inline vmask vlt(vreal a, vreal b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
static inline vmask vle(vreal a, vreal b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
static inline vmask vgt(vreal a, vreal b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
static inline vmask vge(vreal a, vreal b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
static inline vmask veq(vreal a, vreal b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
static inline vmask vmand(vmask a, vmask b) { return _mm256_and_ps(a, b); }
static inline vmask vmor(vmask a, vmask b) { return _mm256_or_ps(a, b); }
static inline vmask vmnot(vmask a) {
  return _mm256_xor_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(-1)));
}
static inline vreal vsel(vmask m, vreal a, vreal b) { return _mm256_blendv_ps(b, a, m); }
// vsel_op: vsel as the instruction itself, for the SVD's selects
// (svd3_core.h). GCC 12 folds the blendv builtins into a generic select on
// "m < 0" and, where it cannot see that m is a compare result, expands that
// back as vpcmpgtd + vblendvps: one more operation on the chain of each
// Jacobi pair (18 per vector in the SVD). The asm keeps one vblendvps, the
// same selection (docs/perf.md, "SVD", twelfth round). Not vsel itself: in
// every kernel it changed GCC's code, and the warm polar's f64 AoS bits
// (ek-hash: one entry of the extremes' inputs, where the code's other
// choices reach NaN lanes differently).
#define EK_HAVE_VSEL_OP
static inline vreal vsel_op(vmask m, vreal a, vreal b) {
  vreal r;
  __asm__("vblendvps %3, %2, %1, %0" : "=x"(r) : "x"(b), "xm"(a), "x"(m));
  return r;
}
static inline int vany(vmask m) { return _mm256_movemask_ps(m) != 0; }
static inline int vall(vmask m) { return _mm256_movemask_ps(m) == 0xff; }

#else // EK_REAL_F64
#define EK_W 4
typedef __m256d vreal;
typedef __m256d vmask;

static inline vreal vset(real x) { return _mm256_set1_pd(x); }
static inline vreal vzero(void) { return _mm256_setzero_pd(); }
static inline vreal vload(const real *p) { return _mm256_loadu_pd(p); }
static inline void vstore(real *p, vreal v) { _mm256_storeu_pd(p, v); }
static inline void vstream(real *p, vreal v) { _mm256_stream_pd(p, v); }
static inline vreal vadd(vreal a, vreal b) { return _mm256_add_pd(a, b); }
static inline vreal vsub(vreal a, vreal b) { return _mm256_sub_pd(a, b); }
static inline vreal vmul(vreal a, vreal b) { return _mm256_mul_pd(a, b); }
static inline vreal vdiv(vreal a, vreal b) { return _mm256_div_pd(a, b); }
static inline vreal vneg(vreal a) { return _mm256_xor_pd(a, _mm256_set1_pd(-0.0)); }
static inline vreal vabs(vreal a) { return _mm256_andnot_pd(_mm256_set1_pd(-0.0), a); }
static inline vreal vmin(vreal a, vreal b) { return _mm256_min_pd(a, b); }
static inline vreal vmax(vreal a, vreal b) { return _mm256_max_pd(a, b); }
static inline vreal vsqrt(vreal a) { return _mm256_sqrt_pd(a); }
static inline vreal vfma(vreal a, vreal b, vreal c) { return _mm256_fmadd_pd(a, b, c); }
// AVX2 has no double estimate. The float one, made valid for any double
// (exponent split), converted, and refined by Newton steps to double's
// precision cost more than the square root and the divide: on Zen 4 the f64
// SVD took 100 ns against 78 with them (README, "Accuracy"). So vrsqrt_raw
// and vrsqrt_est are the exact 1/sqrt here (generic.h).
static inline vmask vlt(vreal a, vreal b) { return _mm256_cmp_pd(a, b, _CMP_LT_OQ); }
static inline vmask vle(vreal a, vreal b) { return _mm256_cmp_pd(a, b, _CMP_LE_OQ); }
static inline vmask vgt(vreal a, vreal b) { return _mm256_cmp_pd(a, b, _CMP_GT_OQ); }
static inline vmask vge(vreal a, vreal b) { return _mm256_cmp_pd(a, b, _CMP_GE_OQ); }
static inline vmask veq(vreal a, vreal b) { return _mm256_cmp_pd(a, b, _CMP_EQ_OQ); }
static inline vmask vmand(vmask a, vmask b) { return _mm256_and_pd(a, b); }
static inline vmask vmor(vmask a, vmask b) { return _mm256_or_pd(a, b); }
static inline vmask vmnot(vmask a) {
  return _mm256_xor_pd(a, _mm256_castsi256_pd(_mm256_set1_epi64x(-1)));
}
static inline vreal vsel(vmask m, vreal a, vreal b) { return _mm256_blendv_pd(b, a, m); }
#define EK_HAVE_VSEL_OP
static inline vreal vsel_op(vmask m, vreal a, vreal b) { // as vsel_op of float
  vreal r;
  __asm__("vblendvpd %3, %2, %1, %0" : "=x"(r) : "x"(b), "xm"(a), "x"(m));
  return r;
}
static inline int vany(vmask m) { return _mm256_movemask_pd(m) != 0; }
static inline int vall(vmask m) { return _mm256_movemask_pd(m) == 0xf; }
#endif

#if defined(EK_REAL_F32)
static inline vreal vmls(vreal a, vreal b, vreal c) { return _mm256_fmsub_ps(a, b, c); }
static inline vreal vnmla(vreal a, vreal b, vreal c) { return _mm256_fnmadd_ps(a, b, c); }
#else
static inline vreal vmls(vreal a, vreal b, vreal c) { return _mm256_fmsub_pd(a, b, c); }
static inline vreal vnmla(vreal a, vreal b, vreal c) { return _mm256_fnmadd_pd(a, b, c); }
#endif
#if defined(EK_REAL_F32)
static inline vreal vxorsign(vreal y, vreal x) {
  return _mm256_xor_ps(y, _mm256_and_ps(x, _mm256_set1_ps(-0.0f)));
}
#else
static inline vreal vxorsign(vreal y, vreal x) {
  return _mm256_xor_pd(y, _mm256_and_pd(x, _mm256_set1_pd(-0.0)));
}
#endif

// vmant_exp(x, &e): x = m 2^e with m in [1, 2) and e an integer (as a
// vreal), for positive normal x only (subnormal, zero, negative, inf, NaN
// give unspecified m and e: callers select those lanes away). Exponent
// extraction for vlog (kernels/simd/vmath.h).
#if defined(EK_REAL_F32)
static inline vreal vmant_exp(vreal x, vreal *e) {
  __m256i bits = _mm256_castps_si256(x);
  __m256i field = _mm256_srli_epi32(bits, 23);
  *e = _mm256_cvtepi32_ps(_mm256_sub_epi32(field, _mm256_set1_epi32(127)));
  __m256i mant = _mm256_or_si256(_mm256_and_si256(bits, _mm256_set1_epi32(0x007fffff)),
                                 _mm256_set1_epi32(0x3f800000));
  return _mm256_castsi256_ps(mant);
}
#else
static inline vreal vmant_exp(vreal x, vreal *e) {
  __m256i bits = _mm256_castpd_si256(x);
  // Exponent field (0..2047) to double without a 64-bit convert (AVX2 has
  // none): OR it into the mantissa of 2^52 and subtract 2^52.
  __m256i field = _mm256_srli_epi64(bits, 52);
  __m256d two52 = _mm256_set1_pd(0x1p52);
  __m256d f =
      _mm256_sub_pd(_mm256_castsi256_pd(_mm256_or_si256(field, _mm256_castpd_si256(two52))), two52);
  *e = _mm256_sub_pd(f, _mm256_set1_pd(1023.0));
  __m256i mant = _mm256_or_si256(_mm256_and_si256(bits, _mm256_set1_epi64x(0x000fffffffffffffLL)),
                                 _mm256_set1_epi64x(0x3ff0000000000000LL));
  return _mm256_castsi256_pd(mant);
}
#endif
// vgather(x, idx): lane l = x[idx[l]], EK_W int32 indices; a lane with
// idx < 0 (padding) reads x[0].
#if defined(EK_REAL_F32)
static inline vreal vgather(const real *x, const int32_t *idx) {
  __m256i i = _mm256_max_epi32(_mm256_loadu_si256((const __m256i *)idx), _mm256_setzero_si256());
  return _mm256_i32gather_ps(x, i, 4);
}
#else
static inline vreal vgather(const real *x, const int32_t *idx) {
  __m128i i = _mm_max_epi32(_mm_loadu_si128((const __m128i *)idx), _mm_setzero_si128());
  return _mm256_i32gather_pd(x, i, 8);
}
#endif
// vgather_points(x, idx, p): p[k] lane l = x[3 idx[l] + k] (x: points,
// n x 3), EK_W int32 indices from idx; a lane with idx < 0 (padding) reads
// point 0 and is set in the returned mask. Indices below 2^31 / 3.
#if defined(EK_REAL_F32)
static inline vmask vgather_points(const real *x, const int32_t *idx, vreal p[3]) {
  __m256i i = _mm256_loadu_si256((const __m256i *)idx), zero = _mm256_setzero_si256();
  __m256i o = _mm256_mullo_epi32(_mm256_max_epi32(i, zero), _mm256_set1_epi32(3));
  for (int k = 0; k < 3; k++)
    p[k] = _mm256_i32gather_ps(x + k, o, 4);
  return _mm256_castsi256_ps(_mm256_cmpgt_epi32(zero, i));
}
#else
static inline vmask vgather_points(const real *x, const int32_t *idx, vreal p[3]) {
  __m128i i = _mm_loadu_si128((const __m128i *)idx), zero = _mm_setzero_si128();
  __m128i o = _mm_mullo_epi32(_mm_max_epi32(i, zero), _mm_set1_epi32(3));
  for (int k = 0; k < 3; k++)
    p[k] = _mm256_i32gather_pd(x + k, o, 8);
  return _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm_cmpgt_epi32(zero, i)));
}
#endif
// vload_points and vscatter_add_rows4 (avx512.h says why and how) on 8
// lanes, f32: rows[k] holds points k and 4 + k, the same 4x4 transposes
// inside each 128-bit lane. The loads are vmaskmovps (12 bytes: no read
// past the array); rows of 4 need no masked store, and the NaN rule of the
// scalar add is the add's operand order.
#if defined(EK_REAL_F32)
#define EK_HAVE_VLOAD_POINTS
EK_INLINE vmask vload_points(const real *x, const int32_t *idx, vreal p[3]) {
  const __m128i m3 = _mm_setr_epi32(-1, -1, -1, 0);
  const __m256i pad =
      _mm256_cmpgt_epi32(_mm256_setzero_si256(), _mm256_loadu_si256((const __m256i *)idx));
  __m128 r[8];
  // No padding lane: each row address straight from its index (avx512.h).
  if (__builtin_expect(_mm256_testz_si256(pad, pad), 1)) {
#pragma GCC unroll 8
    for (int l = 0; l < 8; l++)
      r[l] = _mm_maskload_ps(x + (ptrdiff_t)idx[l] * 3, m3);
  } else {
#pragma GCC unroll 8
    for (int l = 0; l < 8; l++)
      r[l] = _mm_maskload_ps(x + (size_t)(idx[l] < 0 ? 0 : idx[l]) * 3, m3);
  }
  __m256 rows[4];
#pragma GCC unroll 4
  for (int k = 0; k < 4; k++)
    rows[k] = _mm256_insertf128_ps(_mm256_castps128_ps256(r[k]), r[4 + k], 1);
  __m256d t0 = _mm256_castps_pd(_mm256_unpacklo_ps(rows[0], rows[1])); // x0 x1 y0 y1
  __m256d t1 = _mm256_castps_pd(_mm256_unpackhi_ps(rows[0], rows[1])); // z0 z1 0 0
  __m256d t2 = _mm256_castps_pd(_mm256_unpacklo_ps(rows[2], rows[3])); // x2 x3 y2 y3
  __m256d t3 = _mm256_castps_pd(_mm256_unpackhi_ps(rows[2], rows[3])); // z2 z3 0 0
  p[0] = _mm256_castpd_ps(_mm256_unpacklo_pd(t0, t2));
  p[1] = _mm256_castpd_ps(_mm256_unpackhi_pd(t0, t2));
  p[2] = _mm256_castpd_ps(_mm256_unpacklo_pd(t1, t3));
  return _mm256_castsi256_ps(pad);
}
// vstore_points (avx512.h's contract, keep a mask vector here) on 8 lanes:
// lane l's x y as one 8-byte store (vmovlps / vmovhps from the unpacked x,
// y pairs) and its z as one 4-byte store (vmovss / vextractps), 12 bytes
// in all. AVX2 has no cheap masked store (vmaskmovps) and a 16-byte store
// would write the next point's x: that point may be another lane's or
// another thread's (a race, and a stale value).
#define EK_HAVE_VSTORE_POINTS
EK_INLINE void vstore_points(real *x, const int32_t *idx, vmask keep, const vreal p[3]) {
  const unsigned bits = (unsigned)_mm256_movemask_ps(keep);
  const __m256 t0 = _mm256_unpacklo_ps(p[0], p[1]); // x0 y0 x1 y1 | x4 y4 x5 y5
  const __m256 t1 = _mm256_unpackhi_ps(p[0], p[1]); // x2 y2 x3 y3 | x6 y6 x7 y7
  // xy[l / 2]: the pairs of lanes (0, 1), (2, 3), (4, 5), (6, 7); z[l / 4].
  const __m128 xy[4] = {_mm256_castps256_ps128(t0), _mm256_castps256_ps128(t1),
                        _mm256_extractf128_ps(t0, 1), _mm256_extractf128_ps(t1, 1)};
  const __m128 z[2] = {_mm256_castps256_ps128(p[2]), _mm256_extractf128_ps(p[2], 1)};
#pragma GCC unroll 8
  for (int l = 0; l < 8; l++) {
    if (!(bits >> l & 1))
      continue;
    real *o = x + (ptrdiff_t)idx[l] * 3;
    if (l & 1)
      _mm_storeh_pi((__m64 *)o, xy[l / 2]);
    else
      _mm_storel_pi((__m64 *)o, xy[l / 2]);
    if (l % 4 == 0)
      _mm_store_ss(o + 2, z[l / 4]);
    else { // vextractps to memory
      const int zl = _mm_extract_ps(z[l / 4], l % 4);
      __builtin_memcpy(o + 2, &zl, sizeof zl);
    }
  }
}
#define EK_HAVE_VSCATTER_ADD_ROWS4
EK_INLINE void vscatter_add_rows4(real *out, const int32_t *idx, int stride, const vreal h[12]) {
  __m256 rows[4][4];
  const __m256 zero = _mm256_setzero_ps();
#pragma GCC unroll 4
  for (int c = 0; c < 4; c++) {
    __m256d t0 = _mm256_castps_pd(_mm256_unpacklo_ps(h[3 * c], h[3 * c + 1]));
    __m256d t1 = _mm256_castps_pd(_mm256_unpackhi_ps(h[3 * c], h[3 * c + 1]));
    __m256d t2 = _mm256_castps_pd(_mm256_unpacklo_ps(h[3 * c + 2], zero));
    __m256d t3 = _mm256_castps_pd(_mm256_unpackhi_ps(h[3 * c + 2], zero));
    rows[c][0] = _mm256_castpd_ps(_mm256_unpacklo_pd(t0, t2));
    rows[c][1] = _mm256_castpd_ps(_mm256_unpackhi_pd(t0, t2));
    rows[c][2] = _mm256_castpd_ps(_mm256_unpacklo_pd(t1, t3));
    rows[c][3] = _mm256_castpd_ps(_mm256_unpackhi_pd(t1, t3));
  }
#pragma GCC unroll 8
  for (int l = 0; l < 8; l++) {
    if (idx[l] < 0)
      continue;
#pragma GCC unroll 4
    for (int c = 0; c < 4; c++) {
      real *o = out + (size_t)idx[c * stride + l] * 4;
      __m128 hv =
          l < 4 ? _mm256_castps256_ps128(rows[c][l % 4]) : _mm256_extractf128_ps(rows[c][l % 4], 1);
      __m128 ov = _mm_loadu_ps(o);
      // o first (avx512.h's vadd_row4): vaddps returns o's NaN
      // where o is NaN, as the compare and blend it replaces did.
      __m128 sum;
      __asm__("vaddps %2, %1, %0" : "=x"(sum) : "x"(ov), "x"(hv));
      _mm_storeu_ps(o, sum);
    }
  }
}
#else
// f64, 4 lanes: a point or a row of 4 doubles is one register (vmaskmovpd
// loads of 3 doubles); the transposes are 4x4 ones by unpacks and
// vperm2f128.
#define EK_HAVE_VLOAD_POINTS
EK_INLINE vmask vload_points(const real *x, const int32_t *idx, vreal p[3]) {
  const __m256i m3 = _mm256_setr_epi64x(-1, -1, -1, 0);
  __m256d r[4];
#pragma GCC unroll 4
  for (int l = 0; l < 4; l++)
    r[l] = _mm256_maskload_pd(x + (size_t)(idx[l] < 0 ? 0 : idx[l]) * 3, m3);
  __m256d t0 = _mm256_unpacklo_pd(r[0], r[1]); // x0 x1 z0 z1
  __m256d t1 = _mm256_unpackhi_pd(r[0], r[1]); // y0 y1 0 0
  __m256d t2 = _mm256_unpacklo_pd(r[2], r[3]); // x2 x3 z2 z3
  __m256d t3 = _mm256_unpackhi_pd(r[2], r[3]); // y2 y3 0 0
  p[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  p[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  p[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  __m128i i = _mm_loadu_si128((const __m128i *)idx);
  return _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm_cmpgt_epi32(_mm_setzero_si128(), i)));
}
// vstore_points (the f32 comment above) on 4 lanes: lane l's x y as one
// 16-byte store (vmovupd / vextractf128 from the unpacked pairs) and its z
// as one 8-byte store (vmovlpd / vmovhpd).
#define EK_HAVE_VSTORE_POINTS
EK_INLINE void vstore_points(real *x, const int32_t *idx, vmask keep, const vreal p[3]) {
  const unsigned bits = (unsigned)_mm256_movemask_pd(keep);
  const __m256d t0 = _mm256_unpacklo_pd(p[0], p[1]); // x0 y0 | x2 y2
  const __m256d t1 = _mm256_unpackhi_pd(p[0], p[1]); // x1 y1 | x3 y3
  const __m128d z[2] = {_mm256_castpd256_pd128(p[2]), _mm256_extractf128_pd(p[2], 1)};
#pragma GCC unroll 4
  for (int l = 0; l < 4; l++) {
    if (!(bits >> l & 1))
      continue;
    real *o = x + (ptrdiff_t)idx[l] * 3;
    const __m256d t = l & 1 ? t1 : t0;
    _mm_storeu_pd(o, l < 2 ? _mm256_castpd256_pd128(t) : _mm256_extractf128_pd(t, 1));
    if (l & 1)
      _mm_storeh_pd(o + 2, z[l / 2]);
    else
      _mm_storel_pd(o + 2, z[l / 2]);
  }
}
#define EK_HAVE_VSCATTER_ADD_ROWS4
EK_INLINE void vscatter_add_rows4(real *out, const int32_t *idx, int stride, const vreal h[12]) {
  __m256d rows[4][4];
  const __m256d zero = _mm256_setzero_pd();
#pragma GCC unroll 4
  for (int c = 0; c < 4; c++) {
    __m256d t0 = _mm256_unpacklo_pd(h[3 * c], h[3 * c + 1]); // x0 y0 x2 y2
    __m256d t1 = _mm256_unpackhi_pd(h[3 * c], h[3 * c + 1]); // x1 y1 x3 y3
    __m256d t2 = _mm256_unpacklo_pd(h[3 * c + 2], zero);     // z0 0 z2 0
    __m256d t3 = _mm256_unpackhi_pd(h[3 * c + 2], zero);     // z1 0 z3 0
    rows[c][0] = _mm256_permute2f128_pd(t0, t2, 0x20);
    rows[c][1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    rows[c][2] = _mm256_permute2f128_pd(t0, t2, 0x31);
    rows[c][3] = _mm256_permute2f128_pd(t1, t3, 0x31);
  }
#pragma GCC unroll 4
  for (int l = 0; l < 4; l++) {
    if (idx[l] < 0)
      continue;
#pragma GCC unroll 4
    for (int c = 0; c < 4; c++) {
      real *o = out + (size_t)idx[c * stride + l] * 4;
      __m256d ov = _mm256_loadu_pd(o);
      // o first, as in the f32 version above.
      __m256d sum;
      __asm__("vaddpd %2, %1, %0" : "=x"(sum) : "x"(ov), "x"(rows[c][l]));
      _mm256_storeu_pd(o, sum);
    }
  }
}
#endif

// The record transposes' primitives (generic.h, EK_HAVE_VREC_PERM): a
// blend by a constant lane mask (vblendps / vblendpd, an immediate, where
// the mask folds to a constant, as the fully unrolled loops of generic.h
// make it at -O2 and above; else vblendvps / vblendvpd on a mask vector: the
// -O1 sanitizer build does not fold it, and an immediate would not compile), a
// one-source lane permute (vpermps; doubles move as float pairs) and a
// two-source one (two permutes and a blend: AVX2 has no vpermt2ps).
#define EK_HAVE_VREC_PERM
#if defined(EK_REAL_F32)
EK_INLINE vreal vrec_blend(unsigned m, vreal a, vreal b) {
  int32_t sel[8];
#pragma GCC unroll 8
  for (int l = 0; l < 8; l++)
    sel[l] = -(int32_t)((m >> l) & 1);
  if (__builtin_constant_p(m))
    return _mm256_blend_ps(a, b, (int)(m & 0xff));
  return _mm256_blendv_ps(a, b, _mm256_castsi256_ps(_mm256_loadu_si256((const __m256i *)sel)));
}
#else
EK_INLINE vreal vrec_blend(unsigned m, vreal a, vreal b) {
  int64_t sel[4];
#pragma GCC unroll 4
  for (int l = 0; l < 4; l++)
    sel[l] = -(int64_t)((m >> l) & 1);
  if (__builtin_constant_p(m))
    return _mm256_blend_pd(a, b, (int)(m & 0xf));
  return _mm256_blendv_pd(a, b, _mm256_castsi256_pd(_mm256_loadu_si256((const __m256i *)sel)));
}
#endif
// Lane l = v[idx[l] mod W] (idx constant).
EK_INLINE vreal vrec_perm(vreal v, const int *idx) {
  int32_t ix[8];
#pragma GCC unroll 8
  for (int i = 0; i < 8; i++)
    ix[i] = EK_W == 8 ? idx[i] % 8 : 2 * (idx[i / 2] % 4) + i % 2;
  __m256i x = _mm256_loadu_si256((const __m256i *)ix);
#if defined(EK_REAL_F32)
  return _mm256_permutevar8x32_ps(v, x);
#else
  return _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(v), x));
#endif
}
// Lane l = idx[l] < W ? a[idx[l]] : b[idx[l] - W] (idx constant).
EK_INLINE vreal vrec_perm2(vreal a, vreal b, const int *idx) {
  unsigned m = 0;
#pragma GCC unroll 8
  for (int l = 0; l < EK_W; l++)
    m |= (unsigned)(idx[l] >= EK_W) << l;
  return vrec_blend(m, vrec_perm(a, idx), vrec_perm(b, idx));
}
// vsum_run3 (generic.h's contract), as avx512.h's: each of the block's 3
// rows summed in a 256-bit register, 3 doubles wide (vmaskmovpd load and
// store of K's row: nothing past its 3 values touched), the element's 3
// values gathered from their planes and widened; the partial sum the add's
// first operand, so a NaN sum is kept (quieted) as the scalar rule keeps it:
// the same adds in the same order, so the same bits. The generic body (a
// loop per value, a compare per add) made the AVX2 assembly's sums twice
// its element kernel (docs/perf.md, "Hessian assembly", thirteenth round).
#define EK_HAVE_VSUM_RUN3
// a + b with a's NaN kept (avx512.h's vadd_pd_nan_first, in ymm registers).
static inline __m256d vadd_pd_nan_first(__m256d a, __m256d b) {
  __m256d s;
  __asm__("vaddpd %2, %1, %0" : "=x"(s) : "x"(a), "x"(b));
  return s;
}
static inline __m256d vsum_elem3_(const real *ei, size_t es) {
#if defined(EK_REAL_F32)
  return _mm256_cvtps_pd(_mm_setr_ps(ei[0], ei[es], ei[2 * es], 0));
#else
  return _mm256_setr_pd(ei[0], ei[es], ei[2 * es], 0);
#endif
}
static inline void vsum_run3(double *o, size_t rs, const real *e, size_t es, const uint16_t *off,
                             int n, int first) {
  const __m256i m3 = _mm256_setr_epi64x(-1, -1, -1, 0);
  __m256d acc[3];
  for (int i = 0; i < 3; i++)
    acc[i] = first ? _mm256_setzero_pd() : _mm256_maskload_pd(o + (size_t)i * rs, m3);
  for (int j = 0; j < n; j++)
    for (int i = 0; i < 3; i++)
      acc[i] = vadd_pd_nan_first(acc[i], vsum_elem3_(e + off[j] + (size_t)(3 * i) * es, es));
  for (int i = 0; i < 3; i++)
    _mm256_maskstore_pd(o + (size_t)i * rs, m3, acc[i]);
}

#endif
