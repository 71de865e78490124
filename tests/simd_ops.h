// Between test_simd.c (built at baseline) and simd_ops.c (built once per
// target x precision with that target's flags, named by EK_SYM).
#ifndef EK_TEST_SIMD_OPS_H
#define EK_TEST_SIMD_OPS_H

#include <stdint.h>

typedef struct {
  int ops;      // ops of the vector API checked
  int lanes;    // lane results compared
  int failures; // ops that failed
} ek_simd_tally;

// Checks every op of kernels/simd/simd.h (and vmath.h) on one target and
// precision, printing one line per op; adds to *t.
typedef void ek_simd_ops_fn(uint64_t seed, ek_simd_tally *t);
ek_simd_ops_fn ek_simd_ops_scalar_f32, ek_simd_ops_scalar_f64;
ek_simd_ops_fn ek_simd_ops_avx2_f32, ek_simd_ops_avx2_f64;
ek_simd_ops_fn ek_simd_ops_avx512_f32, ek_simd_ops_avx512_f64;

#endif
