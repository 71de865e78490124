// ek-hash: one FNV-1a-64 hash of the output bytes of every kernel variant,
// so that a restructuring of the kernels (files, dispatch, out-of-line
// helpers) can be shown to keep every result's bits: run it on the tree
// before and after and diff the two outputs, which must be identical.
//
// A variant is (family, kernel/op, model, knob setting, strategy, ISA,
// precision, thread count). Each prints one line, in a fixed order:
//   <family>/<op>/<knobs...>/<isa>/<prec>/t<threads> <16-hex hash>
// An API error (rc < 0) prints "<name> rc=<rc>" instead of the hash; a
// positive return value (material: elements outside the domain) is printed
// after the hash as " rc=<rc>", so return values are compared too.
// "auto" in the ISA slot means the entry point takes no ISA (it follows
// EK_ISA or the best target); explicit ISAs are iterated over every target
// ek_isa_available reports, so EK_ISA changes only the "auto" lines.
//
// Only public headers (include/ek/) are used, and sim/cli.h for the command
// line as every ek program reads it, so the same source builds against the
// old and the new tree. Inputs come from a fixed-seed generator
// in this file: near-identity and general random matrices, stretched
// rotations, and the extremes (scale 1e-30 and 1e30, rank 0, 1 and 2,
// inverted, repeated singular values, a NaN in one lane); batch sizes are
// not multiples of a block and above the libraries' parallel thresholds so
// that the two-thread run really splits the work.
//
// Hashes are of raw bytes (NaN payloads and signed zeros included); AoSoA
// outputs are hashed whole, padding lanes included (the kernels evaluate
// them, include/ek/material.h), after the buffer is filled with a fixed
// byte so that unwritten bytes are deterministic too.
//
// FNV-1a: Fowler, Noll, Vo, http://www.isthe.com/chongo/tech/comp/fnv/
// (64-bit offset basis 0xcbf29ce484222325, prime 0x100000001b3).
// setenv, execv (POSIX).
#define _POSIX_C_SOURCE 200809L
#include <ek/cloth_force.h>
#include <ek/ek.h>
#include <ek/sim/sim.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "cli.h"
#include "omp_env.h"
#include <string.h>
#include <unistd.h>

// ---- Hash and output ------------------------------------------------------

#define FNV_OFFSET 0xcbf29ce484222325ull
#define FNV_PRIME 0x100000001b3ull

static uint64_t fnv(uint64_t h, const void *p, size_t bytes) {
  const unsigned char *c = p;
  for (size_t i = 0; i < bytes; i++) {
    h ^= c[i];
    h *= FNV_PRIME;
  }
  return h;
}

// Current ISA label, precision label and thread count: the name's suffix.
static const char *g_isa = "auto";
static const char *g_prec = "f64";
static int g_threads = 1;
static long g_lines = 0;

