// The vector API. A kernel source includes this header only and is compiled
// once per (target x precision): CMake defines exactly one EK_TARGET_<ISA>
// and one EK_REAL_<PREC>. The target header (scalar.h, avx2.h, avx512.h)
// defines the ops that map to its instructions; generic.h defines the
// derived ones once for all targets (vmla, vrsqrt, vrsqrt_raw/_est where
// the target has no estimate instruction, visfinite, vsel_neg, the record
// transposes), and a target with a better sequence overrides one with
// EK_HAVE_<OP>. tests/test_simd.c checks every op below on every target.
// Every target provides the same names:
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
//   vrsqrt_est(x) = hardware estimate + EK_RSQRT_NEWTON Newton steps (1
//                   for float, 2 for double); relative error ~1e-7 (f32) /
//                   ~1e-16 (f64): each step takes e to <= 1.5 e^2 (+ a few
//                   roundings); valid for positive normal x; exact on the
//                   scalar target and for AVX2 double (no estimate there:
//                   avx2.h), where EK_HAVE_VRSQRT_RAW is not defined
//   vrsqrt_raw(x) = the hardware estimate alone: relative error
//                   <= EK_RSQRT_RAW_TOL = 2^-14 (AVX-512), 1.5 2^-12 (AVX2
//                   float); exact where vrsqrt_est is
//   vsel_neg(m, a, b) = m ? -a : b
//   vsel_op(m, a, b) = vsel(m, a, b), the select instruction as such (avx2.h)
//   vxorsign(y, x) = y with its sign flipped where x's sign bit is set
//   vlt vle vgt vge veq (-> vmask), visfinite(x), vmand vmor vmnot
//   vsel(m, a, b) = m ? a : b,  vany(m), vall(m)
//   vmant_exp(x, &e) = m with x = m 2^e, m in [1, 2) (positive normal x)
//   vgather_points(x, idx, p) = the 3 coordinates of points x[idx[l]]
//                 (n x 3 array, int32 indices); mask: lanes with idx < 0
//   vgather(x, idx) = x[idx[l]] per lane (x[0] where idx < 0)
//   vload_records(p, np, planes) / vstore_records(p, np, planes): EK_W
//                 consecutive records of np reals (AoS, np <= 9) from / to
//                 np vectors, one per field (the AoS <-> AoSoA transpose of
//                 one vector of records, through L1)
//   vstream(p, v)  a non-temporal store (p aligned to the vector's bytes)
//                 past the caches, weakly ordered: vstream_fence() after
//                 the last one before another thread reads them; the
//                 scalar target stores plainly
//   vstore_records_nt(p, np, planes): vstore_records with vstream (p
//                 aligned to the vector's bytes)
//
// EK_SYM(name) names a kernel for this build: ek_<name>_<isa>_<prec>.
#ifndef EK_SIMD_H
#define EK_SIMD_H

#include "../inline.h" // EK_INLINE
#include "../real.h"

#define EK_RECORD_MAX 9 // fields per record in vload_records / vstore_records

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

#include "fpmode.h" // the kernels' floating-point mode (ek_fpmode_enter, vflush_begin)

#define EK_SYM3_(name, t, p) ek_##name##_##t##_##p
#define EK_SYM2_(name, t, p) EK_SYM3_(name, t, p)
#define EK_SYM(name) EK_SYM2_(name, EK_TARGET_TOKEN, EK_PREC_TOKEN)

// Vectors per AoSoA plane: narrower targets walk a 64-byte plane in steps.
#define EK_VPB (EK_LANES / EK_W)

// Derived ops, written once for every target (after the target header).
#include "generic.h"

#endif
