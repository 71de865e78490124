// FVM force driver (ek_fvm_tet_* API on the element layer; sim/fvm_mesh.c
// forwards the ek_mesh forms): argument checks and dispatch; the scatter
// strategies (scatter.c) decide which thread adds what where, and the block
// kernel in fvm_block.c does one range of blocks. Built once per precision.
//
// Threads: THREAD_BUFFERS (the default) runs as two jobs of the helper
// team (kernels/team.h: parts, then sums; the caller never waits for a
// thread that has not started), the other strategies as team jobs too; a
// mesh below EK_FVM_PARALLEL_MIN_TETS(_SVD) runs on the calling thread
// alone (waking a second thread costs more than it saves there). Every strategy but ATOMIC gives
// the same bits for any thread count (scatter.h).
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include <ek/fvm.h>
#include <ek/polar.h>
#include <ek/svd3.h>

#include "../elements/tets.h"
#include "../kernels.h"
#include "../material/models.h"
#include "../real.h"
#include "../team.h"
#include "fvm_kernel.h"
#include "scatter.h"

#if defined(EK_REAL_F32)
typedef struct ek_fvm_args_f32 fvm_args;
#define BL_IDX(bl) ((bl)->idx_f32)
#define BL_DMI(bl) ((bl)->dm_inv_f32)
#define BL_V0(bl) ((bl)->v0_f32)
#else
typedef struct ek_fvm_args_f64 fvm_args;
#define BL_IDX(bl) ((bl)->idx_f64)
#define BL_DMI(bl) ((bl)->dm_inv_f64)
#define BL_V0(bl) ((bl)->v0_f64)
#endif
#define L EK_LANES

// Whether a force evaluation runs on more than one thread (fvm.h: the
// models that take an SVD cost several times more per tet).
static int parallel_for(const ek_tets *el, const ek_material *mat) {
  return el->ntets >= (ek_model_row_uses_sigma(mat->model, mat->clamp)
                           ? EK_FVM_PARALLEL_MIN_TETS_SVD
                           : EK_FVM_PARALLEL_MIN_TETS);
}

typedef struct {
  const ek_kernel_table *kt;
  fvm_args a;
} fvm_ctx;

// scatter_range_fn of the force kernel.
static void fvm_range(const void *ctx, size_t b0, size_t b1, real *f, real *corner) {
  const fvm_ctx *c = ctx;
  fvm_args a = c->a;
  a.f = f;
  a.corner = corner;
  // The phase split's force pass reads a stored P, whatever the model.
  if (a.P_in)
    c->kt->EK_FIELD(fvm_P_block)(&a, b0, b1);
  else
    c->kt->EK_FIELD(fvm_block)[a.mat->model](&a, b0, b1);
}

// F = Ds Dm^-1 per tet in double, caller order (Teran et al. 2003 sec. 4),
// from positions in the working precision; chunks of F_CHUNK tets on the
// helper team.
#define F_CHUNK 1024
typedef struct {
  const ek_tets *el;
  const real *x;
  double *F;
} tet_F_job;

static void tet_F_chunk(void *ctx, size_t c, int worker) {
  (void)worker;
  const tet_F_job *j = ctx;
  const ek_tets *el = j->el;
  const size_t e1 = el->ntets - c * F_CHUNK < F_CHUNK ? el->ntets : (c + 1) * F_CHUNK;
  for (size_t e = c * F_CHUNK; e < e1; e++) {
    const int32_t *t = el->tets + e * 4;
    const double *Dmi = el->Dm_inv + e * 9;
    double Ds[9];
    for (int k = 0; k < 3; k++)
      for (int i = 0; i < 3; i++)
        Ds[i * 3 + k] = (double)j->x[(size_t)t[k + 1] * 3 + i] - (double)j->x[(size_t)t[0] * 3 + i];
    for (int i = 0; i < 3; i++)
      for (int k = 0; k < 3; k++)
        j->F[e * 9 + i * 3 + k] = Ds[i * 3 + 0] * Dmi[0 * 3 + k] + Ds[i * 3 + 1] * Dmi[1 * 3 + k] +
                                  Ds[i * 3 + 2] * Dmi[2 * 3 + k];
  }
}

