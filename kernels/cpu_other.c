// CPU detection on an architecture without a detection file of its own
// (kernels/cpu.h): only the portable scalar target runs. An Arm file
// (NEON/SVE through getauxval(AT_HWCAP)) takes this one's place when an Arm
// target exists.
#include "cpu.h"

int ek_cpu_runs_isa(ek_isa isa) { return isa == EK_ISA_SCALAR; }

int ek_cpu_svd3_chains(ek_isa isa) {
  (void)isa;
  return 2;
}
