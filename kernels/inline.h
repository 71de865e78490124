// Internal: EK_INLINE, for the kernels' small helpers that must be inlined
// into their caller whatever the compiler's cost model says (the vector
// code keeps its values in registers only once inlined; constant arguments,
// e.g. a record's field count, fold only there). Included by simd/simd.h.
#ifndef EK_INLINE_H
#define EK_INLINE_H

#define EK_INLINE static inline __attribute__((always_inline))

#endif
