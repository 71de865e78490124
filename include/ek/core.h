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

// 64-byte aligned allocation (one AoSoA plane of 16 floats is one cache line).
void *ek_alloc(size_t bytes);
void ek_free(void *p);

#ifdef __cplusplus
}
#endif
#endif
