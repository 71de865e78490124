// ek_check: what tests and ek-verify share to judge a kernel against its
// reference. A seeded random generator (xoshiro256**, seeded by splitmix64),
// the extremes catalogue (named families of input matrices, a table), error
// metrics for the 3x3 SVD and polar decomposition, and the PASS / MARGINAL /
// FAIL verdict; and the library's SVD and material kernels on double data.
#ifndef EK_CHECK_H
#define EK_CHECK_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <ek/material.h>
#include <ek/svd3.h>

#ifdef __cplusplus
extern "C" {
#endif

// ---- Random numbers ----
// xoshiro256** (Blackman & Vigna, "Scrambled linear pseudorandom number
// generators", ACM TOMS 2021), state seeded from one 64-bit value by
// splitmix64 (Steele, Lea & Flood, OOPSLA 2014), as its authors recommend.
typedef struct {
  uint64_t s[4];
} ek_rng;

void ek_rng_seed(ek_rng *rng, uint64_t seed);
uint64_t ek_rng_next(ek_rng *rng);
double ek_rng_uniform(ek_rng *rng);                 // [0, 1)
double ek_rng_gauss(ek_rng *rng);                   // N(0, 1)
void ek_rng_gauss_matrix(ek_rng *rng, double A[9]); // iid N(0, 1) entries
void ek_rng_rotation(ek_rng *rng, double R[9]);     // uniform on SO(3)
// U diag(sigma) V^T with U, V uniform random rotations (sigma signed).
void ek_rng_with_sigma(ek_rng *rng, const double sigma[3], double A[9]);
// Q (I + g G): a rotation Q uniform on SO(3) times a random stretch, G with
// iid N(0, 1) entries (Q drawn first, then G).
void ek_rng_deformation(ek_rng *rng, double g, double A[9]);
// Seed of a named stream: independent of the order of any table.
uint64_t ek_check_stream_seed(uint64_t seed, const char *name);

// ---- Small 3x3 helpers (row-major) ----
double ek_det3(const double M[9]);
void ek_mul3(const double A[9], const double B[9], double C[9]);    // C = A B
void ek_mul3_bt(const double A[9], const double B[9], double C[9]); // C = A B^T
void ek_print3(const char *label, const double M[9]);

// ---- The extremes catalogue ----
// A family generates n matrices (row-major, n x 9) from a random stream.
// Families marked EK_FAMILY_F32 / _F64 are meant for that precision only
// (e.g. scales outside float's range); EK_FAMILY_NONFINITE families put a
// NaN or infinity in some matrices to check that only those lanes go NaN.
enum { EK_FAMILY_F32 = 1, EK_FAMILY_F64 = 2, EK_FAMILY_BOTH = 3, EK_FAMILY_NONFINITE = 4 };

typedef struct {
  const char *name;
  void (*generate)(ek_rng *rng, size_t n, double *A);
  int flags;
  const char *note;
} ek_check_family;

extern const ek_check_family ek_check_families[];
extern const int ek_check_nfamilies;

// 1 if family f is meant for precision 32 or 64.
int ek_check_family_for(const ek_check_family *f, int bits);
// 1 if the 9 entries are all finite.
int ek_check_finite9(const double A[9]);

// Round n x k doubles to float and back, so that a float kernel and the
// double reference see the same input.
void ek_check_to_f32(size_t count, const double *in, float *out);
void ek_check_from_f32(size_t count, const float *in, double *out);
// A new buffer of count floats (ek_check_malloc; free it): in converted,
// or, in NULL, poisoned (ek_check_poison, below): an f32 call's output,
// which a freed buffer of the previous call holding right values could
// otherwise be.
float *ek_check_f32_copy(size_t count, const double *in);

// ---- Error metrics ----
// All relative to s1 = S_ref[0], the largest singular value of the input
// (absolute when s1 == 0, the zero matrix). Orthogonality and determinant
// errors are absolute (a rotation has no scale).
typedef struct {
  double recon;   // |A - U diag(S) V^T|_max / s1
  double orth;    // max(|U^T U - I|_max, |V^T V - I|_max)
  double det;     // max(|det U - 1|, |det V - 1|)
  double sigma;   // |S - S_ref|_max / s1
  double order;   // max(0, S1 - S0, |S2| - S1) / s1: ordering violation
  int sign_wrong; // S2's sign contradicts det A where |S_ref[2]| > margin
  int nonfinite;  // some output not finite
} ek_svd3_metrics;

// sign_margin: the sign rule (S2 < 0 iff det A < 0) is judged only where
// |S_ref[2]| > sign_margin * s1, so a reference-level rounding of a
// vanishing S2 is not counted.
void ek_check_svd3(const double A[9], const double U[9], const double S[3], const double V[9],
                   const double S_ref[3], double sign_margin, ek_svd3_metrics *m);
// Largest of recon, orth, det, sigma, order (+inf if nonfinite or the sign
// is wrong): the number held against the budget.
double ek_svd3_metrics_worst(const ek_svd3_metrics *m);

typedef struct {
  double recon;  // |A - R Ssym|_max / s1
  double orth;   // |R^T R - I|_max
  double det;    // |det R - 1|
  double sym;    // |Ssym - Ssym^T|_max / s1
  double rdiff;  // |R - R_ref|_max * (s2 + s3) / (2 s1), see check_metrics.c
  int nonfinite; // some output not finite
} ek_polar3_metrics;

void ek_check_polar3(const double A[9], const double R[9], const double Ssym[9],
                     const double S_ref[3], const double R_ref[9], ek_polar3_metrics *m);
double ek_polar3_metrics_worst(const ek_polar3_metrics *m);

// ---- SVD3 input sets ----
// n matrices of one family (or the gaussian family as "random"), rounded to
// the precision (bits 32 or 64), with the LAPACK reference: S_ref (n x 3)
// and R_ref = U V^T (n x 9); bad[i] = 1 where A has a non-finite entry.
typedef struct {
  char name[48];
  int nonfinite_family;
  size_t n;
  double *A, *S_ref, *R_ref;
  char *bad;
} ek_svd3_set;

void ek_svd3_set_init(ek_svd3_set *s, const ek_check_family *f, const char *name, uint64_t seed,
                      size_t n, int bits);
void ek_svd3_set_free(ek_svd3_set *s);
// ek_svd3_f32/_f64 (polar = 0) or ek_polar3_f32/_f64 (polar = 1: U <- R,
// V <- Ssym, S unused) on double data, converting for bits == 32. Outputs
// are written only when the call succeeds.
int ek_check_run_svd3(int bits, int polar, size_t n, const double *A, double *U, double *S,
                      double *V, const ek_svd3_opts *o);
// malloc that exits with a message when memory runs out.
void *ek_check_malloc(size_t bytes);
// Fills an output buffer with 0xFF bytes (a NaN in float and in double, -1
// in integers) right before a call writes it, so that an element the call
// did not write (a chunk that never ran) cannot match the reference: the
// same-bits checks across thread counts compare against it, and a buffer
// reused from the previous call (or a malloc handing back freed memory)
// would still hold right values. Not for an output the call adds into or
// reads (those get the same starting values before every call). Returns p.
static inline void *ek_check_poison(void *p, size_t bytes) {
  if (p && bytes)
    memset(p, 0xFF, bytes);
  return p;
}

// ---- Material input set ----
// ek-verify's material set (verify/check_material.c): n elements' F, R and
// dF (n x 9 each) for `seed`, rounded to float when f32 (the reference then
// sees exactly the float input).
void ek_check_material_inputs(uint64_t seed, int f32, size_t n, double *F, double *R, double *dF);
// ek_material_eval_f32/_f64 on double data, converting for f32 (R and dF
// may be NULL). out is written when the call ran (its return >= 0: the
// count of elements outside the model's domain).
int ek_check_run_material(int f32, const ek_material *m, ek_material_op op, ek_isa isa, size_t n,
                          const double *F, const double *R, const double *dF, double *out,
                          int project);

// ---- Verdict ----
// PASS at or below half the budget, MARGINAL above half (reported, not a
// failure), FAIL above the budget or not a number.
typedef enum { EK_PASS = 0, EK_MARGINAL = 1, EK_FAIL = 2 } ek_verdict;
ek_verdict ek_check_verdict(double err, double budget);
const char *ek_verdict_name(ek_verdict v);
// Print "label: err=... budget=... ratio=... VERDICT" and return 1 on FAIL.
int ek_check_report(const char *label, double err, double budget);

#ifdef __cplusplus
}
#endif
#endif
