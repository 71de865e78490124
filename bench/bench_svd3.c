// ek-bench family "svd3": the batched 3x3 SVD and polar decomposition
// (include/ek/svd3.h) against LAPACK ?gesvd called per matrix.
//
// Rows, for each available ISA (forced through opts.isa) x precision x
// thread count:
//   svd3/aosoa/<isa>/<prec>/sweeps:S/rsqrt:R   AoSoA-native ek_svd3_aosoa_*
//       on a cache-resident batch; one row per setting of the
//       sweeps/accuracy trade-off: S = the default and 2, 4, 6, 8, each with
//       R = exact and approx (knob "default=1" marks the precision's
//       defaults). The caller's FTZ/DAZ is left off, the C default (knob
//       caller_ftz_daz), so these rows show what subnormal arithmetic in the
//       Jacobi sweeps would cost (kernels/svd3/svd3_core.h flushes it: issue
//       22 wants 6 exact sweeps within 1.5x of 2)
//   svd3/aosoa_big/...       ek_svd3_aosoa_* on the AoS rows' batch size,
//                            defaults: the baseline of the AoS row
//   svd3/aos/...             the AoS API ek_svd3_* on a batch far bigger
//                            than the caches (conversion included), with
//                            the default options
//   svd3/polar_aosoa/...     ek_polar3_aosoa_* (R and Ssym), defaults
// and per precision x thread count:
//   svd3/convert/<prec>      ek_aosoa_pack of A + unpack of U, S, V: what
//                            staging through AoSoA buffers costs (the AoS
//                            API did so before issue 13; it now transposes
//                            in the kernel)
//   svd3/lapack/<prec>       sgesvd_/dgesvd_ per 3x3 matrix, the baseline of
//                            the speed-up column (same precision, threads)
// Inputs: seeded Gaussian matrices (entries N(0, 1)).
#include <ek/batch.h>
#include <ek/svd3.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "kernels.h"     // ek_svd3_default_knobs_*: the refine sweeps behind a default
#include "simd/fpmode.h" // the caller's FTZ/DAZ, reported in the rows' knobs

// Batch sizes. AoSoA and LAPACK rows: 4096 matrices, A + U + S + V about
// 0.5 MB in float, so the rows time the kernel, not the memory. AoS rows:
// 2^20 float / 2^18 double matrices (120 / 60 MB with the outputs, well
// beyond the 32 MB L3), the way a simulation hands over its data.
#define CACHE_BATCH 4096
#define AOS_BATCH_F32 (1u << 20)
#define AOS_BATCH_F64 (1u << 18)
// Items per conversion chunk: the driver's work chunk (kernels/svd3/svd3.c,
// 32 blocks), the way the AoS API staged its chunks before issue 13.
#define CONVERT_CHUNK_BLOCKS 32

// ---- declared work -------------------------------------------------------

// Floating-point operations of one SVD as kernels/svd3/svd3_core.h performed
// them before issue 13 (kept as the yardstick of the % of peak: the kernel
// now skips some of them, e.g. the QR's zeroed entries and the Newton step
// of the angle rsqrts), counting add, sub, mul, div, sqrt and rsqrt as 1 each (the
// approximate rsqrt also as 1) and an fma as 2; compares, min/max, abs,
// negation and selects are not counted.
//   step 1, scale:           1 mul (m) + 1 div (1/m) + 18 mul          =  20
//   step 2, Gram A'^T A':    6 entries x (3 mul + 2 add)               =  30
//   step 3, per pair:        angle: ch 2, ch^2 sh^2 n2 3, test 1,
//                            rsq 1, scale 2                            =   9
//                            c 3, s 2, w 5, s_pp s_qq s_pq 6,
//                            s_pk s_qk 6                               =  22
//                            quaternion (x) (ch, sh e_k): 4 x 3        =  12
//                            -> 43 per pair, 129 per sweep
//   step 4, |q|^2 7, rsq 1, normalise 4; rotation matrix from q: 10
//           products + 3 diagonals x 3 + 6 off-diagonals x 2; B = A' V:
//           9 x 5                                                      =  88
//   step 5, per pair:        3 dots x 5, x y 2, z 3, r 3, t 1,
//                            t^2+u^2 3, rsq 1, c s 2, rotate 2 columns
//                            of B and of V 36                          =  66
//                            -> 198 per refine sweep
//   step 6, rho_i:           3 x 5                                     =  15
//   step 7, 3 Givens:        each n2 3, rsq 1, c s 2, rows of B 18     =  72
//                            U = G1^T G2^T G3^T: 2 x 18                =  36
//   step 8, S = S' m:        3 mul                                     =   3
// Total 264 + 129 sweeps + 198 refine. Polar adds R = U V^T (9 x 5) and
// Ssym = V diag(S) V^T (9 mul + 6 x 5 + 9 mul for the scale): 93.
static double svd3_flops(int sweeps, int refine) { return 264.0 + 129.0 * sweeps + 198.0 * refine; }
static double polar3_flops(int sweeps, int refine) { return svd3_flops(sweeps, refine) + 93.0; }

