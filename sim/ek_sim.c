// ek-sim: run a scene with its integrator.
//
//   ek-sim SCENE [--steps N] [--threads N] [--out FILE.h5 | --no-output] [--force]
//          [--explain]
//   ek-sim SCENE --advise [--tol X] [--time S] [--threads N] [--explain]
//
// Prints a progress line, and at the end the time per step split by phase,
// the median, 95th percentile and minimum of the steps' wall times, tets
// per second, the energies at start and end, and the state check (inverted
// elements, NaN/inf, extent) at the last and the worst frame. --explain prints the
// pipeline the scene runs (kernels, variants, why) and runs nothing.
// --advise runs the scene's first S simulated seconds with each candidate
// setting (sim/advise.h), prints the table it decided from (each against
// a converged reference over the whole run, checked, timed repeatedly) and
// the pick by the rule there; with --explain also the
// kernels that choice drops and its pipeline.
// Exit status (sim/cli.h, the same in every ek program): 0 done, 1 the run
// failed (a bad scene or mesh, an element inverted with a model undefined
// there, unwritable output), 2 bad usage; 3 a frame held NaN/inf or the
// positions blew up, 4 the run ended with inverted elements (each unless
// the scene's "allow" key says so). SIGINT, SIGTERM or SIGHUP stops the run
// at the next step: the frames are closed, their count printed, and ek-sim
// dies of that signal.
#include <ek/polar.h>
#include <ek/sim/sim.h>

#include <errno.h>
#include <hdf5.h>
#include <math.h>
#include <omp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "advise.h"
#include "cli.h"
#include "ek_git_revision.h"
#include "implicit_petsc.h"
#include "omp_env.h"
#include "scene_find.h"
#include "sim_internal.h"

// SIGINT / SIGTERM / SIGHUP: the handler only records the signal (async-
// signal-safe); the step loop checks it, stops, and the frames are closed as
// at the end. SIGHUP (the terminal closed) left the frames' scratch files
// behind; it is caught unless ignored (nohup), as the caller asked then.
static volatile sig_atomic_t stop_signal = 0;
static void on_stop_signal(int sig) { stop_signal = sig; }

