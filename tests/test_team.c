// The helper team (kernels/team.h, team.c) and its solo paths:
//   a. every chunk of a job runs exactly once, at 2 and 3 threads, for
//      several chunk counts (0, 1, a few, more than one claim word's
//      EK_TEAM_MAX_CHUNKS), through ek_team_run, ek_team_run_static and
//      ek_team_run_ranges; a ranges worker id is 0 exactly where the chunk
//      ran on the calling thread, and below ek_team_threads();
//   b. the stall window: a second job during which ek_team_note_stall()
//      was called (from a chunk, as xpbd.c's flow calls it, or before the
//      job: the flag is read at the end of the next job the team runs,
//      team.c's stall_check), within STALL_REPEAT_S (0.1 s) of the first,
//      opens STALL_SOLO_S (50 ms) from its end, and every job that starts
//      inside it runs on the calling thread alone (worker 0). Judged only
//      for the jobs that returned within 45 ms of the second noted job's
//      start (so they started inside the window whatever the machine did);
//      no judged job in 20 tries fails. After the window
//      the helpers run chunks again: reported, not asserted (a helper on a
//      busy machine may be late for every try);
//   c. the kernels that run on the team give the same bits at 1 thread and
//      at 2 and 3 threads, normally, with a stall noted before the call and
//      a second right before it (its first team job with helpers, the later
//      ones alone), and with the window opened before the call (two noted
//      jobs; every job of the call alone; a probe
//      job after the call shows the window was still open when the call
//      returned within 45 ms): FVM forces (default, coloured, thread
//      buffers and gather scatters; f32, f64), the Hessian's gradient,
//      energy, products (f64, f32) and assembly, the cloth forces and
//      energies (f32, f64), XPBD tets (Gauss-Seidel: the flow, whose chunks
//      run in order on the caller while the window is open; Jacobi; f32,
//      f64), the batch SVD (f32, f64), XPBD clusters (Gauss-Seidel phases,
//      Jacobi; f32, f64), cloth XPBD (StVK, ARAP), material_eval (AoS and
//      AoSoA, f32 and f64), the warm polar batch (AoS and AoSoA, f32 and
//      f64) and the AoSoA staging (the tets' velocity gradient, Kabsch;
//      f32 and f64). A call that differs names the parts that did;
//   d. XPBD's flow beside a thread of this process that spins on a core
//      (the flow's waits for a descheduled thread pass XPBD_STALL_S and
//      open the window themselves, xpbd.c's wait_done; so may the team's
//      own stall_check): the same bits in every call. Whether a stall
//      happened is reported, not asserted: a probe job right after the call
//      that ran alone shows a window or a helper that did not get a core,
//      and either depends on the scheduler.
// The kernels' outputs go to buffers filled with NaN first (a chunk that
// did not run shows; outputs updated in place, XPBD's positions and the
// warm polar's R, start from the same values every call), and the 1-thread
// call is the reference. With a team that dropped each job's last chunk at
// 2 threads and more (a temporary change to team.c, round 19), every part
// of c differed.
#define _GNU_SOURCE
#include <ek/batch.h>
#include <ek/cloth.h>
#include <ek/cloth_force.h>
#include <ek/elements.h>
#include <ek/hessian.h>
#include <ek/material.h>
#include <ek/polar.h>
#include <ek/sim/trimesh.h>
#include <ek/svd3.h>
#include <ek/xpbd.h>
#include <math.h>
#include <omp.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <time.h>

#include "../kernels/team.h"
#include "check_cloth.h"
#include "cli.h"
#include "test_fvm_common.h"
#include "test_xpbd_scene.h"

static int failures = 0;

