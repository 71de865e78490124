// ek-verify's family table: every kernel family is one function that runs
// its variants against its reference and emits rows. A new family adds
// verify/verify_<family>.c, its name in EK_VERIFY_FAMILIES (verify/
// CMakeLists.txt) and one row in the table of ek_verify.c, e.g.
// { "material", verify_material }.
#ifndef EK_VERIFY_H
#define EK_VERIFY_H

#include <stddef.h>
#include <stdint.h>

typedef struct ek_verify_ctx ek_verify_ctx;

// One line of the report: one kernel variant on one input set.
#define EK_VERIFY_MAX_METRICS 6
typedef struct {
  const char *kernel;  // "svd3", "polar3", ...
  char variant[96];    // e.g. "avx2 f32 sweeps=4 rsqrt=approx"
  char inputs[48];     // input family ("random", "scale_1e30", "extremes")
  char worst_case[48]; // for aggregate rows: the input family of the worst
  size_t count;        // matrices measured
  int nmetrics;
  const char *metric[EK_VERIFY_MAX_METRICS];
  double value[EK_VERIFY_MAX_METRICS];
  double worst;            // the number held against the budget
  double budget;           // e.g. EK_SVD3_TOL_F32
  int trade;               // non-default options: printed, never failing on budget
  long nonfinite;          // non-finite outputs for finite inputs (always a failure)
  long leaks;              // non-finite input whose outputs are not all NaN, or a
                           // neighbour disturbed by it (always a failure)
  char nonfinite_case[48]; // aggregate rows: first input family with either
} ek_verify_row;

typedef int (*ek_verify_fn)(ek_verify_ctx *ctx);

typedef struct {
  const char *name;
  ek_verify_fn run;
  const char *note;
} ek_verify_family;

// Options of this run, for the families.
uint64_t ek_verify_seed(const ek_verify_ctx *ctx);
size_t ek_verify_n_random(const ek_verify_ctx *ctx); // random set size
size_t ek_verify_n_family(const ek_verify_ctx *ctx); // matrices per extremes family
int ek_verify_quick(const ek_verify_ctx *ctx);
// 1 if the row named "kernel variant inputs" passes --filter.
int ek_verify_selected(const ek_verify_ctx *ctx, const char *kernel, const char *variant,
                       const char *inputs);
// Print a row, keep it for --json, count failures.
void ek_verify_emit(ek_verify_ctx *ctx, const ek_verify_row *row);
// A note in the report (e.g. an ISA skipped because the CPU lacks it).
void ek_verify_note(ek_verify_ctx *ctx, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

// One note per ISA this build or CPU cannot run, naming the family.
void ek_verify_note_skipped_isas(ek_verify_ctx *ctx, const char *family);

// Families (one per verify_<family>.c).
int verify_svd3(ek_verify_ctx *ctx);
int verify_material(ek_verify_ctx *ctx);
int verify_fvm(ek_verify_ctx *ctx);
int verify_xpbd(ek_verify_ctx *ctx);
int verify_cloth_force(ek_verify_ctx *ctx);
int verify_cloth(ek_verify_ctx *ctx);
int verify_polar_warm(ek_verify_ctx *ctx);

// ek-verify --extremes (verify_extremes.c): the stability scenes per model
// and loop. Prints its table, appends one object per row to rows_json and
// one line per failing row to known_json (cJSON arrays); returns the number
// of failing rows, or -1 when a scene could not be set up.
struct cJSON;
int verify_extremes(ek_verify_ctx *ctx, struct cJSON *rows_json, struct cJSON *known_json);

#endif
