// Invariant: every op of the vector API (kernels/simd/simd.h, generic.h,
// vmath.h) gives, on every target built into this library and runnable on
// this CPU (scalar, avx2, avx512) and in both precisions, in every lane, the
// same operation written in plain C on that lane's inputs (bit for bit), or
// for the approximate ops a result within their documented error bound.
// The per-target checks are tests/simd_ops.c, compiled once per target x
// precision with that target's flags (tests/CMakeLists.txt), as the kernels
// are; a target this CPU cannot run is skipped with a message.
//
// Usage: test_simd [--seed N]
#include <ek/core.h>
#include <stdio.h>

#include "cli.h"
#include "simd_ops.h"

typedef struct {
  ek_isa isa;
  ek_simd_ops_fn *f32, *f64; // NULL: not built
} target;

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_simd: seed %llu\n", (unsigned long long)seed);
  const target targets[] = {
      {EK_ISA_SCALAR, ek_simd_ops_scalar_f32, ek_simd_ops_scalar_f64},
#ifdef EK_BUILT_AVX2
      {EK_ISA_AVX2, ek_simd_ops_avx2_f32, ek_simd_ops_avx2_f64},
#else
      {EK_ISA_AVX2, NULL, NULL},
#endif
#ifdef EK_BUILT_AVX512
      {EK_ISA_AVX512, ek_simd_ops_avx512_f32, ek_simd_ops_avx512_f64},
#else
      {EK_ISA_AVX512, NULL, NULL},
#endif
  };
  int ran = 0, failures = 0, ops = 0, lanes = 0;
  for (size_t k = 0; k < sizeof targets / sizeof targets[0]; k++) {
    const target *tg = &targets[k];
    const char *name = ek_isa_name(tg->isa);
    if (!tg->f32) {
      printf("SKIP %s: not built (the compiler lacks its flags)\n", name);
      continue;
    }
    if (!ek_isa_available(tg->isa)) {
      printf("SKIP %s: CPU lacks it\n", name);
      continue;
    }
    ek_simd_ops_fn *fns[2] = {tg->f32, tg->f64};
    for (int p = 0; p < 2; p++) {
      ek_simd_tally t = {0, 0, 0};
      fns[p](seed, &t);
      printf("%s %s: %d ops, %d lane results, %d failed\n", name, p ? "f64" : "f32", t.ops, t.lanes,
             t.failures);
      ran++;
      failures += t.failures;
      ops += t.ops;
      lanes += t.lanes;
    }
  }
  printf("test_simd: %s: %d op checks over %d target x precision builds, %d lane results, "
         "%d failures\n",
         failures ? "FAIL" : "PASS", ops, ran, lanes, failures);
  return failures ? 1 : 0;
}