static void verdict(int ok, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void verdict(int ok, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vprintf(fmt, ap);
  va_end(ap);
  printf(": %s\n", ok ? "PASS" : "FAIL");
  failures += !ok;
}

// The team's window (team.c STALL_SOLO_S), the margin inside it within
// which a job is judged to have started in it, and the time within which a
// second stall opens it (STALL_REPEAT_S).
#define SOLO_S 0.05
#define JUDGE_S 0.045
#define REPEAT_S 0.1

static void sleep_s(double s) {
  struct timespec ts = {(time_t)s, (long)((s - (double)(time_t)s) * 1e9)};
  while (nanosleep(&ts, &ts) != 0)
    ;
}

// Past any window a previous job opened, and past the time within which a
// stall it saw would make the next one open a window.
static void close_window(void) { sleep_s((SOLO_S > REPEAT_S ? SOLO_S : REPEAT_S) + 0.01); }

// ---- A recording job ----
typedef struct {
  size_t n;
  _Atomic int *runs;     // per chunk: times run
  int *worker;           // per chunk: ek_team_run_ranges' worker (-1: other entry points)
  unsigned char *caller; // per chunk: ran on the calling thread
  pthread_t self;        // the calling thread
  int threads;           // ek_team_threads() at the call
  size_t note_chunk;     // the chunk that calls ek_team_note_stall (n: none)
  int work;              // loop iterations per chunk (~1 ns each)
  atomic_int bad_worker; // a worker id out of range
} rec;

static void rec_do(rec *r, size_t i, int worker) {
  atomic_fetch_add_explicit(&r->runs[i], 1, memory_order_relaxed);
  r->worker[i] = worker;
  r->caller[i] = pthread_equal(pthread_self(), r->self) != 0;
  if (worker < -1 || worker >= r->threads)
    atomic_store(&r->bad_worker, 1);
  if (i == r->note_chunk)
    ek_team_note_stall();
  volatile double s = 0;
  for (int k = 0; k < r->work; k++)
    s += k;
}
static void rec_ranges(void *ctx, size_t i, int worker) { rec_do(ctx, i, worker); }
static void rec_plain(void *ctx, size_t i) { rec_do(ctx, i, -1); }

static rec rec_alloc(size_t n) {
  rec r = {.n = n};
  r.runs = calloc(n ? n : 1, sizeof *r.runs);
  r.worker = calloc(n ? n : 1, sizeof *r.worker);
  r.caller = calloc(n ? n : 1, 1);
  return r;
}
static void rec_free(rec *r) {
  free((void *)r->runs);
  free(r->worker);
  free(r->caller);
}

enum { API_RUN, API_STATIC, API_RANGES, API_COUNT };
static const char *api_name[API_COUNT] = {"ek_team_run", "ek_team_run_static",
                                          "ek_team_run_ranges"};

// One job of r->n chunks through `api`; note: the chunk that notes a stall.
static void rec_run(rec *r, int api, size_t note, int work) {
  for (size_t i = 0; i < r->n; i++) {
    atomic_store_explicit(&r->runs[i], 0, memory_order_relaxed);
    r->worker[i] = -2;
    r->caller[i] = 0;
  }
  r->self = pthread_self();
  r->threads = ek_team_threads();
  r->note_chunk = note;
  r->work = work;
  atomic_store(&r->bad_worker, 0);
  if (api == API_RUN)
    ek_team_run(r->n, rec_plain, r);
  else if (api == API_STATIC)
    ek_team_run_static(r->n, rec_plain, r);
  else
    ek_team_run_ranges(r->n, rec_ranges, r);
}

// 1 if every chunk ran once, with a worker id in range that is 0 exactly
// on the calling thread (ranges); *helper: chunks that ran off the caller.
static int rec_once(const rec *r, int api, size_t *helper) {
  int ok = !atomic_load(&r->bad_worker);
  *helper = 0;
  for (size_t i = 0; i < r->n; i++) {
    ok &= atomic_load_explicit(&r->runs[i], memory_order_relaxed) == 1;
    ok &= api == API_RANGES ? (r->worker[i] == 0) == (r->caller[i] != 0) : r->worker[i] == -1;
    *helper += !r->caller[i];
  }
  return ok;
}

// ---- a ----
static void check_once(void) {
  static const size_t counts[] = {0, 1, 2, 3, 5, 64, 1000, EK_TEAM_MAX_CHUNKS + 5};
  const int ncounts = (int)(sizeof counts / sizeof counts[0]);
  for (int threads = 2; threads <= 3; threads++) {
    omp_set_num_threads(threads);
    for (int api = 0; api < API_COUNT; api++) {
      int ok = 1;
      size_t helped = 0, jobs = 0;
      for (int c = 0; c < ncounts; c++) {
        rec r = rec_alloc(counts[c]);
        // Small jobs often: a helper wakes during some; the big one once.
        const int reps = counts[c] > 100000 ? 1 : 20;
        for (int rep = 0; rep < reps; rep++) {
          size_t h;
          rec_run(&r, api, r.n, counts[c] > 100000 ? 0 : 2000);
          ok &= rec_once(&r, api, &h);
          helped += h;
          jobs++;
        }
        rec_free(&r);
      }
      verdict(ok,
              "a. %d threads, %-18s: every chunk once, worker ids right (%zu jobs of 0 .. %zu "
              "chunks; %zu chunks ran on helpers)",
              threads, api_name[api], jobs, (size_t)(EK_TEAM_MAX_CHUNKS + 5), helped);
    }
  }
  omp_set_num_threads(2);
}

// ---- b ----
// Two jobs whose chunk 5 notes a stall (inside = 1), or two notes each
// followed by a job (inside = 0), then 5 jobs at once: those that return
// within JUDGE_S of the second noted job's start must have run on the
// caller alone (they started before that job's end + SOLO_S). Returns the
// jobs judged; *bad: those that used a helper or ran a chunk other than
// once.
static int window_try(int api, int inside, size_t *bad) {
  rec r = rec_alloc(64);
  close_window();
  double t0 = 0;
  size_t h;
  int judged = 0;
  for (int stall = 0; stall < 2; stall++) { // the second within REPEAT_S opens the window
    t0 = omp_get_wtime();
    if (!inside)
      ek_team_note_stall();
    rec_run(&r, api, inside ? 5 : r.n, 2000);
    *bad += !rec_once(&r, api, &h);
  }
  for (int k = 0; k < 5; k++) {
    rec_run(&r, api, r.n, 2000);
    const double t1 = omp_get_wtime();
    int ok = rec_once(&r, api, &h);
    if (t1 - t0 < JUDGE_S) {
      judged++;
      *bad += !ok || h != 0;
    } else {
      *bad += !ok;
    }
  }
  rec_free(&r);
  return judged;
}

static void check_window(void) {
  for (int threads = 2; threads <= 3; threads++) {
    omp_set_num_threads(threads);
    for (int api = 0; api < API_COUNT; api++)
      for (int inside = 1; inside >= 0; inside--) {
        size_t bad = 0;
        int judged = 0, tries = 0;
        while (judged == 0 && tries < 20) {
          judged += window_try(api, inside, &bad);
          tries++;
        }
        verdict(judged > 0 && bad == 0,
                "b. %d threads, %-18s, note %s: jobs in the window ran on the caller alone (%d "
                "judged in %d tries, %zu bad)",
                threads, api_name[api], inside ? "in a chunk " : "before jobs", judged, tries, bad);
      }
    // After the window the helpers take chunks again: jobs of 64 chunks of
    // ~2 us, each after the window closed, for up to 2 s.
    rec r = rec_alloc(64);
    const double t0 = omp_get_wtime();
    size_t helped = 0;
    int jobs = 0, ok = 1;
    while (helped == 0 && omp_get_wtime() - t0 < 2.0) {
      close_window();
      size_t h;
      rec_run(&r, API_RANGES, r.n, 2000);
      ok &= rec_once(&r, API_RANGES, &h);
      helped += h;
      jobs++;
    }
    rec_free(&r);
    if (helped)
      verdict(ok, "b. %d threads: after the window a helper ran chunks again (job %d)", threads,
              jobs);
    else {
      printf("b. %d threads: skipped: no helper ran a chunk in %d jobs over 2 s (busy machine); "
             "every chunk once: %s\n",
             threads, jobs, ok ? "PASS" : "FAIL");
      failures += !ok;
    }
  }
  omp_set_num_threads(2);
}

// ---- c, d: kernels on the team ----
typedef struct {
  const char *name;
  void (*run)(const void *env, unsigned char *out);
  const void *env;
  size_t bytes;
} kcase;

static unsigned char *put(unsigned char *out, const void *p, size_t bytes) {
  memcpy(out, p, bytes);
  return out + bytes;
}

// An output buffer poisoned (ek_check_poison: NaN in either precision), so
// a chunk that did not run shows: a plain malloc may hand back the
// previous call's buffer, holding its results.
static void *garbage(size_t bytes) { return ek_check_poison(malloc(bytes ? bytes : 1), bytes); }

// FVM forces on an element layer.
typedef struct {
  const ek_tets *el;
  ek_material mat;
  ek_scatter scatter;
  const double *x;
  const float *xf;
  size_t n3;
} fvm_env;

static void run_fvm(const void *e_, unsigned char *out) {
  const fvm_env *e = e_;
  ek_fvm_opts o = {.scatter = e->scatter};
  double *f = garbage(e->n3 * sizeof(double));
  float *ff = garbage(e->n3 * sizeof(float));
  int rc = ek_fvm_tet_forces_ex_f64(e->el, &e->mat, e->x, f, &o) |
           ek_fvm_tet_forces_ex_f32(e->el, &e->mat, e->xf, ff, &o);
  out = put(out, &rc, sizeof rc);
  out = put(out, f, e->n3 * sizeof(double));
  put(out, ff, e->n3 * sizeof(float));
  free(f);
  free(ff);
}

// The Hessian: gradient and energy, K p (f64 and f32 caches), the
// assembled K.
typedef struct {
  const ek_tets *el;
  ek_material mat;
  ek_scatter scatter;
  const double *x, *p;
  const float *pf;
  size_t n3, nnz;
} hess_env;

static void run_hess(const void *e_, unsigned char *out) {
  const hess_env *e = e_;
  double *g = garbage(e->n3 * sizeof(double)), *y = garbage(e->n3 * sizeof(double));
  double *v = garbage(e->nnz * sizeof(double));
  float *yf = garbage(e->n3 * sizeof(float));
  double E = 0;
  ek_fvm_hessian_opts o = {.scatter = e->scatter};
  ek_fvm_hessian *h = ek_fvm_hessian_create(e->el, &e->mat, &o);
  ek_csr_pattern pat;
  int rc = !h;
  rc |= h ? ek_fvm_hessian_gradient_f64(h, e->x, NULL, g, &E, 1) : 0;
  rc |= h ? ek_fvm_hessian_apply_f64(h, e->p, y) : 0;
  rc |= h ? ek_fvm_hessian_pattern(h, &pat) : 0;
  rc |= h && pat.nnz == e->nnz ? ek_fvm_hessian_assemble(h, v) : 1;
  ek_fvm_hessian_destroy(h);
  o.precision = 32;
  h = ek_fvm_hessian_create(e->el, &e->mat, &o);
  rc |= !h;
  rc |= h ? ek_fvm_hessian_gradient_f64(h, e->x, NULL, g, NULL, 1) : 0;
  rc |= h ? ek_fvm_hessian_apply_f32(h, e->pf, yf) : 0;
  ek_fvm_hessian_destroy(h);
  out = put(out, &rc, sizeof rc);
  out = put(out, &E, sizeof E);
  out = put(out, g, e->n3 * sizeof(double));
  out = put(out, y, e->n3 * sizeof(double));
  out = put(out, yf, e->n3 * sizeof(float));
  put(out, v, e->nnz * sizeof(double));
  free(g);
  free(y);
  free(v);
  free(yf);
}

// Cloth forces and energies.
typedef struct {
  const ek_cloth *cl;
  ek_cloth_params p;
  const double *x;
  const float *xf;
  size_t n3;
} cloth_env;

static void run_cloth(const void *e_, unsigned char *out) {
  const cloth_env *e = e_;
  double *f = garbage(e->n3 * sizeof(double)), E[3] = {0, 0, 0};
  float *ff = garbage(e->n3 * sizeof(float));
  int rc = ek_cloth_forces_f64(e->cl, &e->p, e->x, f, NULL) |
           ek_cloth_forces_f32(e->cl, &e->p, e->xf, ff, NULL) |
           ek_cloth_energy_ex_f64(e->cl, &e->p, e->x, &E[0], NULL) |
           ek_cloth_energy_ex_f32(e->cl, &e->p, e->xf, &E[1], NULL);
  E[2] = ek_cloth_energy_f64(e->cl, &e->p, e->x);
  out = put(out, &rc, sizeof rc);
  out = put(out, E, sizeof E);
  out = put(out, f, e->n3 * sizeof(double));
  put(out, ff, e->n3 * sizeof(float));
  free(f);
  free(ff);
}

// An XPBD substep: positions, multipliers, residual.
typedef struct {
  const scene *sc;
  ek_xpbd_opts o;
  const double *xs;
  size_t n3, ncons;
} xpbd_env;

#define XPBD_YOUNG 1e7
#define XPBD_NU 0.3

static void run_xpbd(const void *e_, unsigned char *out) {
  const xpbd_env *e = e_;
  const ek_material mat = {EK_MODEL_STVK, XPBD_YOUNG / (2 * (1 + XPBD_NU)),
                           XPBD_YOUNG * XPBD_NU / ((1 + XPBD_NU) * (1 - 2 * XPBD_NU)), 0};
  double *x = garbage(e->n3 * sizeof(double)), *lam = garbage(e->ncons * sizeof(double));
  double res[2] = {0, 0};
  memcpy(x, e->xs, e->n3 * sizeof(double));
  round_to(e->o.precision, e->n3, x);
  ek_xpbd *xp = ek_xpbd_create(e->sc->el, &mat, XPBD_YOUNG, e->sc->mass, &e->o);
  int rc = xp ? ek_xpbd_set_weights(xp, e->sc->w) : EK_EINVAL;
  rc = rc ? rc : ek_xpbd_begin(xp, 1e-3);
  rc = rc ? rc : lib_iterate(xp, e->o.precision, e->n3, x, 4);
  rc = rc ? rc : ek_xpbd_lambda(xp, lam);
  rc = rc ? rc : lib_residual(xp, e->o.precision, e->n3, x, &res[0], &res[1]);
  ek_xpbd_destroy(xp);
  out = put(out, &rc, sizeof rc);
  out = put(out, res, sizeof res);
  out = put(out, x, e->n3 * sizeof(double));
  put(out, lam, e->ncons * sizeof(double));
  free(x);
  free(lam);
}

// The 4 XPBD cases of one element kind (Gauss-Seidel, Jacobi x f32, f64)
// on scene sc from positions xs, into e[4], cases[nc ..] and names[nc ..];
// returns the new count (the Gauss-Seidel f64 case is at nc + 1).
static int add_xpbd(kcase *cases, char (*names)[64], int nc, xpbd_env e[4], const scene *sc,
                    ek_xpbd_elements elements, const double *xs) {
  const size_t n3 = 3 * sc->t.nverts;
  for (int solver = 0; solver < 2; solver++)
    for (int prec = 32; prec <= 64; prec += 32) {
      xpbd_env *x = &e[2 * solver + prec / 64];
      *x = (xpbd_env){sc,
                      {.elements = elements, .solver = (ek_xpbd_solver)solver, .precision = prec},
                      xs,
                      n3,
                      sc->set[elements].n};
      snprintf(names[nc], 64, "xpbd %s %s f%d (%zu)%s", ek_xpbd_elements_name(elements),
               ek_xpbd_solver_name((ek_xpbd_solver)solver), prec, x->ncons,
               elements == EK_XPBD_TETS && solver == 0 ? " (the flow)" : "");
      cases[nc] =
          (kcase){names[nc], run_xpbd, x, sizeof(int) + 2 * sizeof(double) + (n3 + x->ncons) * 8};
      nc++;
    }
  return nc;
}

// A batch SVD.
typedef struct {
  size_t n;
  const double *A;
  const float *Af;
} svd_env;

static void run_svd(const void *e_, unsigned char *out) {
  const svd_env *e = e_;
  double *U = garbage(9 * e->n * sizeof(double)), *S = garbage(3 * e->n * sizeof(double)),
         *V = garbage(9 * e->n * sizeof(double));
  float *Uf = garbage(9 * e->n * sizeof(float)), *Sf = garbage(3 * e->n * sizeof(float)),
        *Vf = garbage(9 * e->n * sizeof(float));
  int rc = ek_svd3_f64(e->n, e->A, U, S, V, NULL) | ek_svd3_f32(e->n, e->Af, Uf, Sf, Vf, NULL);
  out = put(out, &rc, sizeof rc);
  out = put(out, U, 9 * e->n * sizeof(double));
  out = put(out, S, 3 * e->n * sizeof(double));
  out = put(out, V, 9 * e->n * sizeof(double));
  out = put(out, Uf, 9 * e->n * sizeof(float));
  out = put(out, Sf, 3 * e->n * sizeof(float));
  put(out, Vf, 9 * e->n * sizeof(float));
  free(U), free(S), free(V), free(Uf), free(Sf), free(Vf);
}

// Cloth XPBD (cloth_force.h): a substep's sweeps on positions updated in
// place (the same start every call), the residual (it reads the
// multipliers).
typedef struct {
  const ek_cloth *cl;
  ek_cloth_params p;
  const double *xs, *w;
  size_t n3;
} cxpbd_env;

static void run_cxpbd(const void *e_, unsigned char *out) {
  const cxpbd_env *e = e_;
  double *x = garbage(e->n3 * sizeof(double)), res[2] = {NAN, NAN};
  memcpy(x, e->xs, e->n3 * sizeof(double));
  ek_cloth_xpbd *cx = ek_cloth_xpbd_create(e->cl, &e->p, 2.5e3);
  int rc = cx ? ek_cloth_xpbd_begin(cx, e->w, 1e-3) : EK_EINVAL;
  rc = rc ? rc : ek_cloth_xpbd_iterate(cx, x, 4);
  rc = rc ? rc : ek_cloth_xpbd_residual(cx, x, &res[0], &res[1]);
  ek_cloth_xpbd_destroy(cx);
  out = put(out, &rc, sizeof rc);
  out = put(out, res, sizeof res);
  put(out, x, e->n3 * sizeof(double));
  free(x);
}

// A batch of n 3x3 matrices, AoS (n x 9) or AoSoA (64-byte aligned, tail
// padded), f32 or f64: its bytes; an output batch poisoned (padding too);
// its free; a call's record of it.
static size_t batch9_bytes(int aosoa, int f32, size_t n) {
  if (aosoa)
    return f32 ? ek_aosoa_size_f32(n, 9) * sizeof(float) : ek_aosoa_size_f64(n, 9) * sizeof(double);
  return 9 * n * (f32 ? sizeof(float) : sizeof(double));
}
static void *batch9_garbage(int aosoa, int f32, size_t n) {
  void *p = !aosoa ? malloc(batch9_bytes(0, f32, n))
            : f32  ? (void *)ek_aosoa_alloc_f32(n, 9)
                   : (void *)ek_aosoa_alloc_f64(n, 9);
  return ek_check_poison(p, batch9_bytes(aosoa, f32, n));
}
static void batch9_free(int aosoa, void *p) {
  if (aosoa)
    ek_free(p);
  else
    free(p);
}
// A call's return code, then its output batch (freed).
static void batch9_put(unsigned char *out, int rc, int aosoa, void *o, size_t bytes) {
  put(put(out, &rc, sizeof rc), o, bytes);
  batch9_free(aosoa, o);
}

// An input batch in the four layouts: AoS and AoSoA, f64 and its f32
// rounding ([aosoa][f32]).
typedef struct {
  void *b[2][2];
} batch9_in;
static batch9_in batch9_in_make(size_t n, const double *A) {
  batch9_in in;
  double *d = malloc(9 * n * sizeof(double));
  float *f = malloc(9 * n * sizeof(float));
  memcpy(d, A, 9 * n * sizeof(double));
  for (size_t i = 0; i < 9 * n; i++)
    f[i] = (float)A[i];
  in.b[0][0] = d, in.b[0][1] = f;
  in.b[1][0] = ek_aosoa_alloc_f64(n, 9), in.b[1][1] = ek_aosoa_alloc_f32(n, 9);
  ek_aosoa_pack_f64(n, 9, d, in.b[1][0]);
  ek_aosoa_pack_f32(n, 9, f, in.b[1][1]);
  return in;
}
static void batch9_in_free(batch9_in *in) {
  for (int a = 0; a < 2; a++)
    for (int f = 0; f < 2; f++)
      batch9_free(a, in->b[a][f]);
}

// The material batch (material.h): dP (projected) of n elements through
// ek_material_eval, AoS or AoSoA, f32 or f64; the count it returns.
typedef struct {
  ek_material m;
  int aosoa, f32;
  size_t n;
  const void *F, *dF; // AoS n x 9, or AoSoA batches, in the precision
} mat_env;

static void run_mat(const void *e_, unsigned char *out) {
  const mat_env *e = e_;
  const size_t bytes = batch9_bytes(e->aosoa, e->f32, e->n);
  void *o = batch9_garbage(e->aosoa, e->f32, e->n);
  int rc;
  if (e->aosoa && e->f32)
    rc = ek_material_eval_aosoa_f32(&e->m, EK_MAT_PK1_DIFF, EK_ISA_AUTO, ek_aosoa_blocks_f32(e->n),
                                    e->F, NULL, e->dF, o, 1);
  else if (e->aosoa)
    rc = ek_material_eval_aosoa_f64(&e->m, EK_MAT_PK1_DIFF, EK_ISA_AUTO, ek_aosoa_blocks_f64(e->n),
                                    e->F, NULL, e->dF, o, 1);
  else if (e->f32)
    rc = ek_material_eval_f32(&e->m, EK_MAT_PK1_DIFF, EK_ISA_AUTO, e->n, e->F, NULL, e->dF, o, 1);
  else
    rc = ek_material_eval_f64(&e->m, EK_MAT_PK1_DIFF, EK_ISA_AUTO, e->n, e->F, NULL, e->dF, o, 1);
  batch9_put(out, rc, e->aosoa, o, bytes);
}

// The warm polar batch (polar.h): R is in and out (the guesses, then the
// rotations), so it starts from the same guesses G every call (not
// poisoned: a chunk that did not run leaves G, degrees off the result).
typedef struct {
  int aosoa, f32;
  size_t n;
  const void *A, *G; // AoS n x 9, or AoSoA batches, in the precision
} warm_env;

static void run_warm(const void *e_, unsigned char *out) {
  const warm_env *e = e_;
  const size_t bytes = batch9_bytes(e->aosoa, e->f32, e->n);
  void *R = batch9_garbage(e->aosoa, e->f32, e->n);
  memcpy(R, e->G, bytes);
  int rc;
  if (e->aosoa && e->f32)
    rc = ek_polar3_warm_aosoa_f32(ek_aosoa_blocks_f32(e->n), e->A, R, NULL);
  else if (e->aosoa)
    rc = ek_polar3_warm_aosoa_f64(ek_aosoa_blocks_f64(e->n), e->A, R, NULL);
  else if (e->f32)
    rc = ek_polar3_warm_f32(e->n, e->A, R, NULL);
  else
    rc = ek_polar3_warm_f64(e->n, e->A, R, NULL);
  batch9_put(out, rc, e->aosoa, R, bytes);
}

// The AoSoA staging (batch/aosoa.c's staged chunks, per-worker buffers):
// the tets' velocity gradient L, D, W (f32, f64) and Kabsch's rotations
// (f32, f64).
typedef struct {
  const ek_tets *el;
  const double *x, *v;
  const float *xf, *vf;
  size_t ntets, nsets;
  const size_t *offsets;
  const double *P, *Q;
  const float *Pf, *Qf;
} stage_env;

static size_t stage_bytes(const stage_env *e) {
  return sizeof(int) + e->ntets * 27 * 12 + e->nsets * 9 * 12;
}

static void run_stage(const void *e_, unsigned char *out) {
  const stage_env *e = e_;
  const size_t m = 9 * e->ntets;
  double *L = garbage(m * sizeof(double)), *D = garbage(m * sizeof(double)),
         *W = garbage(m * sizeof(double)), *R = garbage(9 * e->nsets * sizeof(double));
  float *Lf = garbage(m * sizeof(float)), *Df = garbage(m * sizeof(float)),
        *Wf = garbage(m * sizeof(float)), *Rf = garbage(9 * e->nsets * sizeof(float));
  int rc = ek_tet_velocity_gradient_f64(e->el, e->x, e->v, L, D, W, NULL) |
           ek_tet_velocity_gradient_f32(e->el, e->xf, e->vf, Lf, Df, Wf, NULL) |
           ek_kabsch_f64(e->nsets, e->offsets, e->P, e->Q, NULL, R) |
           ek_kabsch_f32(e->nsets, e->offsets, e->Pf, e->Qf, NULL, Rf);
  out = put(out, &rc, sizeof rc);
  out = put(out, L, m * sizeof(double));
  out = put(out, D, m * sizeof(double));
  out = put(out, W, m * sizeof(double));
  out = put(out, Lf, m * sizeof(float));
  out = put(out, Df, m * sizeof(float));
  out = put(out, Wf, m * sizeof(float));
  out = put(out, R, 9 * e->nsets * sizeof(double));
  put(out, Rf, 9 * e->nsets * sizeof(float));
  free(L), free(D), free(W), free(R), free(Lf), free(Df), free(Wf), free(Rf);
}

// A probe job of 64 chunks through ranges: 1 if it ran on the caller alone.
static int probe_alone(void) {
  rec r = rec_alloc(64);
  size_t h;
  rec_run(&r, API_RANGES, r.n, 2000);
  int alone = rec_once(&r, API_RANGES, &h) && h == 0;
  rec_free(&r);
  return alone;
}

enum { MODE_NORMAL, MODE_NOTED, MODE_WINDOW, MODE_COUNT };
static const char *mode_name[MODE_COUNT] = {"normal", "noted", "window"};

// A call of the checks below: parts [0, n) in order, their outputs one
// after the other (a case a part; a few per call keep the sleeps between
// the calls few).
typedef struct {
  const char *name;
  const kcase *part;
  int n;
} kcall;

static size_t call_bytes(const kcall *k) {
  size_t b = 0;
  for (int i = 0; i < k->n; i++)
    b += k->part[i].bytes;
  return b;
}

static void call_run(const kcall *k, unsigned char *out) {
  for (int i = 0; i < k->n; i++) {
    k->part[i].run(k->part[i].env, out);
    out += k->part[i].bytes;
  }
}

// A stall noted and a job of 2 chunks that reads it (team.c stall_check).
static void note_and_run(void) {
  rec r = rec_alloc(2);
  ek_team_note_stall();
  rec_run(&r, API_RUN, r.n, 0);
  rec_free(&r);
}

// c: one call at 1 thread, then at 2 and 3 in each mode: the same bits.
// *in_window: window calls that returned within JUDGE_S of the window's
// opening (their jobs all started inside it), *probe_bad: those after
// which the probe job did not run alone.
static void check_case(const kcall *k, int *in_window, int *probe_bad) {
  const size_t bytes = call_bytes(k);
  unsigned char *ref = malloc(bytes), *out = malloc(bytes);
  omp_set_num_threads(1);
  call_run(k, ref);
  int ok = 1, rc0 = 0;
  size_t off = 0; // each part's output starts with its rc
  for (int i = 0; i < k->n; off += k->part[i].bytes, i++) {
    int rc;
    memcpy(&rc, ref + off, sizeof rc);
    rc0 |= rc;
  }
  char what[160] = "";
  unsigned long long differ = 0; // the parts whose bytes differed in some call
  for (int threads = 2; threads <= 3; threads++) {
    omp_set_num_threads(threads);
    for (int mode = 0; mode < MODE_COUNT; mode++) {
      close_window();
      memset(out, 0xA5, bytes);
      double t0 = omp_get_wtime();
      if (mode != MODE_NORMAL)
        note_and_run();
      if (mode == MODE_NOTED)
        ek_team_note_stall(); // the call's first team job reads it: the window opens at its end
      if (mode == MODE_WINDOW) {
        t0 = omp_get_wtime();
        note_and_run(); // the second stall: the window opens at this job's end
      }
      call_run(k, out);
      if (mode == MODE_WINDOW) {
        const int alone = probe_alone();
        if (omp_get_wtime() - t0 < JUDGE_S) {
          (*in_window)++;
          *probe_bad += !alone;
        }
      }
      if (memcmp(ref, out, bytes) != 0) {
        if (ok)
          snprintf(what, sizeof what, " (first: %d threads, %s)", threads, mode_name[mode]);
        ok = 0;
        size_t at = 0;
        for (int i = 0; i < k->n; at += k->part[i].bytes, i++)
          if (memcmp(ref + at, out + at, k->part[i].bytes) != 0)
            differ |= 1ull << i;
      }
    }
  }
  omp_set_num_threads(2);
  verdict(ok && rc0 == 0, "c. %-26s 1 thread vs 2, 3 threads normal, noted, window: same bits%s",
          k->name, what);
  for (int i = 0; i < k->n; i++)
    printf("     %s%s\n", k->part[i].name, differ >> i & 1 ? ": DIFFERS" : "");
  free(ref);
  free(out);
}

// d: a thread that spins until *stop (at most 5 s).
static void *spinner(void *arg) {
  atomic_int *stop = arg;
  const double t0 = omp_get_wtime();
  while (!atomic_load_explicit(stop, memory_order_relaxed) && omp_get_wtime() - t0 < 5)
    ;
  return NULL;
}

static void check_flow_busy(const kcase *k) {
  unsigned char *ref = malloc(k->bytes), *out = malloc(k->bytes);
  omp_set_num_threads(1);
  k->run(k->env, ref);
  atomic_int stop = 0;
  pthread_t th;
  const int started = pthread_create(&th, NULL, spinner, &stop) == 0;
  int ok = 1, calls = 0, alone = 0;
  for (int threads = 2; threads <= 3; threads++) {
    omp_set_num_threads(threads);
    for (int rep = 0; rep < 8; rep++) {
      memset(out, 0xA5, k->bytes);
      k->run(k->env, out);
      alone += probe_alone();
      ok &= memcmp(ref, out, k->bytes) == 0;
      calls++;
    }
  }
  atomic_store(&stop, 1);
  if (started)
    pthread_join(th, NULL);
  omp_set_num_threads(2);
  verdict(
      ok,
      "d. %s beside a spinning thread: same bits as 1 thread in %d calls at 2 and 3 "
      "threads (a probe job after the call ran on the caller alone after %d: a stall's window or "
      "a late helper; not asserted)",
      k->name, calls, alone);
  free(ref);
  free(out);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 2026, NULL);
  printf("test_team: seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  const double t_start = omp_get_wtime();
  check_once();
  check_window();

  // 12^3 cells: 10368 tets, above EK_FVM_PARALLEL_MIN_TETS and XPBD's 4096
  // constraints (the flow at 2 and 3 threads).
  scene sc;
  scene_init(&sc, &rng, 12, 12, 12, 0.05, 1000.0);
  const size_t n3 = 3 * sc.t.nverts;
  double *x = malloc(n3 * sizeof(double)), *p = malloc(n3 * sizeof(double));
  float *xf = malloc(n3 * sizeof(float)), *pf = malloc(n3 * sizeof(float));
  test_deform(&rng, &sc.t, 0.2, 0.1, x);
  for (size_t i = 0; i < n3; i++) {
    p[i] = 2 * ek_rng_uniform(&rng) - 1;
    xf[i] = (float)x[i];
    pf[i] = (float)p[i];
  }
  kcase cases[40];
  int nc = 0;
  static const ek_scatter scatters[] = {EK_SCATTER_AUTO, EK_SCATTER_COLORED,
                                        EK_SCATTER_THREAD_BUFFERS, EK_SCATTER_GATHER};
  const ek_material mats[2] = {{EK_MODEL_STABLE_NEO_HOOKEAN, 1, 2, 0},
                               {EK_MODEL_FIXED_COROTATED, 1, 2, 0}};
  fvm_env fe[8];
  char names[40][64];
  for (int mi = 0; mi < 2; mi++)
    for (int si = 0; si < 4; si++) {
      fvm_env *e = &fe[4 * mi + si];
      *e = (fvm_env){sc.el, mats[mi], scatters[si], x, xf, n3};
      snprintf(names[nc], sizeof names[nc], "fvm %s %s f32+f64", mi ? "fixed_corot" : "snh",
               ek_scatter_name(scatters[si]));
      cases[nc] = (kcase){names[nc], run_fvm, e, sizeof(int) + n3 * 12};
      nc++;
    }
  hess_env he[2];
  for (int si = 0; si < 2; si++) {
    he[si] = (hess_env){sc.el, mats[0], scatters[si], x, p, pf, n3, 0};
    ek_fvm_hessian_opts o = {.scatter = scatters[si]};
    ek_fvm_hessian *h = ek_fvm_hessian_create(sc.el, &mats[0], &o);
    ek_csr_pattern pat;
    if (h && ek_fvm_hessian_pattern(h, &pat) == 0)
      he[si].nnz = pat.nnz;
    ek_fvm_hessian_destroy(h);
    snprintf(names[nc], sizeof names[nc], "hessian snh %s (g, E, Kp f64 f32, K)",
             ek_scatter_name(scatters[si]));
    cases[nc] = (kcase){names[nc], run_hess, &he[si],
                        sizeof(int) + sizeof(double) + n3 * 20 + he[si].nnz * sizeof(double)};
    nc++;
  }
  // 48 x 48 cells: 4608 triangles, above EK_CLOTH_PARALLEL_MIN_TRIS.
  ek_trimesh *tm = ek_trimesh_grid(48, 48, 4.8, 4.8, "xy");
  const size_t cn3 = tm ? 3 * ek_trimesh_nverts(tm) : 0;
  double *cx = malloc((cn3 ? cn3 : 1) * sizeof(double));
  float *cxf = malloc((cn3 ? cn3 : 1) * sizeof(float));
  const double *CX = tm ? ek_trimesh_rest_positions(tm) : NULL;
  for (size_t i = 0; i < cn3; i++) {
    cx[i] = 1.05 * CX[i] + 0.01 * (2 * ek_rng_uniform(&rng) - 1);
    cxf[i] = (float)cx[i];
  }
  cloth_env ce[2];
  if (!tm) {
    printf("ek_trimesh_grid: %s\nFAIL\n", ek_last_error());
    return 1;
  }
  for (int m = 0; m < EK_MEMBRANE_COUNT; m++) {
    ce[m] = (cloth_env){ek_trimesh_cloth(tm), {(ek_membrane_model)m, 1e3, 2e3, 1e-3}, cx, cxf, cn3};
    snprintf(names[nc], sizeof names[nc], "cloth %s forces, energies f32+f64", m ? "arap" : "stvk");
    cases[nc] = (kcase){names[nc], run_cloth, &ce[m], sizeof(int) + 3 * sizeof(double) + cn3 * 12};
    nc++;
  }
  double *xs = malloc(n3 * sizeof(double));
  test_deform(&rng, &sc.t, 0.1, 0.1, xs);
  xpbd_env xe[4];
  const int flow_case = nc + 1;
  nc = add_xpbd(cases, names, nc, xe, &sc, EK_XPBD_TETS, xs);
  svd_env se = {6000, NULL, NULL};
  double *A = malloc(9 * se.n * sizeof(double));
  float *Af = malloc(9 * se.n * sizeof(float));
  for (size_t i = 0; i < se.n; i++)
    ek_rng_gauss_matrix(&rng, A + 9 * i);
  for (size_t i = 0; i < 9 * se.n; i++)
    Af[i] = (float)A[i];
  se.A = A;
  se.Af = Af;
  snprintf(names[nc], sizeof names[nc], "svd3 batch of %zu f32+f64", se.n);
  cases[nc] = (kcase){names[nc], run_svd, &se, sizeof(int) + se.n * 21 * 12};
  nc++;

  // XPBD clusters, one per vertex: 16^3 cells, 4913 vertices, above the
  // sweeps' 4096 constraints (kernels/xpbd/xpbd.c XPBD_PARALLEL_MIN).
  scene sc2;
  scene_init(&sc2, &rng, 16, 16, 16, 0.05, 1000.0);
  double *xs2 = malloc(3 * sc2.t.nverts * sizeof(double));
  test_deform(&rng, &sc2.t, 0.1, 0.1, xs2);
  xpbd_env xc[4];
  nc = add_xpbd(cases, names, nc, xc, &sc2, EK_XPBD_CLUSTERS, xs2);
  // Cloth XPBD on the 48 x 48 grid (4608 triangles: the colours' jobs on
  // the team from EK_CLOTH_PARALLEL_MIN_TRIS).
  double *cw = malloc((cn3 ? cn3 / 3 : 1) * sizeof(double));
  for (size_t v = 0; v < cn3 / 3; v++)
    cw[v] = 1 / (0.1 * ek_cloth_lumped_area(ek_trimesh_cloth(tm))[v]);
  cxpbd_env cxe[2];
  for (int m = 0; m < EK_MEMBRANE_COUNT; m++) {
    cxe[m] = (cxpbd_env){ek_trimesh_cloth(tm), {(ek_membrane_model)m, 1e3, 2e3, 1e-3}, cx, cw, cn3};
    snprintf(names[nc], sizeof names[nc], "cloth xpbd %s (4 sweeps, residual)",
             m ? "arap" : "stvk");
    cases[nc] = (kcase){names[nc], run_cxpbd, &cxe[m], sizeof(int) + 2 * sizeof(double) + cn3 * 8};
    nc++;
  }
  // The material batch: 2 EK_MATERIAL_PARALLEL_MIN + 17 elements (a tail
  // block), dP projected, stable neo-Hookean.
  const size_t nm = 2 * EK_MATERIAL_PARALLEL_MIN + 17;
  double *mF = malloc(9 * nm * sizeof(double)), *mdF = malloc(9 * nm * sizeof(double));
  for (size_t i = 0; i < nm; i++)
    ek_rng_deformation(&rng, 0.3, mF + 9 * i);
  for (size_t i = 0; i < 9 * nm; i++)
    mdF[i] = 2 * ek_rng_uniform(&rng) - 1;
  batch9_in mFb = batch9_in_make(nm, mF), mdFb = batch9_in_make(nm, mdF);
  mat_env me[4];
  for (int k = 0; k < 4; k++) {
    const int aosoa = k / 2, f32 = k % 2;
    me[k] = (mat_env){mats[0], aosoa, f32, nm, mFb.b[aosoa][f32], mdFb.b[aosoa][f32]};
    snprintf(names[nc], sizeof names[nc], "material_eval %s f%d dP (%zu)", aosoa ? "aosoa" : "aos",
             f32 ? 32 : 64, nm);
    cases[nc] = (kcase){names[nc], run_mat, &me[k], sizeof(int) + batch9_bytes(aosoa, f32, nm)};
    nc++;
  }
  // The warm polar batch: A = R* (I + 0.1 sym N), guesses G = polar(R* (I +
  // 0.15 N')) (ek_polar3_f64), some degrees off R*; 6000 matrices, 24
  // chunks in f64.
  const size_t nw = 6000;
  double *wA = malloc(9 * nw * sizeof(double)), *wG = malloc(9 * nw * sizeof(double));
  double *wT = malloc(9 * nw * sizeof(double)), *wS = malloc(9 * nw * sizeof(double));
  for (size_t i = 0; i < nw; i++) {
    double Rs[9], N[9], S[9], T[9];
    ek_rng_rotation(&rng, Rs);
    ek_rng_gauss_matrix(&rng, N);
    for (int a = 0; a < 3; a++)
      for (int b = 0; b < 3; b++)
        S[3 * a + b] = (a == b) + 0.05 * (N[3 * a + b] + N[3 * b + a]);
    ek_mul3(Rs, S, wA + 9 * i);
    ek_rng_gauss_matrix(&rng, N);
    for (int k = 0; k < 9; k++)
      T[k] = (k % 4 == 0) + 0.15 * N[k];
    ek_mul3(Rs, T, wT + 9 * i);
  }
  int wrc = ek_polar3_f64(nw, wT, wG, wS, NULL);
  batch9_in wAb = batch9_in_make(nw, wA), wGb = batch9_in_make(nw, wG);
  warm_env we[4];
  for (int k = 0; k < 4; k++) {
    const int aosoa = k / 2, f32 = k % 2;
    we[k] = (warm_env){aosoa, f32, nw, wAb.b[aosoa][f32], wGb.b[aosoa][f32]};
    snprintf(names[nc], sizeof names[nc], "polar3_warm %s f%d (%zu)", aosoa ? "aosoa" : "aos",
             f32 ? 32 : 64, nw);
    cases[nc] = (kcase){names[nc], run_warm, &we[k], sizeof(int) + batch9_bytes(aosoa, f32, nw)};
    nc++;
  }
  // The AoSoA staging: the velocity gradient of the 12^3 box's tets (41
  // chunks in f64) and Kabsch on 3000 sets (12 chunks in f64).
  ek_kabsch_set ks;
  ek_kabsch_set_init(&ks, "random", seed, 3000, 64);
  float *kPf = malloc(3 * ks.npoints * sizeof(float)),
        *kQf = malloc(3 * ks.npoints * sizeof(float));
  for (size_t i = 0; i < 3 * ks.npoints; i++) {
    kPf[i] = (float)ks.P[i];
    kQf[i] = (float)ks.Q[i];
  }
  stage_env ste = {sc.el, x, p, xf, pf, sc.t.ntets, ks.nsets, ks.offsets, ks.P, ks.Q, kPf, kQf};
  snprintf(names[nc], sizeof names[nc], "staged: tet L D W, kabsch f32+f64");
  cases[nc] = (kcase){names[nc], run_stage, &ste, stage_bytes(&ste)};
  nc++;

  if (nc != 32 || wrc != 0) { // the calls below name these parts
    printf("%d parts, expected 32; polar guesses rc %d\nFAIL\n", nc, wrc);
    return 1;
  }
  // The calls: parts of one kernel family together.
  const kcall calls[] = {{"fvm snh", &cases[0], 4},
                         {"fvm fixed_corot", &cases[4], 4},
                         {"hessian snh", &cases[8], 2},
                         {"cloth", &cases[10], 2},
                         {"xpbd tets gauss_seidel", &cases[12], 2},
                         {"xpbd tets jacobi", &cases[14], 2},
                         {"svd3", &cases[16], 1},
                         {"xpbd clusters", &cases[17], 4},
                         {"cloth xpbd", &cases[21], 2},
                         {"material, polar warm, staged", &cases[23], 9}};
  const int ncalls = (int)(sizeof calls / sizeof calls[0]);
  const double t_kernels = omp_get_wtime();
  int in_window = 0, probe_bad = 0;
  for (int c = 0; c < ncalls; c++)
    check_case(&calls[c], &in_window, &probe_bad);
  verdict(in_window > 0 && probe_bad == 0,
          "c. window calls returned inside the window: %d of %d; a probe job after them ran alone",
          in_window, 2 * ncalls);
  check_flow_busy(&cases[flow_case]);
  printf("times: a+b %.2f s, c+d %.2f s\n", t_kernels - t_start, omp_get_wtime() - t_kernels);

  free(A);
  free(Af);
  free(xs);
  free(xs2);
  scene_free(&sc2);
  free(cw);
  free(mF), free(mdF), free(wA), free(wG), free(wT), free(wS);
  batch9_in_free(&mFb), batch9_in_free(&mdFb), batch9_in_free(&wAb), batch9_in_free(&wGb);
  ek_kabsch_set_free(&ks);
  free(kPf), free(kQf);
  free(cx);
  free(cxf);
  ek_trimesh_destroy(tm);
  free(x);
  free(p);
  free(xf);
  free(pf);
  scene_free(&sc);
  printf("%s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures != 0;
}