static void tet_F_f64(const ek_tets *el, const real *x, double *F) {
  tet_F_job j = {el, x, F};
  const size_t nchunks = (el->ntets + F_CHUNK - 1) / F_CHUNK;
  ek_team_run_ranges_if(el->ntets >= EK_FVM_PARALLEL_MIN_TETS, nchunks, tet_F_chunk, &j);
}

// Per-tet output fields (ek_fvm_opts J, sigma_min, psi), in double.
static int tet_fields(const ek_tets *el, const ek_material *mat, const real *x, const double *R,
                      double *J, double *sigma_min, double *psi) {
  size_t n = el->ntets;
  double *F = malloc(n * 9 * sizeof(double));
  double *S = sigma_min ? malloc(n * 3 * sizeof(double)) : NULL;
  if (!F || (sigma_min && !S)) {
    free(F);
    free(S);
    ek_set_error("ek_fvm_tet_forces_ex: out of memory for per-tet fields");
    return EK_ENOMEM;
  }
  tet_F_f64(el, x, F);
  int rc = EK_OK;
  if (J)
    for (size_t e = 0; e < n; e++) {
      const double *A = F + e * 9;
      J[e] = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
             A[2] * (A[3] * A[7] - A[4] * A[6]);
    }
  if (sigma_min) {
    rc = ek_svd3_f64(n, F, NULL, S, NULL, NULL);
    if (rc >= 0)
      for (size_t e = 0; e < n; e++)
        sigma_min[e] = S[e * 3 + 2];
  }
  if (psi && rc >= 0) {
    int r2 = ek_energy_f64(mat, n, F, R, psi);
    rc = r2 < 0 ? r2 : EK_OK;
  }
  free(F);
  free(S);
  return rc < 0 ? rc : EK_OK;
}

// Whether the block kernels prefetch the next group's vertex rows
// (fvm_vec.h): when the positions and forces outgrow a core's L2 (1 MiB on Zen 5).
#define PREFETCH_MIN_BYTES ((size_t)1 << 20)
// EK_FVM_PREFETCH=0|1 forces it, read once (not on every force call).
static int prefetch_for(const ek_tets *el) {
  static _Atomic int forced = -2; // -2: not read yet, -1: not set
  if (forced == -2) {
    static const char *const bits[] = {"0", "1"};
    int k; // a bad value: an error through ek_set_error (env.c), the default kept
    forced = ek_env_choice("EK_FVM_PREFETCH", 2, bits, &k) == 1 ? k : -1;
  }
  if (forced >= 0)
    return forced;
  return el->nverts * 3 * sizeof(real) * 2 > PREFETCH_MIN_BYTES;
}

static double now(void) { return omp_get_wtime(); }

static fvm_args args_for(fvm_args a, const ek_tets *el, const ek_tet_blocks *bl) {
  a.idx = BL_IDX(bl);
  a.dm_inv = BL_DMI(bl);
  a.v0 = BL_V0(bl);
  a.slot_tet = bl->slot_tet;
  a.R_direct = (a.R_planes || a.R_warm) && bl == &el->morton;
  return a;
}

// Thread buffers with rows of 4 reals where the row's kernels add a row
// with one load and store (fvm_tet.h, vscatter_add_rows4: AVX-512 and
// AVX2, 16 bytes in f32, 32 in f64); elsewhere the scalar adds gain
// nothing from the pad and the buffers stay nverts x 3.
static int run_strategy(const ek_kernel_table *kt, const ek_tets *el, fvm_args a, real *f,
                        ek_scatter s, ek_isa isa) {
  fvm_ctx c = {kt, args_for(a, el, scatter_blocks(el, s))};
  const int rows4 = s == EK_SCATTER_THREAD_BUFFERS && (isa == EK_ISA_AVX512 || isa == EK_ISA_AVX2);
  c.a.fstride = rows4 ? 4 : 3;
  scatter_job j = {el, s, 3, parallel_for(el, a.mat), fvm_range, &c, c.a.fstride};
  return EK_P(scatter_run)(&j, f);
}

