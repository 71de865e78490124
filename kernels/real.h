// Precision of a translation unit built once per precision (kernels and
// drivers): exactly one of EK_REAL_F32 / EK_REAL_F64 is defined by CMake.
#ifndef EK_REAL_H
#define EK_REAL_H

#include <ek/batch.h>

#if defined(EK_REAL_F32)
typedef float real;
#define EK_PREC_TOKEN f32
#define EK_LANES EK_LANES_F32
#elif defined(EK_REAL_F64)
typedef double real;
#define EK_PREC_TOKEN f64
#define EK_LANES EK_LANES_F64
#else
#error "define EK_REAL_F32 or EK_REAL_F64"
#endif

// EK_P(svd3) -> ek_svd3_f32: the public name of this precision's function
// (the FFTW X() idea).
#define EK_P2_(name, p) ek_##name##_##p
#define EK_P1_(name, p) EK_P2_(name, p)
#define EK_P(name) EK_P1_(name, EK_PREC_TOKEN)

// EK_FIELD(svd3_block) -> svd3_block_f32: this precision's entry of a
// kernel table row (kernels.h).
#define EK_F2_(name, p) name##_##p
#define EK_F1_(name, p) EK_F2_(name, p)
#define EK_FIELD(name) EK_F1_(name, EK_PREC_TOKEN)

#endif