// Print "<name>/<isa>/<prec>/t<threads> <hash>" (or rc=).
static void out(int rc, uint64_t h, const char *fmt, ...) {
  char name[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(name, sizeof name, fmt, ap);
  va_end(ap);
  if (rc < 0)
    printf("%s/%s/%s/t%d rc=%d\n", name, g_isa, g_prec, g_threads, rc);
  else if (rc > 0)
    printf("%s/%s/%s/t%d %016llx rc=%d\n", name, g_isa, g_prec, g_threads, (unsigned long long)h,
           rc);
  else
    printf("%s/%s/%s/t%d %016llx\n", name, g_isa, g_prec, g_threads, (unsigned long long)h);
  g_lines++;
}

static void *xalloc(size_t bytes) {
  void *p = ek_alloc(bytes ? bytes : 64);
  if (!p) {
    fprintf(stderr, "ek-hash: out of memory (%zu bytes)\n", bytes);
    exit(2);
  }
  return p;
}

// Scratch output buffers, filled with a fixed byte before each call.
#define FILL 0xA5
static void *scratch(void *p, size_t bytes) {
  memset(p, FILL, bytes);
  return p;
}

// ---- Deterministic inputs -------------------------------------------------

// splitmix64 (Steele, Lea, Flood 2014), enough for test inputs.
static uint64_t g_rng = 0x0123456789abcdefull;
static uint64_t rng_next(void) {
  uint64_t z = (g_rng += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
// Uniform in [-1, 1).
static double urand(void) { return (double)(rng_next() >> 11) * 0x1.0p-52 - 1.0; }

static void mul3(const double *A, const double *B, double *C) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

// Rotation from a unit quaternion near (1, small * random) (small = 0:
// any rotation).
static void rotation(double small, double *R) {
  double q[4];
  double nrm = 0;
  for (int k = 0; k < 4; k++) {
    q[k] = small > 0 ? (k == 0 ? 1.0 : small * urand()) : urand();
    nrm += q[k] * q[k];
  }
  nrm = sqrt(nrm);
  if (nrm == 0)
    nrm = 1, q[0] = 1;
  for (int k = 0; k < 4; k++)
    q[k] /= nrm;
  double w = q[0], x = q[1], y = q[2], z = q[3];
  double M[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                 2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                 2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
  memcpy(R, M, sizeof M);
}

// n 3x3 matrices: a mix of near-identity, stretched rotations Q S
// (singular values in [0.5, 2]) and general random ones; then the extremes
// at fixed indices. Guess[i]: a rotation near the polar factor for the
// stretched rotations, any rotation otherwise (used as warm-polar guesses
// and corotated-linear R).
static void make_matrices(size_t n, double *A, double *guess) {
  for (size_t i = 0; i < n; i++) {
    double *a = A + 9 * i;
    if (i % 4 == 0) {
      for (int k = 0; k < 9; k++)
        a[k] = (k % 4 == 0) + 0.1 * urand();
      rotation(0.1, guess + 9 * i);
    } else if (i % 4 == 1) {
      double Q[9], P[9], S[9] = {0}, T[9], D[9];
      rotation(0, Q);
      rotation(0, P);
      for (int k = 0; k < 3; k++)
        S[4 * k] = 0.5 + 0.75 * (urand() + 1);
      // Q (P S P^T): a rotation times a symmetric stretch.
      mul3(P, S, T);
      double Pt[9] = {P[0], P[3], P[6], P[1], P[4], P[7], P[2], P[5], P[8]};
      mul3(T, Pt, D);
      mul3(Q, D, a);
      double dQ[9];
      rotation(0.05, dQ);
      mul3(dQ, Q, guess + 9 * i);
    } else {
      for (int k = 0; k < 9; k++)
        a[k] = 2 * urand();
      rotation(0, guess + 9 * i);
    }
  }
  // Extremes (tiny and huge scales, low ranks, identity), at fixed indices < n.
  for (int k = 0; k < 9; k++) {
    A[9 * 3 + k] *= 1e-30;
    A[9 * 7 + k] *= 1e30;
  }
  double u[3] = {0.3, -1.2, 0.7}, v[3] = {1.1, 0.4, -0.5}, w[3] = {-0.2, 0.9, 0.6};
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      A[9 * 11 + 3 * i + j] = u[i] * v[j];                           // rank 1
      A[9 * 23 + 3 * i + j] = u[i] * v[j] + w[i] * u[j];             // rank 2
      A[9 * 19 + 3 * i + j] = 0;                                     // rank 0
      A[9 * 29 + 3 * i + j] = i == j;                                // identity
      A[9 * 37 + 3 * i + j] = 1e30 * u[i] * v[j] + 1e-30 * (i == j); // huge rank 1
    }
  for (int k = 0; k < 3; k++) {
    A[9 * 13 + k] = -A[9 * 13 + k]; // inverted: first row of a near-identity negated
    A[9 * 33 + k] = -A[9 * 33 + k]; // inverted stretched rotation
  }
  double Q[9];
  rotation(0, Q);
  for (int k = 0; k < 9; k++)
    A[9 * 31 + k] = 2 * Q[k]; // repeated singular values
  A[9 * 17 + 4] = NAN;        // NaN in one lane
  A[9 * 41 + 2] = INFINITY;   // infinity in one lane
  A[9 * 43 + 0] = 1e-40;      // subnormal (f64) / zero (f32) entries
  // Warm-polar guesses that are not rotations (replaced by their
  // quaternion's rotation in the first iteration), a zero one, a NaN one,
  // and one 180 degrees off (a saddle).
  for (int k = 0; k < 9; k++) {
    guess[9 * 5 + k] *= 2;
    guess[9 * 9 + k] = 0;
    guess[9 * 21 + k] = A[9 * 21 + k];
  }
  guess[9 * 25 + 3] = NAN;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      guess[9 * 45 + 3 * i + j] =
          (i == j) * (i == 0 ? 1 : -1) * A[9 * 45 + 0] / fabs(A[9 * 45 + 0]);
}

typedef struct {
  size_t n;
  double *d;
  float *f;
} arr;

static arr arr_from(size_t n, const double *src) {
  arr a = {n, xalloc(n * sizeof(double)), xalloc(n * sizeof(float))};
  for (size_t i = 0; i < n; i++)
    a.d[i] = src[i], a.f[i] = (float)src[i];
  return a;
}
static const void *P(const arr *a, int f64) {
  return f64 ? (const void *)a->d : (const void *)a->f;
}

// AoSoA packed copy of an AoS array (n items x nplanes).
typedef struct {
  size_t nblocks;
  double *d;
  float *f;
} packed;
static packed pack(const arr *a, size_t n, int nplanes) {
  packed p = {ek_aosoa_blocks_f64(n), ek_aosoa_alloc_f64(n, nplanes),
              ek_aosoa_alloc_f32(n, nplanes)};
  if (!p.d || !p.f || ek_aosoa_pack_f64(n, nplanes, a->d, p.d) ||
      ek_aosoa_pack_f32(n, nplanes, a->f, p.f)) {
    fprintf(stderr, "ek-hash: pack failed\n");
    exit(2);
  }
  return p;
}

// ---- Sizes ----------------------------------------------------------------

// Above EK_MATERIAL_PARALLEL_MIN (4096) and not a multiple of a block.
#define NMAT 4133

static arr gA, gG, gdF;                  // matrices, guesses/R, dF
static packed pA, pG, pdF;               // their AoSoA forms
static size_t NPAD;                      // items in the padded AoSoA (f32 blocks * 16)
static unsigned char *o1, *o2, *o3, *o4; // scratch outputs
static size_t OBYTES;

static void setup_matrices(void) {
  double *A = malloc(NMAT * 9 * sizeof(double)), *G = malloc(NMAT * 9 * sizeof(double)),
         *dF = malloc(NMAT * 9 * sizeof(double));
  make_matrices(NMAT, A, G);
  for (size_t i = 0; i < NMAT * 9; i++)
    dF[i] = urand();
  gA = arr_from(NMAT * 9, A);
  gG = arr_from(NMAT * 9, G);
  gdF = arr_from(NMAT * 9, dF);
  free(A), free(G), free(dF);
  pA = pack(&gA, NMAT, 9);
  pG = pack(&gG, NMAT, 9);
  pdF = pack(&gdF, NMAT, 9);
  NPAD = ek_aosoa_blocks_f32(NMAT) * EK_LANES_F32;
  OBYTES = NPAD * 81 * sizeof(double);
  o1 = xalloc(OBYTES), o2 = xalloc(OBYTES), o3 = xalloc(OBYTES), o4 = xalloc(OBYTES);
}

static const void *PP(const packed *p, int f64) {
  return f64 ? (const void *)p->d : (const void *)p->f;
}
static size_t NB(int f64) { return f64 ? ek_aosoa_blocks_f64(NMAT) : ek_aosoa_blocks_f32(NMAT); }

// ---- svd3 and SVD polar ---------------------------------------------------

static int svd_call(int f64, int aosoa, const void *A, void *U, void *S, void *V,
                    const ek_svd3_opts *o) {
  if (aosoa)
    return f64 ? ek_svd3_aosoa_f64(NB(1), A, U, S, V, o) : ek_svd3_aosoa_f32(NB(0), A, U, S, V, o);
  return f64 ? ek_svd3_f64(NMAT, A, U, S, V, o) : ek_svd3_f32(NMAT, A, U, S, V, o);
}
static int polar_call(int f64, int aosoa, const void *A, void *R, void *S, const ek_svd3_opts *o) {
  if (aosoa)
    return f64 ? ek_polar3_aosoa_f64(NB(1), A, R, S, o) : ek_polar3_aosoa_f32(NB(0), A, R, S, o);
  return f64 ? ek_polar3_f64(NMAT, A, R, S, o) : ek_polar3_f32(NMAT, A, R, S, o);
}

// Bytes of a 9-plane (or 3-plane) output in the layout.
static size_t obytes(int f64, int aosoa, int planes) {
  size_t items = aosoa ? NB(f64) * (f64 ? EK_LANES_F64 : EK_LANES_F32) : NMAT;
  return items * (size_t)planes * (f64 ? 8 : 4);
}

static void hash_svd(int f64, int aosoa, const char *tag, const ek_svd3_opts *o, int want_u,
                     int want_v) {
  const void *A = aosoa ? PP(&pA, f64) : P(&gA, f64);
  size_t b9 = obytes(f64, aosoa, 9), b3 = obytes(f64, aosoa, 3);
  void *U = want_u ? scratch(o1, b9) : NULL, *S = scratch(o2, b3),
       *V = want_v ? scratch(o3, b9) : NULL;
  int rc = svd_call(f64, aosoa, A, U, S, V, o);
  uint64_t h = FNV_OFFSET;
  if (U)
    h = fnv(h, U, b9);
  h = fnv(h, S, b3);
  if (V)
    h = fnv(h, V, b9);
  out(rc, h, "svd3/%s/%s", aosoa ? "aosoa" : "aos", tag);
}

static void hash_polar(int f64, int aosoa, const char *tag, const ek_svd3_opts *o, int want_s) {
  const void *A = aosoa ? PP(&pA, f64) : P(&gA, f64);
  size_t b9 = obytes(f64, aosoa, 9);
  void *R = scratch(o1, b9), *S = want_s ? scratch(o2, b9) : NULL;
  int rc = polar_call(f64, aosoa, A, R, S, o);
  uint64_t h = fnv(FNV_OFFSET, R, b9);
  if (S)
    h = fnv(h, S, b9);
  out(rc, h, "polar3/%s/%s%s", aosoa ? "aosoa" : "aos", tag, want_s ? "" : ",R_only");
}

static void run_svd(ek_isa isa, int f64) {
  static const int sweeps[] = {0, 1, 2, 4, 6, 8};
  static const int rsqrt[] = {0, 1, -1};
  static const int refine[] = {0, EK_SVD3_REFINE_NONE, 1, 2, 3};
  char tag[96];
  for (int aosoa = 0; aosoa < 2; aosoa++) {
    for (size_t a = 0; a < sizeof sweeps / sizeof *sweeps; a++)
      for (size_t b = 0; b < sizeof rsqrt / sizeof *rsqrt; b++)
        for (size_t c = 0; c < sizeof refine / sizeof *refine; c++) {
          ek_svd3_opts o = {
              .sweeps = sweeps[a], .exact_rsqrt = rsqrt[b], .isa = isa, .refine = refine[c]};
          snprintf(tag, sizeof tag, "sweeps=%d,rsqrt=%d,refine=%d", sweeps[a], rsqrt[b], refine[c]);
          hash_svd(f64, aosoa, tag, &o, 1, 1);
        }
    ek_svd3_opts d = {.isa = isa};
    hash_svd(f64, aosoa, "default,S_only", &d, 0, 0);
    hash_svd(f64, aosoa, "default,US", &d, 1, 0);
    hash_svd(f64, aosoa, "default,SV", &d, 0, 1);
    ek_svd3_opts bad1 = {.sweeps = EK_SVD3_MAX_SWEEPS + 1, .isa = isa};
    hash_svd(f64, aosoa, "bad_sweeps", &bad1, 1, 1);
    ek_svd3_opts bad2 = {.refine = EK_SVD3_MAX_REFINE + 1, .isa = isa};
    hash_svd(f64, aosoa, "bad_refine", &bad2, 1, 1);
    // SVD polar: default, McAdams as published, the most accurate.
    ek_svd3_opts mca = {.sweeps = 4, .exact_rsqrt = -1, .refine = EK_SVD3_REFINE_NONE, .isa = isa};
    ek_svd3_opts best = {.sweeps = 8, .exact_rsqrt = 1, .refine = 3, .isa = isa};
    for (int s = 1; s >= 0; s--) {
      hash_polar(f64, aosoa, "default", &d, s);
      hash_polar(f64, aosoa, "sweeps=4,rsqrt=-1,refine=-1", &mca, s);
      hash_polar(f64, aosoa, "sweeps=8,rsqrt=1,refine=3", &best, s);
    }
  }
}

// The entry points without an ISA option, NULL opts.
static void run_svd_auto(int f64) {
  for (int aosoa = 0; aosoa < 2; aosoa++) {
    hash_svd(f64, aosoa, "null_opts", NULL, 1, 1);
    hash_polar(f64, aosoa, "null_opts", NULL, 1);
  }
}

// ---- AoSoA packing (batch.h) ---------------------------------------------

// Pack and unpack of n items of 1, 3, 9 and 64 planes (tails padded:
// identity for 9 planes, zero otherwise).
static void run_batch(int f64) {
  static const int planes[] = {1, 3, 9, 64};
  for (size_t k = 0; k < sizeof planes / sizeof *planes; k++) {
    int np = planes[k];
    size_t n = NMAT * 9 / (size_t)np; // items whose scalars fit in gA
    size_t sz = f64 ? ek_aosoa_size_f64(n, np) : ek_aosoa_size_f32(n, np);
    size_t pb = sz * (f64 ? 8 : 4), ab = n * (size_t)np * (f64 ? 8 : 4);
    void *soa = scratch(o1, pb), *aos = scratch(o2, ab);
    int rc = f64 ? ek_aosoa_pack_f64(n, np, gA.d, soa) : ek_aosoa_pack_f32(n, np, gA.f, soa);
    uint64_t h = fnv(fnv(FNV_OFFSET, &sz, sizeof sz), soa, pb);
    out(rc, h, "batch/pack/planes=%d", np);
    rc = f64 ? ek_aosoa_unpack_f64(n, np, soa, aos) : ek_aosoa_unpack_f32(n, np, soa, aos);
    out(rc, fnv(FNV_OFFSET, aos, ab), "batch/unpack/planes=%d", np);
  }
}

// ---- Warm-started polar ---------------------------------------------------

static void run_polar_warm(ek_isa isa, int f64) {
  static const int iters[] = {
      0, 1, 2, 3, 4, 8, EK_POLAR_WARM_MAX_ITERATIONS, EK_POLAR_WARM_MAX_ITERATIONS + 1};
  for (int aosoa = 0; aosoa < 2; aosoa++)
    for (size_t k = 0; k < sizeof iters / sizeof *iters; k++) {
      ek_polar_warm_opts o = {.iterations = iters[k], .isa = isa};
      size_t b9 = obytes(f64, aosoa, 9);
      // The guess is read from R: copy it in.
      memcpy(o1, aosoa ? PP(&pG, f64) : P(&gG, f64), b9);
      const void *A = aosoa ? PP(&pA, f64) : P(&gA, f64);
      int rc;
      if (aosoa)
        rc = f64 ? ek_polar3_warm_aosoa_f64(NB(1), A, (double *)o1, &o)
                 : ek_polar3_warm_aosoa_f32(NB(0), A, (float *)o1, &o);
      else
        rc = f64 ? ek_polar3_warm_f64(NMAT, A, (double *)o1, &o)
                 : ek_polar3_warm_f32(NMAT, A, (float *)o1, &o);
      out(rc, fnv(FNV_OFFSET, o1, b9), "polar_warm/%s/iterations=%d", aosoa ? "aosoa" : "aos",
          iters[k]);
    }
}

// ---- Materials ------------------------------------------------------------

static const char *op_name[] = {"energy", "P", "dP", "hessian"};
static int op_planes(int op) { return op == EK_MAT_ENERGY ? 1 : op == EK_MAT_HESSIAN ? 81 : 9; }

static ek_material material(int model, double clamp) {
  // mu, lambda of a rubber-like solid, lambda > 0 (stable neo-Hookean
  // needs lambda != 0).
  ek_material m = {(ek_model)model, 1.5, 4.0, clamp};
  return m;
}

static void run_material(ek_isa isa, int f64) {
  static const double clamps[] = {0.0, 0.25};
  for (int model = 0; model < EK_MODEL_COUNT; model++)
    for (int c = 0; c < 2; c++) {
      ek_material m = material(model, clamps[c]);
      for (int op = EK_MAT_ENERGY; op <= EK_MAT_HESSIAN; op++)
        for (int project = 0; project < (op >= EK_MAT_PK1_DIFF ? 2 : 1); project++)
          for (int aosoa = 0; aosoa < 2; aosoa++) {
            size_t b = obytes(f64, aosoa, op_planes(op));
            void *o = scratch(o1, b);
            int rc;
            if (aosoa)
              rc = f64 ? ek_material_eval_aosoa_f64(&m, op, isa, NB(1), pA.d, pG.d, pdF.d, o,
                                                    project)
                       : ek_material_eval_aosoa_f32(&m, op, isa, NB(0), pA.f, pG.f, pdF.f, o,
                                                    project);
            else
              rc = f64 ? ek_material_eval_f64(&m, op, isa, NMAT, gA.d, gG.d, gdF.d, o, project)
                       : ek_material_eval_f32(&m, op, isa, NMAT, gA.f, gG.f, gdF.f, o, project);
            out(rc, fnv(FNV_OFFSET, o, b), "material/%s/%s/clamp=%g,project=%d/%s", op_name[op],
                ek_model_name((ek_model)model), clamps[c], project, aosoa ? "aosoa" : "aos");
          }
    }
}

// The entry points without an ISA option, and the refused materials.
static void run_material_auto(int f64) {
  static const double clamps[] = {0.0, 0.25};
  for (int model = 0; model < EK_MODEL_COUNT; model++)
    for (int c = 0; c < 2; c++) {
      ek_material m = material(model, clamps[c]);
      const char *mn = ek_model_name((ek_model)model);
      size_t b9 = obytes(f64, 0, 9), b81 = obytes(f64, 0, 81), b9p = obytes(f64, 1, 9);
      int rc;
      if (f64) {
        rc = ek_energy_f64(&m, NMAT, gA.d, gG.d, scratch(o1, NMAT * 8));
        out(rc, fnv(FNV_OFFSET, o1, NMAT * 8), "material/energy/%s/clamp=%g/aos_entry", mn,
            clamps[c]);
      }
      rc = f64 ? ek_pk1_f64(&m, NMAT, gA.d, gG.d, scratch(o1, b9))
               : ek_pk1_f32(&m, NMAT, gA.f, gG.f, scratch(o1, b9));
      out(rc, fnv(FNV_OFFSET, o1, b9), "material/P/%s/clamp=%g/aos_entry", mn, clamps[c]);
      rc = f64 ? ek_pk1_aosoa_f64(&m, NB(1), pA.d, pG.d, scratch(o1, b9p))
               : ek_pk1_aosoa_f32(&m, NB(0), pA.f, pG.f, scratch(o1, b9p));
      out(rc, fnv(FNV_OFFSET, o1, b9p), "material/P/%s/clamp=%g/aosoa_entry", mn, clamps[c]);
      for (int project = 0; project < 2; project++) {
        rc = f64 ? ek_pk1_diff_f64(&m, NMAT, gA.d, gG.d, gdF.d, scratch(o1, b9), project)
                 : ek_pk1_diff_f32(&m, NMAT, gA.f, gG.f, gdF.f, scratch(o1, b9), project);
        out(rc, fnv(FNV_OFFSET, o1, b9), "material/dP/%s/clamp=%g,project=%d/aos_entry", mn,
            clamps[c], project);
        rc = f64 ? ek_pk1_diff_aosoa_f64(&m, NB(1), pA.d, pG.d, pdF.d, scratch(o1, b9p), project)
                 : ek_pk1_diff_aosoa_f32(&m, NB(0), pA.f, pG.f, pdF.f, scratch(o1, b9p), project);
        out(rc, fnv(FNV_OFFSET, o1, b9p), "material/dP/%s/clamp=%g,project=%d/aosoa_entry", mn,
            clamps[c], project);
        rc = f64 ? ek_pk1_hessian_f64(&m, NMAT, gA.d, gG.d, scratch(o1, b81), project)
                 : ek_pk1_hessian_f32(&m, NMAT, gA.f, gG.f, scratch(o1, b81), project);
        out(rc, fnv(FNV_OFFSET, o1, b81), "material/hessian/%s/clamp=%g,project=%d/aos_entry", mn,
            clamps[c], project);
      }
    }
  // Refused materials: the return codes.
  ek_material bad[] = {
      {EK_MODEL_NEO_HOOKEAN, 0.0, 1.0, 0},     {EK_MODEL_NEO_HOOKEAN, 1.0, -1.0, 0},
      {EK_MODEL_NEO_HOOKEAN, 1.0, 1.0, -0.5},  {EK_MODEL_STABLE_NEO_HOOKEAN, 1.0, 0.0, 0},
      {(ek_model)EK_MODEL_COUNT, 1.0, 1.0, 0}, {EK_MODEL_ARAP, NAN, 1.0, 0}};
  for (size_t k = 0; k < sizeof bad / sizeof *bad; k++) {
    size_t b9 = obytes(f64, 0, 9);
    int rc = f64 ? ek_pk1_f64(&bad[k], NMAT, gA.d, gG.d, scratch(o1, b9))
                 : ek_pk1_f32(&bad[k], NMAT, gA.f, gG.f, scratch(o1, b9));
    out(rc, fnv(FNV_OFFSET, o1, b9), "material/P/bad%zu/aos_entry", k);
  }
  ek_material cl = {EK_MODEL_COROTATED_LINEAR, 1.5, 4.0, 0};
  size_t b9 = obytes(f64, 0, 9);
  int rc = f64 ? ek_pk1_f64(&cl, NMAT, gA.d, NULL, scratch(o1, b9))
               : ek_pk1_f32(&cl, NMAT, gA.f, NULL, scratch(o1, b9));
  out(rc, fnv(FNV_OFFSET, o1, b9), "material/P/corot_linear_no_R/aos_entry");
}

// ---- Tet mesh: FVM forces, Hessian, XPBD ----------------------------------

// A jittered box of 10 x 9 x 8 cubes (4320 tets: above the FVM's parallel
// thresholds) and two deformed states: "mild" (an affine map plus noise, no
// inverted tet) and "inv" (the same with a few vertices pushed through
// their neighbours: inverted and flat tets).
#define BOX_NX 10
#define BOX_NY 9
#define BOX_NZ 8
static ek_mesh *gmesh;
static const ek_tets *gel;
static size_t gnv, gnt;
static arr gX, gx[2], gp, gv; // rest, states, Hessian direction, velocities
static double *gRtet[2];      // per-tet rotations (caller order) per state
static ek_tet_state *gRstate[2];
static const char *state_name[] = {"mild", "inv"};

static void setup_mesh(void) {
  double L[3] = {1.0, 0.9, 0.8};
  ek_mesh *box = ek_mesh_box(BOX_NX, BOX_NY, BOX_NZ, L[0], L[1], L[2]);
  if (!box) {
    fprintf(stderr, "ek-hash: ek_mesh_box: %s\n", ek_last_error());
    exit(2);
  }
  gnv = ek_mesh_nverts(box), gnt = ek_mesh_ntets(box);
  size_t n3 = 3 * gnv;
  double *X = malloc(n3 * sizeof(double)), *x = malloc(n3 * sizeof(double)),
         *x2 = malloc(n3 * sizeof(double)), *p = malloc(n3 * sizeof(double)),
         *v = malloc(n3 * sizeof(double));
  int32_t *T = malloc(gnt * 4 * sizeof(int32_t));
  memcpy(T, ek_mesh_tets(box), gnt * 4 * sizeof(int32_t));
  const double *X0 = ek_mesh_rest_positions(box);
  double cell = 0.1;
  for (size_t i = 0; i < n3; i++) {
    double xi = X0[i], len = L[i % 3];
    int interior = xi > 1e-9 && xi < len - 1e-9;
    X[i] = xi + (interior ? 0.1 * cell * urand() : 0);
  }
  ek_mesh_destroy(box);
  gmesh = ek_mesh_create(gnv, X, gnt, T);
  if (!gmesh) {
    fprintf(stderr, "ek-hash: ek_mesh_create: %s\n", ek_last_error());
    exit(2);
  }
  gel = ek_mesh_elements(gmesh);
  double Q[9], G[9], A[9];
  rotation(0, Q);
  for (int k = 0; k < 9; k++)
    G[k] = (k % 4 == 0) + 0.15 * urand();
  mul3(Q, G, A);
  for (size_t vtx = 0; vtx < gnv; vtx++)
    for (int i = 0; i < 3; i++) {
      double s = 0;
      for (int k = 0; k < 3; k++)
        s += A[3 * i + k] * X[3 * vtx + k];
      x[3 * vtx + i] = s + 0.05 * cell * urand();
      p[3 * vtx + i] = urand();
      v[3 * vtx + i] = urand();
    }
  memcpy(x2, x, n3 * sizeof(double));
  // Push a few interior vertices by 1.5 cells: their tets invert.
  size_t push[] = {gnv / 3, gnv / 2, (2 * gnv) / 3 + 5};
  for (size_t k = 0; k < 3; k++)
    for (int i = 0; i < 3; i++)
      x2[3 * push[k] + i] += 1.5 * cell * (i == (int)k ? 1 : -0.5);
  gX = arr_from(n3, X);
  gx[0] = arr_from(n3, x);
  gx[1] = arr_from(n3, x2);
  gp = arr_from(n3, p);
  gv = arr_from(n3, v);
  // Per-tet rotations: the SVD polar of each tet's F (scalar, default
  // knobs, so the inputs do not depend on the ISA under test), as a
  // corotated-linear loop would refresh them.
  double *F = malloc(gnt * 9 * sizeof(double));
  ek_svd3_opts so = {.isa = EK_ISA_SCALAR};
  for (int s = 0; s < 2; s++) {
    gRtet[s] = malloc(gnt * 9 * sizeof(double));
    if (ek_mesh_deformation_gradients_f64(gmesh, s ? x2 : x, F) ||
        ek_polar3_f64(gnt, F, gRtet[s], NULL, &so)) {
      fprintf(stderr, "ek-hash: setup rotations: %s\n", ek_last_error());
      exit(2);
    }
    gRstate[s] = ek_tet_state_create(gel, 9, 1);
    if (!gRstate[s] || ek_tet_state_set_f64(gRstate[s], gRtet[s])) {
      fprintf(stderr, "ek-hash: setup R state: %s\n", ek_last_error());
      exit(2);
    }
  }
  free(F), free(X), free(x), free(x2), free(p), free(v), free(T);
}

// One force evaluation; hashes f (and the polar state and per-tet outputs
// when given).
static void hash_fvm(int f64, int s, const ek_material *m, ek_fvm_opts *o, const char *tag,
                     int tet_form) {
  size_t fb = 3 * gnv * (f64 ? 8 : 4);
  void *f = scratch(o1, fb);
  ek_tet_state *ps = NULL;
  if (o->polar_state) {
    // Seeded with the SVD polar of this state's F (the documented start).
    ps = ek_tet_state_create(gel, 9, f64);
    ek_tet_state_set_f64(ps, gRtet[s]);
    o->polar_state = ps;
  }
  int rc;
  if (tet_form)
    rc = f64 ? ek_fvm_tet_forces_ex_f64(gel, m, gx[s].d, f, o)
             : ek_fvm_tet_forces_ex_f32(gel, m, gx[s].f, f, o);
  else
    rc = f64 ? ek_mesh_fvm_forces_ex_f64(gmesh, m, gx[s].d, f, o)
             : ek_mesh_fvm_forces_ex_f32(gmesh, m, gx[s].f, f, o);
  uint64_t h = fnv(FNV_OFFSET, f, fb);
  if (ps) {
    double *st = (double *)scratch(o2, gnt * 9 * sizeof(double));
    ek_tet_state_get_f64(ps, st);
    h = fnv(h, st, gnt * 9 * sizeof(double));
    ek_tet_state_destroy(ps);
    o->polar_state = (ek_tet_state *)1;
  }
  if (o->J)
    h = fnv(h, o->J, gnt * 8), h = fnv(h, o->sigma_min, gnt * 8), h = fnv(h, o->psi, gnt * 8);
  out(rc, h, "fvm/forces/%s/%s/clamp=%g/%s/%s", ek_model_name(m->model), state_name[s], m->clamp,
      ek_scatter_name(o->scatter), tag);
}

static int uses_svd(const ek_material *m) {
  ek_model_needs n = ek_model_need(m->model, m->clamp);
  return n == EK_NEEDS_POLAR || n == EK_NEEDS_SVD;
}

static void run_fvm(ek_isa isa, int f64) {
  static const double clamps[] = {0.0, 0.3};
  for (int s = 0; s < 2; s++)
    for (int model = 0; model < EK_MODEL_COUNT; model++)
      for (int c = 0; c < 2; c++) {
        ek_material m = material(model, clamps[c]);
        int corot = ek_model_need(model, 0) == EK_NEEDS_R_INPUT;
        int warm = ek_model_need(m.model, m.clamp) == EK_NEEDS_POLAR;
        for (int sc = EK_SCATTER_AUTO; sc < EK_SCATTER_COUNT; sc++) {
          // Atomic sums depend on the schedule: reproducible on one thread
          // only.
          if (sc == EK_SCATTER_ATOMIC && g_threads > 1)
            continue;
          ek_fvm_opts o = {.scatter = (ek_scatter)sc, .isa = isa};
          if (corot)
            o.R = gRtet[s];
          hash_fvm(f64, s, &m, &o, corot ? "R" : "plain", 0);
          if (corot) {
            ek_fvm_opts r = {.scatter = (ek_scatter)sc, .isa = isa, .R_state = gRstate[s]};
            if (f64)
              hash_fvm(f64, s, &m, &r, "R_state", 0);
          }
          if (warm) {
            ek_fvm_opts w = o;
            w.polar_state = (ek_tet_state *)1;
            hash_fvm(f64, s, &m, &w, "warm_polar", 0);
          }
        }
        // Knobs, with the default scatter.
        ek_fvm_opts base = {.isa = isa};
        if (corot)
          base.R = gRtet[s];
        if (uses_svd(&m)) {
          ek_fvm_opts k = base;
          k.svd_sweeps = 4, k.svd_exact_rsqrt = -1, k.svd_refine = EK_SVD3_REFINE_NONE;
          hash_fvm(f64, s, &m, &k, "sweeps=4,rsqrt=-1,refine=-1", 0);
          k.svd_sweeps = 8, k.svd_exact_rsqrt = 1, k.svd_refine = 3;
          hash_fvm(f64, s, &m, &k, "sweeps=8,rsqrt=1,refine=3", 0);
        }
        if (warm)
          for (int it = 1; it <= 3; it += 2) {
            ek_fvm_opts w = base;
            w.polar_state = (ek_tet_state *)1;
            w.polar_iterations = it;
            char tag[64];
            snprintf(tag, sizeof tag, "warm_polar,iterations=%d", it);
            hash_fvm(f64, s, &m, &w, tag, 0);
          }
        {
          ek_fvm_opts k = base;
          k.J = (double *)scratch(o3, gnt * 8);
          k.sigma_min = (double *)scratch(o3 + gnt * 8, gnt * 8);
          k.psi = (double *)scratch(o3 + 2 * gnt * 8, gnt * 8);
          hash_fvm(f64, s, &m, &k, "fields", 0);
          ek_fvm_phase_times pt;
          ek_fvm_opts t = base;
          t.phase_times = &pt;
          hash_fvm(f64, s, &m, &t, "phase_times", 0);
          hash_fvm(f64, s, &m, &base, "tet_form", 1);
        }
      }
}

// Entry points without an ISA option: forces, energies, F.
static void run_fvm_auto(int f64) {
  static const double clamps[] = {0.0, 0.3};
  for (int s = 0; s < 2; s++)
    for (int model = 0; model < EK_MODEL_COUNT; model++)
      for (int c = 0; c < 2; c++) {
        ek_material m = material(model, clamps[c]);
        const char *mn = ek_model_name(m.model);
        size_t fb = 3 * gnv * (f64 ? 8 : 4);
        int rc = f64 ? ek_mesh_fvm_forces_f64(gmesh, &m, gx[s].d, scratch(o1, fb))
                     : ek_mesh_fvm_forces_f32(gmesh, &m, gx[s].f, scratch(o1, fb));
        out(rc, fnv(FNV_OFFSET, o1, fb), "fvm/forces/%s/%s/clamp=%g/entry", mn, state_name[s],
            clamps[c]);
        if (f64) {
          const double *R = ek_model_need(m.model, 0) == EK_NEEDS_R_INPUT ? gRtet[s] : NULL;
          double E[3] = {ek_mesh_fvm_energy_f64(gmesh, &m, gx[s].d),
                         ek_mesh_fvm_energy_ex_f64(gmesh, &m, gx[s].d, R),
                         ek_fvm_tet_energy_f64(gel, &m, gx[s].d, R)};
          out(0, fnv(FNV_OFFSET, E, sizeof E), "fvm/energy/%s/%s/clamp=%g/entry", mn, state_name[s],
              clamps[c]);
        }
      }
  if (f64)
    for (int s = 0; s < 2; s++) {
      int rc = ek_mesh_deformation_gradients_f64(gmesh, gx[s].d, scratch(o1, gnt * 72));
      out(rc, fnv(FNV_OFFSET, o1, gnt * 72), "fvm/F/%s/mesh", state_name[s]);
      rc = ek_fvm_tet_deformation_gradients_f64(gel, gx[s].d, scratch(o1, gnt * 72));
      out(rc, fnv(FNV_OFFSET, o1, gnt * 72), "fvm/F/%s/tets", state_name[s]);
    }
}

// Matrix-free Hessian (hessian.h): per model, clamp, projection, scatter
// and cache precision: the gradient pass (grad and E), one product, the
// diagonal blocks. prec32: the cache and product precision (the "prec"
// slot of the name); the gradient is double either way.
static void hash_hessian(int s, const ek_material *m, ek_projection pr, ek_scatter sc, ek_isa isa,
                         int prec32, const char *tag) {
  ek_fvm_hessian_opts o = {
      .scatter = sc, .isa = isa, .projection = pr, .precision = prec32 ? 32 : 64};
  if (!strcmp(tag, "mca"))
    o.svd_sweeps = 4, o.svd_exact_rsqrt = -1, o.svd_refine = EK_SVD3_REFINE_NONE;
  const char *mn = ek_model_name(m->model);
  char base[256];
  snprintf(base, sizeof base, "hessian/%%s/%s/%s/clamp=%g,projection=%s/%s/%s", mn, state_name[s],
           m->clamp, ek_projection_name(pr), ek_scatter_name(sc), tag);
  ek_fvm_hessian *h = ek_fvm_hessian_create(gel, m, &o);
  if (!h) {
    out(EK_EINVAL, 0, base, "create");
    return;
  }
  size_t n3 = 3 * gnv;
  double *g = (double *)scratch(o1, n3 * 8), E = 0;
  const ek_tet_state *Rs = ek_model_need(m->model, 0) == EK_NEEDS_R_INPUT ? gRstate[s] : NULL;
  int rc = ek_fvm_hessian_gradient_f64(h, gx[s].d, Rs, g, &E, 1);
  uint64_t hh = fnv(fnv(FNV_OFFSET, g, n3 * 8), &E, sizeof E);
  size_t cb = ek_fvm_hessian_cache_bytes(h);
  int cp = ek_fvm_hessian_cache_planes(h);
  hh = fnv(fnv(hh, &cb, sizeof cb), &cp, sizeof cp);
  out(rc, hh, base, "gradient");
  size_t yb = n3 * (prec32 ? 4 : 8);
  void *y = scratch(o2, yb);
  rc = prec32 ? ek_fvm_hessian_apply_f32(h, gp.f, y) : ek_fvm_hessian_apply_f64(h, gp.d, y);
  out(rc, fnv(FNV_OFFSET, y, yb), base, "apply");
  double *B = (double *)scratch(o3, gnv * 6 * 8);
  rc = ek_fvm_hessian_diagonal_f64(h, B);
  out(rc, fnv(FNV_OFFSET, B, gnv * 6 * 8), base, "diagonal");
  // The assembled K (ek_fvm_hessian_assemble): pattern and values.
  ek_csr_pattern pat;
  rc = ek_fvm_hessian_pattern(h, &pat);
  double *K = rc == 0 ? malloc(pat.nnz * sizeof(double)) : NULL;
  if (rc == 0)
    rc = K ? ek_fvm_hessian_assemble(h, K) : EK_ENOMEM;
  hh = rc == 0 ? fnv(fnv(fnv(FNV_OFFSET, pat.row_ptr, (pat.nrows + 1) * 4), pat.col, pat.nnz * 4),
                     K, pat.nnz * 8)
               : 0;
  out(rc, hh, base, "assembled");
  free(K);
  // K's upper block triangle (ek_fvm_hessian_assemble_upper_*): pattern and
  // values in the cache's precision.
  ek_bsr_pattern up;
  rc = ek_fvm_hessian_pattern_upper(h, &up);
  const size_t ub = rc == 0 ? 9 * up.nblocks * (prec32 ? 4 : 8) : 0;
  void *U = rc == 0 ? malloc(ub ? ub : 1) : NULL;
  if (rc == 0)
    rc = !U       ? EK_ENOMEM
         : prec32 ? ek_fvm_hessian_assemble_upper_f32(h, U)
                  : ek_fvm_hessian_assemble_upper_f64(h, U);
  hh = rc == 0
           ? fnv(fnv(fnv(FNV_OFFSET, up.bptr, (up.nbrows + 1) * 4), up.bcol, up.nblocks * 4), U, ub)
           : 0;
  out(rc, hh, base, "assembled_upper");
  free(U);
  ek_fvm_hessian_destroy(h);
}

static void run_hessian(ek_isa isa, int prec32) {
  static const double clamps[] = {0.0, 0.3};
  for (int s = 0; s < 2; s++)
    for (int model = 0; model < EK_MODEL_COUNT; model++)
      for (int c = 0; c < 2; c++) {
        ek_material m = material(model, clamps[c]);
        for (int pr = 0; pr < EK_PROJECT_COUNT; pr++)
          hash_hessian(s, &m, (ek_projection)pr, EK_SCATTER_AUTO, isa, prec32, "plain");
        for (int sc = EK_SCATTER_COLORED; sc < EK_SCATTER_COUNT; sc++)
          if (sc != EK_SCATTER_ATOMIC || g_threads == 1)
            hash_hessian(s, &m, EK_PROJECT_CLAMP, (ek_scatter)sc, isa, prec32, "plain");
        if (uses_svd(&m))
          hash_hessian(s, &m, EK_PROJECT_CLAMP, EK_SCATTER_AUTO, isa, prec32, "mca");
      }
}

// One model's XPBD rows (run_xpbd below).
static void run_xpbd_model(ek_isa isa, int f64, int snh) {
  ek_material m = {snh ? EK_MODEL_STABLE_NEO_HOOKEAN : EK_XPBD_MODEL, 1.5e3, 4.0e3, 0};
  double young = m.mu * (3 * m.lambda + 2 * m.mu) / (m.lambda + m.mu);
  const double *lv = ek_mesh_lumped_volume(gmesh);
  size_t n3 = 3 * gnv;
  double *mass = malloc(gnv * sizeof(double)), *w = malloc(gnv * sizeof(double));
  for (size_t i = 0; i < gnv; i++) {
    mass[i] = 1000 * lv[i];
    w[i] = gX.d[3 * i] < 1e-9 ? 0 : 1 / mass[i]; // the x = 0 face pinned
  }
  for (int e = 0; e < EK_XPBD_ELEMENTS_COUNT; e++)
    for (int so = 0; so < EK_XPBD_SOLVER_COUNT; so++) {
      ek_xpbd_opts o = {(ek_xpbd_elements)e, (ek_xpbd_solver)so, isa, f64 ? 64 : 32};
      char base[128];
      snprintf(base, sizeof base, "%s/%%s/%s/%s", snh ? "xpbd_snh" : "xpbd",
               ek_xpbd_elements_name(o.elements), ek_xpbd_solver_name(o.solver));
      ek_xpbd *xp = ek_xpbd_create(gel, &m, young, mass, &o);
      if (!xp) {
        out(EK_EINVAL, 0, base, "create");
        continue;
      }
      // Structure: counts, order, members and b of every constraint.
      size_t nc = ek_xpbd_count(xp);
      int info[2] = {ek_xpbd_ncolors(xp), ek_xpbd_max_members(xp)};
      uint64_t h = fnv(fnv(FNV_OFFSET, &nc, sizeof nc), info, sizeof info);
      int32_t *ord = malloc(nc * sizeof(int32_t));
      int rc = ek_xpbd_order(xp, ord);
      h = fnv(h, ord, nc * sizeof(int32_t));
      int32_t mem[64];
      double b[3 * 64];
      for (size_t j = 0; j < nc; j++) {
        int K = ek_xpbd_members(xp, j, NULL, NULL);
        if (K > 0 && K <= 64) {
          ek_xpbd_members(xp, j, mem, b);
          h = fnv(fnv(h, mem, K * sizeof(int32_t)), b, 3 * (K - 1) * sizeof(double));
        } else
          h = fnv(h, &K, sizeof K);
      }
      free(ord);
      out(rc, h, base, "structure");
      double *lam = malloc(nc * sizeof(double));
      for (int based = 0; based < 2; based++) {
        rc = ek_xpbd_set_weights(xp, w);
        if (!rc)
          rc = ek_xpbd_begin(xp, 1e-3);
        // x: the positions, or the displacements from the rest shape.
        double res[2] = {0, 0};
        size_t xb = n3 * (f64 ? 8 : 4);
        void *x = o1;
        for (size_t i = 0; i < n3; i++) {
          double v = based ? gx[0].d[i] - gX.d[i] : gx[0].d[i];
          if (f64)
            ((double *)x)[i] = v;
          else
            ((float *)x)[i] = (float)v;
        }
        const void *xbase = based ? P(&gX, f64) : NULL;
        uint64_t hx = FNV_OFFSET;
        for (int it = 0; it < 2 && rc >= 0; it++) {
          rc = f64 ? ek_xpbd_iterate_f64(xp, xbase, x, 3) : ek_xpbd_iterate_f32(xp, xbase, x, 3);
          if (rc >= 0)
            rc = f64 ? ek_xpbd_residual_f64(xp, xbase, x, &res[0], &res[1])
                     : ek_xpbd_residual_f32(xp, xbase, x, &res[0], &res[1]);
          if (rc >= 0)
            rc = ek_xpbd_lambda(xp, scratch(lam, nc * 8));
          hx = fnv(fnv(fnv(hx, x, xb), res, sizeof res), lam, nc * 8);
          if (snh && rc >= 0) {
            rc = ek_xpbd_lambda_h(xp, scratch(lam, nc * 8));
            hx = fnv(hx, lam, nc * 8);
          }
        }
        out(rc, hx, base, based ? "iterate_base" : "iterate");
      }
      free(lam);
      ek_xpbd_destroy(xp);
    }
  free(mass), free(w);
}

// XPBD (xpbd.h): every element kind x solver x precision; the constraint
// structure, then sweeps from the mild state with and without a base. The
// StVK constraint's rows ("xpbd/..."), then the stable neo-Hookean pair's
// ("xpbd_snh/...", which also hash the hydrostatic multipliers).
static void run_xpbd(ek_isa isa, int f64) {
  for (int snh = 0; snh < 2; snh++)
    run_xpbd_model(isa, f64, snh);
}

// ---- Cloth kernels (cloth.h) ----------------------------------------------

#define NTRI 4133
#define NSETS 613
static arr cX, cx, cv, cDm, cF; // rest and deformed corners, velocities, Dm^-1, 3x2 F
static packed pcx, pcv, pcDm, pcF;
static arr kP, kQ, kW;
static size_t *koff;

static void setup_cloth_inputs(void) {
  double *X = malloc(NTRI * 9 * 8), *x = malloc(NTRI * 9 * 8), *v = malloc(NTRI * 9 * 8),
         *F = malloc(NTRI * 6 * 8);
  for (size_t t = 0; t < NTRI; t++) {
    // Rest: a random well-shaped triangle (corners near an equilateral one).
    double eq[9] = {0, 0, 0, 1, 0, 0, 0.5, 0.866, 0};
    double Q[9];
    rotation(0, Q);
    double s = 0.1 + urand() * urand();
    for (int c = 0; c < 3; c++)
      for (int i = 0; i < 3; i++) {
        double r = 0;
        for (int k = 0; k < 3; k++)
          r += Q[3 * i + k] * (eq[3 * c + k] + 0.1 * urand());
        X[9 * t + 3 * c + i] = s * r + urand();
      }
    for (int k = 0; k < 9; k++) {
      x[9 * t + k] = X[9 * t + k] * (1 + 0.2 * urand()) + 0.05 * urand();
      v[9 * t + k] = urand();
    }
    for (int k = 0; k < 6; k++)
      F[6 * t + k] = (t % 2 ? 2 * urand() : (k == 0 || k == 3) + 0.1 * urand());
  }
  // Deformed extremes: collinear, coincident, scaled 1e30 / 1e-30, NaN;
  // and the same for F (rank 1, zero, scaled, NaN, flipped).
  for (int c = 0; c < 3; c++)
    for (int i = 0; i < 3; i++) {
      x[9 * 3 + 3 * c + i] = (c + 1) * (i + 0.5);
      x[9 * 5 + 3 * c + i] = 0.25;
      x[9 * 7 + 3 * c + i] *= 1e30;
      x[9 * 9 + 3 * c + i] *= 1e-30;
    }
  x[9 * 11 + 4] = NAN;
  for (int k = 0; k < 6; k++) {
    F[6 * 3 + k] = (k / 2 + 1) * (k % 2 ? 2.0 : 1.0); // rank 1
    F[6 * 5 + k] = 0;
    F[6 * 7 + k] *= 1e30;
    F[6 * 9 + k] *= 1e-30;
  }
  F[6 * 11 + 1] = NAN;
  F[6 * 13 + 2] = -F[6 * 13 + 2];
  cX = arr_from(NTRI * 9, X);
  cx = arr_from(NTRI * 9, x);
  cv = arr_from(NTRI * 9, v);
  cF = arr_from(NTRI * 6, F);
  double *Dm = malloc(NTRI * 4 * 8);
  if (ek_tri_rest_f64(NTRI, X, Dm, NULL)) {
    fprintf(stderr, "ek-hash: ek_tri_rest_f64: %s\n", ek_last_error());
    exit(2);
  }
  cDm = arr_from(NTRI * 4, Dm);
  pcx = pack(&cx, NTRI, 9);
  pcv = pack(&cv, NTRI, 9);
  pcDm = pack(&cDm, NTRI, 4);
  pcF = pack(&cF, NTRI, 6);
  free(X), free(x), free(v), free(F), free(Dm);
  // Kabsch sets: sizes 0..9, Q = R P + noise, some reflected, degenerate,
  // scaled or with a NaN.
  koff = malloc((NSETS + 1) * sizeof(size_t));
  koff[0] = 0;
  for (size_t s = 0; s < NSETS; s++)
    koff[s + 1] = koff[s] + s % 10;
  size_t np = koff[NSETS];
  double *Pp = malloc(np * 24), *Qp = malloc(np * 24), *Wp = malloc(np * 8);
  for (size_t s = 0; s < NSETS; s++) {
    double R[9];
    rotation(0, R);
    for (size_t k = koff[s]; k < koff[s + 1]; k++) {
      for (int i = 0; i < 3; i++)
        Pp[3 * k + i] = urand();
      if (s == 17) // collinear
        Pp[3 * k + 1] = 2 * Pp[3 * k], Pp[3 * k + 2] = -Pp[3 * k];
      if (s == 27) // coincident
        Pp[3 * k] = Pp[3 * k + 1] = Pp[3 * k + 2] = 0.5;
      for (int i = 0; i < 3; i++) {
        double q = 0;
        for (int j = 0; j < 3; j++)
          q += R[3 * i + j] * Pp[3 * k + j];
        Qp[3 * k + i] = (s == 13 ? -q : q) + 0.01 * urand() + 3;
        if (s == 23)
          Qp[3 * k + i] *= 1e30, Pp[3 * k + i] *= 1e-30;
      }
      Wp[k] = 0.1 + urand() + 1;
    }
  }
  Qp[3 * koff[33] + 1] = NAN;
  kP = arr_from(np * 3, Pp);
  kQ = arr_from(np * 3, Qp);
  kW = arr_from(np, Wp);
  free(Pp), free(Qp), free(Wp);
}

static size_t tbytes(int f64, int aosoa, int planes) {
  size_t items = aosoa ? (f64 ? ek_aosoa_blocks_f64(NTRI) * EK_LANES_F64
                              : ek_aosoa_blocks_f32(NTRI) * EK_LANES_F32)
                       : NTRI;
  return items * (size_t)planes * (f64 ? 8 : 4);
}
static size_t TB(int f64) { return f64 ? ek_aosoa_blocks_f64(NTRI) : ek_aosoa_blocks_f32(NTRI); }

static void run_cloth(ek_isa isa, int f64) {
  ek_cloth_opts o = {isa};
  int rc;
  for (int aosoa = 0; aosoa < 2; aosoa++) {
    const char *lay = aosoa ? "aosoa" : "aos";
    // Triangle F.
    size_t b6 = tbytes(f64, aosoa, 6), b4 = tbytes(f64, aosoa, 4), b9 = tbytes(f64, aosoa, 9);
    void *F = scratch(o1, b6);
    if (aosoa)
      rc = f64 ? ek_tri_deformation_aosoa_f64(TB(1), pcx.d, pcDm.d, F, &o)
               : ek_tri_deformation_aosoa_f32(TB(0), pcx.f, pcDm.f, F, &o);
    else
      rc = f64 ? ek_tri_deformation_ex_f64(NTRI, cx.d, cDm.d, F, &o)
               : ek_tri_deformation_ex_f32(NTRI, cx.f, cDm.f, F, &o);
    out(rc, fnv(FNV_OFFSET, F, b6), "cloth/tri_deformation/%s", lay);
    // polar32.
    for (int want_uc = 1; want_uc >= (aosoa ? 1 : 0); want_uc--) {
      void *R = scratch(o1, b6), *Uc = want_uc ? scratch(o2, b4) : NULL;
      if (aosoa)
        rc = f64 ? ek_polar32_aosoa_f64(TB(1), pcF.d, R, Uc, &o)
                 : ek_polar32_aosoa_f32(TB(0), pcF.f, R, Uc, &o);
      else
        rc = f64 ? ek_polar32_ex_f64(NTRI, cF.d, R, Uc, &o)
                 : ek_polar32_ex_f32(NTRI, cF.f, R, Uc, &o);
      uint64_t h = fnv(FNV_OFFSET, R, b6);
      if (Uc)
        h = fnv(h, Uc, b4);
      out(rc, h, "cloth/polar32/%s%s", lay, want_uc ? "" : ",R_only");
    }
    // Triangle velocity gradient: L, D, W and L alone.
    for (int all = 1; all >= 0; all--) {
      void *L = scratch(o1, b9), *D = all ? scratch(o2, b9) : NULL,
           *W = all ? scratch(o3, b9) : NULL;
      if (aosoa)
        rc = f64 ? ek_tri_velocity_gradient_aosoa_f64(TB(1), pcx.d, pcv.d, L, D, W, &o)
                 : ek_tri_velocity_gradient_aosoa_f32(TB(0), pcx.f, pcv.f, L, D, W, &o);
      else
        rc = f64 ? ek_tri_velocity_gradient_f64(NTRI, cx.d, cv.d, L, D, W, &o)
                 : ek_tri_velocity_gradient_f32(NTRI, cx.f, cv.f, L, D, W, &o);
      uint64_t h = fnv(FNV_OFFSET, L, b9);
      if (all)
        h = fnv(fnv(h, D, b9), W, b9);
      out(rc, h, "cloth/tri_velocity_gradient/%s%s", lay, all ? "" : ",L_only");
    }
  }
  // Kabsch, with and without weights.
  for (int weighted = 1; weighted >= 0; weighted--) {
    size_t b = NSETS * 9 * (f64 ? 8 : 4);
    void *R = scratch(o1, b);
    rc = f64 ? ek_kabsch_ex_f64(NSETS, koff, kP.d, kQ.d, weighted ? kW.d : NULL, R, &o)
             : ek_kabsch_ex_f32(NSETS, koff, kP.f, kQ.f, weighted ? kW.f : NULL, R, &o);
    out(rc, fnv(FNV_OFFSET, R, b), "cloth/kabsch/%s", weighted ? "weighted" : "unweighted");
  }
  // Tet velocity gradient on the mesh's element layer, both states.
  for (int s = 0; s < 2; s++)
    for (int all = 1; all >= 0; all--) {
      size_t b = gnt * 9 * (f64 ? 8 : 4);
      void *L = scratch(o1, b), *D = all ? scratch(o2, b) : NULL, *W = all ? scratch(o3, b) : NULL;
      rc = f64 ? ek_tet_velocity_gradient_f64(gel, gx[s].d, gv.d, L, D, W, &o)
               : ek_tet_velocity_gradient_f32(gel, gx[s].f, gv.f, L, D, W, &o);
      uint64_t h = fnv(FNV_OFFSET, L, b);
      if (all)
        h = fnv(fnv(h, D, b), W, b);
      out(rc, h, "cloth/tet_velocity_gradient/%s%s", state_name[s], all ? "" : ",L_only");
    }
}

// Entry points without an ISA option.
static void run_cloth_auto(int f64) {
  int rc;
  if (f64) {
    double *Dm = (double *)scratch(o1, NTRI * 32), *area = (double *)scratch(o2, NTRI * 8);
    rc = ek_tri_rest_f64(NTRI, cX.d, Dm, area);
    out(rc, fnv(fnv(FNV_OFFSET, Dm, NTRI * 32), area, NTRI * 8), "cloth/tri_rest/aos_entry");
    // A degenerate rest triangle is refused.
    double bad[9] = {0, 0, 0, 1, 1, 1, 2, 2, 2};
    rc = ek_tri_rest_f64(1, bad, Dm, NULL);
    out(rc, 0, "cloth/tri_rest/degenerate");
  }
  size_t b6 = NTRI * 6 * (f64 ? 8 : 4), b4 = NTRI * 4 * (f64 ? 8 : 4);
  rc = f64 ? ek_tri_deformation_f64(NTRI, cx.d, cDm.d, scratch(o1, b6))
           : ek_tri_deformation_f32(NTRI, cx.f, cDm.f, scratch(o1, b6));
  out(rc, fnv(FNV_OFFSET, o1, b6), "cloth/tri_deformation/aos_entry");
  rc = f64 ? ek_polar32_f64(NTRI, cF.d, scratch(o1, b6), scratch(o2, b4))
           : ek_polar32_f32(NTRI, cF.f, scratch(o1, b6), scratch(o2, b4));
  out(rc, fnv(fnv(FNV_OFFSET, o1, b6), o2, b4), "cloth/polar32/aos_entry");
  size_t bk = NSETS * 9 * (f64 ? 8 : 4);
  rc = f64 ? ek_kabsch_f64(NSETS, koff, kP.d, kQ.d, kW.d, scratch(o1, bk))
           : ek_kabsch_f32(NSETS, koff, kP.f, kQ.f, kW.f, scratch(o1, bk));
  out(rc, fnv(FNV_OFFSET, o1, bk), "cloth/kabsch/weighted/entry");
  for (int s = 0; s < 2; s++) {
    size_t b = gnt * 9 * (f64 ? 8 : 4);
    rc = f64 ? ek_mesh_velocity_gradient_f64(gmesh, gx[s].d, gv.d, scratch(o1, b), scratch(o2, b),
                                             scratch(o3, b))
             : ek_mesh_velocity_gradient_f32(gmesh, gx[s].f, gv.f, scratch(o1, b), scratch(o2, b),
                                             scratch(o3, b));
    out(rc, fnv(fnv(fnv(FNV_OFFSET, o1, b), o2, b), o3, b), "cloth/mesh_velocity_gradient/%s/entry",
        state_name[s]);
  }
}

// ---- Cloth forces (cloth_force.h) -----------------------------------------

#define CLOTH_NX 40
#define CLOTH_NY 32
static ek_cloth *gcloth;
static size_t gcnv;
static arr gcX, gcx, gcp;

static void setup_cloth_mesh(void) {
  size_t nx = CLOTH_NX, ny = CLOTH_NY;
  gcnv = (nx + 1) * (ny + 1);
  size_t ntris = 2 * nx * ny;
  double *X = malloc(gcnv * 24), *x = malloc(gcnv * 24), *p = malloc(gcnv * 24);
  int32_t *tris = malloc(ntris * 3 * sizeof(int32_t));
  for (size_t j = 0; j <= ny; j++)
    for (size_t i = 0; i <= nx; i++) {
      size_t v = j * (nx + 1) + i;
      X[3 * v] = 0.025 * i + (i && i < nx ? 0.003 * urand() : 0);
      X[3 * v + 1] = 0.025 * j + (j && j < ny ? 0.003 * urand() : 0);
      X[3 * v + 2] = 0;
      // Stretched along x, compressed along y, bent out of the plane.
      x[3 * v] = 1.05 * X[3 * v] + 0.002 * urand();
      x[3 * v + 1] = 0.97 * X[3 * v + 1] + 0.002 * urand();
      x[3 * v + 2] = 0.05 * sin(6 * X[3 * v]) * cos(4 * X[3 * v + 1]) + 0.002 * urand();
      for (int k = 0; k < 3; k++)
        p[3 * v + k] = urand();
    }
  size_t t = 0;
  for (size_t j = 0; j < ny; j++)
    for (size_t i = 0; i < nx; i++) {
      int32_t a = (int32_t)(j * (nx + 1) + i), b = a + 1, c = a + (int32_t)nx + 1, d = c + 1;
      if ((i + j) % 2) {
        int32_t t1[6] = {a, b, d, a, d, c};
        memcpy(tris + 3 * t, t1, sizeof t1);
      } else {
        int32_t t1[6] = {a, b, c, b, d, c};
        memcpy(tris + 3 * t, t1, sizeof t1);
      }
      t += 2;
    }
  gcloth = ek_cloth_create(gcnv, X, ntris, tris);
  if (!gcloth) {
    fprintf(stderr, "ek-hash: ek_cloth_create: %s\n", ek_last_error());
    exit(2);
  }
  gcX = arr_from(gcnv * 3, X);
  gcx = arr_from(gcnv * 3, x);
  gcp = arr_from(gcnv * 3, p);
  free(X), free(x), free(p), free(tris);
}

static const ek_cloth_params cloth_params[] = {
    {EK_MEMBRANE_STVK, 50.0, 20.0, 0.0},
    {EK_MEMBRANE_STVK, 50.0, 20.0, 1e-3},
    {EK_MEMBRANE_ARAP, 50.0, 0.0, 1e-3},
    {EK_MEMBRANE_ARAP, 50.0, 0.0, 0.0},
};
#define NCP (sizeof cloth_params / sizeof *cloth_params)

static void run_cloth_force(ek_isa isa, int f64) {
  for (size_t k = 0; k < NCP; k++) {
    const ek_cloth_params *p = &cloth_params[k];
    for (int timed = 0; timed < 2; timed++) {
      ek_cloth_phase_times pt = {0, 0, 0};
      ek_cloth_force_opts o = {isa, timed ? &pt : NULL};
      size_t b = gcnv * 3 * (f64 ? 8 : 4);
      void *f = scratch(o1, b);
      int rc = f64 ? ek_cloth_forces_f64(gcloth, p, gcx.d, f, &o)
                   : ek_cloth_forces_f32(gcloth, p, gcx.f, f, &o);
      out(rc, fnv(FNV_OFFSET, f, b), "cloth_force/forces/params%zu/%s", k,
          timed ? "phase_times" : "plain");
    }
    // The vector energy and Hessian product (cloth_membrane_block.c).
    double E = 0;
    int rc = f64 ? ek_cloth_energy_ex_f64(gcloth, p, gcx.d, &E, &(ek_cloth_force_opts){isa, NULL})
                 : ek_cloth_energy_ex_f32(gcloth, p, gcx.f, &E, &(ek_cloth_force_opts){isa, NULL});
    out(rc, fnv(FNV_OFFSET, &E, 8), "cloth_force/energy_ex/params%zu", k);
    for (int project = 0; project < 2; project++) {
      size_t b = gcnv * 3 * (f64 ? 8 : 4);
      void *q = scratch(o1, b);
      ek_cloth_force_opts o = {isa, NULL};
      rc = f64 ? ek_cloth_hessian_apply_ex_f64(gcloth, p, gcx.d, project, gcp.d, q, &o)
               : ek_cloth_hessian_apply_ex_f32(gcloth, p, gcx.f, project, gcp.f, q, &o);
      out(rc, fnv(FNV_OFFSET, q, b), "cloth_force/hessian_apply_ex/params%zu/project=%d", k,
          project);
    }
  }
}

static void run_cloth_force_auto(void) {
  size_t n3 = gcnv * 3;
  {
    size_t nums[3] = {ek_cloth_nverts(gcloth), ek_cloth_ntris(gcloth), ek_cloth_nhinges(gcloth)};
    uint64_t h = fnv(FNV_OFFSET, nums, sizeof nums);
    h = fnv(h, ek_cloth_rest_areas(gcloth), nums[1] * 8);
    h = fnv(h, ek_cloth_dm_inv(gcloth), nums[1] * 32);
    h = fnv(h, ek_cloth_hinges(gcloth), nums[2] * 16);
    h = fnv(h, ek_cloth_hinge_k(gcloth), nums[2] * 32);
    h = fnv(h, ek_cloth_lumped_area(gcloth), nums[0] * 8);
    out(0, h, "cloth_force/layer");
  }
  double *w = malloc(gcnv * 8);
  for (size_t i = 0; i < gcnv; i++)
    w[i] = i <= CLOTH_NX ? 0 : 1.0 / (0.1 * ek_cloth_lumped_area(gcloth)[i]); // one edge held
  for (size_t k = 0; k < NCP; k++) {
    const ek_cloth_params *p = &cloth_params[k];
    double E = ek_cloth_energy_f64(gcloth, p, gcx.d);
    out(0, fnv(FNV_OFFSET, &E, 8), "cloth_force/energy/params%zu", k);
    for (int project = 0; project < 2; project++) {
      int rc = ek_cloth_hessian_apply_f64(gcloth, p, gcx.d, project, gcp.d, scratch(o1, n3 * 8));
      out(rc, fnv(FNV_OFFSET, o1, n3 * 8), "cloth_force/hessian_apply/params%zu/project=%d", k,
          project);
    }
    int rc = ek_cloth_hessian_diagonal_f64(gcloth, p, gcx.d, scratch(o1, gcnv * 72));
    out(rc, fnv(FNV_OFFSET, o1, gcnv * 72), "cloth_force/hessian_diagonal/params%zu", k);
    size_t nt = ek_cloth_ntris(gcloth);
    double *J = (double *)scratch(o1, nt * 8), *s1 = (double *)scratch(o2, nt * 8),
           *s2 = (double *)scratch(o3, nt * 8), *psi = (double *)scratch(o4, nt * 8);
    rc = ek_cloth_fields_f64(gcloth, p, gcx.d, J, s1, s2, psi);
    out(rc, fnv(fnv(fnv(fnv(FNV_OFFSET, J, nt * 8), s1, nt * 8), s2, nt * 8), psi, nt * 8),
        "cloth_force/fields/params%zu", k);
    // Cloth XPBD: a substep of three rounds of sweeps.
    ek_cloth_xpbd *cx = ek_cloth_xpbd_create(gcloth, p, 200.0);
    if (!cx) {
      out(EK_EINVAL, 0, "cloth_force/xpbd/params%zu", k);
      continue;
    }
    size_t cnt = ek_cloth_xpbd_count(cx);
    int col = ek_cloth_xpbd_colors(cx);
    uint64_t h = fnv(fnv(FNV_OFFSET, &cnt, sizeof cnt), &col, sizeof col);
    double *pos = (double *)o1;
    memcpy(pos, gcx.d, n3 * 8);
    rc = ek_cloth_xpbd_begin(cx, w, 1e-3);
    for (int it = 0; it < 3 && rc >= 0; it++) {
      double res[2] = {0, 0};
      rc = ek_cloth_xpbd_iterate(cx, pos, 2);
      if (rc >= 0)
        rc = ek_cloth_xpbd_residual(cx, pos, &res[0], &res[1]);
      h = fnv(fnv(h, pos, n3 * 8), res, sizeof res);
    }
    out(rc, h, "cloth_force/xpbd/params%zu", k);
    ek_cloth_xpbd_destroy(cx);
  }
  free(w);
}

// ---- Driver ---------------------------------------------------------------

static const ek_isa isas[] = {EK_ISA_SCALAR, EK_ISA_AVX2, EK_ISA_AVX512};

// Seconds per family (stderr, with --times): where the run's time goes.
static int g_times = 0;
static double g_t0;
static void lap(const char *family) {
  double t = omp_get_wtime();
  if (g_times && family)
    fprintf(stderr, "ek-hash: t%d %-12s %6.2f s\n", g_threads, family, t - g_t0);
  g_t0 = t;
}

// fn(f64) for both precisions, as ISA "auto".
static void each_auto(void (*fn)(int f64)) {
  g_isa = "auto";
  for (int f64 = 0; f64 < 2; f64++) {
    g_prec = f64 ? "f64" : "f32";
    fn(f64);
  }
}

// fn(isa, f64) for every available ISA x precision.
static void each_isa(void (*fn)(ek_isa isa, int f64)) {
  for (size_t i = 0; i < 3; i++) {
    if (!ek_isa_available(isas[i]))
      continue;
    g_isa = ek_isa_name(isas[i]);
    for (int f64 = 0; f64 < 2; f64++) {
      g_prec = f64 ? "f64" : "f32";
      fn(isas[i], f64);
    }
  }
}

// The families that share a pass over the ISAs and precisions.
static void batch_svd_auto(int f64) {
  run_batch(f64);
  run_svd_auto(f64);
}
static void svd_polar(ek_isa isa, int f64) {
  run_svd(isa, f64);
  run_polar_warm(isa, f64);
}
static void hessian(ek_isa isa, int f64) { run_hessian(isa, !f64); }
static void cloth_and_force(ek_isa isa, int f64) {
  run_cloth(isa, f64);
  run_cloth_force(isa, f64);
}

// The whole table at the current thread count: per family, "auto" entry
// points first, then every available ISA x precision.
static void run_table(void) {
  lap(NULL);
  each_auto(batch_svd_auto);
  each_isa(svd_polar);
  lap("svd3+polar");
  each_auto(run_material_auto);
  each_isa(run_material);
  lap("material");
  each_auto(run_fvm_auto);
  each_isa(run_fvm);
  lap("fvm");
  each_isa(hessian);
  lap("hessian");
  each_isa(run_xpbd);
  lap("xpbd");
  each_auto(run_cloth_auto);
  g_prec = "f64";
  run_cloth_force_auto();
  each_isa(cloth_and_force);
  lap("cloth");
}

// libgomp's default wait policy spins at barriers: on a loaded machine (a
// build on the other core) the two-thread pass took 100 s instead of 18 s
// here, the spinning thread holding the core its partner needs. The
// policy changes no result; libgomp reads it at start-up only, so the
// program re-executes itself once with it set (as sim/omp_env.c does for
// OMP_PROC_BIND), unless the caller chose a policy.
#define REEXEC_GUARD "EK_HASH_REEXEC"
static void wait_policy_default(char **argv) {
  if (getenv("OMP_WAIT_POLICY") || getenv(REEXEC_GUARD))
    return;
  setenv("OMP_WAIT_POLICY", "passive", 1);
  setenv(REEXEC_GUARD, "1", 1);
  execv("/proc/self/exe", argv);
  fprintf(stderr, "ek-hash: note: re-exec with OMP_WAIT_POLICY=passive failed; going on\n");
}

static void usage(FILE *out) {
  fputs("usage: ek-hash [--threads N] [--times]\n"
        "Prints '<variant> <FNV-1a-64 of its output bytes>' for every kernel variant,\n"
        "at 1 and 2 OpenMP threads (or N only, 1..4096); --times: seconds per family on\n"
        "stderr.\n",
        out);
}

int main(int argc, char **argv) {
  if (omp_env_check_threads("ek-hash"))
    return EK_EXIT_USAGE;
  wait_policy_default(argv);
  int threads[2] = {1, 2};
  int nthreads = 2;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    ek_cli_common("ek-hash", a, usage);
    if (!strcmp(a, "--threads")) {
      // Strict (sim/cli.h): "--threads 2x" or " 2" was atoi's 2, "x" its 0.
      long n;
      if (i + 1 >= argc)
        return ek_cli_usage_error("ek-hash", "--threads: needs a value");
      if (ek_cli_parse_long(argv[++i], 1, 4096, &n))
        return ek_cli_usage_error("ek-hash", "--threads '%s': expected a whole number in [1, 4096]",
                                  argv[i]);
      threads[0] = (int)n;
      nthreads = 1;
    } else if (!strcmp(a, "--times")) {
      g_times = 1;
    } else {
      return ek_cli_usage_error("ek-hash", "unexpected argument \"%s\"", a);
    }
  }
  if (ek_cli_env_check("ek-hash")) // every EK_* variable is one of its values
    return EK_EXIT_USAGE;
  // Resolve AUTO once: an EK_ISA naming an unavailable target stops here.
  ek_isa best;
  if (ek_isa_resolve(EK_ISA_AUTO, &best)) {
    fprintf(stderr, "ek-hash: %s\n", ek_last_error());
    return 2;
  }
  setup_matrices();
  setup_mesh();
  setup_cloth_inputs();
  setup_cloth_mesh();
  for (int t = 0; t < nthreads; t++) {
    g_threads = threads[t];
    omp_set_num_threads(g_threads);
    run_table();
  }
  fprintf(stderr, "ek-hash: %ld lines; auto = %s; isas:", g_lines, ek_isa_name(best));
  for (size_t i = 0; i < 3; i++)
    if (ek_isa_available(isas[i]))
      fprintf(stderr, " %s", ek_isa_name(isas[i]));
  fprintf(stderr, "\n");
  return 0;
}
