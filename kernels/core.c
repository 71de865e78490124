// Error messages and aligned memory.
#include <ek/core.h>

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kernels.h"

static _Thread_local char last_error[512];

const char *ek_last_error(void) { return last_error; }

void ek_set_error(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(last_error, sizeof last_error, fmt, ap);
  va_end(ap);
  const char *verbose = getenv("EK_VERBOSE");
  if (verbose && *verbose && strcmp(verbose, "0") != 0)
    fprintf(stderr, "ek: %s\n", last_error);
}

void *ek_alloc(size_t bytes) {
  // aligned_alloc wants a size that is a multiple of the alignment.
  size_t rounded = (bytes + 63) / 64 * 64;
  return aligned_alloc(64, rounded ? rounded : 64);
}

void ek_free(void *p) { free(p); }
