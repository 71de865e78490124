// CPU feature detection, one source per architecture (BLIS keeps its
// bli_cpuid.c apart from the context tables in the same way): CMake picks
// kernels/cpu_x86.c on x86 and kernels/cpu_other.c elsewhere, from
// CMAKE_SYSTEM_PROCESSOR. Internal to libek; dispatch.c is the one caller.
#ifndef EK_KERNELS_CPU_H
#define EK_KERNELS_CPU_H

#include <ek/core.h>

// 1 if this CPU and its OS can run code built for `isa` (for x86 the CPU
// flags and the register state the OS saves), else 0; 0 for EK_ISA_AUTO and
// out-of-range values. Asks the hardware on every call: dispatch.c caches
// the answer per ISA.
int ek_cpu_runs_isa(ek_isa isa);

// The SVD block kernel's vectors in flight on this CPU for target isa
// (2 or 4; kernels/svd3/svd3_block.c): a tuning, never a correctness
// matter (every count gives the same bits).
int ek_cpu_svd3_chains(ek_isa isa);

#endif
