// EK_ISA and the kernel table rows (BLIS bli_arch.c / bli_cntx_init_<arch>.c
// play this part there); the CPU detection is per architecture in
// kernels/cpu_<arch>.c (cpu.h).
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cpu.h"
#include "kernels.h"

// Each target's fill functions, from CMake: EK_FILLS_<ISA> lists
// ek_<source>_fill_<isa>_<prec> for every kernel source built for that
// target (kernels/CMakeLists.txt, EK_KERNEL_SOURCES_<isa>).
extern ek_kernel_fill_fn EK_FILLS_SCALAR;
static ek_kernel_fill_fn *const fills_scalar[] = {EK_FILLS_SCALAR};
#ifdef EK_FILLS_AVX2
extern ek_kernel_fill_fn EK_FILLS_AVX2;
static ek_kernel_fill_fn *const fills_avx2[] = {EK_FILLS_AVX2};
#endif
#ifdef EK_FILLS_AVX512
extern ek_kernel_fill_fn EK_FILLS_AVX512;
static ek_kernel_fill_fn *const fills_avx512[] = {EK_FILLS_AVX512};
#endif

#define EK_FILLS(f) f, sizeof f / sizeof *f
static const struct {
  ek_kernel_fill_fn *const *fills; // NULL: the target is not built
  size_t n;
  int lanes_f32, lanes_f64;
} targets[EK_ISA_COUNT] = {
    [EK_ISA_SCALAR] = {EK_FILLS(fills_scalar), 1, 1},
#ifdef EK_FILLS_AVX2
    [EK_ISA_AVX2] = {EK_FILLS(fills_avx2), 8, 4},
#endif
#ifdef EK_FILLS_AVX512
    [EK_ISA_AVX512] = {EK_FILLS(fills_avx512), 16, 8},
#endif
};

// The rows, made once: the scalar kernels, then the target's own over them.
static ek_kernel_table rows[EK_ISA_COUNT];
static pthread_once_t rows_once = PTHREAD_ONCE_INIT;

// Per-microarchitecture tuning of a row (kernels.h: svd3_chains): the CPU's
// choice (cpu_x86.c), or EK_SVD3_CHAINS=2|4 to compare both on one machine
// (any other value is an error through ek_set_error, env.c, and ignored: a
// tuning, the same bits either way). Read once, with the rows.
static int svd3_chains_for(ek_isa isa) {
  static const char *const chains[] = {"2", "4"};
  int k;
  if (ek_env_choice("EK_SVD3_CHAINS", 2, chains, &k) == 1)
    return k ? 4 : 2;
  return ek_cpu_svd3_chains(isa);
}

static void make_rows(void) {
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++) {
    if (!targets[i].fills)
      continue;
    ek_kernel_table *t = &rows[i];
    for (size_t k = 0; k < targets[EK_ISA_SCALAR].n; k++)
      targets[EK_ISA_SCALAR].fills[k](t);
    if (i != EK_ISA_SCALAR)
      for (size_t k = 0; k < targets[i].n; k++)
        targets[i].fills[k](t);
    t->isa = (ek_isa)i;
    t->lanes_f32 = targets[i].lanes_f32;
    t->lanes_f64 = targets[i].lanes_f64;
    t->svd3_chains = svd3_chains_for((ek_isa)i);
  }
}

static const ek_kernel_table *row(ek_isa isa) {
  pthread_once(&rows_once, make_rows);
  return &rows[isa];
}

static const char *const isa_names[EK_ISA_COUNT] = {"auto", "scalar", "avx2", "avx512"};

const char *ek_isa_name(ek_isa isa) {
  return (unsigned)isa < EK_ISA_COUNT ? isa_names[isa] : "invalid";
}

// cpuid traps to the hypervisor in a VM (microseconds), and a forced ISA is
// checked on every kernel call: the answer is computed once per ISA.
// 0 = not yet known, 1 = no, 2 = yes; racing first calls agree.
static int cpu_runs(ek_isa isa) {
  static atomic_int known[EK_ISA_COUNT];
  int k = atomic_load(&known[isa]);
  if (!k) {
    k = ek_cpu_runs_isa(isa) ? 2 : 1;
    atomic_store(&known[isa], k);
  }
  return k == 2;
}

static int built(ek_isa isa) {
  return isa > EK_ISA_AUTO && isa < EK_ISA_COUNT && targets[isa].fills != NULL;
}

int ek_isa_available(ek_isa isa) { return built(isa) && cpu_runs(isa); }

static int check_available(ek_isa isa, const char *origin) {
  if (!built(isa)) {
    ek_set_error("%s: ISA '%s' is not built into this library", origin, ek_isa_name(isa));
    return EK_EISA;
  }
  if (!cpu_runs(isa)) {
    ek_set_error("%s: ISA '%s' is not supported by this CPU", origin, ek_isa_name(isa));
    return EK_EISA;
  }
  return EK_OK;
}

// AUTO, resolved once: EK_ISA if set, else the best available target.
// -1 = not yet resolved; the race on first use is benign (same answer).
static atomic_int auto_isa = -1;

static int resolve_auto(ek_isa *out) {
  int cached = atomic_load(&auto_isa);
  if (cached >= 0) {
    *out = (ek_isa)cached;
    return EK_OK;
  }
  ek_isa pick = EK_ISA_SCALAR;
  const char *env = getenv("EK_ISA");
  if (env && *env) {
    pick = EK_ISA_COUNT;
    for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
      if (strcmp(env, isa_names[i]) == 0)
        pick = (ek_isa)i;
    if (pick == EK_ISA_COUNT) {
      ek_set_error("EK_ISA='%s' is not one of scalar, avx2, avx512", env);
      return EK_EISA;
    }
    int rc = check_available(pick, "EK_ISA");
    if (rc)
      return rc;
  } else {
    for (int i = EK_ISA_COUNT - 1; i > EK_ISA_SCALAR; i--)
      if (ek_isa_available((ek_isa)i)) {
        pick = (ek_isa)i;
        break;
      }
  }
  if (ek_env_verbose())
    fprintf(stderr, "ek: using ISA %s%s\n", ek_isa_name(pick), env && *env ? " (EK_ISA)" : "");
  atomic_store(&auto_isa, (int)pick);
  *out = pick;
  return EK_OK;
}

int ek_isa_resolve(ek_isa requested, ek_isa *resolved) {
  if ((unsigned)requested >= EK_ISA_COUNT) {
    ek_set_error("isa option %d is not a valid ek_isa", (int)requested);
    return EK_EISA;
  }
  if (requested == EK_ISA_AUTO)
    return resolve_auto(resolved);
  int rc = check_available(requested, "isa option");
  if (rc == EK_OK)
    *resolved = requested;
  return rc;
}

const ek_kernel_table *ek_kernels_for(ek_isa isa) {
  return ek_isa_available(isa) ? row(isa) : NULL;
}

const ek_kernel_table *ek_kernels_resolve(ek_isa requested) {
  ek_isa isa;
  if (ek_isa_resolve(requested, &isa) != EK_OK)
    return NULL;
  return row(isa);
}