// The phase split's passes, each a job of PHASE_CHUNK blocks per chunk on
// the helper team (kernels/team.h), as the fused force: an OpenMP region
// here leaves libgomp's thread spinning for milliseconds on the core the
// team's helper needs for the fused steps that follow (ek-sim times one step
// in ten this way: the fused steps' 2-thread median was the 1-thread one).
// The polar and material calls of a chunk stay below their own parallel
// thresholds (32 blocks, EK_MATERIAL_PARALLEL_MIN elements), so they run on
// the thread that runs the chunk; every pass is per tet: the same bits.
#define PHASE_CHUNK 32
typedef struct {
  const ek_kernel_table *kt;
  const fvm_args *a;
  const ek_material *mat;
  const ek_svd3_opts *so;
  ek_isa isa;
  size_t nb;
  real *F, *P, *R;
  _Atomic int rc;
} phase_job;

static void chunk_of(const phase_job *j, size_t i, size_t *b0, size_t *nb) {
  *b0 = i * PHASE_CHUNK;
  *nb = j->nb - *b0 < PHASE_CHUNK ? j->nb - *b0 : PHASE_CHUNK;
}

static void phase_F(void *ctx, size_t i) {
  phase_job *j = ctx;
  size_t b0, nb;
  chunk_of(j, i, &b0, &nb);
  j->kt->EK_FIELD(fvm_F_block)(j->a, b0, b0 + nb, j->F);
}

static void phase_polar(void *ctx, size_t i) {
  phase_job *j = ctx;
  size_t b0, nb;
  chunk_of(j, i, &b0, &nb);
  const size_t o = b0 * 9 * L;
  int rc = EK_P(polar3_aosoa)(nb, j->F + o, j->R + o, NULL, j->so);
  if (rc < 0)
    atomic_store(&j->rc, rc);
}

static void phase_P(void *ctx, size_t i) {
  phase_job *j = ctx;
  size_t b0, nb;
  chunk_of(j, i, &b0, &nb);
  const size_t o = b0 * 9 * L;
  int rc = EK_P(material_eval_aosoa)(j->mat, EK_MAT_PK1, j->isa, nb, j->F + o, j->R + o, NULL,
                                     j->P + o, 0);
  if (rc < 0)
    atomic_store(&j->rc, rc);
}

// Phase split (ek_fvm_opts.phase_times): F pass, polar pass (timing only,
// for models that need one), P pass through the material API, then H and
// scatter from the stored P with the chosen strategy.
static int phased(const ek_kernel_table *kt, const ek_tets *el, const ek_material *mat, fvm_args a,
                  real *f, ek_scatter s, const ek_svd3_opts *so, ek_isa isa,
                  ek_fvm_phase_times *pt) {
  const ek_tet_blocks *bl = scatter_blocks(el, s);
  a = args_for(a, el, bl);
  size_t nb = bl->nslots / L;
  real *F = EK_P(scratch_get)(SCATTER_SCRATCH_FREE, nb * 9 * L * 3 * sizeof(real));
  if (!F)
    return EK_ENOMEM;
  real *P = F + nb * 9 * L, *R = P + nb * 9 * L;
  memset(pt, 0, sizeof *pt);
  phase_job j = {kt, &a, mat, so, isa, nb, F, P, R, 0};
  const int par = parallel_for(el, a.mat);
  const size_t nchunks = (nb + PHASE_CHUNK - 1) / PHASE_CHUNK;

  double t0 = now();
  ek_team_run_if(par, nchunks, phase_F, &j);
  double t1 = now();
  pt->deformation_gradient = t1 - t0;

  ek_model_needs need = ek_model_need(mat->model, mat->clamp);
  int takes_svd = need == EK_NEEDS_POLAR || need == EK_NEEDS_SVD;
  if (takes_svd) {
    ek_team_run_if(par, nchunks, phase_polar, &j);
    if (atomic_load(&j.rc) < 0) // the whole call again, for its message on this thread
      return EK_P(polar3_aosoa)(nb, F, R, NULL, so);
  }
  double t2 = now();
  pt->svd = takes_svd ? t2 - t1 : 0;

  if (need == EK_NEEDS_R_INPUT) {
    // The given rotations (state or caller order) -> slot blocks.
    for (size_t sl = 0; sl < bl->nslots; sl++) {
      int32_t t = bl->slot_tet[sl];
      for (int k = 0; k < 9; k++) {
        real v = (real)(k % 4 == 0);
        if (t >= 0 && a.R_planes) {
          size_t ms = (size_t)el->morton_slot[t];
          v = a.R_planes[((ms / L) * 9 + k) * L + ms % L];
        } else if (t >= 0) {
          v = (real)a.R[(size_t)t * 9 + k];
        }
        R[((sl / L) * 9 + k) * L + sl % L] = v;
      }
    }
  }
  double t3 = now();
  ek_team_run_if(par, nchunks, phase_P, &j);
  if (atomic_load(&j.rc) < 0)
    return EK_P(material_eval_aosoa)(mat, EK_MAT_PK1, isa, nb, F, R, NULL, P, 0);
  double t4 = now();
  pt->pk1 = t4 - t3;

  a.P_in = P;
  int rc = run_strategy(kt, el, a, f, s, isa);
  pt->scatter = now() - t4;
  return rc;
}

