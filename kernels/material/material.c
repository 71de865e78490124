// Material driver (built once per precision, baseline ISA): checks the
// arguments, resolves the kernel table, and runs the block kernel over
// chunks of blocks on the helper team (kernels/team.h). The AoS forms pack
// each chunk into its worker's AoSoA buffer, call the kernel and unpack,
// so the kernels only ever see whole blocks (tails padded with the
// identity for F and R, zero for dF).
// Results do not depend on the thread count: each element is computed
// alone, and the only reduction is an integer count.
#include <ek/material.h>
#include <limits.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels.h"
#include "../real.h"
#include "../team.h"
#include "models.h"

// Blocks per team chunk / staging chunk (16 blocks of 16 floats: F,
// dF and P of a chunk take 27 KB, a Hessian chunk 83 KB).
#define CHUNK_BLOCKS 16

static int out_planes(ek_material_op op) {
  return op == EK_MAT_ENERGY ? 1 : op == EK_MAT_HESSIAN ? 81 : 9;
}

static int check_params(const char *fn, const ek_material *m) {
  if (!m) {
    ek_set_error("%s: material is NULL", fn);
    return EK_EINVAL;
  }
  if ((unsigned)m->model >= EK_MODEL_COUNT) {
    ek_set_error("%s: model = %d is not an ek_model", fn, (int)m->model);
    return EK_EINVAL;
  }
  if (!isfinite(m->mu) || !isfinite(m->lambda) || !isfinite(m->clamp)) {
    ek_set_error("%s: non-finite parameter (mu = %g, lambda = %g, clamp = %g)", fn, m->mu,
                 m->lambda, m->clamp);
    return EK_EINVAL;
  }
  if (!(m->mu > 0)) {
    ek_set_error("%s: mu = %g, must be > 0", fn, m->mu);
    return EK_EINVAL;
  }
  if (!(m->lambda > -2 * m->mu / 3)) {
    ek_set_error("%s: lambda = %g, must be > -2 mu / 3 = %g", fn, m->lambda, -2 * m->mu / 3);
    return EK_EINVAL;
  }
  if (m->clamp < 0) {
    ek_set_error("%s: clamp = %g, must be >= 0", fn, m->clamp);
    return EK_EINVAL;
  }
  const char *why =
      ek_models[m->model]->param_error ? ek_models[m->model]->param_error(m->mu, m->lambda) : NULL;
  if (why) {
    ek_set_error("%s: %s", fn, why);
    return EK_EINVAL;
  }
  return EK_OK;
}

// count: items (lanes = 1) or blocks (lanes = EK_LANES).
static int check_call(const char *fn, const ek_material *m, ek_material_op op, size_t count,
                      size_t lanes, const real *F, const real *R, const real *dF, const real *out) {
  int rc = check_params(fn, m);
  if (rc)
    return rc;
  if ((unsigned)op > EK_MAT_HESSIAN) {
    ek_set_error("%s: op = %d is not an ek_material_op", fn, (int)op);
    return EK_EINVAL;
  }
  if (count == 0)
    return EK_OK;
  if (!F || !out) {
    ek_set_error("%s: %s is NULL", fn, !F ? "F" : "the output array");
    return EK_EINVAL;
  }
  if (ek_models[m->model]->needs == EK_NEEDS_R_INPUT && !R) {
    ek_set_error("%s: %s needs R (got NULL)", fn, ek_models[m->model]->long_name);
    return EK_EINVAL;
  }
  if (op == EK_MAT_PK1_DIFF && !dF) {
    ek_set_error("%s: dF is NULL", fn);
    return EK_EINVAL;
  }
  const size_t planes = out_planes(op) > 9 ? (size_t)out_planes(op) : 9;
  return ek_batch_check(fn, count, planes * lanes * sizeof(real), _Alignof(real), 4,
                        (const void *[]){F, R, dF, out},
                        (const char *const[]){"F", "R", "dF", "the output array"});
}

static ek_material_knobs knobs_of(const ek_material *m, ek_material_op op, int project) {
  return (ek_material_knobs){.op = op,
                             .project = project != 0,
                             .mu = m->mu,
                             .lambda = m->lambda,
                             .clamp = m->clamp,
                             .svd = EK_P(svd3_default_knobs)()};
}

