// FMA throughput probe: CHAINS independent multiply-add chains (vmla: fused
// where the target has FMA, as the kernels use it), long
// enough to cover the FMA latency on every target, so the loop runs at the
// FMA issue rate. ek-bench divides the declared flops by the time to get the
// machine's compute bound per ISA and precision.
#include "simd/simd.h"

#define CHAINS 12

double EK_SYM(fma_probe)(long iters, double *flops) {
  vreal acc[CHAINS];
  for (int c = 0; c < CHAINS; c++)
    acc[c] = vset((real)(1 + c) * (real)1e-3);
  // x*a + b with a slightly below 1 keeps every chain bounded (no overflow,
  // no subnormals) for any iteration count.
  const vreal a = vset((real)0.999999), b = vset((real)1e-6);
  for (long i = 0; i < iters; i++)
    for (int c = 0; c < CHAINS; c++)
      acc[c] = vmla(acc[c], a, b);
  real lanes[EK_W];
  double sum = 0;
  for (int c = 0; c < CHAINS; c++) {
    vstore(lanes, acc[c]);
    for (int l = 0; l < EK_W; l++)
      sum += lanes[l];
  }
  *flops = 2.0 * EK_W * CHAINS * (double)iters;
  return sum;
}
