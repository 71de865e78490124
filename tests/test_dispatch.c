// Invariant: ek_isa_available(isa) is true exactly for the ISAs built into
// this library (EK_BUILT_<ISA>, from CMake) whose CPU flags Linux lists in
// /proc/cpuinfo (avx2 and fma for avx2; avx512f, avx512dq and avx512vl for
// avx512): an independent reading of the CPU, which also covers the OS
// support, since Linux clears a flag whose register state the OS does not
// save (without /proc/cpuinfo that comparison is skipped, saying so).
// ek_isa_resolve(AUTO) gives the best ISA this CPU and build can run (scalar
// always available); a concrete ISA resolves to itself when available and
// otherwise returns EK_EISA with an error naming it; the environment
// variable EK_ISA forces AUTO to that ISA, and an unknown, unbuilt or
// unsupported EK_ISA returns EK_EISA with a message naming it (never a
// silent fallback). AUTO is resolved once per process, so every
// environment case runs in its own forked child.
//
// Usage: test_dispatch [--seed N] (no randomness; the seed is accepted and
// printed for uniformity)
#include <ek/core.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "cli.h"
#include "kernels.h" // the kernel table rows

static int failures;

static void check(int ok, const char *fmt, const char *a, const char *b) {
  printf("%s: ", ok ? "PASS" : "FAIL");
  printf(fmt, a, b);
  printf("\n");
  failures += !ok;
}

// Which ISAs should be available: built (CMake's EK_BUILT_<ISA>) and
// listed by the kernel in /proc/cpuinfo. Without /proc/cpuinfo (not Linux)
// the library's own answer stands in, and the test says so.
static int expect_available[EK_ISA_COUNT];

// 1 if the whitespace-separated list `flags` holds the token `name`.
static int has_flag(const char *flags, const char *name) {
  size_t n = strlen(name);
  for (const char *p = flags; (p = strstr(p, name)) != NULL; p += n)
    if ((p == flags || p[-1] == ' ' || p[-1] == '\t') &&
        (p[n] == ' ' || p[n] == '\t' || p[n] == '\n' || p[n] == 0))
      return 1;
  return 0;
}

// The first "flags : ..." line of /proc/cpuinfo (x86 Linux) into line;
// 0 when there is none.
static int cpuinfo_flags(char *line, size_t size) {
  FILE *f = fopen("/proc/cpuinfo", "r");
  if (!f)
    return 0;
  int found = 0;
  while (!found && fgets(line, (int)size, f))
    found = strncmp(line, "flags", 5) == 0 && strchr(line, ':') != NULL;
  fclose(f);
  return found;
}

static void check_against_cpuinfo(void) {
  static char line[1 << 16];
  int built[EK_ISA_COUNT] = {0};
  built[EK_ISA_SCALAR] = 1;
#ifdef EK_BUILT_AVX2
  built[EK_ISA_AVX2] = 1;
#endif
#ifdef EK_BUILT_AVX512
  built[EK_ISA_AVX512] = 1;
#endif
  if (!cpuinfo_flags(line, sizeof line)) {
    printf("SKIP: no 'flags' line in /proc/cpuinfo (not x86 Linux?): ek_isa_available is not "
           "checked against an independent reading of the CPU here\n");
    for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
      expect_available[i] = ek_isa_available((ek_isa)i);
    return;
  }
  const char *flags = strchr(line, ':') + 1;
  int cpu[EK_ISA_COUNT] = {0};
  cpu[EK_ISA_SCALAR] = 1;
  cpu[EK_ISA_AVX2] = has_flag(flags, "avx2") && has_flag(flags, "fma");
  cpu[EK_ISA_AVX512] =
      has_flag(flags, "avx512f") && has_flag(flags, "avx512dq") && has_flag(flags, "avx512vl");
  printf("/proc/cpuinfo: avx2 %d fma %d avx512f %d avx512dq %d avx512vl %d\n",
         has_flag(flags, "avx2"), has_flag(flags, "fma"), has_flag(flags, "avx512f"),
         has_flag(flags, "avx512dq"), has_flag(flags, "avx512vl"));
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++) {
    expect_available[i] = built[i] && cpu[i];
    int got = ek_isa_available((ek_isa)i);
    char what[160];
    snprintf(what, sizeof what, "ek_isa_available(%s) = %d; built %d, /proc/cpuinfo %d",
             ek_isa_name((ek_isa)i), got, built[i], cpu[i]);
    check(got == expect_available[i], "%s%s", what, "");
  }
}

