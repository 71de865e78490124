// Internal: what ek's programs and test binaries share on their command
// lines, so that all of them behave alike. Not installed.
//
// Exit status, everywhere:
//   0  done, every check passed
//   1  a check failed or the run could not be done (bad input file, failed
//      step, unwritable output)
//   2  usage: a bad option or value on the command line or in EK_ISA
// ek-sim only (the state check, ek_sim_check; the scene's "allow" key,
// include/ek/sim/scene.h, turns each off):
//   3  the run finished but a frame holds NaN or inf, or the positions blew
//      up (beyond EK_SIM_BLOWUP_EXTENT body sizes from the rest centre)
//   4  the run finished with inverted elements (J <= 0) at its last frame
// A run that fails both ways exits 3.
#ifndef EK_SIM_CLI_H
#define EK_SIM_CLI_H

#include <stdio.h>

enum {
  EK_EXIT_OK = 0,
  EK_EXIT_FAILED = 1,
  EK_EXIT_USAGE = 2,
  EK_EXIT_NONFINITE = 3,
  EK_EXIT_INVERTED = 4
};

// --help / -h: print help(stdout) and the common footer, exit 0;
// --version: print "<program> (ek <version>)", exit 0. Any other argument
// is left to the caller. Call it first for each argument.
void ek_cli_common(const char *program, const char *arg, void (*help)(FILE *out));

// The lines every help text ends with: the environment variables ek reads
// and the exit status.
void ek_cli_footer(FILE *out);

// Prints "<program>: <message> (see <program> --help)" on stderr once and
// returns EK_EXIT_USAGE.
int ek_cli_usage_error(const char *program, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

// Strict numbers for options: the whole text is the number, in decimal,
// without white space, in range (one that overflows is out of range).
// Each returns 0 and sets *out, or -1 (the caller names the option).
//   ek_cli_parse_long: a whole number in [lo, hi];
//   ek_cli_parse_ull: a whole number >= 0, no sign;
//   ek_cli_parse_double: a finite number (not inf, nan, hexadecimal; no
//   overflow).
int ek_cli_parse_long(const char *s, long lo, long hi, long *out);
int ek_cli_parse_ull(const char *s, unsigned long long *out);
int ek_cli_parse_double(const char *s, double *out);

// A comma-separated list without an empty item ("a,,b", ",a", "a,", ""):
// 1, else 0.
int ek_cli_list_ok(const char *s);

// Whether the folder of an output path (its part before the last '/', or
// ".") takes a new file now: 0, or the errno (ENOTDIR when it is not a
// directory: a regular file passes access(W_OK) as root, and the run would
// fail after its last row). A file is created and removed in it to be sure
// (root passes access(W_OK) on /proc too). folder
// receives the folder's name.
int ek_cli_folder_error(const char *path, char *folder, size_t n);

// Until the process ends, SIGINT, SIGTERM and SIGHUP (each unless ignored,
// as a shell ignores SIGINT for a background job) print one line and end
// the process by the signal (exit status 128 + its number):
//   "<program>: stopped by SIGINT (row <*row> of <*total>); <note>"
// (the parenthesis when row is not NULL and *row > 0; " of" when total is
// not NULL). For programs that write their files at the end: the line says
// what was not written, where the shell said nothing. The handler only
// calls async-signal-safe functions; program and note must stay valid.
void ek_cli_stop_notice(const char *program, const int *row, const int *total, const char *note);
// Installs handler for SIGINT, SIGTERM and SIGHUP, once (SA_RESETHAND: a
// second signal ends the process); a signal the shell ignores stays ignored.
void ek_cli_catch_stop_signals(void (*handler)(int));

// The EK_* environment variables (ek_env_check): 0, or the usage error
// naming the variable and its value (printed; returns EK_EXIT_USAGE), as a
// bad EK_ISA. Every program calls it first.
int ek_cli_env_check(const char *program);

// Test binaries: parses [--seed N] [--help] [--version], and [--scenes DIR]
// when scenes is not NULL (*scenes is set to DIR); anything else is a usage
// error (exit 2). Returns the seed (fallback when not given).
unsigned long long ek_cli_test_args(int argc, char **argv, unsigned long long fallback,
                                    const char **scenes);

#endif