// Bytes moved per matrix: SVD reads A (9) and writes U, S, V (21), 30
// values; polar reads 9 and writes R and Ssym, 27 values; conversion
// packs A (9 read, 9 written) and unpacks U, S, V (21 read, 21 written).
#define SVD3_VALUES 30
#define POLAR3_VALUES 27
#define CONVERT_VALUES 60

// ---- inputs and contexts -----------------------------------------------

typedef struct {
  int f64;
  size_t n;                // matrices per call
  size_t lanes;            // EK_LANES_F32 / _F64
  void *A, *U, *S, *V;     // AoS or AoSoA, as the row needs
  void *Ap, *Up, *Sp, *Vp; // AoSoA staging for the conversion row
  void *block, *block_p;   // A..V and Ap..Vp, each set in one block
  ek_svd3_opts opts;
  int rc; // last return code of the timed call
} svd_ctx;

static size_t real_size(int f64) { return f64 ? sizeof(double) : sizeof(float); }

// n Gaussian 3x3 matrices, AoS, from the run's seed (and the precision, so
// f32 and f64 rows see different but reproducible inputs), into A.
static void gaussian_aos(ek_bench *b, int f64, size_t n, void *A) {
  ek_bench_rng rng;
  ek_bench_rng_init(&rng, ek_bench_seed(b) * 2 + (unsigned)f64);
  for (size_t i = 0; i < 9 * n; i++) {
    double g = ek_bench_rng_gauss(&rng);
    if (f64)
      ((double *)A)[i] = g;
    else
      ((float *)A)[i] = (float)g;
  }
}

static void free_ctx(svd_ctx *c) {
  ek_free(c->block), ek_free(c->block_p);
  memset(c, 0, sizeof *c);
}

// A, U, S and V of n matrices (planes 9, 9, 3, 9 per matrix, `blocks` AoSoA
// blocks of `lanes`, or AoS with blocks * lanes = n), one after the other
// in one zeroed block (ek_bench_arrays: the same relative placement in
// every run; zeroed so that page faults happen here, not in the first
// timed call). NULL when out of memory.
static void *zeroed_set(size_t blocks, size_t lanes, size_t sz, void **A, void **U, void **S,
                        void **V) {
  size_t p = blocks * lanes * sz, bytes[4] = {9 * p, 9 * p, 3 * p, 9 * p};
  void *a[4];
  void *block = ek_bench_arrays(4, bytes, 0, a);
  if (block)
    memset(block, 0, (size_t)((char *)a[3] + bytes[3] - (char *)block));
  *A = a[0], *U = a[1], *S = a[2], *V = a[3];
  return block;
}

// AoSoA batch of n Gaussian matrices with its output planes.
static int setup_aosoa(ek_bench *b, svd_ctx *c, int f64, size_t n) {
  memset(c, 0, sizeof *c);
  c->f64 = f64;
  c->n = n;
  c->lanes = f64 ? EK_LANES_F64 : EK_LANES_F32;
  size_t blocks = (n + c->lanes - 1) / c->lanes, sz = real_size(f64);
  void *aos = ek_alloc(n * 9 * sz);
  c->block = zeroed_set(blocks, c->lanes, sz, &c->A, &c->U, &c->S, &c->V);
  int rc = -1;
  if (aos && c->block) {
    gaussian_aos(b, f64, n, aos);
    rc = f64 ? ek_aosoa_pack_f64(n, 9, aos, c->A) : ek_aosoa_pack_f32(n, 9, aos, c->A);
  }
  ek_free(aos);
  if (rc)
    free_ctx(c);
  return rc;
}

