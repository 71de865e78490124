// The command-line conventions of ek's programs (see cli.h).
#include "cli.h"

#include <ek/core.h>

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef EK_VERSION_STRING
#define EK_VERSION_STRING "unknown"
#endif

void ek_cli_footer(FILE *out) {
  fputs("Environment:\n"
        "  EK_ISA=scalar|avx2|avx512  force one kernel ISA (default: the best this CPU runs;\n"
        "                             one the CPU lacks is an error, exit 2)\n"
        "  EK_VERBOSE=1               print the ISA chosen, and each library error as it happens\n"
        "  EK_SVD3_CHAINS=2|4, EK_FVM_PREFETCH=0|1  tunings (the same bits; default: the CPU's\n"
        "                             choice); an EK_ variable set to any other value is an\n"
        "                             error, exit 2\n"
        "  OMP_NUM_THREADS=N          OpenMP threads, 1..4096 (default: all cores; another\n"
        "                             value, or a nested level's N > 1 as in 4,2, is an\n"
        "                             error, exit 2)\n"
        "Exit status: 0 done, 1 a check or the run failed, 2 bad usage.\n",
        out);
}

void ek_cli_common(const char *program, const char *arg, void (*help)(FILE *out)) {
  if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) {
    help(stdout);
    ek_cli_footer(stdout);
    exit(EK_EXIT_OK);
  }
  if (!strcmp(arg, "--version")) {
    printf("%s (ek %s)\n", program, EK_VERSION_STRING);
    exit(EK_EXIT_OK);
  }
}

int ek_cli_env_check(const char *program) {
  return ek_env_check() == EK_OK ? 0 : ek_cli_usage_error(program, "%s", ek_last_error());
}

int ek_cli_usage_error(const char *program, const char *fmt, ...) {
  char msg[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  fprintf(stderr, "%s: %s (see %s --help)\n", program, msg, program);
  return EK_EXIT_USAGE;
}

// The whole text is the number: strtol/strtod alone take leading white
// space (" 5"), and strtoull takes a sign (" -1" wraps to 2^64 - 1).
static int whole_number_text(const char *s, int sign) {
  if (!s || !*s)
    return 0;
  if (*s == '-' || *s == '+')
    s += sign;
  return *s >= '0' && *s <= '9';
}

int ek_cli_parse_long(const char *s, long lo, long hi, long *out) {
  if (!whole_number_text(s, 1))
    return -1;
  char *end;
  errno = 0;
  long v = strtol(s, &end, 10);
  if (errno || *end || v < lo || v > hi)
    return -1;
  *out = v;
  return 0;
}

int ek_cli_parse_ull(const char *s, unsigned long long *out) {
  if (!whole_number_text(s, 0))
    return -1;
  char *end;
  errno = 0;
  unsigned long long v = strtoull(s, &end, 10);
  if (errno || *end)
    return -1;
  *out = v;
  return 0;
}

int ek_cli_parse_double(const char *s, double *out) {
  // A digit, a sign or a point first: no space, and no "inf" or "nan";
  // no 'x': strtod's hexadecimal form is not decimal.
  if (!s || !(*s == '-' || *s == '+' || *s == '.' || (*s >= '0' && *s <= '9')) || strpbrk(s, "xX"))
    return -1;
  char *end;
  errno = 0;
  double v = strtod(s, &end);
  if (end == s || *end || errno == ERANGE || !isfinite(v))
    return -1;
  *out = v;
  return 0;
}

int ek_cli_list_ok(const char *s) {
  if (!s || !*s || *s == ',' || s[strlen(s) - 1] == ',' || strstr(s, ",,"))
    return 0;
  return 1;
}

static const char *test_program;
static int test_takes_scenes;

static void test_help(FILE *out) {
  fprintf(out, "usage: %s [--seed N]%s\n", test_program,
          test_takes_scenes ? " [--scenes DIR]" : "");
  fputs("  --seed N       seed of the random inputs (the default is printed on start)\n", out);
  if (test_takes_scenes)
    fputs("  --scenes DIR   the shipped scenes (default: the source tree's scenes/)\n", out);
}

unsigned long long ek_cli_test_args(int argc, char **argv, unsigned long long fallback,
                                    const char **scenes) {
  test_takes_scenes = scenes != NULL;
  const char *slash = strrchr(argv[0], '/');
  test_program = slash ? slash + 1 : argv[0];
  unsigned long long seed = fallback;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    ek_cli_common(test_program, a, test_help);
    if (!strcmp(a, "--seed") && i + 1 < argc) {
      const char *v = argv[++i];
      if (ek_cli_parse_ull(v, &seed))
        exit(ek_cli_usage_error(test_program, "--seed: '%s' is not a non-negative integer", v));
    } else if (scenes && !strcmp(a, "--scenes") && i + 1 < argc) {
      *scenes = argv[++i];
    } else {
      exit(ek_cli_usage_error(test_program, "unknown or incomplete argument '%s'", a));
    }
  }
  return seed;
}

