// ek core: instruction-set targets, error codes, aligned memory.
// Every other ek header includes this one.
#ifndef EK_CORE_H
#define EK_CORE_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

// Instruction-set target of a kernel. AUTO picks the best one the CPU and the
// build support, unless the environment variable EK_ISA=scalar|avx2|avx512
// forces one.
typedef enum { EK_ISA_AUTO = 0, EK_ISA_SCALAR, EK_ISA_AVX2, EK_ISA_AVX512, EK_ISA_COUNT } ek_isa;

// Return codes: 0 is success, every error is negative.
enum {
  EK_OK = 0,
  EK_EINVAL = -1, // invalid argument (bad option, NULL pointer, bad parameter)
  EK_EISA = -2,   // ISA not built into this library or not supported by this CPU
  EK_ENOMEM = -3, // allocation failed
  EK_EIO = -4     // file missing, unreadable or malformed
};

// Name of a target ("auto", "scalar", "avx2", "avx512").
const char *ek_isa_name(ek_isa isa);
// 1 if the target was built into this library and this CPU (and its OS)
// can run it, else 0.
int ek_isa_available(ek_isa isa);
// Resolve a request to a concrete target: AUTO becomes EK_ISA from the
// environment if set, else the best available target. Returns EK_EISA (and
// sets ek_last_error) if the request or EK_ISA names a target that is
// unknown, not built or not supported by this CPU; never falls back silently.
int ek_isa_resolve(ek_isa requested, ek_isa *resolved);

// Message of the last error on the calling thread ("" if none). The library
// prints nothing itself (the caller reports the error once); EK_VERBOSE=1
// also writes each error to stderr as it happens.
const char *ek_last_error(void);

// The EK_* environment variables the library reads, each unset, empty or
// exactly one of its values: EK_ISA=scalar|avx2|avx512, EK_VERBOSE=0|1,
// EK_SVD3_CHAINS=2|4, EK_FVM_PREFETCH=0|1. EK_OK, or EK_EINVAL with
// ek_last_error naming the variable and its value ("EK_FVM_PREFETCH='yes'
// is not one of 0, 1"). Where the library reads a bad value it sets that
// error and keeps the default (a tuning) or fails the call (EK_ISA); a
// program calls this first and refuses to run (ek's programs exit 2).
int ek_env_check(void);

// Batch arguments (every entry point that takes a count n or nblocks:
// batch.h, svd3.h, material.h):
//   - alignment: a float array must be aligned to 4 bytes and a double
//     array to 8 (_Alignof of the element type: what malloc, ek_alloc and
//     any C array of that type give). Reading a double through a pointer at
//     a 4-byte offset is undefined behaviour in C, so such an array is
//     refused with EK_EINVAL and nothing is written. AoSoA batches need no
//     more than that; 64 bytes (ek_alloc, ek_aosoa_alloc_*) keeps each plane
//     in one cache line and is faster.
//   - size: a batch whose byte count would exceed PTRDIFF_MAX (n = SIZE_MAX,
//     say) is refused with EK_EINVAL, never run as the small batch its
//     wrapped count would describe.
// Floating-point mode (x86: MXCSR; FTZ = flush-to-zero, DAZ =
// denormals-are-zero): every kernel computes in ek's own mode, round to
// nearest with gradual underflow (FTZ/DAZ off) and exceptions masked. It
// sets it on the thread it runs on and restores the caller's mode, flags
// included, before it returns, so the caller's FTZ/DAZ or rounding mode
// neither changes a kernel's results (the same bits either way) nor is left
// changed by it; floating-point exceptions raised inside are not reported.
// (Sums a driver forms across elements, e.g. the per-part force buffers of
// fvm.h's thread-buffer scatter, run in the caller's mode.) Inside, a
// kernel may flush subnormals where its own arithmetic tolerates it (the
// SVD's Jacobi sweeps beyond the default, svd3.h), so that asking for more
// sweeps does not mean computing on subnormals. tests/test_fpmode.c checks
// this.
// 64-byte aligned allocation (one AoSoA plane of 16 floats is one cache line).
// NULL when bytes is beyond what can be allocated.
void *ek_alloc(size_t bytes);
void ek_free(void *p);

#ifdef __cplusplus
}
#endif
#endif