// AoS batch (A, U, S, V as n x 9 / n x 3) plus AoSoA staging for the
// conversion row.
static int setup_aos(ek_bench *b, svd_ctx *c, int f64, size_t n) {
  memset(c, 0, sizeof *c);
  c->f64 = f64;
  c->n = n;
  c->lanes = f64 ? EK_LANES_F64 : EK_LANES_F32;
  size_t blocks = (n + c->lanes - 1) / c->lanes, sz = real_size(f64);
  c->block = zeroed_set(n, 1, sz, &c->A, &c->U, &c->S, &c->V);
  c->block_p = zeroed_set(blocks, c->lanes, sz, &c->Ap, &c->Up, &c->Sp, &c->Vp);
  if (!c->block || !c->block_p) {
    free_ctx(c);
    return -1;
  }
  gaussian_aos(b, f64, n, c->A);
  return 0;
}

static void call_svd_aosoa(void *p) {
  svd_ctx *c = p;
  size_t nb = (c->n + c->lanes - 1) / c->lanes;
  c->rc = c->f64 ? ek_svd3_aosoa_f64(nb, c->A, c->U, c->S, c->V, &c->opts)
                 : ek_svd3_aosoa_f32(nb, c->A, c->U, c->S, c->V, &c->opts);
  ek_do_not_optimize(c->V);
}

static void call_polar_aosoa(void *p) {
  svd_ctx *c = p;
  size_t nb = (c->n + c->lanes - 1) / c->lanes;
  c->rc = c->f64 ? ek_polar3_aosoa_f64(nb, c->A, c->U, c->V, &c->opts)
                 : ek_polar3_aosoa_f32(nb, c->A, c->U, c->V, &c->opts);
  ek_do_not_optimize(c->V);
}

static void call_svd_aos(void *p) {
  svd_ctx *c = p;
  c->rc = c->f64 ? ek_svd3_f64(c->n, c->A, c->U, c->S, c->V, &c->opts)
                 : ek_svd3_f32(c->n, c->A, c->U, c->S, c->V, &c->opts);
  ek_do_not_optimize(c->V);
}

// Pack A and unpack U, S, V chunk by chunk, as the AoS API does around the
// kernel (the kernel itself is not run: the outputs are whatever the
// staging buffers hold).
static void call_convert(void *p) {
  svd_ctx *c = p;
  const size_t chunk = CONVERT_CHUNK_BLOCKS * c->lanes, sz = real_size(c->f64);
  const size_t nchunks = (c->n + chunk - 1) / chunk;
  int failed = 0;
#pragma omp parallel for schedule(static) reduction(| : failed)
  for (size_t k = 0; k < nchunks; k++) {
    size_t i0 = k * chunk, m = c->n - i0 < chunk ? c->n - i0 : chunk;
    size_t p9 = i0 * 9 * sz, p3 = i0 * 3 * sz; // byte offsets (AoS and AoSoA agree
                                               // at chunk starts: whole blocks)
    char *A = c->A, *U = c->U, *S = c->S, *V = c->V;
    char *Ap = c->Ap, *Up = c->Up, *Sp = c->Sp, *Vp = c->Vp;
    if (c->f64)
      failed |= ek_aosoa_pack_f64(m, 9, (double *)(A + p9), (double *)(Ap + p9)) |
                ek_aosoa_unpack_f64(m, 9, (double *)(Up + p9), (double *)(U + p9)) |
                ek_aosoa_unpack_f64(m, 3, (double *)(Sp + p3), (double *)(S + p3)) |
                ek_aosoa_unpack_f64(m, 9, (double *)(Vp + p9), (double *)(V + p9));
    else
      failed |= ek_aosoa_pack_f32(m, 9, (float *)(A + p9), (float *)(Ap + p9)) |
                ek_aosoa_unpack_f32(m, 9, (float *)(Up + p9), (float *)(U + p9)) |
                ek_aosoa_unpack_f32(m, 3, (float *)(Sp + p3), (float *)(S + p3)) |
                ek_aosoa_unpack_f32(m, 9, (float *)(Vp + p9), (float *)(V + p9));
  }
  c->rc = failed;
  ek_do_not_optimize(c->V);
}