static ek_isa best_available(void) {
  ek_isa best = EK_ISA_SCALAR;
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
    if (expect_available[i])
      best = (ek_isa)i;
  return best;
}

// In a child: set (or clear) EK_ISA, resolve AUTO, compare with the
// expectation; the exit status carries the verdict.
static int child_auto(const char *env_value) {
  if (env_value)
    setenv("EK_ISA", env_value, 1);
  else
    unsetenv("EK_ISA");
  ek_isa expect = EK_ISA_COUNT;  // EK_ISA_COUNT: an error is expected
  if (!env_value || !*env_value) // unset or empty: the best available
    expect = best_available();
  else
    for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
      if (strcmp(env_value, ek_isa_name((ek_isa)i)) == 0 && expect_available[i])
        expect = (ek_isa)i;
  ek_isa got = EK_ISA_AUTO;
  int rc = ek_isa_resolve(EK_ISA_AUTO, &got);
  int ok;
  if (expect == EK_ISA_COUNT) {
    ok = rc == EK_EISA && strstr(ek_last_error(), env_value) != NULL;
    printf("  child EK_ISA=%s: rc %d, message \"%s\" (expected EK_EISA naming it)\n", env_value, rc,
           ek_last_error());
  } else {
    ok = rc == EK_OK && got == expect;
    // A second call must give the same answer (cached).
    ek_isa again = EK_ISA_AUTO;
    ok &= ek_isa_resolve(EK_ISA_AUTO, &again) == EK_OK && again == got;
    printf("  child EK_ISA=%s: rc %d, resolved %s (expected %s)\n",
           env_value ? env_value : "(unset)", rc, ek_isa_name(got), ek_isa_name(expect));
  }
  fflush(stdout);
  return ok ? 0 : 1;
}

// The EK_* variables' one rule (kernels/env.c): unset, empty or exactly one
// of the variable's values is EK_OK; anything else (atoi read "yes" as 0,
// and " 1" as 1) is EK_EINVAL naming the variable and the value.
static void check_env_rule(void) {
  static const struct {
    const char *name, *good[3], *bad[6];
  } vars[] = {
      {"EK_VERBOSE", {"0", "1", ""}, {"2", "yes", " 1", "1 ", "01", "-0"}},
      {"EK_FVM_PREFETCH", {"0", "1", ""}, {"2", "yes", "on", "1x", "01", "+1"}},
      {"EK_SVD3_CHAINS", {"2", "4", ""}, {"3", "8", "0", "4 ", "two", "04"}},
      {"EK_ISA", {"scalar", "avx2", ""}, {"AVX2", "sse", " avx2", "auto", "x", "avx"}},
  };
  for (size_t k = 0; k < sizeof vars / sizeof vars[0]; k++) {
    const char *saved = getenv(vars[k].name);
    char keep[64];
    snprintf(keep, sizeof keep, "%s", saved ? saved : "");
    for (int i = 0; i < 3; i++) {
      setenv(vars[k].name, vars[k].good[i], 1);
      check(ek_env_check() == EK_OK, "%s='%s' is accepted", vars[k].name, vars[k].good[i]);
    }
    for (int i = 0; i < 6; i++) {
      setenv(vars[k].name, vars[k].bad[i], 1);
      char named[96];
      snprintf(named, sizeof named, "%s='%s' is not one of", vars[k].name, vars[k].bad[i]);
      int rc = ek_env_check();
      check(rc == EK_EINVAL && strstr(ek_last_error(), named) != NULL,
            "%s='%s' is EK_EINVAL, naming the variable and the value", vars[k].name,
            vars[k].bad[i]);
    }
    if (saved)
      setenv(vars[k].name, keep, 1);
    else
      unsetenv(vars[k].name);
  }
}

