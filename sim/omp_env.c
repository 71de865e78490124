// OpenMP environment defaults of ek's programs (omp_env.h).
#include "omp_env.h"

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

void omp_env_defaults(const char *program, char **argv) {
  int set = set_default("OMP_PROC_BIND", "close");
  set |= set_default("OMP_PLACES", "cores");
  if (set && !getenv(REEXEC_GUARD)) {
    setenv(REEXEC_GUARD, "1", 1);
    execv("/proc/self/exe", argv);
    fprintf(stderr,
            "%s: note: re-exec for the OpenMP settings failed (%s); running with "
            "libgomp's defaults\n",
            program, strerror(errno));
  }
}
