// Error messages and aligned memory.
#include <ek/core.h>

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kernels.h"

static _Thread_local char last_error[2048];

const char *ek_last_error(void) { return last_error; }

void ek_set_error(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(last_error, sizeof last_error, fmt, ap);
  va_end(ap);
  if (ek_env_verbose())
    fprintf(stderr, "ek: %s\n", last_error);
}

void *ek_alloc(size_t bytes) {
  if (bytes > SIZE_MAX - 63) // the rounding below would wrap to a tiny block
    return NULL;
  // aligned_alloc wants a size that is a multiple of the alignment.
  size_t rounded = (bytes + 63) / 64 * 64;
  return aligned_alloc(64, rounded ? rounded : 64);
}

void ek_free(void *p) { free(p); }

int ek_batch_check(const char *fn, size_t count, size_t item_bytes, size_t align, int narrays,
                   const void *const *arrays, const char *const *names) {
  // Pointer arithmetic is defined up to PTRDIFF_MAX bytes; the drivers
  // round a batch up to whole staging chunks (EK_BATCH_SLACK items).
  size_t max = (size_t)PTRDIFF_MAX / item_bytes - EK_BATCH_SLACK;
  if (count > max) {
    ek_set_error("%s: batch of %zu items of %zu bytes overflows the byte count (at most %zu "
                 "items)",
                 fn, count, item_bytes, max);
    return EK_EINVAL;
  }
  for (int i = 0; i < narrays; i++)
    if (arrays[i] && (uintptr_t)arrays[i] % align) {
      ek_set_error("%s: %s = %p is not aligned to %zu bytes (the alignment of its element "
                   "type; see core.h)",
                   fn, names[i], arrays[i], align);
      return EK_EINVAL;
    }
  return EK_OK;
}

size_t ek_aos_head(const void *p, size_t rec_bytes, size_t n) {
  for (size_t h = 0; h < EK_LANES_F32 && h < n; h++)
    if (((uintptr_t)p + h * rec_bytes) % 64 == 0)
      return h;
  return 0;
}