// Elements outside the domain, read off the output (the kernel's own
// decision, so the count agrees with what it wrote): psi = +inf or a NaN
// first entry, for a finite F. Only neo-Hookean without clamp has any.
static int outside(real value, ek_material_op op) {
  return op == EK_MAT_ENERGY ? value == (real)INFINITY : isnan(value);
}

static int counts_domain(const ek_material *m) {
  return ek_models[m->model]->j_domain && !(m->clamp > 0);
}

static int entries_finite(const real *a, size_t stride, int n) {
  for (int k = 0; k < n; k++)
    if (!isfinite(a[k * stride]))
      return 0;
  return 1;
}

// One material_eval call's chunks on the helper team (team.h). Fs, Rs, dFs,
// Os: the AoS form's staging, `per_worker` reals for each worker (a worker
// runs one chunk at a time).
typedef struct {
  const ek_material *m;
  const ek_kernel_table *t;
  ek_material_knobs k;
  size_t n; // blocks (AoSoA) or elements (AoS)
  const real *F, *R, *dF;
  real *out;
  int nout, dom, use_R, use_dF;
  real *buffers;
  size_t per_worker;
  atomic_long count; // integer: the same total in any order
} eval_job;

static void aosoa_chunk(void *ctx, size_t c, int worker) {
  (void)worker;
  eval_job *j = ctx;
  const int nout = j->nout;
  const real *F = j->F, *R = j->R, *dF = j->dF;
  size_t b0 = c * CHUNK_BLOCKS, nb = j->n - b0 < CHUNK_BLOCKS ? j->n - b0 : CHUNK_BLOCKS;
  const size_t in = b0 * 9 * EK_LANES;
  real *o = j->out + b0 * (size_t)nout * EK_LANES;
  j->t->EK_FIELD(material_block)[j->m->model](nb, F + in, R ? R + in : NULL, dF ? dF + in : NULL, o,
                                              &j->k);
  long count = 0;
  if (j->dom)
    for (size_t b = 0; b < nb; b++)
      for (int l = 0; l < EK_LANES; l++)
        count += outside(o[b * nout * EK_LANES + l], j->k.op) &&
                 entries_finite(F + in + b * 9 * EK_LANES + l, EK_LANES, 9);
  if (count)
    atomic_fetch_add_explicit(&j->count, count, memory_order_relaxed);
}

// Fills the job's fields both forms share, runs its chunks and returns the
// count of elements outside the domain, saturated.
static int run_eval(eval_job *j, const ek_material *m, const ek_kernel_table *t, ek_material_op op,
                    int project, const real *F, const real *R, const real *dF, real *out,
                    int parallel, size_t nchunks, ek_team_worker_fn *chunk) {
  j->m = m;
  j->t = t;
  j->k = knobs_of(m, op, project);
  j->F = F, j->R = R, j->dF = dF, j->out = out;
  j->nout = out_planes(op);
  j->dom = counts_domain(m);
  atomic_init(&j->count, 0);
  ek_team_run_ranges_if(parallel, nchunks, chunk, j);
  long count = atomic_load(&j->count);
  return count > INT_MAX ? INT_MAX : (int)count;
}

int EK_P(material_eval_aosoa)(const ek_material *m, ek_material_op op, ek_isa isa, size_t nblocks,
                              const real *F, const real *R, const real *dF, real *out,
                              int project) {
  static const char fn[] = "ek_material_eval_aosoa";
  int rc = check_call(fn, m, op, nblocks, EK_LANES, F, R, dF, out);
  if (rc)
    return rc;
  const ek_kernel_table *t = ek_kernels_resolve(isa);
  if (!t)
    return EK_EISA;
  if (nblocks == 0)
    return 0;
  eval_job j = {.n = nblocks};
  return run_eval(&j, m, t, op, project, F, R, dF, out,
                  nblocks * EK_LANES >= EK_MATERIAL_PARALLEL_MIN,
                  (nblocks + CHUNK_BLOCKS - 1) / CHUNK_BLOCKS, aosoa_chunk);
}

