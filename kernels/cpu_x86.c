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

// CPUID leaf 0's vendor, and for AMD leaf 1's display family (base family,
// plus the extended family when the base is 0xf: AMD's and Intel's
// documented rule).
static int cpuid_vendor_is(unsigned eb, unsigned ec, unsigned ed) {
  // Set: GCC -O1 (the asan preset) warned "may be used uninitialized".
  unsigned a = 0, b = 0, c = 0, d = 0;
  return __get_cpuid(0, &a, &b, &c, &d) && b == eb && c == ec && d == ed;
}

static int amd_family(void) {
  unsigned a, b, c, d;
  if (!cpuid_vendor_is(signature_AMD_ebx, signature_AMD_ecx, signature_AMD_edx) ||
      !__get_cpuid(1, &a, &b, &c, &d))
    return 0;
  unsigned base = (a >> 8) & 0xf, ext = (a >> 20) & 0xff;
  return (int)(base == 0xf ? base + ext : base);
}

// Four vectors in flight where AVX-512 runs at full width with two 512-bit
// FMA pipes, measured: AMD family 0x1a (Zen 5; a server EPYC here, FMA probe
// 278 GFLOP/s f32 AVX-512 against 139 AVX2 at one thread), where the SVD's
// dependency chains (Jacobi pair -> rsqrt -> rotation, ~40 dependent
// operations a pair) leave the pipes idle with two chains: 4 chains took
// 9.0-9.1 ns against 10.2-10.4 ns per matrix (docs/perf.md). Intel's
// AVX-512 too, measured on a Xeon (Emerald Rapids, seventeenth round, 3
// interleaved rounds of each, minima): 4 chains took 0.74-1.00x the time of
// 2 on every SVD, polar, material and FVM row, f32 and f64, 1 and 2
// threads (SVD f32 14.56 against 15.82 ns, f64 35.9 against 40.3; FVM fixed
// corotated f32 21.0 against 23.9 ns/tet; docs/perf.md). Family 0x19 (Zen 3
// and Zen 4, whose 256-bit FP pipes are the same) takes 4 chains for AVX2
// since the ninth round's leaner 4-vector copy: on a Zen 4, AVX2 f32 SVD
// 20.7 against 23.4 ns, f64 58.8 against 70.0, polar and the AoS API 0.87x,
// the FVM level (Zen 3 not measured); its AVX-512 (512-bit ops as two
// halves) keeps 2: 0.97x at 1 thread but 1.03x at 2 and the AoS API 1.10x
// (docs/perf.md, ninth round). Intel's AVX2 keeps 2 (not measured).
int ek_cpu_svd3_chains(ek_isa isa) {
  const int family = amd_family();
  if (isa == EK_ISA_AVX512 &&
      (family >= 0x1a ||
       cpuid_vendor_is(signature_INTEL_ebx, signature_INTEL_ecx, signature_INTEL_edx)))
    return 4;
  if (isa == EK_ISA_AVX2 && family == 0x19)
    return 4;
  return 2;
}
