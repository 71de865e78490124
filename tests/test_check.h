// The PASS/FAIL line of the bench harness tests (test_results_io,
// test_bench_robust, test_tradeoff): one line per check, failures counted
// in the including file's `failures`; and reading back a whole file.
#ifndef EK_TEST_CHECK_H
#define EK_TEST_CHECK_H

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

static int failures;

static void check(const char *what, int ok, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void check(const char *what, int ok, const char *fmt, ...) {
  char detail[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(detail, sizeof detail, fmt, ap);
  va_end(ap);
  printf("%-5s %s (%s)\n", ok ? "PASS" : "FAIL", what, detail);
  if (!ok)
    failures++;
}

// The whole file as a string (malloc'd), or NULL if it cannot be read.
static inline char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f)
    return NULL;
  fseek(f, 0, SEEK_END);
  long len = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *s = len >= 0 ? malloc((size_t)len + 1) : NULL;
  size_t got = s ? fread(s, 1, (size_t)len, f) : 0;
  fclose(f);
  if (!s || got != (size_t)len) {
    free(s);
    return NULL;
  }
  s[len] = 0;
  return s;
}

#endif