// ---- LAPACK baseline -----------------------------------------------------
//
// A call covers 4096 matrices (several ms), so on a 2-core machine shared
// with other work the threads:2 row is sensitive to that load: one thread
// descheduled holds up the barrier at the end of the loop (seen on the
// reference machine: 0.3x to 1.5x of threads:1 across runs). Its MAD shows
// it; compare speed-ups from a quiet machine.

// Fortran LAPACK (liblapack); the trailing size_t are the hidden lengths of
// the character arguments (gfortran calling convention).
void sgesvd_(const char *jobu, const char *jobvt, const int *m, const int *n, float *a,
             const int *lda, float *s, float *u, const int *ldu, float *vt, const int *ldvt,
             float *work, const int *lwork, int *info, size_t jobu_len, size_t jobvt_len);
void dgesvd_(const char *jobu, const char *jobvt, const int *m, const int *n, double *a,
             const int *lda, double *s, double *u, const int *ldu, double *vt, const int *ldvt,
             double *work, const int *lwork, int *info, size_t jobu_len, size_t jobvt_len);

// LAPACK's version (reference LAPACK and OpenBLAS both provide it).
void ilaver_(int *major, int *minor, int *patch);

typedef struct {
  int f64;
  size_t n;
  int threads;
  void *A, *U, *S, *V; // AoS; LAPACK reads A column-major, i.e. it factors
                       // A^T = V S U^T: the same work, outputs transposed
  void *block;         // A, U, S and V (zeroed_set)
  int lwork;
  void **work;    // one workspace per thread
  void **scratch; // one 3x3 copy of A per thread (?gesvd overwrites A)
  int failures;   // matrices with info != 0 in the last call
} lapack_ctx;

static int lapack_one(lapack_ctx *c, size_t i, int tid) {
  const int three = 3;
  int info = 0;
  if (c->f64) {
    double *a = c->scratch[tid];
    memcpy(a, (double *)c->A + 9 * i, 9 * sizeof *a);
    dgesvd_("A", "A", &three, &three, a, &three, (double *)c->S + 3 * i, (double *)c->U + 9 * i,
            &three, (double *)c->V + 9 * i, &three, c->work[tid], &c->lwork, &info, 1, 1);
  } else {
    float *a = c->scratch[tid];
    memcpy(a, (float *)c->A + 9 * i, 9 * sizeof *a);
    sgesvd_("A", "A", &three, &three, a, &three, (float *)c->S + 3 * i, (float *)c->U + 9 * i,
            &three, (float *)c->V + 9 * i, &three, c->work[tid], &c->lwork, &info, 1, 1);
  }
  return info != 0;
}

static void call_lapack(void *p) {
  lapack_ctx *c = p;
  int failures = 0;
#pragma omp parallel num_threads(c->threads) reduction(+ : failures)
  {
    int tid = omp_get_thread_num();
#pragma omp for schedule(static)
    for (size_t i = 0; i < c->n; i++)
      failures += lapack_one(c, i, tid);
  }
  c->failures = failures;
  ek_do_not_optimize(c->V);
}

static void free_lapack(lapack_ctx *c) {
  for (int t = 0; t < c->threads && c->work; t++)
    ek_free(c->work[t]);
  for (int t = 0; t < c->threads && c->scratch; t++)
    ek_free(c->scratch[t]);
  free(c->work);
  free(c->scratch);
  ek_free(c->block);
  memset(c, 0, sizeof *c);
}

