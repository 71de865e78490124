// Machine limits for roofline fractions: FMA peak per ISA x precision x
// threads, and stream-triad bandwidth per threads.
//
// Peak: the fma_probe kernel (kernels/probe/fma_probe.c, through the
// dispatch table) runs independent multiply-add chains on every thread;
// GFLOP/s counts 2 flops per lane per multiply-add. Triad: a[i] = b[i] +
// s*c[i] over three 64 MiB double arrays (far bigger than the L3), counted
// as STREAM does: 24 bytes per element (read b, read c, write a; the
// write-allocate read of a is not counted). Both are the best (minimum
// time) sample, as STREAM reports its best rate: a limit, not a typical
// time.
#ifndef EK_BENCH_MACHINE_H
#define EK_BENCH_MACHINE_H

#include <ek/core.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EK_MACHINE_MAX_THREADS 64

typedef struct {
  // [isa][0 = f32, 1 = f64][threads], GFLOP/s; NaN = not measured.
  double peak_gflops[EK_ISA_COUNT][2][EK_MACHINE_MAX_THREADS + 1];
  // [threads], GB/s (1e9 bytes); NaN = not measured.
  double triad_gbs[EK_MACHINE_MAX_THREADS + 1];
  double triad_array_bytes; // size of each triad array
} ek_machine;

// All entries NaN.
void ek_machine_init(ek_machine *m);
// Measure the peak of every available ISA x precision, and the triad, at
// each of the thread counts (1..EK_MACHINE_MAX_THREADS). min_time: timer
// budget per measurement, s. 0 on success, < 0 on error (message printed).
int ek_machine_measure(ek_machine *m, const int *threads, int nthreads, double min_time);
// Peak FMA rate of one probe; isa must be available. GFLOP/s or NaN.
double ek_machine_measure_peak(ek_isa isa, int f64, int threads, double min_time);
// Triad rate, GB/s, on three arrays of `array_bytes` each; NaN on error.
double ek_machine_measure_triad(int threads, double array_bytes, double min_time);

// Lookups; EK_ISA_AUTO means the best available ISA. NaN if not measured.
double ek_machine_peak(const ek_machine *m, ek_isa isa, int f64, int threads);
double ek_machine_triad(const ek_machine *m, int threads);

#ifdef __cplusplus
}
#endif
#endif
