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

// A probe at T threads is checked against the same probe at 1 thread, T
// counted up to the cores the threads can use (OpenMP places, else CPUs):
// the FMA peak must scale by at least EK_MACHINE_PEAK_MIN_SCALING per
// thread (1.5x at 2 threads; the units of each core are independent) and
// by at most EK_MACHINE_PEAK_MAX_SCALING per thread (a faster 2-thread
// reading means a disturbed 1-thread one); the triad must not fall below
// the 1-thread triad (bandwidth need not scale: 1.29x-1.47x at 2 threads
// on the quiet reference machines, README). Outside these bounds both
// probes are measured again, up to EK_MACHINE_PROBE_ATTEMPTS in all, each
// keeping its best reading; a probe still outside is marked disturbed.
#define EK_MACHINE_PEAK_MIN_SCALING 0.75
#define EK_MACHINE_PEAK_MAX_SCALING 1.15
#define EK_MACHINE_PROBE_ATTEMPTS 4

typedef struct {
  // [isa][0 = f32, 1 = f64][threads], GFLOP/s; NaN = not measured. For a
  // disturbed probe: the estimate threads x the 1-thread peak.
  double peak_gflops[EK_ISA_COUNT][2][EK_MACHINE_MAX_THREADS + 1];
  // [threads], GB/s (1e9 bytes); NaN = not measured or disturbed.
  double triad_gbs[EK_MACHINE_MAX_THREADS + 1];
  double triad_array_bytes; // size of each triad array
  // What the probes read (best of all attempts), and whether they stayed
  // disturbed; attempts made.
  double peak_measured[EK_ISA_COUNT][2][EK_MACHINE_MAX_THREADS + 1];
  double triad_measured[EK_MACHINE_MAX_THREADS + 1];
  unsigned char peak_disturbed[EK_ISA_COUNT][2][EK_MACHINE_MAX_THREADS + 1];
  unsigned char triad_disturbed[EK_MACHINE_MAX_THREADS + 1];
  int attempts[EK_MACHINE_MAX_THREADS + 1];
  // Cores each thread count can use (ek_machine_effective_threads); 0 =
  // not measured.
  int cores[EK_MACHINE_MAX_THREADS + 1];
} ek_machine;

// All entries NaN.
void ek_machine_init(ek_machine *m);
// Measure the peak of every available ISA x precision, and the triad, at
// each of the thread counts (1..EK_MACHINE_MAX_THREADS) and at 1 thread (the
// reference of the checks above), measuring again what the checks refuse.
// min_time: timer budget per measurement, s. 0 on success, < 0 on error
// (message printed).
int ek_machine_measure(ek_machine *m, const int *threads, int nthreads, double min_time);
// Peak FMA rate of one probe; isa must be available. GFLOP/s or NaN.
double ek_machine_measure_peak(ek_isa isa, int f64, int threads, double min_time);
// Triad rate, GB/s, on three arrays of `array_bytes` each; NaN on error.
double ek_machine_measure_triad(int threads, double array_bytes, double min_time);

// Threads the probes can expect to scale over: min(threads, OpenMP places,
// or online CPUs without places).
int ek_machine_effective_threads(int threads);
// 1 if the scaling from 1 thread to threads on `cores` cores is within the
// bounds above (always 1 below 2 cores or for a value not measured).
int ek_machine_peak_plausible(double peak_1, double peak_t, int cores);
int ek_machine_triad_plausible(double triad_1, double triad_t, int cores);
// From the readings (peak_measured, triad_measured, cores): the values the
// rows are compared with and the disturbed marks, as described above.
// ek_machine_measure calls it; tests call it on readings of their own.
void ek_machine_settle(ek_machine *m);
// Warnings about disturbed probes, one line each ("" if none); returns buf.
const char *ek_machine_warnings(const ek_machine *m, const int *threads, int nthreads, char *buf,
                                size_t cap);
// 1 if the peak a row at (isa, threads) is compared with is an estimate
// (EK_ISA_AUTO: any ISA's), or the triad at threads was disturbed.
int ek_machine_peak_estimated(const ek_machine *m, ek_isa isa, int f64, int threads);
int ek_machine_triad_disturbed(const ek_machine *m, int threads);

// Lookups; EK_ISA_AUTO means the best available ISA. NaN if not measured.
double ek_machine_peak(const ek_machine *m, ek_isa isa, int f64, int threads);
double ek_machine_triad(const ek_machine *m, int threads);

#ifdef __cplusplus
}
#endif
#endif