int EK_P(fvm_tet_forces_ex)(const ek_tets *el, const ek_material *mat, const real *x, real *f,
                            const ek_fvm_opts *opts) {
  static const char *fn = "ek_fvm_tet_forces_ex";
  ek_fvm_opts o = {0};
  if (opts)
    o = *opts;
  if (!el || !mat || !x || !f) {
    ek_set_error("%s: NULL argument (elements %p, material %p, x %p, f %p)", fn, (const void *)el,
                 (const void *)mat, (const void *)x, (void *)f);
    return EK_EINVAL;
  }
  int rc = ek_material_check(mat);
  if (rc < 0)
    return rc;
  if (ek_models[mat->model]->needs == EK_NEEDS_R_INPUT && (o.R_state ? !o.R && o.psi : !o.R)) {
    ek_set_error("%s: corotated linear needs per-tet rotations (opts->R is NULL%s)", fn,
                 o.R_state ? "; the psi output reads it" : " and so is opts->R_state");
    return EK_EINVAL;
  }
  const ek_tet_state *st = o.R_state;
  if (st && (st->el != el || st->planes != 9 || st->f64 != (sizeof(real) == 8))) {
    ek_set_error("%s: opts->R_state must be a 9-plane state of these elements in the call's "
                 "precision (got %d planes, %s, %s elements)",
                 fn, st->planes, st->f64 ? "f64" : "f32", st->el == el ? "these" : "other");
    return EK_EINVAL;
  }
  ek_tet_state *ws = o.polar_state;
  int warm = ws && ek_models[mat->model]->needs == EK_NEEDS_POLAR && !(mat->clamp > 0);
  if (ws && (ws->el != el || ws->planes != 9 || ws->f64 != (sizeof(real) == 8))) {
    ek_set_error("%s: opts->polar_state must be a 9-plane state of these elements in the call's "
                 "precision (got %d planes, %s, %s elements)",
                 fn, ws->planes, ws->f64 ? "f64" : "f32", ws->el == el ? "these" : "other");
    return EK_EINVAL;
  }
  int polar_iters = 0;
  if ((rc = EK_P(polar_warm_iterations_from)(fn, o.polar_iterations, &polar_iters)) < 0)
    return rc;
  if ((unsigned)o.scatter >= EK_SCATTER_COUNT) {
    ek_set_error("%s: scatter strategy %d is not a valid ek_scatter", fn, (int)o.scatter);
    return EK_EINVAL;
  }
  ek_svd3_knobs knobs;
  if ((rc = EK_P(svd3_knobs_from)(fn, o.svd_sweeps, o.svd_exact_rsqrt, o.svd_refine, &knobs)) < 0)
    return rc;
  ek_isa isa;
  rc = ek_isa_resolve(o.isa, &isa);
  if (rc < 0)
    return rc;
  const ek_kernel_table *kt = ek_kernels_for(isa);
  if (!kt)
    return EK_EISA;
  // The row's SVD chains (kernels.h): the force kernel's wide variant where 4 (fvm_model.h).
  knobs.chains = kt->svd3_chains;

  // AUTO: see fvm.h for why thread buffers.
  ek_scatter s = o.scatter == EK_SCATTER_AUTO ? EK_SCATTER_DEFAULT : o.scatter;
  fvm_args a = {.R = o.R,
                .R_planes =
                    st && ek_models[mat->model]->needs == EK_NEEDS_R_INPUT ? st->data : NULL,
                .morton_slot = el->morton_slot,
                .mat = mat,
                .svd = &knobs,
                .R_warm = warm ? ws->data : NULL,
                .polar_iters = polar_iters,
                .prefetch = prefetch_for(el),
                .fstride = 3,
                .x = x};
  if (o.phase_times && !warm) {
    ek_svd3_opts so = {.sweeps = o.svd_sweeps,
                       .exact_rsqrt = o.svd_exact_rsqrt,
                       .refine = o.svd_refine,
                       .isa = isa};
    rc = phased(kt, el, mat, a, f, s, &so, isa, o.phase_times);
  } else if (o.phase_times) {
    // Warm polar: fused (fvm.h), the whole call reported as the P phase.
    memset(o.phase_times, 0, sizeof *o.phase_times);
    double t0 = now();
    rc = run_strategy(kt, el, a, f, s, isa);
    o.phase_times->pk1 = now() - t0;
  } else {
    rc = run_strategy(kt, el, a, f, s, isa);
  }
  if (rc == EK_ENOMEM)
    ek_set_error("%s: out of memory for scratch buffers", fn);
  if (rc < 0)
    return rc;

  if (o.J || o.sigma_min || o.psi)
    return tet_fields(el, mat, x, o.R, o.J, o.sigma_min, o.psi);
  return EK_OK;
}

