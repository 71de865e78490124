// ek-verify: every kernel variant this machine can run, against its double
// reference, on a seeded random set and on every family of the extremes
// catalogue; prints the worst errors and worst/budget per row and exits
// non-zero if a default-option row misses its budget, a finite input gives
// a non-finite output, or a NaN leaks into a neighbour. `ek-verify --help`
// lists the options; exit status as in sim/cli.h (0 pass, 1 fail, 2 usage).
// `ek-verify --extremes` runs the stability scenes instead
// (verify_extremes.c): exit 0 when every row expected to survive did.
#include <cjson/cJSON.h>
#include <ek/ek.h>
#include <errno.h>
#include <math.h>
#include <regex.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "cli.h"
#include "not_regular.h"
#include "omp_env.h"
#include "verify.h"

// The family table: one row per kernel family (FFTW "favor a table").
static const ek_verify_family families[] = {
    {"svd3", verify_svd3, "3x3 SVD and polar decomposition vs LAPACK dgesvd"},
    {"material", verify_material, "psi, P, dP, Hessian per model vs the double reference"},
    {"fvm", verify_fvm,
     "FVM force per scatter strategy, gradient and Hessian products per projection vs the "
     "double references"},
    {"xpbd", verify_xpbd,
     "XPBD sweeps (Gauss-Seidel, Jacobi) on tets and clusters vs the double reference"},
    {"cloth_force", verify_cloth_force,
     "cloth membrane (StVK, ARAP) and bending forces vs the double reference (metric form, "
     "LAPACK)"},
    {"cloth", verify_cloth,
     "polar32, Kabsch, triangle velocity gradient vs LAPACK (dgesvd) references"},
    {"polar_warm", verify_polar_warm,
     "warm-started polar vs the SVD polar (LAPACK): random, near, far guesses, inverted, and "
     "over the cantilever and twist runs"},
};

struct ek_verify_ctx {
  uint64_t seed;
  size_t n_random, n_family;
  int quick;
  int has_filter;
  regex_t filter;
  cJSON *rows, *notes;
  int failures, rows_printed;
  const char *last_kernel;
  // Progress on stderr when stderr is a terminal: with the table
  // redirected, a line as each family starts and every 5 s; with the table
  // on the terminal too, a status line under it (rows done, family, time
  // left), cleared before each line of the table.
  int progress; // 1: lines, 2: a status line
  int status_shown;
  double t0, last_progress;
  size_t family;     // the family running
  int family_rows0;  // rows before it
  double done_share; // the reference run's time share of the families before it
};

static double now_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

// The time left: each family's share of a whole run's time (the reference
// run: ek-verify and ek-verify --quick on the 2-core Zen 4, 3 ISAs, round 16:
// 181 s and 117 s), the family running counted by its rows against that
// run's. An estimate ("about"); none under --filter, whose rows are another
// set. Rows of the reference run per family, in the order of families[].
static const double ref_seconds[2][7] = {{47, 12, 74, 0.3, 0.3, 10, 38},
                                         {2, 15, 90, 0.3, 0.3, 2, 8}};
static const int ref_rows[2][7] = {{864, 96, 288, 12, 24, 18, 40}, {648, 96, 288, 12, 24, 18, 40}};

// Rows of the whole run ("about": the reference CPU's ISAs) and the seconds
// left; 0 when there is no estimate.
static int progress_estimate(const ek_verify_ctx *ctx, int *total, double *left) {
  const int q = ctx->quick ? 1 : 0;
  if (ctx->has_filter || ctx->family >= 7)
    return 0;
  double sum = 0;
  *total = 0;
  for (int f = 0; f < 7; f++)
    sum += ref_seconds[q][f], *total += ref_rows[q][f];
  // Another CPU runs other ISAs: its rows differ, the shares stand.
  int isas = 0;
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; i++)
    isas += ek_isa_available((ek_isa)i);
  if (isas != 3)
    *total = 0;
  double in_family = (double)(ctx->rows_printed - ctx->family_rows0) / ref_rows[q][ctx->family];
  in_family = in_family < 0.95 ? in_family : 0.95;
  const double done = (ctx->done_share + ref_seconds[q][ctx->family] * in_family) / sum;
  const double elapsed = now_s() - ctx->t0;
  if (done < 0.005 || elapsed < 1)
    return 0;
  *left = elapsed * (1 - done) / done;
  return 1;
}

