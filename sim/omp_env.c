// OpenMP environment defaults of ek's programs (omp_env.h).
#include "omp_env.h"

#include "cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

// Set in the re-executed image, so that a failed setenv cannot make the
// program re-execute itself forever.
#define REEXEC_GUARD "EK_OMP_ENV_REEXEC"

static int set_default(const char *name, const char *value) {
  if (getenv(name))
    return 0;
  setenv(name, value, 1);
  return 1;
}

// Whether /proc/self/exe is the program itself: started through the
// dynamic loader (ld-linux-x86-64.so.2 --library-path ... ek-bench ...) it is
// the loader, which would take the program's options as its own.
static int self_is(const char *program) {
  char exe[4096];
  ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0)
    return 0;
  exe[n] = 0;
  const char *base = strrchr(exe, '/');
  return strcmp(base ? base + 1 : exe, program) == 0;
}

void omp_env_defaults(const char *program, char **argv) {
  int set = set_default("OMP_PROC_BIND", "close");
  set |= set_default("OMP_PLACES", "cores");
  if (set && !getenv(REEXEC_GUARD) && !self_is(program)) {
    fprintf(stderr,
            "%s: note: /proc/self/exe is not %s (started through a loader, or renamed): "
            "running with libgomp's defaults; set OMP_PROC_BIND=close OMP_PLACES=cores for ek's\n",
            program, program);
    return;
  }
  if (set && !getenv(REEXEC_GUARD)) {
    setenv(REEXEC_GUARD, "1", 1);
    execv("/proc/self/exe", argv);
    fprintf(stderr,
            "%s: note: re-exec for the OpenMP settings failed (%s); running with "
            "libgomp's defaults\n",
            program, strerror(errno));
  }
}

int omp_env_check_threads(const char *program) {
  const char *v = getenv("OMP_NUM_THREADS");
  if (!v)
    return 0;
  // Each item: a whole number of threads in 1..4096, blanks around it
  // allowed (as libgomp reads it). libgomp only warns about a bad item
  // ("0", "x", "-1", "") and runs on every core, which a user who set it
  // never meant; a number too large it takes (99999999999 wrapped to
  // 1215752191) and aborts at the first parallel region, "out of memory".
  // Items after the first are the threads of nested parallel regions,
  // which ek never opens (kernels/team.c runs its own team instead of
  // nesting): more than 1 there would be silently unused.
  int item = 0;
  for (const char *p = v;; ++p, ++item) {
    p += strspn(p, " \t");
    size_t digits = strspn(p, "0123456789");
    const char *q = p + digits;
    q += strspn(q, " \t");
    long n = 0;
    for (size_t k = 0; k < digits && n <= 4096; k++)
      n = n * 10 + (p[k] - '0');
    if (!digits || n < 1 || n > 4096 || (*q && *q != ','))
      return ek_cli_usage_error(program,
                                "OMP_NUM_THREADS='%s': each comma-separated item must be a whole "
                                "number of threads in 1..4096",
                                v);
    if (item > 0 && n > 1)
      return ek_cli_usage_error(program,
                                "OMP_NUM_THREADS='%s': item %d (%ld threads) is for nested "
                                "parallel regions, which ek never opens; give one number, the "
                                "threads of its parallel regions",
                                v, item + 1, n);
    if (!*q)
      return 0;
    p = q;
  }
}
