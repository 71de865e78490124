// The vector API. A kernel source includes this header only and is compiled
// once per (target x precision): CMake defines exactly one EK_TARGET_<ISA>
// and one EK_REAL_<PREC>. Every target header defines the same names:
//
//   real, vreal, vmask, EK_W (lanes per vector)
//   vset(x) vzero() vload(p) vstore(p, v)        loads/stores are unaligned
//   vadd vsub vmul vdiv vneg vabs vmin vmax vsqrt
//   vfma(a,b,c) = a*b+c, always fused
//   vmla(a,b,c) = a*b+c, vmls(a,b,c) = a*b-c, vnmla(a,b,c) = c-a*b: fused
//                 where the target has FMA (unfused on scalar: baseline
//                 x86-64 has no FMA instruction and libm's fma is a slow
//                 software routine there)
//   vrsqrt(x)     = 1/sqrt(x), correctly rounded sqrt then divide
//   vrsqrt_est(x) = hardware estimate + Newton steps (1 for float, 2 for
//                   double); relative error ~1e-7 (f32) / ~1e-14 (f64);
//                   valid for positive normal x; exact on the scalar target
//   vlt vle vgt vge veq (-> vmask), visfinite(x), vmand vmor vmnot
//   vsel(m, a, b) = m ? a : b,  vany(m), vall(m)
//   vmant_exp(x, &e) = m with x = m 2^e, m in [1, 2) (positive normal x)
//   vgather_points(x, idx, p) = the 3 coordinates of points x[idx[l]]
//                 (n x 3 array, int32 indices); mask: lanes with idx < 0
//   vgather(x, idx) = x[idx[l]] per lane (x[0] where idx < 0)
//
// EK_SYM(name) names a kernel for this build: ek_<name>_<isa>_<prec>.
#ifndef EK_SIMD_H
#define EK_SIMD_H

#include "../real.h"

#if defined(EK_TARGET_AVX512)
#include "avx512.h"
#define EK_TARGET_TOKEN avx512
#elif defined(EK_TARGET_AVX2)
#include "avx2.h"
#define EK_TARGET_TOKEN avx2
#elif defined(EK_TARGET_SCALAR)
#include "scalar.h"
#define EK_TARGET_TOKEN scalar
#else
#error "define one of EK_TARGET_SCALAR, EK_TARGET_AVX2, EK_TARGET_AVX512"
#endif

#define EK_SYM3_(name, t, p) ek_##name##_##t##_##p
#define EK_SYM2_(name, t, p) EK_SYM3_(name, t, p)
#define EK_SYM(name) EK_SYM2_(name, EK_TARGET_TOKEN, EK_PREC_TOKEN)

// Vectors per AoSoA plane: narrower targets walk a 64-byte plane in steps.
#define EK_VPB (EK_LANES / EK_W)

#endif