// The status line's text: "N of about T rows, family F (k of 7), E s, about L s left".
static void progress_text(const ek_verify_ctx *ctx, char *buf, size_t cap) {
  int total = 0;
  double left = 0;
  const int est = progress_estimate(ctx, &total, &left);
  char of[48] = "";
  if (est && total)
    snprintf(of, sizeof of, " of about %d", total);
  char eta[48] = "";
  if (est)
    snprintf(eta, sizeof eta, ", about %.0f s left", left);
  snprintf(buf, cap, "%d%s rows, %d failing, %.0f s%s", ctx->rows_printed, of, ctx->failures,
           now_s() - ctx->t0, eta);
}

// Before a line of the table on the terminal: the status line cleared.
static void status_clear(ek_verify_ctx *ctx) {
  if (ctx->status_shown) {
    fputs("\r\033[K", stderr);
    ctx->status_shown = 0;
  }
}

uint64_t ek_verify_seed(const ek_verify_ctx *ctx) { return ctx->seed; }
size_t ek_verify_n_random(const ek_verify_ctx *ctx) { return ctx->n_random; }
size_t ek_verify_n_family(const ek_verify_ctx *ctx) { return ctx->n_family; }
int ek_verify_quick(const ek_verify_ctx *ctx) { return ctx->quick; }

int ek_verify_selected(const ek_verify_ctx *ctx, const char *kernel, const char *variant,
                       const char *inputs) {
  if (!ctx->has_filter)
    return 1;
  char name[256];
  snprintf(name, sizeof name, "%s %s %s", kernel, variant, inputs);
  return regexec(&ctx->filter, name, 0, NULL, 0) == 0;
}

void ek_verify_note(ek_verify_ctx *ctx, const char *fmt, ...) {
  char msg[256];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  status_clear(ctx);
  printf("note: %s\n", msg);
  cJSON_AddItemToArray(ctx->notes, cJSON_CreateString(msg));
}

void ek_verify_note_skipped_isas(ek_verify_ctx *ctx, const char *family) {
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    if (!ek_isa_available((ek_isa)isa))
      ek_verify_note(ctx, "%s: ISA %s skipped (not built or not supported by this CPU)", family,
                     ek_isa_name((ek_isa)isa));
}