static void aos_chunk(void *ctx, size_t c, int worker) {
  eval_job *j = ctx;
  const size_t chunk = (size_t)CHUNK_BLOCKS * EK_LANES; // elements per chunk
  const int nout = j->nout, use_R = j->use_R, use_dF = j->use_dF;
  const real *F = j->F, *R = j->R, *dF = j->dF;
  real *Fs = j->buffers + (size_t)worker * j->per_worker;
  real *Rs = Fs + chunk * 9;
  real *dFs = Rs + (use_R ? chunk * 9 : 0);
  real *Os = dFs + (use_dF ? chunk * 9 : 0);
  const size_t e0 = c * chunk, ne = j->n - e0 < chunk ? j->n - e0 : chunk;
  const size_t nb = (ne + EK_LANES - 1) / EK_LANES;
  // Pack (AoSoA layout of batch.h), tails: identity F and R, zero dF.
  for (size_t b = 0; b < nb; b++)
    for (int l = 0; l < EK_LANES; l++) {
      const size_t e = b * EK_LANES + (size_t)l;
      for (int q = 0; q < 9; q++) {
        const size_t s = (b * 9 + (size_t)q) * EK_LANES + (size_t)l;
        const real id = q % 4 == 0 ? 1 : 0;
        Fs[s] = e < ne ? F[(e0 + e) * 9 + (size_t)q] : id;
        if (use_R)
          Rs[s] = e < ne ? R[(e0 + e) * 9 + (size_t)q] : id;
        if (use_dF)
          dFs[s] = e < ne ? dF[(e0 + e) * 9 + (size_t)q] : 0;
      }
    }
  j->t->EK_FIELD(material_block)[j->m->model](nb, Fs, use_R ? Rs : NULL, use_dF ? dFs : NULL, Os,
                                              &j->k);
  long count = 0;
  for (size_t e = 0; e < ne; e++) {
    const size_t b = e / EK_LANES, l = e % EK_LANES;
    real *dst = j->out + (e0 + e) * (size_t)nout;
    for (int q = 0; q < nout; q++)
      dst[q] = Os[(b * (size_t)nout + (size_t)q) * EK_LANES + l];
    if (j->dom)
      count += outside(dst[0], j->k.op) && entries_finite(F + (e0 + e) * 9, 1, 9);
  }
  if (count)
    atomic_fetch_add_explicit(&j->count, count, memory_order_relaxed);
}

int EK_P(material_eval)(const ek_material *m, ek_material_op op, ek_isa isa, size_t n,
                        const real *F, const real *R, const real *dF, real *out, int project) {
  static const char fn[] = "ek_material_eval";
  int rc = check_call(fn, m, op, n, 1, F, R, dF, out);
  if (rc)
    return rc;
  const ek_kernel_table *t = ek_kernels_resolve(isa);
  if (!t)
    return EK_EISA;
  if (n == 0)
    return 0;
  const int nout = out_planes(op);
  const int use_R = ek_models[m->model]->needs == EK_NEEDS_R_INPUT, use_dF = op == EK_MAT_PK1_DIFF;
  const size_t chunk = (size_t)CHUNK_BLOCKS * EK_LANES; // elements per chunk
  const size_t per_worker = chunk * (9 + (use_R ? 9 : 0) + (use_dF ? 9 : 0) + (size_t)nout);
  // Staging buffers for every worker, allocated up front so a failure leaves
  // the output untouched.
  const int parallel = n >= EK_MATERIAL_PARALLEL_MIN;
  const int workers = parallel ? ek_team_threads() : 1;
  real *buffers = ek_alloc((size_t)workers * per_worker * sizeof(real));
  if (!buffers) {
    ek_set_error("%s: out of memory (%zu bytes of staging)", fn,
                 (size_t)workers * per_worker * sizeof(real));
    return EK_ENOMEM;
  }
  eval_job j = {
      .n = n, .use_R = use_R, .use_dF = use_dF, .buffers = buffers, .per_worker = per_worker};
  rc = run_eval(&j, m, t, op, project, F, R, dF, out, parallel, (n + chunk - 1) / chunk, aos_chunk);
  ek_free(buffers);
  return rc;
}

