// x86 CPU detection (kernels/cpu.h): CPUID flags and XCR0, read with GCC's
// and clang's <cpuid.h> and __builtin_cpu_supports (BLIS bli_cpuid.c reads
// the same bits; FFTW simd-support/avx2.c and SLEEF's dispatcher check
// XGETBV as well).
#include <cpuid.h>

#include "cpu.h"

// XCR0: which register states the OS saves on a context switch. A CPU flag
// alone is not enough: the OS must enable YMM (bits 1-2) and, for AVX-512,
// opmask and ZMM (bits 5-7).
static unsigned long long xcr0(void) {
  unsigned a, b, c, d;
  if (!__get_cpuid(1, &a, &b, &c, &d) || !(c & bit_OSXSAVE))
    return 0;
  unsigned lo, hi;
  __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
  return ((unsigned long long)hi << 32) | lo;
}

int ek_cpu_runs_isa(ek_isa isa) {
  __builtin_cpu_init();
  unsigned long long x = xcr0();
  switch (isa) {
  case EK_ISA_SCALAR:
    return 1;
  case EK_ISA_AVX2:
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && (x & 0x6) == 0x6;
  case EK_ISA_AVX512:
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl") && (x & 0xe6) == 0xe6;
  default:
    return 0;
  }
}