void ek_verify_emit(ek_verify_ctx *ctx, const ek_verify_row *r) {
  double ratio = r->worst / r->budget;
  ek_verdict v = ek_check_verdict(r->worst, r->budget);
  const char *status;
  int failed = r->nonfinite > 0 || r->leaks > 0;
  if (failed)
    status = "FAIL";
  else if (r->trade)
    status = "trade";
  else {
    status = ek_verdict_name(v);
    failed = v == EK_FAIL;
  }
  ctx->failures += failed;
  status_clear(ctx);
  if (!ctx->last_kernel || strcmp(ctx->last_kernel, r->kernel) != 0) {
    printf("\n%-7s %-32s %-16s %7s", "kernel", "variant", "inputs", "n");
    for (int k = 0; k < r->nmetrics; k++)
      printf(" %9s", r->metric[k]);
    printf(" %9s %s\n", "worst/bud", "status");
    ctx->last_kernel = r->kernel;
  }
  printf("%-7s %-32s %-16s %7zu", r->kernel, r->variant, r->inputs, r->count);
  for (int k = 0; k < r->nmetrics; k++)
    printf(" %9.2e", r->value[k]);
  printf(" %9.3g %s", ratio, status);
  if (r->worst_case[0])
    printf(" (worst: %s)", r->worst_case);
  if (r->nonfinite)
    printf(" [%ld non-finite outputs for finite inputs]", r->nonfinite);
  if (r->leaks)
    printf(" [%ld NaN isolation errors]", r->leaks);
  if (r->nonfinite_case[0])
    printf(" [first in %s]", r->nonfinite_case);
  printf("\n");
  ctx->rows_printed++;
  fflush(stdout); // the row on the terminal before the status line under it
  char text[160];
  if (ctx->progress == 1 && now_s() - ctx->last_progress > 5.0) {
    ctx->last_progress = now_s();
    progress_text(ctx, text, sizeof text);
    fprintf(stderr, "ek-verify: %s\n", text);
  } else if (ctx->progress == 2 && now_s() - ctx->last_progress > 0.5) {
    ctx->last_progress = now_s();
    // Short (under 80 columns: a wrapped line is not cleared by \r):
    // "[1126/~1342 rows, 0 failing, 95 s, ~87 s left; fvm 3/7]".
    int total = 0;
    double left = 0;
    const int est = progress_estimate(ctx, &total, &left);
    char of[24] = "", eta[32] = "";
    if (est && total)
      snprintf(of, sizeof of, "/~%d", total);
    if (est)
      snprintf(eta, sizeof eta, ", ~%.0f s left", left);
    fprintf(stderr, "[%d%s rows, %d failing, %.0f s%s; %s %zu/7]", ctx->rows_printed, of,
            ctx->failures, now_s() - ctx->t0, eta, families[ctx->family].name, ctx->family + 1);
    ctx->status_shown = 1;
  }

  cJSON *j = cJSON_CreateObject();
  cJSON_AddStringToObject(j, "kernel", r->kernel);
  cJSON_AddStringToObject(j, "variant", r->variant);
  cJSON_AddStringToObject(j, "inputs", r->inputs);
  if (r->worst_case[0])
    cJSON_AddStringToObject(j, "worst_inputs", r->worst_case);
  cJSON_AddNumberToObject(j, "count", (double)r->count);
  cJSON *m = cJSON_AddObjectToObject(j, "errors");
  for (int k = 0; k < r->nmetrics; k++)
    cJSON_AddNumberToObject(m, r->metric[k], isfinite(r->value[k]) ? r->value[k] : 1e308);
  cJSON_AddNumberToObject(j, "worst", isfinite(r->worst) ? r->worst : 1e308);
  cJSON_AddNumberToObject(j, "budget", r->budget);
  cJSON_AddNumberToObject(j, "ratio", isfinite(ratio) ? ratio : 1e308);
  cJSON_AddBoolToObject(j, "trade", r->trade);
  cJSON_AddNumberToObject(j, "nonfinite", (double)r->nonfinite);
  cJSON_AddNumberToObject(j, "leaks", (double)r->leaks);
  if (r->nonfinite_case[0])
    cJSON_AddStringToObject(j, "nonfinite_inputs", r->nonfinite_case);
  cJSON_AddStringToObject(j, "status", status);
  cJSON_AddItemToArray(ctx->rows, j);
}

// --json FILE, checked before any row runs (issue 28: a bad path was
// reported mid-table while the summary said PASS, and an existing file was
// overwritten without --force): not an existing file unless force, never
// anything but a regular file, in a folder that exists and is writable.
// 0, or EK_EXIT_FAILED with the message printed.
static int check_json_path(const char *path, int force) {
  const char *what = not_regular(path);
  if (what) {
    fprintf(stderr, "ek-verify: --json '%s' is %s, not a regular file; not replaced\n", path, what);
    return EK_EXIT_FAILED;
  }
  if (!force && access(path, F_OK) == 0) {
    fprintf(stderr, "ek-verify: --json '%s' exists; not overwritten (use --force)\n", path);
    return EK_EXIT_FAILED;
  }
  char folder[4096];
  int e = ek_cli_folder_error(path, folder, sizeof folder);
  if (e) {
    fprintf(stderr, "ek-verify: cannot write --json '%s': folder '%s': %s\n", path, folder,
            strerror(e));
    return EK_EXIT_FAILED;
  }
  return 0;
}

