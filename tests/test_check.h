// The PASS/FAIL line of the bench harness tests (test_results_io,
// test_bench_robust, test_tradeoff): one line per check, failures counted
// in the including file's `failures`.
#ifndef EK_TEST_CHECK_H
#define EK_TEST_CHECK_H

#include <stdarg.h>
#include <stdio.h>

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

#endif
