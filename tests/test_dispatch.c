// Invariant: ek_isa_resolve(AUTO) gives the best ISA this CPU and build can
// run (scalar always available); a concrete ISA resolves to itself when
// available and otherwise returns EK_EISA with an error naming it; the
// environment variable EK_ISA forces AUTO to that ISA, and an unknown,
// unbuilt or unsupported EK_ISA returns EK_EISA with a message naming it
// (never a silent fallback). AUTO is resolved once per process, so every
// environment case runs in its own forked child.
//
// Usage: test_dispatch [--seed N] (no randomness; the seed is accepted and
// printed for uniformity)
#include <ek/core.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "cli.h"

static int failures;

static void check(int ok, const char *fmt, const char *a, const char *b) {
  printf("%s: ", ok ? "PASS" : "FAIL");
  printf(fmt, a, b);
  printf("\n");
  failures += !ok;
}

static ek_isa best_available(void) {
  ek_isa best = EK_ISA_SCALAR;
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
    if (ek_isa_available((ek_isa)i))
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
  ek_isa expect = EK_ISA_COUNT; // EK_ISA_COUNT: an error is expected
  if (!env_value)
    expect = best_available();
  else
    for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
      if (strcmp(env_value, ek_isa_name((ek_isa)i)) == 0 && ek_isa_available((ek_isa)i))
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

  check(ek_isa_available(EK_ISA_SCALAR), "scalar is always available%s%s", "", "");
  check(!ek_isa_available(EK_ISA_AUTO) && !ek_isa_available((ek_isa)99),
        "AUTO and out-of-range values are not 'available' ISAs%s%s", "", "");
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++) {
    ek_isa isa = (ek_isa)i, got = EK_ISA_AUTO;
    int rc = ek_isa_resolve(isa, &got);
    const char *name = ek_isa_name(isa);
    if (ek_isa_available(isa))
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

  // Environment forcing, each in a fresh process (AUTO is cached).
  in_child(NULL);
  in_child("scalar");
  in_child("avx2");
  in_child("avx512");
  in_child("sse9");
  in_child("AVX2"); // names are case-sensitive: an unknown name, not avx2

  printf("test_dispatch: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