// Write a report's JSON root to path: a temporary file next to it, then a
// hard link (without force: fails if the name appeared meanwhile) or a
// rename over it (force), so the file is whole or absent. 0, or 1 with a
// message.
static int write_json(cJSON *root, const char *path, int force) {
  char tmp[4200];
  snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
  char *text = cJSON_Print(root);
  FILE *fp = text ? fopen(tmp, "wx") : NULL;
  int bad = !text || !fp || fputs(text, fp) < 0 || fputc('\n', fp) == EOF;
  if (fp && fclose(fp) != 0)
    bad = 1;
  free(text);
  int e = errno;
  if (!bad && !not_regular(path)) {
    bad = force ? rename(tmp, path) != 0 : link(tmp, path) != 0;
    e = errno;
  } else if (!bad) {
    bad = 1, e = EEXIST;
  }
  if (fp)
    unlink(tmp); // after a rename: no such name any more
  if (bad) {
    fprintf(stderr, "ek-verify: cannot write --json file '%s': %s\n", path, strerror(e));
    return 1;
  }
  return 0;
}

// ek-verify --extremes: the stability table (verify_extremes.c) and its
// JSON, shaped like the families' report with "mode": "extremes" and the
// known failures.
static int run_extremes(ek_verify_ctx *ctx, const char *json_path, int force, const char *filter) {
  printf("ek-verify --extremes: seed %llu%s%s%s\n", (unsigned long long)ctx->seed,
         ctx->quick ? ", quick" : "", filter ? ", filter " : "", filter ? filter : "");
  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  cJSON *known = cJSON_CreateArray();
  int failures = verify_extremes(ctx, ctx->rows, known);
  clock_gettime(CLOCK_MONOTONIC, &t1);
  double elapsed = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
  int rc = failures != 0 ? 1 : 0;
  const int nrows = cJSON_GetArraySize(ctx->rows);
  if (ctx->has_filter && nrows == 0 && failures == 0) {
    // Nothing verified is no PASS (a mistyped filter exited 0).
    cJSON_Delete(known);
    cJSON_Delete(ctx->rows);
    cJSON_Delete(ctx->notes);
    regfree(&ctx->filter);
    return ek_cli_usage_error("ek-verify", "--filter '%s': no row matches; nothing verified",
                              filter);
  }
  cJSON *root = cJSON_CreateObject();
  cJSON_AddStringToObject(root, "tool", "ek-verify");
  cJSON_AddStringToObject(root, "mode", "extremes");
  cJSON_AddNumberToObject(root, "seed", (double)ctx->seed);
  cJSON_AddBoolToObject(root, "quick", ctx->quick);
  if (filter)
    cJSON_AddStringToObject(root, "filter", filter);
  cJSON_AddItemToObject(root, "notes", ctx->notes);
  cJSON_AddItemToObject(root, "rows", ctx->rows);
  cJSON_AddItemToObject(root, "known_failures", known);
  cJSON_AddNumberToObject(root, "failures", failures < 0 ? 0 : failures);
  cJSON_AddBoolToObject(root, "setup_errors", failures < 0);
  cJSON_AddNumberToObject(root, "elapsed_s", elapsed);
  cJSON_AddStringToObject(root, "result", rc ? "FAIL" : "PASS");
  // Written before the summary, which then tells whether it was.
  const int json_failed = json_path && write_json(root, json_path, force) != 0;
  cJSON_Delete(root);
  rc |= json_failed;
  printf("\nek-verify --extremes: %d rows, %d failing%s%s, %.1f s -> %s\n", nrows,
         failures < 0 ? 0 : failures, failures < 0 ? ", setup errors" : "",
         json_failed ? ", --json not written" : "", elapsed, rc ? "FAIL" : "PASS");
  if (ctx->has_filter)
    regfree(&ctx->filter);
  return rc;
}