static int setup_lapack(ek_bench *b, lapack_ctx *c, int f64, size_t n, int threads) {
  memset(c, 0, sizeof *c);
  c->f64 = f64;
  c->n = n;
  c->threads = threads;
  size_t sz = real_size(f64);
  c->block = zeroed_set(n, 1, sz, &c->A, &c->U, &c->S, &c->V);
  c->work = calloc((size_t)threads, sizeof *c->work);
  c->scratch = calloc((size_t)threads, sizeof *c->scratch);
  if (!c->block || !c->work || !c->scratch)
    goto fail;
  gaussian_aos(b, f64, n, c->A);
  // Workspace query, once: lwork = -1 returns the optimal size in work[0].
  const int three = 3, query = -1;
  int info = 0;
  double a[9] = {0}, s[3], u[9], vt[9], best = 0;
  float af[9] = {0}, sf[3], uf[9], vtf[9], bestf = 0;
  if (f64) {
    dgesvd_("A", "A", &three, &three, a, &three, s, u, &three, vt, &three, &best, &query, &info, 1,
            1);
  } else {
    sgesvd_("A", "A", &three, &three, af, &three, sf, uf, &three, vtf, &three, &bestf, &query,
            &info, 1, 1);
    best = bestf;
  }
  if (info != 0 || !(best >= 1))
    goto fail;
  c->lwork = (int)best;
  for (int t = 0; t < threads; t++) {
    // Cache-line aligned and padded (ek_alloc): threads never share a line.
    c->work[t] = ek_alloc((size_t)c->lwork * sz);
    c->scratch[t] = ek_alloc(9 * sz);
    if (!c->work[t] || !c->scratch[t])
      goto fail;
  }
  return 0;
fail:
  free_lapack(c);
  return -1;
}

// ---- rows ----------------------------------------------------------------

typedef struct {
  ek_bench *b;
  int f64;
  const char *prec;
  int threads;
  char lapack_name[EK_BENCH_NAME_MAX];
} row_env;

// Time one ek SVD/polar row whose ctx is set up; checks the return code of
// a first call and of the timed calls.
static void run_ek_row(row_env *e, const char *name, ek_isa isa, const char *knobs, ek_bench_fn *fn,
                       svd_ctx *c, double flops, double values, const char *baseline) {
  ek_bench_row row = {.name = name,
                      .family = "svd3",
                      .isa = isa,
                      .precision = e->prec,
                      .threads = e->threads,
                      .knobs = knobs,
                      .items = c ? c->n : 1,
                      .flops_per_item = flops,
                      .bytes_per_item = values * real_size(e->f64),
                      .baseline = baseline ? baseline : e->lapack_name,
                      .fn = fn,
                      .ctx = c};
  if (ek_bench_listing(e->b)) {
    ek_bench_run(e->b, &row);
    return;
  }
  c->rc = 0;
  fn(c);
  if (c->rc != 0) {
    ek_bench_fail(e->b, "%s: the call returned %d (%s)", name, c->rc, ek_last_error());
    return;
  }
  row.rc = &c->rc;
  ek_bench_run(e->b, &row);
}

