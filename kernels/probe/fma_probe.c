// fma_probe: the machine's multiply-add peak for this target and precision,
// measured by ek-bench (bench/machine.c) to turn kernel GFLOP/s into a
// fraction of what the core can do.
//
// Twelve independent chains acc = acc * m + a: a multiply-add has a latency
// of about 4 cycles and two pipes can start one each per cycle, so at least
// 8 chains in flight keep both pipes busy (the latency x throughput product,
// as in the peak-flops loops of BLIS' and Agner Fog's measurements); 12
// leaves margin for a 6-cycle unfused mul + add on the scalar target and
// still fits the 16 vector registers with the two constants.
//
// vmla, not vfma: it is a fused multiply-add on every target that has one,
// and a plain multiply + add on the scalar target, where a fused fma() would
// be a slow software routine and not the scalar code's real peak. Either
// way a chain step is 2 flops per lane.
//
// On the scalar target GCC -O3 packs the chains into SSE2 vectors (SLP
// vectorisation), which then run latency-bound (about 6 cycles per mul +
// add step for 3-4 vectors): measured 4 flops per cycle, the same as the
// one-lane peak of two multiply and two add pipes (Zen 3). The scalar
// number is thus the rate the scalar build really reaches; it is not an
// SSE2 packed peak.
#include "../simd/simd.h"
// simd.h first: kernels.h after it for the table type.
#include "kernels.h"

#define PROBE_CHAINS 12

double EK_SYM(fma_probe)(long iters, double *flops) {
  // acc -> a / (1 - m) = 1: values stay normal and bounded for any iters.
  const vreal m = vset((real)0.5), a = vset((real)0.5);
  vreal acc[PROBE_CHAINS];
  for (int c = 0; c < PROBE_CHAINS; c++)
    acc[c] = vset((real)(c + 1));
  for (long i = 0; i < iters; i++)
    for (int c = 0; c < PROBE_CHAINS; c++)
      acc[c] = vmla(acc[c], m, a);
  // Sum every lane of every chain so none of the work is dead.
  vreal sum = acc[0];
  for (int c = 1; c < PROBE_CHAINS; c++)
    sum = vadd(sum, acc[c]);
  real lanes[EK_W];
  vstore(lanes, sum);
  double total = 0;
  for (int l = 0; l < EK_W; l++)
    total += (double)lanes[l];
  if (flops)
    *flops = 2.0 * EK_W * PROBE_CHAINS * (double)(iters > 0 ? iters : 0);
  return total;
}

// This source's entries in a kernel table row (dispatch.c).
void EK_SYM(fma_probe_fill)(ek_kernel_table *t);
void EK_SYM(fma_probe_fill)(ek_kernel_table *t) { t->EK_FIELD(fma_probe) = EK_SYM(fma_probe); }