static void usage(FILE *out) {
  fputs("usage: ek-verify [--seed N] [--n N] [--json FILE [--force]] [--filter REGEX] "
        "[--quick]\n"
        "       ek-verify --extremes [--seed N] [--json FILE [--force]] [--filter REGEX] "
        "[--quick]\n"
        "  --seed N       seed of every input set (default 1)\n"
        "  --n N          size of the random set, >= 1 (default 100000; --quick 10000)\n"
        "  --json FILE    also write the rows as JSON (checked before the first row)\n"
        "  --force        overwrite an existing --json file\n"
        "  --filter REGEX only rows whose \"kernel variant inputs\" match (POSIX ERE;\n"
        "                 none matching is bad usage, exit 2)\n"
        "  --quick        fewer matrices and variants (--extremes: a CI-sized subset)\n"
        "  --extremes     stability at the extremes: crush to a plane and a point,\n"
        "                 rest, nu, E and element size sweeps per model and loop;\n"
        "                 --filter matches \"model loop precision case\"\n"
        "  -h, --help     this text\n"
        "  --version      print the version\n"
        "Every ISA this CPU runs is verified by name; EK_ISA picks what 'auto' means.\n"
        "Progress goes to stderr when it is a terminal: rows done, of about how many, and\n"
        "about how long is left (an estimate from a reference run's time per family; none\n"
        "under --filter); a status line under the table, or lines when the table is\n"
        "redirected.\n",
        out);
}

// A whole number in [lo, ULLONG_MAX]: the whole string, decimal, no sign.
static int parse_count(const char *opt, const char *s, unsigned long long lo,
                       unsigned long long *out) {
  if (ek_cli_parse_ull(s, out) || *out < lo)
    return ek_cli_usage_error("ek-verify", "%s: '%s' is not a whole number >= %llu", opt, s, lo);
  return 0;
}