#if defined(EK_REAL_F64)
// Precision-free entry points, built once (in the f64 instance).

const char *ek_scatter_name(ek_scatter s) {
  static const char *const names[EK_SCATTER_COUNT] = {"auto", "colored", "thread_buffers", "gather",
                                                      "atomic"};
  return (unsigned)s < EK_SCATTER_COUNT ? names[s] : "invalid";
}

int ek_fvm_tet_deformation_gradients_f64(const ek_tets *el, const double *x, double *F) {
  if (!el || !x || !F) {
    ek_set_error("ek_fvm_tet_deformation_gradients_f64: NULL argument");
    return EK_EINVAL;
  }
  tet_F_f64(el, x, F);
  return EK_OK;
}

double ek_fvm_tet_energy_f64(const ek_tets *el, const ek_material *mat, const double *x,
                             const double *R) {
  if (!el || !mat || !x) {
    ek_set_error("ek_fvm_tet_energy_f64: NULL argument");
    return NAN;
  }
  if (ek_models[mat->model]->needs == EK_NEEDS_R_INPUT && !R) {
    ek_set_error("ek_fvm_tet_energy_f64: corotated linear needs per-tet rotations (R is NULL)");
    return NAN;
  }
  size_t n = el->ntets;
  double *F = malloc(n * 10 * sizeof(double));
  if (!F) {
    ek_set_error("ek_fvm_tet_energy_f64: out of memory");
    return NAN;
  }
  double *psi = F + n * 9;
  tet_F_f64(el, x, F);
  int rc = ek_energy_f64(mat, n, F, R, psi);
  double E = NAN;
  if (rc >= 0) {
    // E = sum_e V0_e psi(F_e) in caller tet order (fixed, thread-free).
    E = 0;
    for (size_t e = 0; e < n; e++)
      E += el->V0[e] * psi[e];
  }
  free(F);
  return E;
}
#endif