static void catch_stop_signals(void) {
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART; // file writes in flight are not cut short
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
  struct sigaction hup;
  if (sigaction(SIGHUP, NULL, &hup) == 0 && hup.sa_handler != SIG_IGN)
    sigaction(SIGHUP, &sa, NULL);
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void usage(FILE *out) {
  fprintf(out,
          "usage: ek-sim SCENE [--steps N] [--threads N] [--out FILE.h5 | --no-output] "
          "[--force] [--explain] [--residuals]\n"
          "       ek-sim SCENE --advise [--tol X] [--time S] [--threads N] [--explain]\n"
          "  SCENE         a scene file, or a shipped scene's name (e.g. drop), looked up in\n"
          "                EK_SCENES_DIR if set, else the installed or the source tree's scenes/\n"
          "  --steps N     override the scene's step count\n"
          "  --threads N   OpenMP threads (default: OMP_NUM_THREADS or all cores)\n"
          "  --out FILE.h5 write frames here (overrides the scene's output.file), and\n"
          "                their XDMF (for ParaView) beside it as FILE.xmf\n"
          "  --no-output   write no frames (overrides the scene's output.file)\n"
          "  --force       overwrite existing output files\n"
          "  --explain     print the pipeline the scene runs, run nothing\n"
          "  --residuals   XPBD: print each step's constraint residual (max |C + alpha~ "
          "lambda|\n"
          "                after the last sweep) and its largest C\n"
          "  --advise      run the scene's first S simulated seconds with each candidate\n"
          "                setting (model valid for the strains, rotations and J the scene\n"
          "                reaches, precision, SVD sweeps, loop, its step and iterations),\n"
          "                compare each over the whole run with a converged reference\n"
          "                (explicit f64, dt halved until it moves by <= tol / 10), check it\n"
          "                (inversion, flattening, blow-up, energy), time it repeatedly and\n"
          "                print the table and the pick (rule in the output); progress on\n"
          "                stderr. With --explain: the kernels that choice drops\n"
          "  --tol X       advise: largest deviation accepted, a fraction of the smaller of\n"
          "                the body size and the reference's motion (0 <= X < 1, default 0.01)\n"
          "  --time S      advise: simulated seconds per candidate (from the scene's dt to\n"
          "                1e9 steps of it; default 0.5 or the scene's duration if shorter)\n"
          "  -h, --help    this text\n"
          "  --version     print the version\n"
          "The state is checked at every frame time (with or without --out): the summary\n"
          "gives the inverted elements (J <= 0) and NaN/inf values at the last and the worst\n"
          "frame. Exit 3 when a frame holds NaN/inf or the positions blew up (beyond %g body\n"
          "sizes), 4 when the run ends with inverted elements, unless the scene's \"allow\"\n"
          "key says it studies that (include/ek/sim/scene.h).\n"
          "OMP_PROC_BIND / OMP_PLACES default to close / cores (threads\n"
          "pinned, one per core); values the user set are kept. Meshes below %d tets\n"
          "(%d for the models that take an SVD) run each force evaluation on one\n"
          "thread (EK_FVM_PARALLEL_MIN_TETS in <ek/fvm.h>, fixed when ek is built).\n",
          EK_SIM_BLOWUP_EXTENT, EK_FVM_PARALLEL_MIN_TETS, EK_FVM_PARALLEL_MIN_TETS_SVD);
}

// The frames' name, or their XDMF's, that is an input of the run (the
// scene file or its mesh; stat follows links, so two names of one file
// match): the commit would rename over it (issue 28: --out scene.json
// --force replaced the scene). Returns the input's path, or NULL.
static const char *output_is_input(const char *out, const ek_scene *s) {
  char xdmf[EK_SCENE_PATH_MAX];
  ek_frames_xdmf_path(out, xdmf, sizeof xdmf);
  const char *outs[2] = {out, xdmf};
  const char *ins[2] = {s->path, s->mesh_file};
  for (int i = 0; i < 2; ++i) {
    struct stat so;
    if (stat(outs[i], &so) != 0)
      continue;
    for (int k = 0; k < 2; ++k) {
      struct stat si;
      if (ins[k][0] && stat(ins[k], &si) == 0 && si.st_dev == so.st_dev && si.st_ino == so.st_ino)
        return ins[k];
    }
  }
  return NULL;
}

// An XPBD step runs substeps x iterations sweeps over every constraint,
// whatever the state: their count is known before the run. At 1 ns per
// constraint and sweep (below every measured cost: ek-sim --residuals
// prints the measured one) a step that needs over a minute is warned about
// with the estimate (issue 28: 1e5 substeps x 1e5 iterations were accepted
// without a word). Ctrl-C stops such a step (ek_sim_set_stop_flag).
static void warn_long_xpbd_step(const ek_scene *s, size_t constraints, long steps) {
  const double sweeps = (double)s->xpbd.substeps * (double)s->xpbd.iterations;
  const double seconds = sweeps * (double)constraints * 1e-9;
  char where[EK_SCENE_AT_MAX];
  if (seconds > 60)
    fprintf(stderr,
            "ek-sim: warning: %s: each step runs %ld substeps x %ld iterations = %.3g sweeps "
            "over %zu constraints: at least %.3g s per step (1 ns per constraint and sweep), "
            "%.3g s for the %ld steps\n",
            ek_scene_at(s, s->where.substeps.line ? s->where.substeps : s->where.integrator, where,
                        sizeof where),
            s->xpbd.substeps, s->xpbd.iterations, sweeps, constraints, seconds,
            seconds * (double)steps, steps);
}

// Bytes per tet a box scene takes at least: the peak resident size of
// ek-sim on boxes of 20^3 and 40^3 cells (48 000 and 384 000 tets, fixed
// corotated, f64 and f32) grew by 565 bytes per tet without output and by
// 1290 with it (x86-64, glibc, measured with /usr/bin/time).
#define BOX_BYTES_PER_TET 500.0

// A box that cannot fit in this machine's memory is refused before
// anything is allocated, with the estimate (issue 28: 440^3 cells, 511 M
// tets, passed the scene check and allocated 20 GB before "out of
// memory"). A file mesh is bounded by its file; cloth grids are not
// estimated. 0, or EK_EXIT_FAILED with the message printed.
static int box_fits_memory(const ek_scene *s) {
  if (s->triangles || s->mesh_file[0])
    return 0;
  const double tets = 6.0 * s->box_cells[0] * s->box_cells[1] * s->box_cells[2];
  const double need = BOX_BYTES_PER_TET * tets;
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  const double have = pages > 0 && page > 0 ? (double)pages * (double)page : INFINITY;
  if (need <= have)
    return 0;
  char where[EK_SCENE_AT_MAX];
  fprintf(stderr,
          "ek-sim: %s: mesh.box %d x %d x %d cells = %.3g tets needs at least %.3g GB (%.0f "
          "bytes per tet, measured), more than this machine's %.3g GB of memory\n",
          ek_scene_at(s, s->where.mesh, where, sizeof where), s->box_cells[0], s->box_cells[1],
          s->box_cells[2], tets, need / 1e9, BOX_BYTES_PER_TET, have / 1e9);
  return EK_EXIT_FAILED;
}

// The run, as attributes of the frames file (docs/outputs.md).
static int describe_frames(ek_frames *frames, const ek_scene *s, const ek_sim *sim, char *err,
                           size_t errlen) {
  const ek_frames_info info = {.program = "ek-sim",
                               .scene = s->path,
                               .model = s->model_name,
                               .precision = s->precision == 32 ? "f32" : "f64",
                               .integrator = ek_sim_integrator_name(sim),
                               .git_revision = EK_BUILD_GIT_REVISION};
  if (ek_frames_set_info(frames, &info) == 0)
    return 0;
  snprintf(err, errlen, "%s", ek_last_error());
  return EK_EIO;
}

// The ETA from a running mean of the recent steps' wall times (frames
// included): a mean since the start misleads when the steps change speed
// (issue 23: a 240 s bracket run's ETA said 80 s). The mean is over the
// last ETA_SPAN_S seconds (from (time, step) marks taken every
// ETA_MARK_S), or over the last ETA_MIN_STEPS steps where those seconds
// hold fewer: long enough to average fast steps' jitter and the
// phase-timed step in ten, short enough to follow slow steps.
enum { ETA_MARKS = 32, ETA_MIN_STEPS = 4 };
#define ETA_SPAN_S 5.0
#define ETA_MARK_S 0.25
typedef struct {
  double mark_t[ETA_MARKS]; // a ring of (time, steps done) marks
  long mark_n[ETA_MARKS];
  long nmarks;
  double end[ETA_MIN_STEPS + 1]; // a ring: the end of the last steps
  long n;                        // steps done
} eta_mean;
static void eta_init(eta_mean *e, double t_start) {
  memset(e, 0, sizeof *e);
  e->mark_t[0] = t_start;
  e->nmarks = 1;
  e->end[0] = t_start; // "step 0" ends at the start
}
static void eta_add(eta_mean *e, double t_end) {
  e->n++;
  e->end[e->n % (ETA_MIN_STEPS + 1)] = t_end;
  if (t_end - e->mark_t[(e->nmarks - 1) % ETA_MARKS] >= ETA_MARK_S) {
    e->mark_t[e->nmarks % ETA_MARKS] = t_end;
    e->mark_n[e->nmarks % ETA_MARKS] = e->n;
    e->nmarks++;
  }
}
static double eta_seconds(const eta_mean *e, long remaining) {
  if (e->n == 0)
    return 0;
  const double t = e->end[e->n % (ETA_MIN_STEPS + 1)];
  // The oldest mark within the span.
  long first = e->nmarks > ETA_MARKS ? e->nmarks - ETA_MARKS : 0, m = e->nmarks - 1;
  while (m > first && t - e->mark_t[(m - 1) % ETA_MARKS] <= ETA_SPAN_S)
    m--;
  long k = e->n - e->mark_n[m % ETA_MARKS];
  double span = t - e->mark_t[m % ETA_MARKS];
  if (k < ETA_MIN_STEPS) { // slow steps: the last few
    k = e->n < ETA_MIN_STEPS ? e->n : ETA_MIN_STEPS;
    span = t - e->end[(e->n - k) % (ETA_MIN_STEPS + 1)];
  }
  return span / (double)k * (double)remaining;
}

// A mesh file's vertices that no element uses (stray points, or a file
// whose elements were cut) are accepted, as before, but said once: how
// many and the first (0-based, in the file's order of vertices).
static void warn_unused_vertices(const char *mesh_file, int triangles, size_t unused, size_t nverts,
                                 size_t first) {
  if (unused && mesh_file[0] && implicit_mpi_rank() == 0)
    fprintf(stderr,
            "ek-sim: warning: %s: %zu of %zu vertices belong to no %s (the first: vertex %zu, "
            "counting from 0 in the file's order)\n",
            mesh_file, unused, nverts, triangles ? "triangle" : "tet", first);
}

// The library's pending warning (ek_sim_warning), on its own line.
static void print_sim_warning(ek_sim *sim, int tty) {
  const char *w = ek_sim_warning(sim);
  if (w && implicit_mpi_rank() == 0) // every rank has the same warnings
    fprintf(stderr, "%sek-sim: warning: %s\n", tty ? "\n" : "", w);
}

// The per-frame field buffers (any may be NULL).
// The state check at every frame time (issue 25: no run turns a body
// inside out or writes NaN without saying so): the last check, the worst
// one (most non-finite values, then most inverted elements) and the
// largest extent. Taken with or without frames; with frames, `nonfinite`
// adds the frame fields' own count.
typedef struct {
  long checks, last_step;
  ek_sim_health last, worst;
  double t_last, t_worst, extent_max, t_extent;
  long step_extent; // the frame of extent_max, its farthest vertex and where
  size_t farthest;  // that vertex was then (ek_sim_health.farthest)
  double far_x[3];
  int warned;       // the first frame with NaN / inf was said on stderr
  const char *path; // the scene, for the messages
} state_watch;

static size_t frame_nonfinite(const ek_frame_fields *ff, size_t nv, size_t ne) {
  return ek_count_nonfinite(ff->J, ne) + ek_count_nonfinite(ff->smin, ne) +
         ek_count_nonfinite(ff->psi, ne) + ek_count_nonfinite(ff->smax, ne) +
         ek_count_nonfinite(ff->D, 9 * ne) + ek_count_nonfinite(ff->W, 9 * ne) +
         ek_count_nonfinite(ff->strain_rates, 3 * ne) + ek_count_nonfinite(ff->vertex_R, 9 * nv);
}

// The first NaN / inf of a frame, for the warning: "vertex 3: position
// (nan, 0, 1), ..." from the state (h: ek_sim_check's, its own count),
// else "J of element 7 = -nan" from the fields in the order
// frame_nonfinite counts them. Called once per run (the first frame that
// holds one).
static const char *first_nonfinite(const ek_sim *sim, const ek_sim_health *h,
                                   const ek_frame_fields *ff, size_t nv, size_t ne, char *buf,
                                   size_t len) {
  if (h->nonfinite > 0) { // the state's own (ek_sim_check): named first
    const double *x = ek_sim_positions(sim) + 3 * h->first_nonfinite;
    const double *v = ek_sim_velocities(sim) + 3 * h->first_nonfinite;
    snprintf(buf, len, "vertex %zu: position (%g, %g, %g), velocity (%g, %g, %g)",
             h->first_nonfinite, x[0], x[1], x[2], v[0], v[1], v[2]);
    return buf;
  }
  const struct {
    const char *name;
    const double *a;
    size_t per, n;
  } f[] = {{"J", ff->J, 1, ne},
           {"smin", ff->smin, 1, ne},
           {"psi", ff->psi, 1, ne},
           {"smax", ff->smax, 1, ne},
           {"D", ff->D, 9, ne},
           {"W", ff->W, 9, ne},
           {"strain_rates", ff->strain_rates, 3, ne},
           {"vertex_rotation", ff->vertex_R, 9, nv}};
  for (size_t k = 0; k < sizeof f / sizeof f[0]; ++k)
    for (size_t i = 0; f[k].a && i < f[k].per * f[k].n; ++i)
      if (!isfinite(f[k].a[i])) {
        snprintf(buf, len, "%s of %s %zu = %g", f[k].name, k == 7 ? "vertex" : "element",
                 i / f[k].per, f[k].a[i]);
        return buf;
      }
  snprintf(buf, len, "none found");
  return buf;
}

// Check the state now (ff: the frame's fields just written, or NULL).
static int watch_state(state_watch *w, const ek_sim *sim, long step, const ek_frame_fields *ff,
                       size_t nv, size_t ne, int tty) {
  ek_sim_health h;
  if (ek_sim_check(sim, &h) != 0)
    return -1;
  const size_t state_nonfinite = h.nonfinite;
  if (ff)
    h.nonfinite += frame_nonfinite(ff, nv, ne);
  const double t = ek_sim_time(sim);
  if (h.nonfinite > 0 && !w->warned) {
    w->warned = 1;
    char first[192];
    ek_sim_health hs = h;
    hs.nonfinite = state_nonfinite;
    fprintf(stderr,
            "%sek-sim: warning: %s: the frame at step %ld (t = %g s) holds %zu NaN/inf values "
            "(first: %s)\n",
            tty ? "\n" : "", w->path, step, t, h.nonfinite,
            first_nonfinite(sim, &hs, ff, nv, ne, first, sizeof first));
  }
  if (w->checks == 0 || h.nonfinite > w->worst.nonfinite ||
      (h.nonfinite == w->worst.nonfinite && h.inverted > w->worst.inverted))
    w->worst = h, w->t_worst = t;
  if (w->checks == 0 || !(h.extent <= w->extent_max)) {
    w->extent_max = h.extent, w->t_extent = t, w->step_extent = step, w->farthest = h.farthest;
    memcpy(w->far_x, ek_sim_positions(sim) + 3 * h.farthest, sizeof w->far_x);
  }
  w->last = h, w->t_last = t, w->last_step = step;
  ++w->checks;
  return 0;
}

// The summary's check lines and the verdict: 0, EK_EXIT_NONFINITE or
// EK_EXIT_INVERTED (the scene's "allow" key turns each off).
static int watch_report(const state_watch *w, const ek_scene *s, const ek_sim_elements *el) {
  if (w->checks == 0)
    return 0;
  const char *elem = el->kind;
  const ek_sim_health *l = &w->last, *b = &w->worst;
  if (el->oriented)
    printf("check      last frame (t = %g s): %zu of %zu %s inverted (J <= 0), %zu non-finite "
           "values, extent %.3g body sizes\n",
           w->t_last, l->inverted, l->elements, elem, l->nonfinite, l->extent);
  else // no orientation: no inversion to count
    printf("check      last frame (t = %g s): %zu %s (no orientation: none can invert), %zu "
           "non-finite values, extent %.3g body sizes\n",
           w->t_last, l->elements, elem, l->nonfinite, l->extent);
  printf("           worst frame (t = %g s): %zu inverted, %zu non-finite; largest extent "
         "%.3g (t = %g s), %ld checks\n",
         w->t_worst, b->inverted, b->nonfinite, w->extent_max, w->t_extent, w->checks);
  const int nonfinite = b->nonfinite > 0, blown = !(w->extent_max <= EK_SIM_BLOWUP_EXTENT);
  int rc = 0;
  if (nonfinite || blown) {
    if (s->allow_nonfinite)
      printf("           %s allowed by the scene (allow.nonfinite)\n",
             nonfinite ? "NaN/inf in the frames" : "the blow-up");
    else {
      if (nonfinite)
        fprintf(stderr,
                "ek-sim: %s: FAILED: frames hold NaN/inf (%zu values at t = %g s, %zu at the "
                "last frame)\n",
                s->path, b->nonfinite, w->t_worst, l->nonfinite);
      if (blown)
        fprintf(stderr,
                "ek-sim: %s: FAILED: the positions blew up: at step %ld (t = %g s) vertex %zu "
                "is at (%g, %g, %g), %.3g body sizes from the rest centre (limit %g)\n",
                s->path, w->step_extent, w->t_extent, w->farthest, w->far_x[0], w->far_x[1],
                w->far_x[2], w->extent_max, EK_SIM_BLOWUP_EXTENT);
      rc = EK_EXIT_NONFINITE;
    }
  }
  if (l->inverted > 0) {
    if (s->allow_inverted)
      printf("           inverted elements allowed: the scene studies inversion "
             "(allow.inverted)\n");
    else {
      fprintf(stderr,
              "ek-sim: %s: FAILED: the run ends with %zu of %zu %s INVERTED (J <= 0; at the last "
              "frame, step %ld (t = %g s), the first is element %zu with J = %.3g; worst frame "
              "%zu at t = %g s); a scene that studies inversion says so with \"allow\": "
              "{\"inverted\": true}\n",
              s->path, l->inverted, l->elements, elem, w->last_step, w->t_last, l->first_inverted,
              l->first_inverted_J, b->inverted, w->t_worst);
      if (!rc)
        rc = EK_EXIT_INVERTED;
    }
  }
  return rc;
}

static void free_frame_fields(double *J, double *smin, double *psi, double *smax, double *D,
                              double *W, double *rates, double *vrot) {
  double *bufs[] = {J, smin, psi, smax, D, W, rates, vrot};
  for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; ++i)
    free(bufs[i]);
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

// Median and 95th percentile (nearest rank: the smallest value with at
// least 95% of the samples at or below it) of n > 0 samples; sorts them.
static void median_p95(double *v, size_t n, double *median, double *p95) {
  qsort(v, n, sizeof *v, compare_double);
  *median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  size_t rank = (size_t)ceil(0.95 * (double)n);
  *p95 = v[rank > 0 ? rank - 1 : 0];
}

static int parse_long(const char *opt, const char *s, long lo, long hi, long *out) {
  long v = 0;
  if (!s)
    return ek_cli_usage_error("ek-sim", "%s: needs a value", opt);
  if (ek_cli_parse_long(s, lo, hi, &v)) {
    return ek_cli_usage_error("ek-sim", "%s '%s': expected a whole number in [%ld, %ld]", opt, s,
                              lo, hi);
  }
  *out = v;
  return 0;
}

// A finite number >= lo (> lo when strict).
static int parse_double(const char *opt, const char *s, double lo, int strict, double *out) {
  double v = 0;
  if (!s)
    return ek_cli_usage_error("ek-sim", "%s: needs a value", opt);
  if (ek_cli_parse_double(s, &v) || (strict ? !(v > lo) : !(v >= lo))) {
    return ek_cli_usage_error("ek-sim", "%s '%s': expected a finite number %s %g", opt, s,
                              strict ? ">" : ">=", lo);
  }
  *out = v;
  return 0;
}

static const char *need_text(ek_model_needs need) {
  switch (need) {
  case EK_NEEDS_NOTHING:
    return "no SVD: P is polynomial in F";
  case EK_NEEDS_J:
    return "no SVD: J = det F and F^-T only";
  case EK_NEEDS_POLAR:
    return "SVD for the polar rotation R(F) = U V^T";
  case EK_NEEDS_SVD:
    return "full SVD: singular values clamped at material.clamp (Irving 2004 sec. 5), "
           "P = U P_hat(sigma_hat) V^T";
  case EK_NEEDS_R_INPUT:
    return "no SVD in the force kernel: R^n given per tet, refreshed at step start";
  }
  return "?";
}

// What each pass of a step takes, per loop (issue 26: --explain said "no
// SVD" for stable neo-Hookean and then "the step takes an SVD" in the
// implicit loop, whose gradient pass does take one). A pass the loop does
// not run says so. The rules are ek_trial_uses_svd's (trial.h) for tets.
typedef struct {
  const char *force, *gradient, *hessian, *refresh;
} loop_passes;

static loop_passes passes_of(const ek_scene *s) {
  loop_passes p = {"not run by this loop's step", "none (no Newton solve)", "none (no Hessian)",
                   NULL};
  const ek_model m = s->material.model;
  if (s->triangles) {
    const int arap = m == EK_MODEL_ARAP;
    const char *membrane = arap ? "membrane P = 2 mu (F - R): the 3x2 polar R of each "
                                  "triangle's F (ek_polar32), no 3x3 SVD; bending constant"
                                : "membrane P = F S: no SVD, no polar; bending constant";
    if (s->integrator == EK_INTEGRATOR_XPBD) {
      p.gradient = arap ? "constraint sweeps: C = sqrt(2 W / k) of the ARAP energy: the 3x2 "
                          "polar per triangle, no 3x3 SVD"
                        : "constraint sweeps: C = sqrt(2 W / k) of the StVK energy: no SVD";
    } else {
      p.force = membrane;
      if (s->integrator == EK_INTEGRATOR_IMPLICIT) {
        p.gradient = "the cloth force above (grad E = -f), no element eigensystems";
        p.hessian = arap ? "2 mu (I - dR), dR the 3x2 polar's differential, recomputed per "
                           "product from the last gradient's x"
                         : "dF S + F dS with S's negative eigenvalues set to 0: no SVD";
      }
    }
    return p;
  }
  const ek_model_desc *d = ek_model_describe(m);
  const ek_model_needs need = ek_model_need(m, s->material.clamp);
  if (need == EK_NEEDS_R_INPUT)
    p.refresh = s->polar == EK_POLAR_WARM
                    ? "R^n refresh at step start: the warm polar (no SVD; the SVD polar at the "
                      "first step)"
                    : "R^n refresh at step start: the SVD polar (ek_polar3_f64)";
  if (s->integrator == EK_INTEGRATOR_XPBD) {
    p.gradient = "constraint sweeps: F and the constraints from invariants (StVK: P = F S; "
                 "stable neo-Hookean: C_D, C_H): no SVD";
    return p;
  }
  if (s->integrator == EK_INTEGRATOR_IMPLICIT) {
    p.gradient = d->isotropic ? "SVD3 per tet (f64): the projected Hessian's eigensystem is in "
                                "the U, V frame for every isotropic model, whatever P alone "
                                "needs"
                 : need == EK_NEEDS_R_INPUT ? "no SVD: P from the given R^n"
                                            : "no SVD: P linear in F, a constant Hessian";
    p.hessian = d->isotropic               ? "no SVD: the eigensystems the gradient pass cached"
                : need == EK_NEEDS_R_INPUT ? "no SVD: R^n cached"
                                           : "no SVD: the constant element stiffness";
    return p;
  }
  p.force = need == EK_NEEDS_NOTHING   ? "no SVD: P is polynomial in F"
            : need == EK_NEEDS_J       ? "no SVD: J = det F and F^-T only"
            : need == EK_NEEDS_R_INPUT ? "no SVD: R^n given per tet"
            : need == EK_NEEDS_POLAR && s->polar == EK_POLAR_WARM
                ? "no SVD: R(F) by the warm-started polar (the SVD polar at the first step)"
            : need == EK_NEEDS_POLAR ? "SVD3 for the polar rotation R(F) = U V^T"
                                     : "SVD3: singular values clamped at material.clamp";
  return p;
}

static void print_passes(const ek_scene *s, const char *indent) {
  const loop_passes p = passes_of(s);
  printf("%sforce pass: %s\n", indent, p.force);
  printf("%sgradient pass: %s\n", indent, p.gradient);
  printf("%sHessian products: %s\n", indent, p.hessian);
  if (p.refresh)
    printf("%s%s\n", indent, p.refresh);
}

// The loads, boundary conditions and output of --explain.
static void explain_tail(const ek_scene *s, long steps, const char *out) {
  printf("       gravity (%g, %g, %g), damping c = %g 1/s, dt = %g s, %ld steps (t_end = %g s)\n",
         s->gravity[0], s->gravity[1], s->gravity[2], s->damping, s->dt, steps,
         s->dt * (double)steps);
  for (int b = 0; b < s->nbc; ++b) {
    const ek_scene_bc *c = &s->bc[b];
    printf("       boundary[%d] %s on [%g %g %g]..[%g %g %g]", b,
           c->kind == EK_BC_PIN     ? "pin"
           : c->kind == EK_BC_TWIST ? "twist"
                                    : "stretch",
           c->box_min[0], c->box_min[1], c->box_min[2], c->box_max[0], c->box_max[1],
           c->box_max[2]);
    if (c->kind == EK_BC_TWIST)
      printf(", %g rad/s about (%g, %g, %g) through (%g, %g, %g)", c->rate, c->axis[0], c->axis[1],
             c->axis[2], c->center[0], c->center[1], c->center[2]);
    if (c->kind == EK_BC_STRETCH)
      printf(", velocity (%g, %g, %g)", c->velocity[0], c->velocity[1], c->velocity[2]);
    if (isfinite(c->until))
      printf(", until t = %g then %s", c->until, c->release ? "released" : "held");
    printf("\n");
  }
  if (s->has_ground)
    printf("       ground z = %g: friction-free (project position, zero normal velocity)\n",
           s->ground_height);
  printf("passes     what each pass of the step takes:\n");
  print_passes(s, "             ");
  if (out && out[0])
    printf("output     %s (+ .xmf XDMF) every %ld steps: positions, J, smallest singular value, "
           "energy density from the rest shape (one extra double pass per frame)\n",
           out, s->output_every);
  else
    printf("output     none\n");
}

// A cloth scene's pipeline (cloth_force.h).
static void explain_cloth(const ek_scene *s, long steps, const char *out, int threads) {
  printf("scene      %s\n", s->path);
  if (s->mesh_file[0])
    printf("mesh       triangles from %s\n", s->mesh_file);
  else
    printf("mesh       grid %d x %d cells, %g x %g m in the %s plane -> %ld triangles\n",
           s->grid_cells[0], s->grid_cells[1], s->grid_size[0], s->grid_size[1], s->grid_plane,
           2L * s->grid_cells[0] * s->grid_cells[1]);
  printf("material   %s membrane: mu = %g, lambda = %g Pa, thickness %g m, bending stiffness %g "
         "N m, density %g\n",
         s->model_name, s->material.mu, s->material.lambda, s->thickness, s->bending_stiffness,
         s->density);
  ek_isa isa;
  int isa_ok = ek_isa_resolve(s->svd.isa, &isa) == EK_OK;
  printf("kernels    precision f%d, ISA %s, threads %d (one thread below %d triangles)\n",
         s->precision, isa_ok ? ek_isa_name(isa) : "UNAVAILABLE", threads, 4096);
  printf("integrator %s: %s\n", ek_scene_integrator_name(s->integrator),
         ek_scene_integrator_description(s->integrator));
  printf("pipeline   per step:\n");
  printf("  1. cloth force (ek_cloth_forces_f%d), blocks of %d triangles / hinges:\n"
         "       membrane: gather x -> F = Ds Dm^-1 (3x2) -> P(F) -> -A P Dm^-T to corners\n"
         "       bending (Bergou 2006): gather 4 x -> s = sum k_i x_i -> -k_b k_i s to corners\n"
         "       gather: each vertex sums its corners in element order (deterministic)\n",
         s->precision, s->precision == 32 ? EK_LANES_F32 : EK_LANES_F64);
  ek_scene_integrator_explain(s, stdout, 2);
  explain_tail(s, steps, out);
}

static void explain(const ek_scene *s, long steps, const char *out, int threads) {
  if (s->triangles) {
    explain_cloth(s, steps, out, threads);
    return;
  }
  const ek_material *m = &s->material;
  printf("scene      %s\n", s->path);
  if (s->mesh_file[0])
    printf("mesh       file %s%s\n", s->mesh_file,
           s->fix_orientation ? " (inverted rest tets re-oriented)" : "");
  else
    printf("mesh       box %d x %d x %d cubes, %g x %g x %g m -> %ld tets (6 per cube), "
           "%ld vertices\n",
           s->box_cells[0], s->box_cells[1], s->box_cells[2], s->box_size[0], s->box_size[1],
           s->box_size[2], 6L * s->box_cells[0] * s->box_cells[1] * s->box_cells[2],
           (long)(s->box_cells[0] + 1) * (s->box_cells[1] + 1) * (s->box_cells[2] + 1));
  printf("material   %s: mu = %g, lambda = %g", s->model_name, m->mu, m->lambda);
  if (!isnan(s->young))
    printf(" (from E = %g, nu = %g)", s->young, s->poisson);
  printf(", density %g, clamp %g\n", s->density, m->clamp);
  ek_isa isa;
  int isa_ok = ek_isa_resolve(s->svd.isa, &isa) == EK_OK;
  printf("kernels    precision f%d, ISA %s%s, threads %d\n", s->precision,
         isa_ok ? ek_isa_name(isa) : "UNAVAILABLE",
         s->svd.isa == EK_ISA_AUTO ? " (auto: best this CPU runs)" : " (forced by the scene)",
         threads);
  ek_model_needs need = ek_model_need(m->model, m->clamp);
  long grain = need == EK_NEEDS_POLAR || need == EK_NEEDS_SVD ? EK_FVM_PARALLEL_MIN_TETS_SVD
                                                              : EK_FVM_PARALLEL_MIN_TETS;
  long box_tets = 6L * s->box_cells[0] * s->box_cells[1] * s->box_cells[2];
  if (threads > 1 && !s->mesh_file[0] && box_tets < grain)
    printf("           the force runs on 1 thread: %ld tets, below the parallel grain of %ld "
           "(EK_FVM_PARALLEL_MIN_TETS%s in fvm.h)\n",
           box_tets, grain, grain == EK_FVM_PARALLEL_MIN_TETS ? "" : "_SVD");
  for (int i = EK_ISA_SCALAR; i < EK_ISA_COUNT; ++i)
    if (!ek_isa_available((ek_isa)i))
      printf("           %s: skipped (not built or not supported by this CPU)\n",
             ek_isa_name((ek_isa)i));
  printf("integrator %s: %s\n", ek_scene_integrator_name(s->integrator),
         ek_scene_integrator_description(s->integrator));
  printf("pipeline   per step:\n");
  int k = 1;
  const int warm = s->polar == EK_POLAR_WARM;
  if (need == EK_NEEDS_R_INPUT && warm)
    printf("  %d. R^n refresh (seed 000): F = Ds Dm^-1 in double "
           "(ek_mesh_deformation_gradients_f64), R = polar(F) by the warm polar from R^(n-1) "
           "(ek_polar3_warm_f64, %d iterations; the SVD polar at the first step)\n",
           k++, ek_polar_warm_default_iterations_f64());
  else if (need == EK_NEEDS_R_INPUT)
    printf("  %d. R^n refresh (seed 000): F = Ds Dm^-1 in double "
           "(ek_mesh_deformation_gradients_f64), R = polar(F) (ek_polar3_f64, %d sweeps%s)\n",
           k++, s->svd.sweeps ? s->svd.sweeps : ek_svd3_default_sweeps_f64(),
           s->svd.exact_rsqrt < 0 ? ", approximate rsqrt" : "");
  // The implicit loop's pass is the gradient (hessian.h), which also
  // caches each tet's eigensystem: the isotropic models take an SVD there.
  const int implicit = s->integrator == EK_INTEGRATOR_IMPLICIT;
  const int iso = ek_model_describe(m->model)->isotropic;
  if (s->integrator == EK_INTEGRATOR_XPBD) {
    // XPBD runs its own constraint kernel (xpbd.h), not the force.
    ek_scene_integrator_explain(s, stdout, k);
    explain_tail(s, steps, out);
    return;
  }
  if (implicit)
    printf("  %d. gradient + element eigensystems, fused per block of %d tets "
           "(ek_fvm_hessian_gradient_f64, once per Newton iteration and line-search trial):\n",
           k++, EK_LANES_F64);
  else
    printf("  %d. FVM force (Teran 2003, seed 004), fused per block of %d tets "
           "(ek_fvm_forces_ex_f%d):\n",
           k++, s->precision == 32 ? EK_LANES_F32 : EK_LANES_F64, s->precision);
  printf("       gather x of 4 corners -> F = Ds Dm^-1 -> ");
  const int prec = implicit ? 64 : s->precision;
  if (warm && need == EK_NEEDS_POLAR && !implicit)
    printf("warm polar from the tet's R of the last call (polar.h, %d iterations; kept per "
           "tet) -> ",
           prec == 32 ? ek_polar_warm_default_iterations_f32()
                      : ek_polar_warm_default_iterations_f64());
  else if (need == EK_NEEDS_POLAR || need == EK_NEEDS_SVD || (implicit && iso))
    printf("SVD3 (%d sweeps, %s rsqrt) -> ",
           s->svd.sweeps
               ? s->svd.sweeps
               : (prec == 32 ? ek_svd3_default_sweeps_f32() : ek_svd3_default_sweeps_f64()),
           (s->svd.exact_rsqrt ? s->svd.exact_rsqrt > 0
            : prec == 32       ? ek_svd3_default_exact_rsqrt_f32()
                               : ek_svd3_default_exact_rsqrt_f64())
               ? "exact"
               : "approximate");
  if (implicit) {
    printf("P(F), psi, %s -> G = V0 P Dm^-T -> scatter\n",
           iso ? "U,V-frame eigensystem projected to PSD (20 planes per tet, cached in the "
                 "product's precision)"
           : ek_model_need(m->model, 0) == EK_NEEDS_R_INPUT ? "R^n cached for the products"
                                                            : "(constant Hessian: nothing cached)");
  } else {
    printf("P(F) -> H = -V0 P Dm^-T -> scatter\n");
  }
  if (implicit)
    printf("       %s: P alone needs %s; this pass: %s\n", s->model_name, need_text(need),
           passes_of(s).gradient);
  else
    printf("       %s: %s\n", s->model_name,
           warm && need == EK_NEEDS_POLAR
               ? "no SVD: R(F) by the warm-started polar, P = 2 mu (F - R) + lambda (J - 1) J "
                 "F^-T"
               : need_text(need));
  ek_scatter sc = s->scatter == EK_SCATTER_AUTO ? EK_SCATTER_DEFAULT : s->scatter;
  static const char *why[] = {
      "", "tets of one colour share no vertex: blocks add straight into f, deterministic",
      "per-part force buffers summed in part order: deterministic, extra memory",
      "corner forces to scratch, each vertex sums its list in fixed order: deterministic",
      "atomics: the baseline, summation order varies (not deterministic)"};
  printf("       scatter %s%s: %s\n", ek_scatter_name(sc),
         s->scatter == EK_SCATTER_AUTO ? " (auto)" : "", why[sc]);
  ek_scene_integrator_explain(s, stdout, k);
  explain_tail(s, steps, out);
}

// The implicit loop's summary: time per phase, iterations, convergence,
// and the cost per tet of a Hessian product next to a gradient pass.
static void print_implicit_times(const ek_sim_times *tm, long done, size_t nt) {
  const double n = (double)done;
  const double vals[] = {tm->gradient,   tm->matvec,       tm->preconditioner,
                         tm->cg_vectors, tm->line_search,  tm->integration + tm->polar_refresh,
                         tm->assembly,   tm->solver_setup, tm->solver_solve,
                         tm->mpi_sum};
  const char *names[] = {"gradient+eigensystems",
                         "Hessian products",
                         "preconditioner",
                         "CG vectors",
                         "line search",
                         "integration",
                         "assembly",
                         "setup",
                         "solve",
                         "MPI sums over ranks"};
  // The assembled solvers' phases (linear_solver amg, direct) when they
  // ran, and the ranks' sum when there were ranks.
  const int nph = tm->mpi_sum > 0 ? 10 : tm->assembly > 0 ? 9 : 6;
  double total = 0;
  for (int i = 0; i < nph; i++)
    total += vals[i];
  printf("per step   %.4f ms:", 1e3 * total / n);
  for (int i = 0; i < nph; i++)
    printf("%s %s %.4f ms (%.0f%%)", i ? "," : "", names[i], 1e3 * vals[i] / n,
           100 * vals[i] / total);
  printf("\n");
  printf("newton     %.2f iterations per step, %.1f CG iterations per Newton iteration, %ld "
         "line-search backtracks; residual last %.3g, worst %.3g; %ld of %ld steps stopped "
         "above newton_tol\n",
         (double)tm->newton_iterations / n,
         tm->newton_iterations ? (double)tm->cg_iterations / (double)tm->newton_iterations : 0.0,
         tm->backtracks, tm->last_residual, tm->worst_residual, tm->unconverged_steps, done);
  // An assembled solver (amg, direct) runs no Hessian products: say so, not nan.
  if (tm->matvecs)
    printf("per tet    Hessian product %.2f ns (%ld products), ",
           1e9 * tm->matvec / ((double)tm->matvecs * (double)nt), tm->matvecs);
  else
    printf("per tet    no Hessian products, ");
  printf("gradient+eigensystems pass %.2f ns (%ld passes)",
         1e9 * tm->gradient / ((double)tm->gradient_passes * (double)nt), tm->gradient_passes);
  if (tm->gradient_timed > 0)
    printf("; caching the eigensystems is %.0f%% of a pass (phase-timed steps: a pass without "
           "the cache first)",
           100 * tm->eigensystems / tm->gradient_timed);
  printf("\n");
}

// The step-time line: median, p95 and minimum of the n steps' wall times
// (sorted here), which steps they are in `which`.
static void print_step_times(double *step_s, size_t n, const char *which) {
  if (n == 0)
    return;
  double median, p95;
  median_p95(step_s, n, &median, &p95); // sorted: step_s[0] is the fastest
  printf("step time  median %.4f ms, p95 %.4f ms, min %.4f ms (wall time of each of the %zu %s)\n",
         1e3 * median, 1e3 * p95, 1e3 * step_s[0], n, which);
}

// The XPBD loop's summary: time per step, sweeps, the per-sweep phase
// split (phase-timed steps), and the constraint residual over the steps.
static void print_xpbd_times(const ek_sim_times *tm, long done, size_t ncons, double *res,
                             size_t nres) {
  const double n = (double)done, total = tm->xpbd_solve + tm->integration;
  printf("per step   %.4f ms: solver sweeps %.4f ms (%.0f%%), prediction + velocities %.4f ms; "
         "%.1f sweeps per step, %.2f ns per constraint and sweep\n",
         1e3 * total / n, 1e3 * tm->xpbd_solve / n, 100 * tm->xpbd_solve / total,
         1e3 * tm->integration / n, (double)tm->xpbd_sweeps / n,
         1e9 * tm->xpbd_solve / ((double)tm->xpbd_sweeps * (double)ncons));
  if (tm->xpbd_profiles > 0) {
    const double p = (double)tm->xpbd_profiles,
                 sum = tm->xpbd_sweep_F + tm->xpbd_sweep_eval + tm->xpbd_sweep_project;
    printf("sweep split (separate passes once per phase-timed step, %ld steps): deformation "
           "gradients %.4f ms (%.0f%%), constraint evaluation %.4f ms (%.0f%%), projection "
           "%.4f ms (%.0f%%)\n",
           tm->xpbd_profiles, 1e3 * tm->xpbd_sweep_F / p, 100 * tm->xpbd_sweep_F / sum,
           1e3 * tm->xpbd_sweep_eval / p, 100 * tm->xpbd_sweep_eval / sum,
           1e3 * tm->xpbd_sweep_project / p, 100 * tm->xpbd_sweep_project / sum);
  }
  if (nres > 0) {
    double median, p95;
    median_p95(res, nres, &median, &p95);
    printf("residual   max |C + alpha~ lambda| after the last sweep: last step %.3g (largest C "
           "%.3g), median %.3g, p95 %.3g, worst %.3g over %zu steps\n",
           tm->xpbd_last_residual, tm->xpbd_last_cmax, median, p95, tm->xpbd_worst_residual, nres);
  }
}

// --advise --explain: what the pick leaves out of the scene's own step.
static void explain_drops(const ek_scene *scene, const ek_scene *pick) {
  const ek_scene *both[2] = {scene, pick};
  const char *who[2] = {"scene", "pick"};
  for (int i = 0; i < 2; ++i) {
    const ek_scene *s = both[i];
    printf(
        "%-10s %s, %s loop%s%s, f%d, dt %g: %s\n", who[i], s->model_name,
        ek_scene_integrator_name(s->integrator),
        s->integrator == EK_INTEGRATOR_IMPLICIT ? ", linear_solver " : "",
        s->integrator == EK_INTEGRATOR_IMPLICIT ? ek_linear_solver_name(s->implicit.linear_solver)
                                                : "",
        s->precision, s->dt, ek_trial_uses_svd(s) ? "the step takes an SVD" : "no SVD in the step");
    print_passes(s, "             ");
  }
  int n = 0;
  printf("drops      what the scene's step runs and the pick's does not:");
  if (ek_trial_uses_svd(scene) && !ek_trial_uses_svd(pick))
    n += printf("\n             the SVD3 kernel (%s)",
                ek_model_need(scene->material.model, scene->material.clamp) == EK_NEEDS_POLAR
                    ? "polar R(F) = U V^T"
                    : "singular values and rotations") > 0;
  else if (ek_trial_uses_svd(pick) &&
           (pick->svd.sweeps != scene->svd.sweeps || pick->svd.refine != scene->svd.refine ||
            pick->svd.exact_rsqrt != scene->svd.exact_rsqrt))
    n += printf("\n             SVD sweeps: %d%s -> %d%s (0 = the precision's default)",
                scene->svd.sweeps,
                scene->svd.refine == EK_SVD3_REFINE_NONE ? " without refinement" : "",
                pick->svd.sweeps,
                pick->svd.refine == EK_SVD3_REFINE_NONE ? " without refinement" : "") > 0;
  if (scene->integrator == EK_INTEGRATOR_IMPLICIT && pick->integrator != EK_INTEGRATOR_IMPLICIT)
    n += printf("\n             Newton: the gradient + eigensystem passes, Hessian products, PCG "
                "and line "
                "search") > 0;
  // The solver axis (issue 24): an implicit pick with another linear solver.
  const ek_linear_solver ls_scene = scene->integrator == EK_INTEGRATOR_IMPLICIT
                                        ? scene->implicit.linear_solver
                                        : EK_LINSOLVE_COUNT,
                         ls_pick = pick->integrator == EK_INTEGRATOR_IMPLICIT
                                       ? pick->implicit.linear_solver
                                       : EK_LINSOLVE_COUNT;
  if (ls_scene == EK_LINSOLVE_MATRIX_FREE && ls_pick != EK_LINSOLVE_COUNT &&
      ls_pick != EK_LINSOLVE_MATRIX_FREE)
    n += printf("\n             the matrix-free Hessian products and their PCG (linear_solver %s "
                "instead: the projected element Hessians assembled, then %s)",
                ek_linear_solver_name(ls_pick),
                ls_pick == EK_LINSOLVE_AMG ? "PETSc CG + GAMG" : "PETSc sparse Cholesky") > 0;
  else if (ls_scene != EK_LINSOLVE_COUNT && ls_pick != EK_LINSOLVE_COUNT && ls_scene != ls_pick)
    n += printf("\n             the linear solver: %s -> %s", ek_linear_solver_name(ls_scene),
                ek_linear_solver_name(ls_pick)) > 0;
  if (scene->integrator == EK_INTEGRATOR_XPBD && pick->integrator != EK_INTEGRATOR_XPBD)
    n += printf("\n             the XPBD constraint sweeps") > 0;
  if (scene->integrator == EK_INTEGRATOR_EXPLICIT && pick->integrator != EK_INTEGRATOR_EXPLICIT)
    n += printf("\n             the %g s explicit steps (%.0f per simulated s -> %.0f)", scene->dt,
                1 / scene->dt, 1 / pick->dt) > 0;
  if (scene->integrator == pick->integrator && scene->dt != pick->dt)
    n += printf("\n             the step: dt %g -> %g (%.3g x the steps per simulated s)",
                scene->dt, pick->dt, scene->dt / pick->dt) > 0;
  if (scene->integrator == EK_INTEGRATOR_XPBD && pick->integrator == EK_INTEGRATOR_XPBD &&
      (scene->xpbd.substeps != pick->xpbd.substeps ||
       scene->xpbd.iterations != pick->xpbd.iterations))
    n += printf("\n             XPBD sweeps: %ld substeps x %ld iterations -> %ld x %ld",
                scene->xpbd.substeps, scene->xpbd.iterations, pick->xpbd.substeps,
                pick->xpbd.iterations) > 0;
  if (scene->precision == 64 && pick->precision == 32)
    n += printf("\n             the f64 kernels (f32 variants instead)") > 0;
  if (scene->precision == 32 && pick->precision == 64)
    n += printf("\n             (adds: f64 kernels instead of f32)") > 0;
  if (pick->integrator == EK_INTEGRATOR_IMPLICIT && scene->integrator == EK_INTEGRATOR_IMPLICIT &&
      pick->implicit.max_newton < scene->implicit.max_newton)
    n += printf("\n             Newton iterations beyond %ld per step", pick->implicit.max_newton) >
         0;
  printf("%s\n", n ? "" : " nothing (the pick runs the scene's kernels)");
}

// ek-sim SCENE --advise: the table and the pick (sim/advise.h); 0 or
// EK_EXIT_FAILED.
static int run_advise(const ek_scene *scene, double tol, double sim_time, int do_explain,
                      int threads) {
  if (scene->triangles) {
    char where[EK_SCENE_AT_MAX];
    fprintf(stderr, "ek-sim: %s: mesh: --advise takes tet scenes only (this is a cloth)\n",
            ek_scene_at(scene, scene->where.mesh, where, sizeof where));
    return EK_EXIT_FAILED;
  }
  char err[1024];
  ek_mesh *mesh = ek_scene_mesh(scene);
  if (!mesh) {
    fprintf(stderr, "ek-sim: %s\n", ek_last_error());
    return EK_EXIT_FAILED;
  }
  size_t first = 0, unused = sim_count_unused(ek_mesh_nverts(mesh), ek_mesh_tets(mesh),
                                              ek_mesh_ntets(mesh), 4, &first);
  warn_unused_vertices(scene->mesh_file, 0, unused, ek_mesh_nverts(mesh), first);
  printf("ek-sim %s --advise: %zu vertices, %zu tets, model %s, integrator %s, f%d, dt %g\n",
         scene->path, ek_mesh_nverts(mesh), ek_mesh_ntets(mesh), scene->model_name,
         ek_scene_integrator_name(scene->integrator), scene->precision, scene->dt);
  fflush(stdout);
  ek_advise_opts o = {.tol = tol, .sim_time = sim_time, .progress = stderr};
  ek_advice a;
  if (ek_advise(scene, mesh, &o, &a, err, sizeof err) != 0) {
    fprintf(stderr, "ek-sim: %s\n", err);
    ek_mesh_destroy(mesh);
    return EK_EXIT_FAILED;
  }
  ek_advice_print(&a, stdout);
  if (do_explain && a.pick >= 0) {
    const ek_scene *pick = &a.rows[a.pick].setting;
    explain_drops(scene, pick);
    printf("the pick's pipeline:\n");
    explain(pick, (long)ceil(sim_time / pick->dt - 1e-9), NULL, threads);
  }
  ek_advice_free(&a);
  ek_mesh_destroy(mesh);
  return 0;
}

static int run(int argc, char **argv);

int main(int argc, char **argv) {
  if (omp_env_check_threads("ek-sim"))
    return EK_EXIT_USAGE;
  omp_env_defaults("ek-sim", argv);
  // HDF5 before 1.14.1 frees a file whose close failed (a full disk) but
  // keeps its ID, and its exit handler then closes that ID again: SIGSEGV
  // at exit after a correct message (issue 28; HDFGroup/hdf5 PR 2496).
  // ek-sim closes every file it opens itself, so the handler has nothing
  // to do: not installing it (before HDF5's first call) removes the crash.
  H5dont_atexit();
  // Under mpirun with more than one process: MPI and PETSc start here
  // (implicit_petsc.h; a plain run starts nothing). Every rank runs the
  // scene (the implicit loop splits its elements and its solve, sim/
  // README.md "MPI"); rank 0 alone prints the summary and writes frames.
  char err[512];
  if (implicit_mpi_start(err, sizeof err) < 0) {
    fprintf(stderr, "ek-sim: %s\n", err);
    return EK_EXIT_FAILED;
  }
  int rc = run(argc, argv);
  // A rank that failed ends every rank (the others may wait in a
  // collective call for it); else all finish together.
  implicit_mpi_finish(rc);
  return rc;
}

static int run(int argc, char **argv) {
  const int rank = implicit_mpi_rank();
  if (rank > 0 && !freopen("/dev/null", "w", stdout)) {
    fprintf(stderr, "ek-sim: MPI rank %d: cannot silence its stdout\n", rank);
    return EK_EXIT_FAILED;
  }
  const char *scene_path = NULL, *out = NULL;
  long steps = -1, threads = 0;
  int force = 0, do_explain = 0, no_output = 0, residuals = 0, advise = 0;
  double tol = EK_ADVISE_TOL_DEFAULT, sim_time = NAN;
  const char *tol_arg = NULL;
  for (int i = 1; i < argc; ++i) {
    const char *a = argv[i];
    ek_cli_common("ek-sim", a, usage);
    if (strcmp(a, "--steps") == 0) {
      if (parse_long(a, i + 1 < argc ? argv[++i] : NULL, 0, 1000000000L, &steps))
        return EK_EXIT_USAGE;
    } else if (strcmp(a, "--threads") == 0) {
      if (parse_long(a, i + 1 < argc ? argv[++i] : NULL, 1, 4096, &threads))
        return EK_EXIT_USAGE;
    } else if (strcmp(a, "--out") == 0) {
      if (i + 1 >= argc || !argv[i + 1][0])
        return ek_cli_usage_error("ek-sim", "--out needs a file name");
      out = argv[++i];
    } else if (strcmp(a, "--no-output") == 0) {
      no_output = 1;
    } else if (strcmp(a, "--force") == 0) {
      force = 1;
    } else if (strcmp(a, "--explain") == 0) {
      do_explain = 1;
    } else if (strcmp(a, "--residuals") == 0) {
      residuals = 1;
    } else if (strcmp(a, "--advise") == 0) {
      advise = 1;
    } else if (strcmp(a, "--tol") == 0) {
      tol_arg = a;
      if (parse_double(a, i + 1 < argc ? argv[++i] : NULL, 0, 0, &tol))
        return EK_EXIT_USAGE;
      if (!(tol < 1)) // holding every vertex still deviates by 1 (advise.h)
        return ek_cli_usage_error("ek-sim", "--tol %g: expected a number in [0, 1)", tol);
    } else if (strcmp(a, "--time") == 0) {
      if (parse_double(a, i + 1 < argc ? argv[++i] : NULL, 0, 1, &sim_time))
        return EK_EXIT_USAGE;
    } else if (a[0] == '-' || scene_path) {
      return ek_cli_usage_error("ek-sim", "unexpected argument \"%s\"", a);
    } else {
      scene_path = a;
    }
  }
  if (!scene_path)
    return ek_cli_usage_error("ek-sim", "no SCENE given");
  if (out && no_output)
    return ek_cli_usage_error("ek-sim", "--out and --no-output exclude each other");
  if (!advise && (tol_arg || !isnan(sim_time)))
    return ek_cli_usage_error("ek-sim", "%s is an option of --advise",
                              tol_arg ? "--tol" : "--time");
  if (advise && implicit_mpi_size() > 1)
    return ek_cli_usage_error("ek-sim", "--advise runs on one process: drop mpirun");
  if (advise && (out || steps >= 0 || force || residuals))
    return ek_cli_usage_error("ek-sim", "--advise writes no frames and runs by --time: drop %s",
                              out          ? "--out"
                              : steps >= 0 ? "--steps"
                              : force      ? "--force"
                                           : "--residuals");
  // Every EK_* variable: unset, empty or one of its values (exit 2 as for a
  // bad EK_ISA, before the scene is read).
  if (ek_cli_env_check("ek-sim"))
    return EK_EXIT_USAGE;
  char err[1024];
  // SCENE is a file, or the name of a shipped scene ("drop"), found in the
  // build or the installed tree (scene_find.h).
  char found[EK_SCENE_PATH_MAX];
  if (ek_scene_arg(scene_path, found, sizeof found, err, sizeof err) != 0) {
    fprintf(stderr, "ek-sim: %s\n", err);
    return 1;
  }
  scene_path = found;
  static ek_scene scene;
  if (ek_scene_load(scene_path, &scene) != 0) {
    fprintf(stderr, "ek-sim: %s\n", ek_last_error());
    return 1;
  }
  // An ISA the CPU lacks (the scene's or EK_ISA's) stops here, before any
  // output exists.
  ek_isa isa;
  char where[EK_SCENE_AT_MAX];
  if (ek_isa_resolve(scene.svd.isa, &isa) != EK_OK) {
    // EK_ISA is part of the invocation (usage); the scene's isa key is input.
    if (scene.svd.isa == EK_ISA_AUTO)
      return ek_cli_usage_error("ek-sim", "%s", ek_last_error());
    fprintf(stderr, "ek-sim: %s: isa: %s\n",
            ek_scene_at(&scene, scene.where.isa, where, sizeof where), ek_last_error());
    return EK_EXIT_FAILED;
  }
  // A scene that names its ISA and an EK_ISA that forces another: the
  // scene's would run while EK_VERBOSE reports EK_ISA's (issue 28). Both
  // are explicit requests; neither silently wins.
  const char *env_isa = getenv("EK_ISA");
  ek_isa forced;
  if (scene.svd.isa != EK_ISA_AUTO && env_isa && env_isa[0] &&
      ek_isa_resolve(EK_ISA_AUTO, &forced) == EK_OK && forced != isa)
    return ek_cli_usage_error("ek-sim",
                              "EK_ISA=%s forces %s but %s names isa \"%s\": unset EK_ISA or "
                              "drop the scene's isa key",
                              env_isa, ek_isa_name(forced),
                              ek_scene_at(&scene, scene.where.isa, where, sizeof where),
                              ek_isa_name(isa));
  if (steps < 0)
    steps = scene.steps;
  if (!out && !no_output && scene.output_file[0])
    out = scene.output_file;
  if (rank > 0)
    out = NULL; // rank 0 writes the frames; the others never open them
  const char *input = out ? output_is_input(out, &scene) : NULL;
  if (input && out == scene.output_file) {
    fprintf(stderr,
            "ek-sim: %s: output.file \"%s\" names the input %s; refusing to write "
            "frames over it\n",
            ek_scene_at(&scene, scene.where.output_file, where, sizeof where), out, input);
    return EK_EXIT_FAILED;
  }
  if (input)
    return ek_cli_usage_error("ek-sim",
                              "--out %s names the input %s; refusing to write frames "
                              "over it",
                              out, input);
  // The name is the HDF5 file's; its XDMF goes beside it (FILE.h5 ->
  // FILE.xmf). A name ending in .xmf put HDF5 into FILE.xmf and the XDMF
  // into FILE.xmf.xmf, which ParaView would be pointed at wrongly.
  size_t out_len = out ? strlen(out) : 0;
  if (out_len >= 4 && !strcmp(out + out_len - 4, ".xmf")) {
    if (out != scene.output_file)
      return ek_cli_usage_error("ek-sim",
                                "--out %s: names the HDF5 file (FILE.h5); its XDMF FILE.xmf "
                                "is written beside it",
                                out);
    fprintf(stderr,
            "ek-sim: %s: output.file \"%s\": names the HDF5 file (FILE.h5); its XDMF FILE.xmf "
            "is written beside it\n",
            ek_scene_at(&scene, scene.where.output_file, where, sizeof where), out);
    return EK_EXIT_FAILED;
  }
  if (threads > 0)
    omp_set_num_threads((int)threads);
  int nthreads = omp_get_max_threads();
  if (advise && box_fits_memory(&scene) != 0)
    return EK_EXIT_FAILED;
  if (advise) {
    const double duration = scene.dt * (double)scene.steps;
    if (isnan(sim_time))
      sim_time = duration < EK_ADVISE_TIME_DEFAULT ? duration : EK_ADVISE_TIME_DEFAULT;
    else if (sim_time < scene.dt || sim_time / scene.dt > (double)EK_TRIAL_MAX_STEPS)
      return ek_cli_usage_error("ek-sim",
                                "--time %g: expected from the scene's dt %g (one step) to %ld "
                                "steps of it (%g s)",
                                sim_time, scene.dt, EK_TRIAL_MAX_STEPS,
                                scene.dt * (double)EK_TRIAL_MAX_STEPS);
    if (!do_explain) // the trials write no file: an interruption loses the table
      ek_cli_stop_notice("ek-sim --advise", NULL, NULL,
                         "no advice (the table and the pick come at the end)");
    return run_advise(&scene, tol, sim_time, do_explain, nthreads);
  }
  if (do_explain) {
    explain(&scene, steps, out, nthreads);
    return 0;
  }
  if (box_fits_memory(&scene) != 0)
    return EK_EXIT_FAILED;
  // The frames' folder, before the setup (seconds for a big mesh), named
  // as ek-bench names it, not through the frames' scratch file; a run that
  // writes nothing (--explain, --advise) needs none.
  char folder[EK_SCENE_PATH_MAX];
  int folder_errno = out ? ek_cli_folder_error(out, folder, sizeof folder) : 0;
  if (folder_errno) {
    if (out == scene.output_file)
      fprintf(stderr, "ek-sim: %s: output.file \"%s\": cannot write to folder '%s': %s\n",
              ek_scene_at(&scene, scene.where.output_file, where, sizeof where), out, folder,
              strerror(folder_errno));
    else
      fprintf(stderr, "ek-sim: --out %s: cannot write to folder '%s': %s\n", out, folder,
              strerror(folder_errno));
    return EK_EXIT_FAILED;
  }

  // Everything that can refuse is checked before the first step.
  double t_setup = now();
  // The sim builds the scene's mesh, whichever its element kind, and owns
  // it; ek-sim reads the elements through ek_sim_elements.
  ek_sim *sim = ek_sim_create_scene(&scene);
  if (!sim) {
    fprintf(stderr, "ek-sim: %s\n", ek_last_error());
    return 1;
  }
  print_sim_warning(sim, 0);
  ek_sim_elements el;
  ek_sim_elements_of(sim, &el);
  {
    size_t first = 0, nverts = 0, unused = sim_unused_vertices(sim, &first, &nverts);
    warn_unused_vertices(scene.mesh_file, scene.triangles, unused, nverts, first);
  }
  const char *elem = el.kind;
  size_t nv = el.nverts, nt = el.count;
  // Wall time of each step that ran the fused force kernel (one in ten runs
  // the phases as separate passes, for the split): their median and p95.
  double *step_s = malloc((size_t)(steps > 0 ? steps : 1) * sizeof(double));
  size_t nstep_s = 0, nres = 0;
  const int xpbd = scene.integrator == EK_INTEGRATOR_XPBD;
  double *res = malloc((size_t)(steps > 0 ? steps : 1) * sizeof(double));
  if (!step_s || !res) {
    free(step_s);
    free(res);
    fprintf(stderr, "ek-sim: out of memory for %ld step times\n", steps);
    ek_sim_destroy(sim);
    return 1;
  }
  double *J = NULL, *smin = NULL, *psi = NULL, *smax = NULL, *Drate = NULL, *Wrate = NULL,
         *rates = NULL, *vrot = NULL;
  ek_frames *frames = NULL;
  catch_stop_signals();
  // The step looks at the flag too (between sweeps, Newton and CG
  // iterations), so a long step ends within about a second of the signal.
  ek_sim_set_stop_flag(sim, &stop_signal);
  if (xpbd)
    warn_long_xpbd_step(&scene, ek_sim_xpbd_constraints(sim), steps);
  if (out) {
    frames = ek_frames_create_ex(out, force, nv, el.rest, nt, el.corners, el.incidence);
    J = malloc(nt * sizeof(double));
    smin = malloc(nt * sizeof(double));
    psi = malloc(nt * sizeof(double));
    smax = malloc(nt * sizeof(double));
    Drate = malloc(9 * nt * sizeof(double));
    Wrate = malloc(9 * nt * sizeof(double));
    rates = malloc(3 * nt * sizeof(double));
    vrot = malloc(9 * nv * sizeof(double));
    if (!frames || !J || !smin || !psi || !smax || !Drate || !Wrate || !rates || !vrot) {
      fprintf(stderr, "ek-sim: %s\n", frames ? "out of memory" : ek_last_error());
      ek_frames_close(frames);
      free_frame_fields(J, smin, psi, smax, Drate, Wrate, rates, vrot);
      free(step_s);
      free(res);
      ek_sim_destroy(sim);
      return 1;
    }
    if (describe_frames(frames, &scene, sim, err, sizeof err) != 0)
      fprintf(stderr, "ek-sim: warning: %s (the frames are written without them)\n", err);
  }
  t_setup = now() - t_setup;
  char body[160];
  // Across MPI ranks the times below are rank 0's (its elements' passes,
  // the parallel solve's wall time).
  char ranks[48] = "";
  if (implicit_mpi_size() > 1)
    snprintf(ranks, sizeof ranks, " on each of %d MPI ranks", implicit_mpi_size());
  printf("ek-sim %s: %zu vertices, %s, integrator %s, f%d, %d threads%s, dt %g (CFL limit %g), "
         "%ld steps\n",
         scene.path, nv, ek_sim_describe(sim, body, sizeof body), ek_sim_integrator_name(sim),
         scene.precision, nthreads, ranks, scene.dt, ek_sim_cfl_dt(sim), steps);
  ek_sim_energies e0, e1;
  ek_sim_energy(sim, &e0);

  double t_output = 0;
  int rc = 0, tty = isatty(fileno(stderr));
  double t_start = now(), t_last_progress = t_start;
  eta_mean eta_steps;
  eta_init(&eta_steps, t_start);
  state_watch watch = {.path = scene.path};
  long stopped_at = -1;   // the step a signal stopped the run before
  int stopped_inside = 0; // ... inside step stopped_at + 1 (not applied)
  for (long n = 0; n <= steps; ++n) {
    if (stop_signal) {
      stopped_at = n;
      break;
    }
    const int frame_time = n % scene.output_every == 0 || n == steps;
    const ek_frame_fields ff = {J, smin, psi, el.has_smax ? smax : NULL, Drate, Wrate, rates, vrot};
    if (frames && frame_time) {
      double t0 = now();
      if (ek_sim_fields(sim, J, smin, psi, smax) != 0 ||
          ek_sim_rate_fields(sim, Drate, Wrate, rates) != 0 ||
          ek_sim_vertex_rotations(sim, vrot) != 0 ||
          ek_frames_write_fields(frames, ek_sim_time(sim), n, ek_sim_positions(sim), &ff) != 0) {
        fprintf(stderr, "%sek-sim: %s: the frame after step %ld (t = %g s): %s\n", tty ? "\n" : "",
                scene.path, n, ek_sim_time(sim), ek_last_error());
        rc = EK_EXIT_FAILED;
        break;
      }
      t_output += now() - t0;
    }
    if (frame_time && watch_state(&watch, sim, n, frames ? &ff : NULL, nv, nt, tty) != 0) {
      fprintf(stderr, "\nek-sim: %s\n", ek_last_error());
      rc = EK_EXIT_FAILED;
      break;
    }
    if (n == steps)
      break;
    // One step in ten runs the force phases as separate passes, for the
    // split; the other nine are the fused kernel the timing reports.
    int phase_timed = n % 10 == 5;
    ek_sim_time_phases(sim, phase_timed);
    double t_step = now();
    int src = ek_sim_step(sim);
    t_step = now() - t_step;
    if (src == EK_SIM_ESTOPPED) {
      stopped_at = n;
      stopped_inside = 1;
      break;
    }
    if (src != 0) {
      fprintf(stderr, "%sek-sim: %s: %s\n", tty ? "\n" : "", scene.path, ek_last_error());
      rc = EK_EXIT_FAILED;
      break;
    }
    print_sim_warning(sim, tty);
    if (!phase_timed)
      step_s[nstep_s++] = t_step;
    if (xpbd) {
      const ek_sim_times *tm = ek_sim_timings(sim);
      res[nres++] = tm->xpbd_last_residual;
      if (residuals)
        printf("step %ld t %.6g residual %.6g cmax %.6g\n", n + 1, ek_sim_time(sim),
               tm->xpbd_last_residual, tm->xpbd_last_cmax);
    }
    double t = now();
    eta_add(&eta_steps, t);
    if (rank == 0 && (t - t_last_progress > 0.5 || n + 1 == steps)) {
      t_last_progress = t;
      double frac = (double)(n + 1) / (double)steps;
      double eta = eta_seconds(&eta_steps, steps - (n + 1));
      if (tty)
        fprintf(stderr, "\r  step %ld / %ld  (%5.1f%%)  t = %.4g s  eta %.1f s   ", n + 1, steps,
                100.0 * frac, ek_sim_time(sim), eta);
      else if ((n + 1) % (steps / 10 > 0 ? steps / 10 : 1) == 0)
        fprintf(stderr, "  step %ld / %ld  (%5.1f%%)  t = %.4g s  eta %.1f s\n", n + 1, steps,
                100.0 * frac, ek_sim_time(sim), eta);
    }
  }
  double wall = now() - t_start;
  if (tty)
    fprintf(stderr, "\n");
  const int wrote_frames = frames != NULL;
  long nframes = frames ? ek_frames_count(frames) : 0;
  if (frames) {
    if (ek_frames_close(frames) != 0) {
      fprintf(stderr, "ek-sim: %s\n", ek_last_error());
      rc = EK_EXIT_FAILED;
    }
    char xdmf[EK_SCENE_PATH_MAX];
    ek_frames_xdmf_path(out, xdmf, sizeof xdmf);
    // A run that ended early (a signal, a failed step) wrote a partial
    // series: said here, next to the count.
    const long ran = ek_sim_steps_done(sim);
    if (ran < steps)
      printf("frames     %ld written to %s (ParaView: %s); partial: the run ended after step "
             "%ld of %ld (t = %g s)\n",
             nframes, out, xdmf, ran, steps, ek_sim_time(sim));
    else
      printf("frames     %ld written to %s (ParaView: %s)\n", nframes, out, xdmf);
  }
  if (stopped_at >= 0)
    fprintf(stderr, "ek-sim: stopped by %s %s step %ld of %ld; %ld frames written%s%s%s\n",
            stop_signal == SIGINT    ? "SIGINT"
            : stop_signal == SIGTERM ? "SIGTERM"
                                     : "SIGHUP",
            stopped_inside ? "inside (not applied)" : "before", stopped_at + stopped_inside, steps,
            nframes, wrote_frames ? " to " : "", wrote_frames ? out : "",
            wrote_frames ? " (file closed, a partial series)" : "");

  const ek_sim_times *tm = ek_sim_timings(sim);
  long done = tm->steps, fused = tm->steps - tm->phase_timed_steps;
  ek_sim_energy(sim, &e1);
  printf("steps      %ld in %.3f s (setup %.3f s, output %.3f s)\n", done, wall, t_setup, t_output);
  if (done > 0 && xpbd) {
    print_xpbd_times(tm, done, ek_sim_xpbd_constraints(sim), res, nres);
    print_step_times(step_s, nstep_s, "steps not phase-timed");
  } else if (done > 0 && tm->gradient_passes > 0) {
    print_implicit_times(tm, done, nt);
    print_step_times(step_s, nstep_s, "steps not phase-timed");
  } else if (done > 0) {
    double force_ms = fused > 0 ? 1e3 * tm->forces / (double)fused : NAN;
    double integ_ms = 1e3 * tm->integration / (double)done;
    double polar_ms = 1e3 * tm->polar_refresh / (double)done;
    double step_ms = (fused > 0 ? force_ms : 0) + integ_ms + polar_ms;
    printf("per step   %.4f ms: force %.4f ms (fused kernel, %ld steps), integration %.4f ms",
           step_ms, force_ms, fused, integ_ms);
    if (polar_ms > 0)
      printf(", R^n refresh %.4f ms", polar_ms);
    printf("\n");
    print_step_times(step_s, nstep_s, "fused-kernel steps");
    const char *names[EK_SIM_MAX_PHASES];
    double vals[EK_SIM_MAX_PHASES];
    const int nphases = ek_sim_force_phases(sim, names, vals, EK_SIM_MAX_PHASES);
    double phase_sum = 0;
    for (int i = 0; i < nphases; ++i)
      phase_sum += vals[i];
    if (tm->phase_timed_steps > 0 && phase_sum > 0) {
      double p = (double)tm->phase_timed_steps;
      printf("force split (separate passes on %ld steps, %.4f ms per step; shares applied to "
             "the fused time):\n",
             tm->phase_timed_steps, 1e3 * phase_sum / p);
      for (int i = 0; i < nphases; ++i)
        printf("  %-22s %5.1f%%  %.4f ms separate, ~%.4f ms fused\n", names[i],
               100.0 * vals[i] / phase_sum, 1e3 * vals[i] / p,
               fused > 0 ? force_ms * vals[i] / phase_sum : NAN);
    }
    printf("throughput %.3g %s/s (whole step), %.3g %s/s (force kernel)\n",
           (double)nt / (step_ms * 1e-3), elem, fused > 0 ? (double)nt / (force_ms * 1e-3) : NAN,
           elem);
  }
  printf("energy     start: kinetic %.6g, elastic %.6g, potential %.6g, total %.6g J\n", e0.kinetic,
         e0.elastic, e0.potential, e0.kinetic + e0.elastic + e0.potential);
  printf("           end:   kinetic %.6g, elastic %.6g, potential %.6g, total %.6g J "
         "(t = %g s)\n",
         e1.kinetic, e1.elastic, e1.potential, e1.kinetic + e1.elastic + e1.potential,
         ek_sim_time(sim));
  // A run that ended between frame times (a failed step, a signal) is
  // checked where it stopped too.
  if (rc != EK_EXIT_FAILED && ek_sim_steps_done(sim) != watch.last_step &&
      watch_state(&watch, sim, ek_sim_steps_done(sim), NULL, nv, nt, 0) != 0) {
    fprintf(stderr, "ek-sim: %s\n", ek_last_error());
    rc = EK_EXIT_FAILED;
  }
  const int verdict = watch_report(&watch, &scene, &el);
  if (rc == 0)
    rc = verdict;
  free_frame_fields(J, smin, psi, smax, Drate, Wrate, rates, vrot);
  free(step_s);
  free(res);
  ek_sim_destroy(sim);
  if (stopped_at >= 0) {
    // Die of the signal, as the caller asked, now that everything is
    // closed: a shell or a job runner sees the signal, not an exit code.
    fflush(stdout);
    fflush(stderr);
    signal(stop_signal, SIG_DFL);
    raise(stop_signal);
  }
  return rc;
}