int main(int argc, char **argv) {
  if (omp_env_check_threads("ek-verify"))
    return EK_EXIT_USAGE;
  ek_verify_ctx ctx = {.seed = 1, .n_random = 0, .n_family = 0};
  const char *json_path = NULL, *filter = NULL;
  unsigned long long n_opt = 0;
  int have_n = 0, extremes = 0, force = 0;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    int has_value = i + 1 < argc;
    unsigned long long v;
    ek_cli_common("ek-verify", a, usage);
    if (strcmp(a, "--quick") == 0)
      ctx.quick = 1;
    else if (strcmp(a, "--extremes") == 0)
      extremes = 1;
    else if (strcmp(a, "--force") == 0)
      force = 1;
    else if (strcmp(a, "--seed") == 0 && has_value) {
      if (parse_count(a, argv[++i], 0, &v))
        return EK_EXIT_USAGE;
      ctx.seed = v;
    } else if (strcmp(a, "--n") == 0 && has_value) {
      if (parse_count(a, argv[++i], 1, &n_opt))
        return EK_EXIT_USAGE;
      have_n = 1;
    } else if (strcmp(a, "--json") == 0 && has_value) {
      json_path = argv[++i];
      if (!*json_path)
        return ek_cli_usage_error("ek-verify", "--json: empty file name");
    } else if (strcmp(a, "--filter") == 0 && has_value)
      filter = argv[++i];
    else
      return ek_cli_usage_error("ek-verify", "unknown or incomplete option '%s'", a);
  }
  ctx.n_random = have_n ? (size_t)n_opt : ctx.quick ? 10000 : 100000;
  ctx.n_family = ctx.quick ? 200 : 2000;
  // ek-verify runs every ISA this CPU has by name; EK_ISA only picks what
  // AUTO means. One the CPU lacks is an error, not a silent pass without it.
  // Checked before the filter is compiled, which every later return frees.
  ek_isa auto_isa;
  if (ek_cli_env_check("ek-verify")) // every EK_* variable is one of its values
    return EK_EXIT_USAGE;
  if (ek_isa_resolve(EK_ISA_AUTO, &auto_isa) != EK_OK)
    return ek_cli_usage_error("ek-verify", "%s", ek_last_error());
  if (force && !json_path)
    return ek_cli_usage_error("ek-verify", "--force goes with --json FILE");
  // The extremes run no random set: --n there changed nothing, silently.
  if (extremes && have_n)
    return ek_cli_usage_error("ek-verify", "--n: not with --extremes (it has no random set)");
  if (filter) {
    int rc = regcomp(&ctx.filter, filter, REG_EXTENDED | REG_NOSUB);
    if (rc) {
      char msg[128];
      regerror(rc, &ctx.filter, msg, sizeof msg);
      return ek_cli_usage_error("ek-verify", "--filter '%s': %s", filter, msg);
    }
    ctx.has_filter = 1;
  }
  if (json_path && check_json_path(json_path, force) != 0) {
    if (ctx.has_filter)
      regfree(&ctx.filter);
    return EK_EXIT_FAILED;
  }
  ek_cli_stop_notice("ek-verify", NULL, NULL,
                     json_path ? "no verdict, and the --json file is not written" : "no verdict");
  ctx.rows = cJSON_CreateArray();
  ctx.notes = cJSON_CreateArray();
  if (extremes)
    return run_extremes(&ctx, json_path, force, filter);

  printf("ek-verify: seed %llu, random set %zu, %zu per extremes family%s%s%s\n",
         (unsigned long long)ctx.seed, ctx.n_random, ctx.n_family, ctx.quick ? ", quick" : "",
         filter ? ", filter " : "", filter ? filter : "");
  printf("errors relative to s1 of the input (absolute for the zero matrix); budgets apply to "
         "the default sweeps (either rsqrt mode); 'trade' rows are reported only\n");
  int setup_errors = 0;
  const size_t nfamilies = sizeof families / sizeof families[0];
  _Static_assert(sizeof families / sizeof families[0] == 7, "ref_seconds, ref_rows: a family each");
  ctx.progress = !isatty(STDERR_FILENO) ? 0 : isatty(STDOUT_FILENO) ? 2 : 1;
  ctx.t0 = ctx.last_progress = now_s();
  for (size_t f = 0; f < nfamilies; f++) {
    if (f > 0)
      ctx.done_share += ref_seconds[ctx.quick ? 1 : 0][f - 1];
    ctx.family = f;
    ctx.family_rows0 = ctx.rows_printed;
    if (ctx.progress == 1) {
      char text[160];
      progress_text(&ctx, text, sizeof text);
      fprintf(stderr, "ek-verify: family %s (%zu of %zu), %d rows so far, %.0f s; %s\n",
              families[f].name, f + 1, nfamilies, ctx.rows_printed, now_s() - ctx.t0, text);
    }
    status_clear(&ctx);
    printf("\n== %s: %s\n", families[f].name, families[f].note);
    setup_errors += families[f].run(&ctx) != 0;
  }
  status_clear(&ctx);
  ctx.family = nfamilies; // no estimate past the last family

  if (ctx.has_filter && ctx.rows_printed == 0 && !setup_errors) {
    // Nothing verified is no PASS (a mistyped filter exited 0), as
    // ek-bench's "no row matches the filter".
    cJSON_Delete(ctx.rows);
    cJSON_Delete(ctx.notes);
    regfree(&ctx.filter);
    return ek_cli_usage_error("ek-verify", "--filter '%s': no row matches; nothing verified",
                              filter);
  }
  int rc = ctx.failures || setup_errors ? 1 : 0;
  int json_failed = 0;
  if (json_path) {
    // Written before the summary, which then tells whether it was.
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "tool", "ek-verify");
    cJSON_AddNumberToObject(root, "seed", (double)ctx.seed);
    cJSON_AddNumberToObject(root, "n_random", (double)ctx.n_random);
    cJSON_AddNumberToObject(root, "n_family", (double)ctx.n_family);
    cJSON_AddBoolToObject(root, "quick", ctx.quick);
    if (filter)
      cJSON_AddStringToObject(root, "filter", filter);
    cJSON_AddItemToObject(root, "notes", ctx.notes);
    cJSON_AddItemToObject(root, "rows", ctx.rows);
    cJSON_AddNumberToObject(root, "failures", ctx.failures);
    cJSON_AddStringToObject(root, "result", rc ? "FAIL" : "PASS");
    json_failed = write_json(root, json_path, force) != 0;
    cJSON_Delete(root);
  } else {
    cJSON_Delete(ctx.rows);
    cJSON_Delete(ctx.notes);
  }
  rc |= json_failed;
  printf("\nek-verify: %d rows, %d failing%s%s -> %s\n", ctx.rows_printed, ctx.failures,
         setup_errors ? ", setup errors" : "", json_failed ? ", --json not written" : "",
         rc ? "FAIL" : "PASS");
  if (ctx.has_filter)
    regfree(&ctx.filter);
  return rc;
}
