// The floating-point mode the kernels compute in: the only place ek reads or
// writes it (x86: MXCSR; elsewhere the ops below do nothing). Included
// through simd.h only.
//
// Why. MXCSR is per thread and belongs to the caller; C programs start with
// round-to-nearest and gradual underflow (FTZ = DAZ = 0), but a caller (or
// a runtime the caller links) may have set FTZ/DAZ, and an OpenMP pool
// thread keeps the mode it was created with. Two facts measured on the
// SVD (kernels/svd3/svd3_core.h; figures in README, "Subnormals"):
//   - The Jacobi sweeps on A^T A drive its off-diagonal entries below
//     FLT_MIN (DBL_MIN) after 3-4 float (5-6 double) sweeps: each rotation
//     multiplies them by a small sine, with no rounding floor. Arithmetic on
//     subnormals takes a microcode assist on Intel cores (ek_svd3_f32, 6
//     exact sweeps: 231 ns/matrix with FTZ/DAZ off against 32 ns on, issue
//     22; 10-14x the 2-sweep time on a Xeon here) and ~25% on Zen 4.
//   - With the caller's FTZ/DAZ on, the SVD before this header missed its
//     budget by 200-500x on rank-1 and graded matrices (the QR and the
//     refinement need their tiny values) and flushed the outputs of inputs
//     near FLT_MIN: flushing is right for the sweeps and wrong elsewhere.
// So every kernel entry point (EK_SYM) runs in one fixed mode, whatever the
// caller's: it saves the caller's mode, sets EK_MXCSR_IEEE, and restores
// the caller's mode, flags included, before it returns. It does this on the
// thread that runs it, so it holds for any driver and any OpenMP thread,
// and results do not depend on the caller's mode (tests/test_fpmode.c). A
// kernel may then flush subnormals in a stretch of its own arithmetic that
// is known to tolerate it and would otherwise meet them (vflush_begin /
// vflush_end: two constant MXCSR loads; a load waits for the instructions
// before it, ~1-2% of an SVD per pair of vectors, so they are used only
// where subnormals are expected; a store of MXCSR right after a load
// stalls ~20 ns on Zen 4, so only the entry point reads it). The exception
// flags the kernel raises are not reported: the caller's flags come back
// as they were.
//
// Order: the compiler does not know that arithmetic depends on MXCSR
// (no -frounding-math), and may move a computation across a mode change
// (GCC manual, "Extended Asm", Volatile: the mtfsf example). The mode
// changes are volatile asm with a memory clobber, so loads and stores stay
// on their side; a value computed in registers that must be used on the
// far side of a change goes through vfence, an empty volatile asm that
// reads and writes it, placed after the change: whatever depends on it
// then comes after the change too (svd3_jacobi_sweeps).
#ifndef EK_SIMD_FPMODE_H
#define EK_SIMD_FPMODE_H

#if defined(__x86_64__) || (defined(__i386__) && defined(__SSE2__))
// MXCSR: exception masks (bits 7-12) all set, round to nearest (bits 13-14
// zero), FTZ (bit 15) and DAZ (bit 6) off: the C default, IEEE 754 gradual
// underflow. EK_MXCSR_FLUSH adds FTZ (subnormal results become zero) and
// DAZ (subnormal operands read as zero). Intel SDM vol. 1, sec. 10.2.3.
#define EK_MXCSR_IEEE 0x1F80u
#define EK_MXCSR_FLUSH (EK_MXCSR_IEEE | 0x8000u | 0x0040u)
typedef unsigned ek_fpmode;

static inline void ek_mxcsr_load_(unsigned m) {
  __asm__ volatile("ldmxcsr %0" : : "m"(m) : "memory");
}

// Save the caller's mode and set ek's (EK_MXCSR_IEEE); at every kernel
// entry point, with ek_fpmode_leave before each return.
static inline ek_fpmode ek_fpmode_enter(void) {
  unsigned old;
  __asm__ volatile("stmxcsr %0" : "=m"(old) : : "memory");
  ek_mxcsr_load_(EK_MXCSR_IEEE);
  return old;
}
static inline void ek_fpmode_leave(ek_fpmode old) { ek_mxcsr_load_(old); }
// Between ek_fpmode_enter and ek_fpmode_leave: subnormals flushed to zero
// (results and operands) until vflush_end.
static inline void vflush_begin(void) { ek_mxcsr_load_(EK_MXCSR_FLUSH); }
static inline void vflush_end(void) { ek_mxcsr_load_(EK_MXCSR_IEEE); }
// vfence(x): x (an lvalue of type vreal or real) is computed before this
// point, and what uses x afterwards comes after it ("v": any SSE/AVX
// register, zmm16-31 included).
#if defined(__AVX512F__)
#define vfence(x) __asm__ volatile("" : "+v"(x))
#else
#define vfence(x) __asm__ volatile("" : "+x"(x))
#endif

// For tests and benchmarks, which play the caller: the raw mode, and the
// bits that turn FTZ and DAZ on.
#define EK_FPMODE_HAS_FLUSH 1
#define EK_FPMODE_FTZ_DAZ (0x8000u | 0x0040u)
static inline ek_fpmode ek_fpmode_get(void) {
  unsigned m;
  __asm__ volatile("stmxcsr %0" : "=m"(m) : : "memory");
  return m;
}
static inline void ek_fpmode_set(ek_fpmode m) { ek_mxcsr_load_(m); }

#else
// No mode to set: ISO C's default environment is assumed. (AArch64's FPCR
// FZ bit would give vflush_begin; a port adds it here.)
typedef int ek_fpmode;
static inline ek_fpmode ek_fpmode_enter(void) { return 0; }
static inline void ek_fpmode_leave(ek_fpmode old) { (void)old; }
static inline void vflush_begin(void) {}
static inline void vflush_end(void) {}
#define vfence(x) ((void)0)
#define EK_FPMODE_HAS_FLUSH 0
#define EK_FPMODE_FTZ_DAZ 0
static inline ek_fpmode ek_fpmode_get(void) { return 0; }
static inline void ek_fpmode_set(ek_fpmode m) { (void)m; }
#endif

#endif