// All rows of one precision and thread count.
static void rows_for(ek_bench *b, int f64, int threads, const ek_isa *isas, int nisa) {
  row_env e = {.b = b, .f64 = f64, .prec = f64 ? "f64" : "f32", .threads = threads};
  snprintf(e.lapack_name, sizeof e.lapack_name, "svd3/lapack/%s/threads:%d", e.prec, threads);
  // The precision's defaults (what zeroed options mean): the polar and AoS
  // rows run them, and their names say which sweeps and rsqrt they are.
  ek_svd3_knobs def = f64 ? ek_svd3_default_knobs_f64() : ek_svd3_default_knobs_f32();
  const char *def_rsqrt = def.exact_rsqrt ? "exact" : "approx";
  char name[EK_BENCH_NAME_MAX], knobs[160];
  int listing = ek_bench_listing(b);

  // LAPACK first, so the table shows the baseline above the rows it scales.
  if (ek_bench_wants(b, e.lapack_name)) {
    int major = 0, minor = 0, patch = 0;
    ilaver_(&major, &minor, &patch);
    char lapack_knobs[96];
    snprintf(lapack_knobs, sizeof lapack_knobs, "api=lapack;jobu=A;jobvt=A;lapack_version=%d.%d.%d",
             major, minor, patch);
    lapack_ctx lc = {0};
    if (!listing && setup_lapack(b, &lc, f64, CACHE_BATCH, threads) != 0) {
      ek_bench_fail(b, "%s: LAPACK setup (workspace query or allocation) failed", e.lapack_name);
    } else {
      ek_bench_row row = {.name = e.lapack_name,
                          .family = "svd3",
                          .isa = EK_ISA_AUTO,
                          .isa_label = "lapack",
                          .precision = e.prec,
                          .threads = threads,
                          .knobs = lapack_knobs,
                          .items = CACHE_BATCH,
                          .bytes_per_item = SVD3_VALUES * real_size(f64),
                          .fn = call_lapack,
                          .ctx = &lc};
      if (!listing) {
        call_lapack(&lc);
        if (lc.failures)
          ek_bench_fail(b, "%s: ?gesvd reported info != 0 on %d matrices", e.lapack_name,
                        lc.failures);
      }
      if (listing || !lc.failures)
        ek_bench_run(b, &row);
      free_lapack(&lc);
    }
  }

  // Sweeps per row: the default and 2, 4, 6, 8, ascending, each once; each
  // with the exact rsqrt, then each with the approximate one.
  int sweep_list[5], nsweeps = 0;
  for (int s = 1; s <= 8; s++)
    if (s == def.sweeps || s == 2 || s == 4 || s == 6 || s == 8)
      sweep_list[nsweeps++] = s;
  const char *ftz_daz = ek_fpmode_get() & EK_FPMODE_FTZ_DAZ ? "on" : "off";

  for (int i = 0; i < nisa; i++) {
    ek_isa isa = isas[i];
    const char *iname = ek_isa_name(isa);
    svd_ctx c = {0};
    int ready = 0; // cache-resident AoSoA batch set up (lazily)
    for (int k = 0; k < 2 * nsweeps; k++) {
      int approx = k >= nsweeps, sweeps = sweep_list[k % nsweeps];
      snprintf(name, sizeof name, "svd3/aosoa/%s/%s/sweeps:%d/rsqrt:%s/threads:%d", iname, e.prec,
               sweeps, approx ? "approx" : "exact", threads);
      if (!ek_bench_wants(b, name))
        continue;
      int is_default = sweeps == def.sweeps && approx == !def.exact_rsqrt;
      snprintf(knobs, sizeof knobs,
               "api=aosoa;sweeps=%d;refine=%d;rsqrt=%s;default=%d;caller_ftz_daz=%s", sweeps,
               def.refine, approx ? "approx" : "exact", is_default, ftz_daz);
      if (!listing && !ready) {
        if (setup_aosoa(b, &c, f64, CACHE_BATCH) != 0) {
          ek_bench_fail(b, "%s: input setup failed", name);
          break;
        }
        ready = 1;
      }
      c.opts = (ek_svd3_opts){.sweeps = sweeps, .exact_rsqrt = approx ? -1 : 1, .isa = isa};
      run_ek_row(&e, name, isa, knobs, call_svd_aosoa, listing ? NULL : &c,
                 svd3_flops(sweeps, def.refine), SVD3_VALUES, NULL);
    }
    snprintf(name, sizeof name, "svd3/polar_aosoa/%s/%s/sweeps:%d/rsqrt:%s/threads:%d", iname,
             e.prec, def.sweeps, def_rsqrt, threads);
    if (ek_bench_wants(b, name)) {
      snprintf(knobs, sizeof knobs, "api=polar_aosoa;sweeps=%d;refine=%d;rsqrt=%s;default=1",
               def.sweeps, def.refine, def_rsqrt);
      if (!listing && !ready && setup_aosoa(b, &c, f64, CACHE_BATCH) == 0)
        ready = 1;
      if (!listing && !ready) {
        ek_bench_fail(b, "%s: input setup failed", name);
      } else {
        c.opts = (ek_svd3_opts){.sweeps = 0, .exact_rsqrt = 0, .isa = isa};
        run_ek_row(&e, name, isa, knobs, call_polar_aosoa, listing ? NULL : &c,
                   polar3_flops(def.sweeps, def.refine), POLAR3_VALUES, NULL);
      }
    }
    if (ready)
      free_ctx(&c);

    // The AoSoA kernel on the AoS rows' batch size: the baseline of the AoS
    // row, so the speed-up column is what the AoS layout costs at equal
    // memory traffic (issue 13's target: AoS <= 1.3x this row's time).
    char big_name[EK_BENCH_NAME_MAX];
    snprintf(big_name, sizeof big_name, "svd3/aosoa_big/%s/%s/sweeps:%d/rsqrt:%s/threads:%d", iname,
             e.prec, def.sweeps, def_rsqrt, threads);
    if (ek_bench_wants(b, big_name)) {
      snprintf(knobs, sizeof knobs, "api=aosoa;batch=big;sweeps=%d;refine=%d;rsqrt=%s;default=1",
               def.sweeps, def.refine, def_rsqrt);
      size_t n = f64 ? AOS_BATCH_F64 : AOS_BATCH_F32;
      if (!listing && setup_aosoa(b, &c, f64, n) != 0) {
        ek_bench_fail(b, "%s: input setup failed", big_name);
      } else {
        c.opts = (ek_svd3_opts){.sweeps = 0, .exact_rsqrt = 0, .isa = isa};
        run_ek_row(&e, big_name, isa, knobs, call_svd_aosoa, listing ? NULL : &c,
                   svd3_flops(def.sweeps, def.refine), SVD3_VALUES, NULL);
        if (!listing)
          free_ctx(&c);
      }
    }

    snprintf(name, sizeof name, "svd3/aos/%s/%s/sweeps:%d/rsqrt:%s/threads:%d", iname, e.prec,
             def.sweeps, def_rsqrt, threads);
    if (ek_bench_wants(b, name)) {
      snprintf(knobs, sizeof knobs, "api=aos;sweeps=%d;refine=%d;rsqrt=%s;default=1", def.sweeps,
               def.refine, def_rsqrt);
      size_t n = f64 ? AOS_BATCH_F64 : AOS_BATCH_F32;
      if (!listing && setup_aos(b, &c, f64, n) != 0) {
        ek_bench_fail(b, "%s: input setup failed", name);
      } else {
        c.opts = (ek_svd3_opts){.sweeps = 0, .exact_rsqrt = 0, .isa = isa};
        run_ek_row(&e, name, isa, knobs, call_svd_aos, listing ? NULL : &c,
                   svd3_flops(def.sweeps, def.refine), SVD3_VALUES, big_name);
        if (!listing)
          free_ctx(&c);
      }
    }
  }

  snprintf(name, sizeof name, "svd3/convert/%s/threads:%d", e.prec, threads);
  if (ek_bench_wants(b, name)) {
    svd_ctx c = {0};
    size_t n = f64 ? AOS_BATCH_F64 : AOS_BATCH_F32;
    if (!listing && setup_aos(b, &c, f64, n) != 0) {
      ek_bench_fail(b, "%s: input setup failed", name);
    } else {
      ek_bench_row row = {.name = name,
                          .family = "svd3",
                          .isa = EK_ISA_AUTO,
                          .isa_label = "none",
                          .precision = e.prec,
                          .threads = threads,
                          .knobs = "api=aosoa_pack+unpack;planes=9+9+3+9",
                          .items = n,
                          .bytes_per_item = CONVERT_VALUES * real_size(f64),
                          .fn = call_convert,
                          .ctx = &c};
      if (!listing) {
        call_convert(&c);
        if (c.rc)
          ek_bench_fail(b, "%s: pack/unpack returned an error", name);
      }
      if (listing || !c.rc)
        ek_bench_run(b, &row);
      if (!listing)
        free_ctx(&c);
    }
  }
}

int bench_svd3(ek_bench *b) {
  ek_isa isas[EK_ISA_COUNT];
  int nisa = ek_bench_isas(b, isas);
  int counts[EK_BENCH_MAX_THREAD_COUNTS];
  int nthreads = ek_bench_thread_counts(b, counts);
  for (int f64 = 0; f64 < 2; f64++)
    for (int t = 0; t < nthreads; t++)
      rows_for(b, f64, counts[t], isas, nisa);
  return 0;
}