int EK_P(pk1)(const ek_material *m, size_t n, const real *F, const real *R, real *P) {
  return EK_P(material_eval)(m, EK_MAT_PK1, EK_ISA_AUTO, n, F, R, NULL, P, 0);
}
int EK_P(pk1_diff)(const ek_material *m, size_t n, const real *F, const real *R, const real *dF,
                   real *dP, int project) {
  return EK_P(material_eval)(m, EK_MAT_PK1_DIFF, EK_ISA_AUTO, n, F, R, dF, dP, project);
}
int EK_P(pk1_hessian)(const ek_material *m, size_t n, const real *F, const real *R, real *H,
                      int project) {
  return EK_P(material_eval)(m, EK_MAT_HESSIAN, EK_ISA_AUTO, n, F, R, NULL, H, project);
}
int EK_P(pk1_aosoa)(const ek_material *m, size_t nblocks, const real *F, const real *R, real *P) {
  return EK_P(material_eval_aosoa)(m, EK_MAT_PK1, EK_ISA_AUTO, nblocks, F, R, NULL, P, 0);
}
int EK_P(pk1_diff_aosoa)(const ek_material *m, size_t nblocks, const real *F, const real *R,
                         const real *dF, real *dP, int project) {
  return EK_P(material_eval_aosoa)(m, EK_MAT_PK1_DIFF, EK_ISA_AUTO, nblocks, F, R, dF, dP, project);
}

#if defined(EK_REAL_F64)
// Precision-free functions: built with the double driver only.
int ek_energy_f64(const ek_material *m, size_t n, const double *F, const double *R, double *psi) {
  return ek_material_eval_f64(m, EK_MAT_ENERGY, EK_ISA_AUTO, n, F, R, NULL, psi, 0);
}

int ek_material_check(const ek_material *m) { return check_params("ek_material_check", m); }

const char *ek_model_name(ek_model model) {
  return (unsigned)model < EK_MODEL_COUNT ? ek_models[model]->name : "invalid";
}

const char *ek_model_long_name(ek_model model) {
  return (unsigned)model < EK_MODEL_COUNT ? ek_models[model]->long_name : "invalid";
}

int ek_model_from_name(const char *name, ek_model *model) {
  for (int i = 0; name && i < EK_MODEL_COUNT; i++)
    if (strcmp(name, ek_models[i]->name) == 0 || strcmp(name, ek_models[i]->long_name) == 0) {
      *model = (ek_model)i;
      return EK_OK;
    }
  return EK_EINVAL;
}

ek_model_needs ek_model_need(ek_model model, double clamp) {
  return (unsigned)model < EK_MODEL_COUNT ? ek_model_row_needs(model, clamp) : EK_NEEDS_NOTHING;
}

// Lame parameters from Young's modulus and Poisson ratio (e.g. Sifakis &
// Barbic 2012 course notes, ch. 3): the one place ek converts them.
int ek_lame_from_young_poisson(double E, double nu, double *mu, double *lambda) {
  if (!mu || !lambda) {
    ek_set_error("ek_lame_from_young_poisson: NULL output");
    return EK_EINVAL;
  }
  if (!isfinite(E) || !(E > 0)) {
    ek_set_error("ek_lame_from_young_poisson: E = %g, must be finite and > 0", E);
    return EK_EINVAL;
  }
  if (!isfinite(nu) || !(nu > -1) || !(nu < 0.5)) {
    ek_set_error("ek_lame_from_young_poisson: nu = %g, must be in (-1, 0.5) (0.5 is "
                 "incompressible: lambda would be infinite)",
                 nu);
    return EK_EINVAL;
  }
  double m = E / (2 * (1 + nu)), l = E * nu / ((1 + nu) * (1 - 2 * nu));
  if (!isfinite(m) || !isfinite(l)) {
    // E near DBL_MAX, or nu near 0.5: finite inputs, an overflowing result.
    ek_set_error("ek_lame_from_young_poisson: E = %g, nu = %g give mu = %g, lambda = %g: not "
                 "finite (E too large for this nu)",
                 E, nu, m, l);
    return EK_EINVAL;
  }
  *mu = m;
  *lambda = l;
  return EK_OK;
}

int ek_young_poisson_from_lame(double mu, double lambda, double *E, double *nu) {
  if (!E || !nu) {
    ek_set_error("ek_young_poisson_from_lame: NULL output");
    return EK_EINVAL;
  }
  if (!isfinite(mu) || !isfinite(lambda) || !(mu > 0) || !(lambda > -2 * mu / 3)) {
    ek_set_error("ek_young_poisson_from_lame: mu = %g, lambda = %g; need mu > 0 and "
                 "lambda > -2 mu / 3",
                 mu, lambda);
    return EK_EINVAL;
  }
  *E = mu * (3 * lambda + 2 * mu) / (lambda + mu);
  *nu = lambda / (2 * (lambda + mu));
  return EK_OK;
}
#endif