int ek_cli_folder_error(const char *path, char *folder, size_t n) {
  snprintf(folder, n, "%s", path);
  char *slash = strrchr(folder, '/');
  if (slash)
    slash[slash == folder ? 1 : 0] = '\0';
  else
    snprintf(folder, n, ".");
  struct stat st;
  if (stat(folder, &st) != 0)
    return errno;
  if (!S_ISDIR(st.st_mode))
    return ENOTDIR;
  if (access(folder, W_OK) != 0)
    return errno;
  // access() answers from the mode bits and a read-only mount alone: root
  // was told yes for /proc and the run failed after its last row. A file
  // is made and removed to know.
  char probe[4200];
  if (snprintf(probe, sizeof probe, "%s/.ek-write-test.%ld", folder, (long)getpid()) >=
      (int)sizeof probe)
    return ENAMETOOLONG;
  int fd = open(probe, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
  if (fd < 0)
    return errno;
  close(fd);
  unlink(probe);
  return 0;
}

static const char *stop_program, *stop_note;
static const volatile int *stop_row, *stop_total;
static int stop_tty;

// Appends text to buf at *n (room for 512 bytes); async-signal-safe.
static void stop_put(char *buf, size_t *n, const char *text) {
  while (*text && *n < 511)
    buf[(*n)++] = *text++;
}
static void stop_put_int(char *buf, size_t *n, int v) {
  char digits[16];
  int k = 0;
  unsigned u = v < 0 ? 0u : (unsigned)v;
  do
    digits[k++] = (char)('0' + u % 10);
  while ((u /= 10) && k < 15);
  while (k && *n < 511)
    buf[(*n)++] = digits[--k];
}

static void on_stop(int sig) {
  char buf[512];
  size_t n = 0;
  if (stop_tty)
    stop_put(buf, &n, "\n"); // after a progress line that \r rewrites
  stop_put(buf, &n, stop_program);
  stop_put(buf, &n,
           sig == SIGINT    ? ": stopped by SIGINT"
           : sig == SIGTERM ? ": stopped by SIGTERM"
                            : ": stopped by SIGHUP");
  if (stop_row && *stop_row > 0) {
    stop_put(buf, &n, " (row ");
    stop_put_int(buf, &n, *stop_row);
    if (stop_total) {
      stop_put(buf, &n, " of ");
      stop_put_int(buf, &n, *stop_total);
    }
    stop_put(buf, &n, ")");
  }
  stop_put(buf, &n, "; ");
  stop_put(buf, &n, stop_note);
  stop_put(buf, &n, "\n");
  ssize_t w = write(STDERR_FILENO, buf, n);
  (void)w;
  // SA_RESETHAND restored the default action; the signal, blocked while
  // this handler runs, ends the process when it returns.
  raise(sig);
}

void ek_cli_catch_stop_signals(void (*handler)(int)) {
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = handler;
  sa.sa_flags = SA_RESETHAND; // a second signal ends at once
  sigemptyset(&sa.sa_mask);
  const int sigs[3] = {SIGINT, SIGTERM, SIGHUP};
  for (int i = 0; i < 3; ++i) {
    struct sigaction old; // a signal the shell ignores (a background job's SIGINT) stays ignored
    if (sigaction(sigs[i], NULL, &old) == 0 && old.sa_handler != SIG_IGN)
      sigaction(sigs[i], &sa, NULL);
  }
}

void ek_cli_stop_notice(const char *program, const int *row, const int *total, const char *note) {
  stop_program = program;
  stop_note = note;
  stop_row = row;
  stop_total = total;
  stop_tty = isatty(STDERR_FILENO);
  ek_cli_catch_stop_signals(on_stop);
}