static void in_child(const char *env_value) {
  fflush(stdout);
  pid_t pid = fork();
  if (pid < 0) {
    printf("FAIL: fork failed\n");
    failures++;
    return;
  }
  if (pid == 0)
    _exit(child_auto(env_value));
  int status = 0;
  waitpid(pid, &status, 0);
  int ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  check(ok, "AUTO with EK_ISA=%s%s", env_value ? env_value : "(unset)", "");
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_dispatch: seed %llu (unused)\n", (unsigned long long)seed);

  check_against_cpuinfo();
  check_env_rule();
  check(ek_isa_available(EK_ISA_SCALAR), "scalar is always available%s%s", "", "");
  check(!ek_isa_available(EK_ISA_AUTO) && !ek_isa_available((ek_isa)99),
        "AUTO and out-of-range values are not 'available' ISAs%s%s", "", "");
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++) {
    ek_isa isa = (ek_isa)i, got = EK_ISA_AUTO;
    int rc = ek_isa_resolve(isa, &got);
    const char *name = ek_isa_name(isa);
    if (expect_available[i])
      check(rc == EK_OK && got == isa, "%s available and resolves to itself%s", name, "");
    else {
      int named = strstr(ek_last_error(), name) != NULL;
      printf("note: %s not available here: \"%s\"\n", name, ek_last_error());
      check(rc == EK_EISA && got == EK_ISA_AUTO && named,
            "%s unavailable: EK_EISA, message names it, nothing resolved%s", name, "");
    }
  }
  ek_isa got = EK_ISA_AUTO;
  check(ek_isa_resolve((ek_isa)99, &got) == EK_EISA && got == EK_ISA_AUTO,
        "isa 99 gives EK_EISA%s%s", "", "");
  check(strcmp(ek_isa_name(EK_ISA_AUTO), "auto") == 0 &&
            strcmp(ek_isa_name(EK_ISA_SCALAR), "scalar") == 0 &&
            strcmp(ek_isa_name(EK_ISA_AVX2), "avx2") == 0 &&
            strcmp(ek_isa_name(EK_ISA_AVX512), "avx512") == 0,
        "ISA names%s%s", "", "");

  // Every entry of every available row is callable: a row starts from the
  // scalar kernels and the target's own override them (kernels.h), so a
  // target that lacks a kernel still has the scalar one. Every field from
  // svd3_block_f32 on is a function pointer.
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++) {
    const ek_kernel_table *t = ek_kernels_for((ek_isa)i);
    if (!t)
      continue;
    typedef void (*any_fn)(void);
    const size_t first = offsetof(ek_kernel_table, svd3_block_f32);
    const size_t n = (sizeof *t - first) / sizeof(any_fn);
    size_t missing = 0;
    for (size_t k = 0; k < n; k++) {
      any_fn f;
      memcpy(&f, (const char *)t + first + k * sizeof f, sizeof f);
      missing += f == NULL;
    }
    check(missing == 0 && t->isa == (ek_isa)i, "row %s: %s entries, none NULL", ek_isa_name(t->isa),
          n == 0 ? "no" : "all");
    if (missing)
      printf("  %zu of %zu entries NULL\n", missing, n);
  }

  // Environment forcing, each in a fresh process (AUTO is cached).
  in_child(NULL);
  in_child("scalar");
  in_child("avx2");
  in_child("avx512");
  in_child("sse9");
  in_child("AVX2"); // names are case-sensitive: an unknown name, not avx2
  in_child("auto"); // an ek_isa name, but not one EK_ISA accepts
  in_child("");     // empty: as if unset

  printf("test_dispatch: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
