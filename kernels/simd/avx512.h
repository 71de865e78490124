// AVX-512 (F, DQ, VL) target. Included through simd.h only.
#ifndef EK_SIMD_AVX512_H
#define EK_SIMD_AVX512_H

#if !defined(__AVX512F__) || !defined(__AVX512DQ__) || !defined(__AVX512VL__)
#error "the avx512 target needs -mavx512f -mavx512dq -mavx512vl"
#endif
#include <immintrin.h>
#include <stdint.h>

// The 14-bit estimates VRSQRT14PS/PD: relative error < 2^-14 (Intel SDM).
#define EK_HAVE_VRSQRT_RAW
#define EK_RSQRT_RAW_TOL 0x1p-14

#if defined(EK_REAL_F32)
#define EK_W 16
typedef __m512 vreal;
typedef __mmask16 vmask;

static inline vreal vset(real x) { return _mm512_set1_ps(x); }
static inline vreal vzero(void) { return _mm512_setzero_ps(); }
static inline vreal vload(const real *p) { return _mm512_loadu_ps(p); }
static inline void vstore(real *p, vreal v) { _mm512_storeu_ps(p, v); }
static inline void vstream(real *p, vreal v) { _mm512_stream_ps(p, v); }
static inline vreal vadd(vreal a, vreal b) { return _mm512_add_ps(a, b); }
static inline vreal vsub(vreal a, vreal b) { return _mm512_sub_ps(a, b); }
static inline vreal vmul(vreal a, vreal b) { return _mm512_mul_ps(a, b); }
static inline vreal vdiv(vreal a, vreal b) { return _mm512_div_ps(a, b); }
static inline vreal vneg(vreal a) { return _mm512_xor_ps(a, _mm512_set1_ps(-0.0f)); }
static inline vreal vabs(vreal a) { return _mm512_abs_ps(a); }
static inline vreal vmin(vreal a, vreal b) { return _mm512_min_ps(a, b); }
static inline vreal vmax(vreal a, vreal b) { return _mm512_max_ps(a, b); }
static inline vreal vsqrt(vreal a) { return _mm512_sqrt_ps(a); }
static inline vreal vfma(vreal a, vreal b, vreal c) { return _mm512_fmadd_ps(a, b, c); }
// One Newton step on the 14-bit estimate (generic.h).
#define EK_RSQRT_NEWTON 1
static inline vreal vrsqrt_raw(vreal a) { return _mm512_rsqrt14_ps(a); }
static inline vmask vlt(vreal a, vreal b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
static inline vmask vle(vreal a, vreal b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
static inline vmask vgt(vreal a, vreal b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
static inline vmask vge(vreal a, vreal b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
static inline vmask veq(vreal a, vreal b) { return _mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ); }
static inline vreal vsel(vmask m, vreal a, vreal b) { return _mm512_mask_blend_ps(m, b, a); }
static inline int vall(vmask m) { return m == 0xffff; }

#else // EK_REAL_F64
#define EK_W 8
typedef __m512d vreal;
typedef __mmask8 vmask;

static inline vreal vset(real x) { return _mm512_set1_pd(x); }
static inline vreal vzero(void) { return _mm512_setzero_pd(); }
static inline vreal vload(const real *p) { return _mm512_loadu_pd(p); }
static inline void vstore(real *p, vreal v) { _mm512_storeu_pd(p, v); }
static inline void vstream(real *p, vreal v) { _mm512_stream_pd(p, v); }
static inline vreal vadd(vreal a, vreal b) { return _mm512_add_pd(a, b); }
static inline vreal vsub(vreal a, vreal b) { return _mm512_sub_pd(a, b); }
static inline vreal vmul(vreal a, vreal b) { return _mm512_mul_pd(a, b); }
static inline vreal vdiv(vreal a, vreal b) { return _mm512_div_pd(a, b); }
static inline vreal vneg(vreal a) { return _mm512_xor_pd(a, _mm512_set1_pd(-0.0)); }
static inline vreal vabs(vreal a) { return _mm512_abs_pd(a); }
static inline vreal vmin(vreal a, vreal b) { return _mm512_min_pd(a, b); }
static inline vreal vmax(vreal a, vreal b) { return _mm512_max_pd(a, b); }
static inline vreal vsqrt(vreal a) { return _mm512_sqrt_pd(a); }
static inline vreal vfma(vreal a, vreal b, vreal c) { return _mm512_fmadd_pd(a, b, c); }
// Two Newton steps on the 14-bit estimate (14 -> 28 -> 56 bits; generic.h).
#define EK_RSQRT_NEWTON 2
static inline vreal vrsqrt_raw(vreal a) { return _mm512_rsqrt14_pd(a); }
static inline vmask vlt(vreal a, vreal b) { return _mm512_cmp_pd_mask(a, b, _CMP_LT_OQ); }
static inline vmask vle(vreal a, vreal b) { return _mm512_cmp_pd_mask(a, b, _CMP_LE_OQ); }
static inline vmask vgt(vreal a, vreal b) { return _mm512_cmp_pd_mask(a, b, _CMP_GT_OQ); }
static inline vmask vge(vreal a, vreal b) { return _mm512_cmp_pd_mask(a, b, _CMP_GE_OQ); }
static inline vmask veq(vreal a, vreal b) { return _mm512_cmp_pd_mask(a, b, _CMP_EQ_OQ); }
static inline vreal vsel(vmask m, vreal a, vreal b) { return _mm512_mask_blend_pd(m, b, a); }
static inline int vall(vmask m) { return m == 0xff; }
#endif

// a + b with a's NaN kept where a is NaN (x86 returns the first operand's
// NaN, quieted; a plain add lets the compiler order the operands either
// way): the NaN rule of the scalar sums, s = s + x keeping a NaN s, in one
// add (vsum_run3; vadd_row4 the same with its row in memory).
static inline __m256d vadd_pd_nan_first(__m256d a, __m256d b) {
  __m256d s;
  __asm__("vaddpd %2, %1, %0" : "=v"(s) : "v"(a), "v"(b));
  return s;
}

#if defined(EK_REAL_F32)
static inline vreal vmls(vreal a, vreal b, vreal c) { return _mm512_fmsub_ps(a, b, c); }
static inline vreal vnmla(vreal a, vreal b, vreal c) { return _mm512_fnmadd_ps(a, b, c); }
#else
static inline vreal vmls(vreal a, vreal b, vreal c) { return _mm512_fmsub_pd(a, b, c); }
static inline vreal vnmla(vreal a, vreal b, vreal c) { return _mm512_fnmadd_pd(a, b, c); }
#endif
// One masked XOR each: -a where m, else b; y with its sign flipped where x has
// its sign bit set (vpternlog (s & x) ^ y, truth table 0x6a).
#define EK_HAVE_VSEL_NEG
#if defined(EK_REAL_F32)
static inline vreal vsel_neg(vmask m, vreal a, vreal b) {
  return _mm512_mask_xor_ps(b, m, a, _mm512_set1_ps(-0.0f));
}
static inline vreal vxorsign(vreal y, vreal x) {
  return _mm512_castsi512_ps(_mm512_ternarylogic_epi32(
      _mm512_set1_epi32(INT32_MIN), _mm512_castps_si512(x), _mm512_castps_si512(y), 0x6a));
}
#else
static inline vreal vsel_neg(vmask m, vreal a, vreal b) {
  return _mm512_mask_xor_pd(b, m, a, _mm512_set1_pd(-0.0));
}
static inline vreal vxorsign(vreal y, vreal x) {
  return _mm512_castsi512_pd(_mm512_ternarylogic_epi64(
      _mm512_set1_epi64(INT64_MIN), _mm512_castpd_si512(x), _mm512_castpd_si512(y), 0x6a));
}
#endif
static inline vmask vmand(vmask a, vmask b) { return a & b; }
static inline vmask vmor(vmask a, vmask b) { return a | b; }
static inline vmask vmnot(vmask a) { return (vmask)~a; }
static inline int vany(vmask m) { return m != 0; }

// vmant_exp(x, &e): x = m 2^e with m in [1, 2) and e an integer (as a
// vreal), for positive normal x only (subnormal, zero, negative, inf, NaN
// give unspecified m and e: callers select those lanes away). Exponent
// extraction for vlog (kernels/simd/vmath.h).
#if defined(EK_REAL_F32)
static inline vreal vmant_exp(vreal x, vreal *e) {
  __m512i bits = _mm512_castps_si512(x);
  __m512i field = _mm512_srli_epi32(bits, 23);
  *e = _mm512_cvtepi32_ps(_mm512_sub_epi32(field, _mm512_set1_epi32(127)));
  __m512i mant = _mm512_or_si512(_mm512_and_si512(bits, _mm512_set1_epi32(0x007fffff)),
                                 _mm512_set1_epi32(0x3f800000));
  return _mm512_castsi512_ps(mant);
}
#else
static inline vreal vmant_exp(vreal x, vreal *e) {
  __m512i bits = _mm512_castpd_si512(x);
  __m512i field = _mm512_srli_epi64(bits, 52);
  *e = _mm512_cvtepi64_pd(_mm512_sub_epi64(field, _mm512_set1_epi64(1023))); // AVX512DQ
  __m512i mant = _mm512_or_si512(_mm512_and_si512(bits, _mm512_set1_epi64(0x000fffffffffffffLL)),
                                 _mm512_set1_epi64(0x3ff0000000000000LL));
  return _mm512_castsi512_pd(mant);
}
#endif
// vgather(x, idx): lane l = x[idx[l]], EK_W int32 indices; a lane with
// idx < 0 (padding) reads x[0].
#if defined(EK_REAL_F32)
static inline vreal vgather(const real *x, const int32_t *idx) {
  __m512i i = _mm512_max_epi32(_mm512_loadu_si512(idx), _mm512_setzero_si512());
  return _mm512_i32gather_ps(i, x, 4);
}
#else
static inline vreal vgather(const real *x, const int32_t *idx) {
  __m256i i = _mm256_max_epi32(_mm256_loadu_si256((const __m256i *)idx), _mm256_setzero_si256());
  return _mm512_i32gather_pd(i, x, 8);
}
#endif
// vgather_points(x, idx, p): p[k] lane l = x[3 idx[l] + k] (x: points,
// n x 3), EK_W int32 indices from idx; a lane with idx < 0 (padding) reads
// point 0 and is set in the returned mask. Indices below 2^31 / 3.
#if defined(EK_REAL_F32)
static inline vmask vgather_points(const real *x, const int32_t *idx, vreal p[3]) {
  __m512i i = _mm512_loadu_si512(idx), zero = _mm512_setzero_si512();
  __m512i o = _mm512_mullo_epi32(_mm512_max_epi32(i, zero), _mm512_set1_epi32(3));
  for (int k = 0; k < 3; k++)
    p[k] = _mm512_i32gather_ps(o, x + k, 4);
  return _mm512_cmplt_epi32_mask(i, zero);
}
#else
static inline vmask vgather_points(const real *x, const int32_t *idx, vreal p[3]) {
  __m256i i = _mm256_loadu_si256((const __m256i *)idx), zero = _mm256_setzero_si256();
  __m256i o = _mm256_mullo_epi32(_mm256_max_epi32(i, zero), _mm256_set1_epi32(3));
  for (int k = 0; k < 3; k++)
    p[k] = _mm512_i32gather_pd(o, x + k, 8);
  return _mm256_cmplt_epi32_mask(i, zero);
}
#endif

// vload_points(x, idx, p): vgather_points' contract (same values, so the
// same bits) by one 3-float masked load per lane and an in-register
// transpose instead of three vgatherdps (f32). Zen 5 (perf on the FVM
// force kernel, docs/perf.md): the 12 gathers per tet vector were 22-28%
// of the kernel's own samples. Here: 16 masked 16-byte loads (element 3
// masked off: no read past the array's end), 12 vinsertf32x4 and 5
// unpacks; lane j of rows[k] holds point 4j + k, and the 4x4 transposes
// inside each 128-bit lane put the lanes in order.
#if defined(EK_REAL_F32)
#define EK_HAVE_VLOAD_POINTS
EK_INLINE vmask vload_points(const real *x, const int32_t *idx, vreal p[3]) {
  const __m512i iv = _mm512_loadu_si512(idx);
  const vmask pad = _mm512_cmplt_epi32_mask(iv, _mm512_setzero_si512());
  __m128 r[16];
  // No padding lane (every vector but a mesh's last few): each lane's row
  // address straight from its index (an index load, a lea and the load),
  // without the per-lane sign test, branch and clamp (6 instructions per
  // lane; FVM fixed corotated f32, 101 400 tets: ~2% of the force's time,
  // docs/perf.md). Tried and slower: the 16 offsets from a vector store
  // (12 max(idx, 0)) read back as integers: GCC moved them lane by lane
  // out of the register (vpextrd), and forced through memory each read
  // waited on the 64-byte store (no forwarding into the narrower loads,
  // +50% time on Zen 5).
  if (__builtin_expect(pad == 0, 1)) {
#pragma GCC unroll 16
    for (int l = 0; l < 16; l++)
      r[l] = _mm_maskz_loadu_ps(7, x + (ptrdiff_t)idx[l] * 3);
  } else {
#pragma GCC unroll 16
    for (int l = 0; l < 16; l++)
      r[l] = _mm_maskz_loadu_ps(7, x + (size_t)(idx[l] < 0 ? 0 : idx[l]) * 3);
  }
  __m512 rows[4];
#pragma GCC unroll 4
  for (int k = 0; k < 4; k++)
    rows[k] = _mm512_insertf32x4(
        _mm512_insertf32x4(_mm512_insertf32x4(_mm512_castps128_ps512(r[k]), r[4 + k], 1), r[8 + k],
                           2),
        r[12 + k], 3);
  __m512d t0 = _mm512_castps_pd(_mm512_unpacklo_ps(rows[0], rows[1])); // x0 x1 y0 y1
  __m512d t1 = _mm512_castps_pd(_mm512_unpackhi_ps(rows[0], rows[1])); // z0 z1 0 0
  __m512d t2 = _mm512_castps_pd(_mm512_unpacklo_ps(rows[2], rows[3])); // x2 x3 y2 y3
  __m512d t3 = _mm512_castps_pd(_mm512_unpackhi_ps(rows[2], rows[3])); // z2 z3 0 0
  p[0] = _mm512_castpd_ps(_mm512_unpacklo_pd(t0, t2));
  p[1] = _mm512_castpd_ps(_mm512_unpackhi_pd(t0, t2));
  p[2] = _mm512_castpd_ps(_mm512_unpacklo_pd(t1, t3));
  return pad;
}
// vstore_points(x, idx, keep, p): the inverse of vload_points for the lanes
// l set in the mask keep: x[3 idx[l] + k] = lane l of p[k], k < 3,
// one masked 3-float store per lane (no write past the point; the lanes'
// points must be distinct). The rows from vstore_rows4's transpose.
#define EK_HAVE_VSTORE_POINTS
EK_INLINE void vstore_points(real *x, const int32_t *idx, vmask keep, const vreal p[3]) {
  const __m512 zero = _mm512_setzero_ps();
  __m512d t0 = _mm512_castps_pd(_mm512_unpacklo_ps(p[0], p[1])); // x0 y0 x1 y1
  __m512d t1 = _mm512_castps_pd(_mm512_unpackhi_ps(p[0], p[1])); // x2 y2 x3 y3
  __m512d t2 = _mm512_castps_pd(_mm512_unpacklo_ps(p[2], zero)); // z0 0 z1 0
  __m512d t3 = _mm512_castps_pd(_mm512_unpackhi_ps(p[2], zero)); // z2 0 z3 0
  __m512 r[4] = {
      _mm512_castpd_ps(_mm512_unpacklo_pd(t0, t2)), _mm512_castpd_ps(_mm512_unpackhi_pd(t0, t2)),
      _mm512_castpd_ps(_mm512_unpacklo_pd(t1, t3)), _mm512_castpd_ps(_mm512_unpackhi_pd(t1, t3))};
#pragma GCC unroll 16
  for (int l = 0; l < 16; l++) // lane l: register l % 4, 128-bit part l / 4
    if (keep >> l & 1)
      _mm_mask_storeu_ps(x + (ptrdiff_t)idx[l] * 3, 7,
                         l < 4 ? _mm512_castps512_ps128(r[l % 4])
                               : _mm512_extractf32x4_ps(r[l % 4], l / 4));
}
// Rows of 4 for the thread buffers (scatter.c), in two steps so that the
// transpose can run where the corner values are made and the adds later:
// vstore_rows4(rows, h) writes the 12 corner planes h[3 c + k] (corner c,
// component k < 3) of the W lanes as W x 4 rows of 4 reals, lane l's row
// of corner c at rows + vrow4_at(l, c) (component 3 zero), 16 W reals,
// rows 64-byte aligned; vadd_row4(o, row) adds one such row into a
// vertex row of 4, o[k] += row[k], o's NaN first (below).
// vstore_rows4 then vadd_rows4 (generic.h) add, for lane l =
// 0..W-1 in order, skipping lanes with idx[l] < 0, and corner c = 0..3 in
// order, out[4 i + k] += lane l of h[3 c + k], i = idx[c stride + l]: the
// scalar scatter's adds in its order (so the same bits) into rows padded
// to 4 floats, one 16-byte load-add-store per row instead of 3 scalar
// ones. The rows come from the inverse of vload_points' transpose (8
// unpacks per corner), register rows[c][q] holding lanes q, q + 4, q + 8,
// q + 12, stored whole: each row's add then takes its row as a memory
// operand instead of a vextractf32x4 of the register (FVM fixed
// corotated f32, Zen 5: 48 shuffles and the 12 planes' store and reload
// per 16 tets fewer, docs/perf.md). Padded rows, not the caller's
// 3-float rows: a row's load then takes its data from the one earlier
// store of the same row (store-to-load forwarding); with 12-byte masked
// rows (rows of 3) the next load of a row waited for the store to leave
// (Zen 5: the FVM force 5-6 ns per tet slower than the scalar scatter).
#define EK_HAVE_VROWS4
static inline unsigned vrow4_at(unsigned l, unsigned c) { return (c * 4 + l % 4) * 16 + l / 4 * 4; }
EK_INLINE void vstore_rows4(real *rows, const vreal h[12]) {
  const __m512 zero = _mm512_setzero_ps();
#pragma GCC unroll 4
  for (int c = 0; c < 4; c++) {
    __m512d t0 = _mm512_castps_pd(_mm512_unpacklo_ps(h[3 * c], h[3 * c + 1])); // x0 y0 x1 y1
    __m512d t1 = _mm512_castps_pd(_mm512_unpackhi_ps(h[3 * c], h[3 * c + 1])); // x2 y2 x3 y3
    __m512d t2 = _mm512_castps_pd(_mm512_unpacklo_ps(h[3 * c + 2], zero));     // z0 0 z1 0
    __m512d t3 = _mm512_castps_pd(_mm512_unpackhi_ps(h[3 * c + 2], zero));     // z2 0 z3 0
    real *r = rows + c * 4 * 16;
    _mm512_store_ps(r, _mm512_castpd_ps(_mm512_unpacklo_pd(t0, t2)));
    _mm512_store_ps(r + 16, _mm512_castpd_ps(_mm512_unpackhi_pd(t0, t2)));
    _mm512_store_ps(r + 32, _mm512_castpd_ps(_mm512_unpacklo_pd(t1, t3)));
    _mm512_store_ps(r + 48, _mm512_castpd_ps(_mm512_unpackhi_pd(t1, t3)));
  }
}
EK_INLINE void vadd_row4(real *o, const real *row) {
  // The scalar o += h gives o's NaN where both are NaN (x86 returns its
  // first operand's); the compiler may order the vector add's operands
  // either way (inverted tets' NaN forces changed sign), so the add is
  // written out with o first: vaddps returns o's NaN (a sum, already
  // quiet: unchanged) where o is NaN, else o + h, the same results as the
  // compare and masked add it replaced, with two instructions fewer on
  // each row's load-add-store chain. The row is the memory operand.
  __m128 ov = _mm_loadu_ps(o), sum;
  __asm__("vaddps %2, %1, %0" : "=v"(sum) : "v"(ov), "m"(*(const __m128 *)row));
  _mm_storeu_ps(o, sum);
}
#else
// f64: the same contracts on 8 lanes, a point or a row of 4 doubles being
// one 256-bit register (3-double masked loads: no read past the array;
// rows of 4 doubles in the thread buffers: one 256-bit load, add and store
// per row instead of 3 scalar adds). The transposes: 4x4 ones inside each
// 256-bit half (unpacks) and one vpermt2pd per output to put the 128-bit
// pieces in lane order.
#define EK_HAVE_VLOAD_POINTS
EK_INLINE vmask vload_points(const real *x, const int32_t *idx, vreal p[3]) {
  __m256d r[8];
#pragma GCC unroll 8
  for (int l = 0; l < 8; l++)
    r[l] = _mm256_maskz_loadu_pd(7, x + (size_t)(idx[l] < 0 ? 0 : idx[l]) * 3);
  __m512d rows[4];
#pragma GCC unroll 4
  for (int k = 0; k < 4; k++) // points k and 4 + k
    rows[k] = _mm512_insertf64x4(_mm512_castpd256_pd512(r[k]), r[4 + k], 1);
  __m512d t0 = _mm512_unpacklo_pd(rows[0], rows[1]); // x0 x1 z0 z1 | x4 x5 z4 z5
  __m512d t1 = _mm512_unpackhi_pd(rows[0], rows[1]); // y0 y1 0 0 | y4 y5 0 0
  __m512d t2 = _mm512_unpacklo_pd(rows[2], rows[3]); // x2 x3 z2 z3 | x6 x7 z6 z7
  __m512d t3 = _mm512_unpackhi_pd(rows[2], rows[3]); // y2 y3 0 0 | y6 y7 0 0
  const __m512i lo = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13);
  const __m512i hi = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
  p[0] = _mm512_permutex2var_pd(t0, lo, t2);
  p[1] = _mm512_permutex2var_pd(t1, lo, t3);
  p[2] = _mm512_permutex2var_pd(t0, hi, t2);
  return _mm256_cmplt_epi32_mask(_mm256_loadu_si256((const __m256i *)idx), _mm256_setzero_si256());
}
// vstore_points (the f32 comment above) on 8 lanes: lane l's point from
// vstore_rows4's transpose, one masked 3-double store each.
#define EK_HAVE_VSTORE_POINTS
EK_INLINE void vstore_points(real *x, const int32_t *idx, vmask keep, const vreal p[3]) {
  const __m512d zero = _mm512_setzero_pd();
  const __m512i lo = _mm512_setr_epi64(0, 1, 8, 9, 2, 3, 10, 11);
  const __m512i hi = _mm512_setr_epi64(4, 5, 12, 13, 6, 7, 14, 15);
  __m512d t0 = _mm512_unpacklo_pd(p[0], p[1]); // x0 y0 x2 y2 x4 y4 x6 y6
  __m512d t1 = _mm512_unpackhi_pd(p[0], p[1]); // x1 y1 x3 y3 ...
  __m512d t2 = _mm512_unpacklo_pd(p[2], zero); // z0 0 z2 0 ...
  __m512d t3 = _mm512_unpackhi_pd(p[2], zero); // z1 0 z3 0 ...
  // r[q], q = (l & 1) * 2 + l / 4, half (l / 2) & 1 (vrow4_at)
  __m512d r[4] = {_mm512_permutex2var_pd(t0, lo, t2), _mm512_permutex2var_pd(t0, hi, t2),
                  _mm512_permutex2var_pd(t1, lo, t3), _mm512_permutex2var_pd(t1, hi, t3)};
#pragma GCC unroll 8
  for (int l = 0; l < 8; l++) {
    const __m512d q = r[(l & 1) * 2 + l / 4];
    if (keep >> l & 1)
      _mm256_mask_storeu_pd(x + (ptrdiff_t)idx[l] * 3, 7,
                            (l / 2) & 1 ? _mm512_extractf64x4_pd(q, 1) : _mm512_castpd512_pd256(q));
  }
}
// Rows of 4 (the f32 comment above): register rows[c][q] holds lanes
// (0, 2), (4, 6), (1, 3), (5, 7) for q = 0..3, so lane l's row is in
// register (l & 1) * 2 + l / 4, half (l / 2) & 1.
#define EK_HAVE_VROWS4
static inline unsigned vrow4_at(unsigned l, unsigned c) {
  return (c * 4 + (l & 1) * 2 + l / 4) * 8 + ((l / 2) & 1) * 4;
}
EK_INLINE void vstore_rows4(real *rows, const vreal h[12]) {
  const __m512d zero = _mm512_setzero_pd();
  const __m512i lo = _mm512_setr_epi64(0, 1, 8, 9, 2, 3, 10, 11);
  const __m512i hi = _mm512_setr_epi64(4, 5, 12, 13, 6, 7, 14, 15);
#pragma GCC unroll 4
  for (int c = 0; c < 4; c++) {
    __m512d t0 = _mm512_unpacklo_pd(h[3 * c], h[3 * c + 1]); // x0 y0 x2 y2 x4 y4 x6 y6
    __m512d t1 = _mm512_unpackhi_pd(h[3 * c], h[3 * c + 1]); // x1 y1 x3 y3 ...
    __m512d t2 = _mm512_unpacklo_pd(h[3 * c + 2], zero);     // z0 0 z2 0 ...
    __m512d t3 = _mm512_unpackhi_pd(h[3 * c + 2], zero);     // z1 0 z3 0 ...
    real *r = rows + c * 4 * 8;
    _mm512_store_pd(r, _mm512_permutex2var_pd(t0, lo, t2));
    _mm512_store_pd(r + 8, _mm512_permutex2var_pd(t0, hi, t2));
    _mm512_store_pd(r + 16, _mm512_permutex2var_pd(t1, lo, t3));
    _mm512_store_pd(r + 24, _mm512_permutex2var_pd(t1, hi, t3));
  }
}
EK_INLINE void vadd_row4(real *o, const real *row) {
  // o first, as in the f32 version above (a NaN o is kept).
  __m256d ov = _mm256_loadu_pd(o), sum;
  __asm__("vaddpd %2, %1, %0" : "=v"(sum) : "v"(ov), "m"(*(const __m256d *)row));
  _mm256_storeu_pd(o, sum);
}
#endif

// The record transposes (simd.h) in registers. generic.h writes the
// transpose once in terms of three primitives (EK_HAVE_VREC_PERM): a blend
// by a constant lane mask, a one-source and a two-source lane permute by
// constant indices (vpermps / vpermt2ps), for the record sizes it can
// factor (np = 3 s, odd np, np = 2). The other sizes (4, 8) take
// vload_records_masked below: lane l of plane k is element np l + k of
// the np vectors, i.e. lane (np l + k) mod W of vector (np l + k) / W, and
// each plane (on the way in) or each vector of records (on the way out) is
// merged from the np vectors by masked one-source permutes (np per plane
// at worst: 81 for np = 9, against generic.h's 9 permutes and 36 blends).
// The loops are unrolled fully (the pragmas) so that, np being a literal
// at every call, the indices and masks fold to constants: without that the
// AoS SVD ran 6.6x slower.
#if defined(EK_REAL_F32)
typedef int32_t vrec_lane;
static inline vreal vrec_permute(vreal acc, vmask m, __m512i i, vreal v) {
  return _mm512_mask_permutexvar_ps(acc, m, i, v);
}
static inline vreal vrec_perm_ix(vreal v, __m512i i) { return _mm512_permutexvar_ps(i, v); }
static inline vreal vrec_perm2_ix(vreal a, vreal b, __m512i i) {
  return _mm512_permutex2var_ps(a, i, b);
}
#else
typedef int64_t vrec_lane;
static inline vreal vrec_permute(vreal acc, vmask m, __m512i i, vreal v) {
  return _mm512_mask_permutexvar_pd(acc, m, i, v);
}
static inline vreal vrec_perm_ix(vreal v, __m512i i) { return _mm512_permutexvar_pd(i, v); }
static inline vreal vrec_perm2_ix(vreal a, vreal b, __m512i i) {
  return _mm512_permutex2var_pd(a, i, b);
}
#endif
#define EK_HAVE_VREC_PERM
// Lane l = bit l of m ? b : a (m a constant at the call): a masked blend
// (vblendmps), its mask a kmov of the constant. generic.h keeps the
// records' loads out of the blends (vrec_load_factored): folded into them
// as masked memory operands they cost 17.9 ns per matrix on Zen 5 (f32,
// the warm polar's AoS API, 2^20 matrices, 1 thread; 4.4 with a vpternlog
// select on a constant vector, the AoSoA kernel 3.3). Against that
// vpternlog select (eleventh round, Zen 4, the same API, process CPU time,
// min of 3 interleaved rounds): 6.43 against 6.93 ns on 2^20, 6.45
// against 6.79 on 4096 (the AoSoA kernel 5.5): the select's destination
// is one of its sources, so each reused stream or constant cost a vector
// copy, and each constant a vector register or a load (docs/perf.md).
EK_INLINE vreal vrec_blend(unsigned m, vreal a, vreal b) {
#if defined(EK_REAL_F32)
  return _mm512_mask_blend_ps((__mmask16)m, a, b);
#else
  return _mm512_mask_blend_pd((__mmask8)m, a, b);
#endif
}
// Lane l = v[idx[l]] (idx constant).
EK_INLINE vreal vrec_perm(vreal v, const int *idx) {
  vrec_lane ix[EK_W];
#pragma GCC unroll 16
  for (int l = 0; l < EK_W; l++)
    ix[l] = idx[l];
  return vrec_perm_ix(v, _mm512_loadu_si512(ix));
}
// Lane l = idx[l] < W ? a[idx[l]] : b[idx[l] - W] (idx constant).
EK_INLINE vreal vrec_perm2(vreal a, vreal b, const int *idx) {
  vrec_lane ix[EK_W];
#pragma GCC unroll 16
  for (int l = 0; l < EK_W; l++)
    ix[l] = idx[l];
  return vrec_perm2_ix(a, b, _mm512_loadu_si512(ix));
}
#define EK_HAVE_VRECORDS_MASKED
EK_INLINE void vload_records_masked(const real *p, int np, vreal *planes) {
  vreal in[EK_RECORD_MAX];
#pragma GCC unroll 16
  for (int v = 0; v < np; v++)
    in[v] = vload(p + v * EK_W);
#pragma GCC unroll 16
  for (int k = 0; k < np; k++) {
    vrec_lane idx[EK_W];
#pragma GCC unroll 16
    for (int l = 0; l < EK_W; l++)
      idx[l] = (np * l + k) % EK_W;
    __m512i ix = _mm512_loadu_si512(idx);
    vreal acc = vzero();
#pragma GCC unroll 16
    for (int v = 0; v < np; v++) {
      unsigned m = 0;
#pragma GCC unroll 16
      for (int l = 0; l < EK_W; l++)
        m |= (unsigned)((np * l + k) / EK_W == v) << l;
      if (m)
        acc = vrec_permute(acc, (vmask)m, ix, in[v]);
    }
    planes[k] = acc;
  }
}
EK_INLINE void vstore_records_masked(real *p, int np, const vreal *planes) {
#pragma GCC unroll 16
  for (int v = 0; v < np; v++) {
    vrec_lane idx[EK_W];
#pragma GCC unroll 16
    for (int i = 0; i < EK_W; i++)
      idx[i] = (EK_W * v + i) / np;
    __m512i ix = _mm512_loadu_si512(idx);
    vreal acc = vzero();
#pragma GCC unroll 16
    for (int k = 0; k < np; k++) {
      unsigned m = 0;
#pragma GCC unroll 16
      for (int i = 0; i < EK_W; i++)
        m |= (unsigned)((EK_W * v + i) % np == k) << i;
      if (m)
        acc = vrec_permute(acc, (vmask)m, ix, planes[k]);
    }
    vstore(p + v * EK_W, acc);
  }
}
// vsum_run3 (generic.h's contract): each of the block's 3 rows summed in a
// 256-bit register, 3 doubles wide (the element's 3 values gathered from
// their planes and widened), with one masked load and one masked store of
// K per run: the same adds in the same order as the scalar body, so the
// same bits. The NaN rule (a NaN partial sum is kept, quieted) by the
// add's operand order, partial sum first (vadd_pd_nan_first): the blend
// it replaced (compare and masked add on the sum's dependency chain) cost
// time (docs/perf.md, "Hessian assembly").
#define EK_HAVE_VSUM_RUN3
static inline __m256d vsum_elem3_(const real *ei, size_t es) {
#if defined(EK_REAL_F32)
  return _mm256_cvtps_pd(_mm_setr_ps(ei[0], ei[es], ei[2 * es], 0));
#else
  return _mm256_setr_pd(ei[0], ei[es], ei[2 * es], 0);
#endif
}
static inline void vsum_run3(double *o, size_t rs, const real *e, size_t es, const uint16_t *off,
                             int n, int first) {
  const __m256d zero = _mm256_setzero_pd();
  __m256d acc[3];
  for (int i = 0; i < 3; i++)
    acc[i] = first ? zero : _mm256_maskz_loadu_pd(7, o + (size_t)i * rs);
  for (int j = 0; j < n; j++)
    for (int i = 0; i < 3; i++)
      acc[i] = vadd_pd_nan_first(acc[i], vsum_elem3_(e + off[j] + (size_t)(3 * i) * es, es));
  for (int i = 0; i < 3; i++)
    _mm256_mask_storeu_pd(o + (size_t)i * rs, 7, acc[i]);
}

#endif
