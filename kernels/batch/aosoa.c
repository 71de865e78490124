// AoS <-> AoSoA conversion (layout in include/ek/batch.h). Built once per
// precision; EK_P() gives the public names.
#include <stdint.h>
#include <string.h>

#include "kernels.h"
#include "real.h"
#include "team.h"

// n / LANES rounded up, written so that it cannot wrap (n + LANES - 1
// would, near SIZE_MAX).
size_t EK_P(aosoa_blocks)(size_t n) { return n / EK_LANES + (n % EK_LANES != 0); }

size_t EK_P(aosoa_size)(size_t n, int nplanes) {
  size_t nb = EK_P(aosoa_blocks)(n);
  if (nplanes < 1 || nplanes > 64 || nb > SIZE_MAX / sizeof(real) / ((size_t)nplanes * EK_LANES))
    return 0; // no such batch (batch.h)
  return nb * (size_t)nplanes * EK_LANES;
}

static int check(const char *fn, size_t n, int nplanes, const void *in, const void *out) {
  if (nplanes < 1 || nplanes > 64 || (n && (!in || !out))) {
    ek_set_error("%s: nplanes %d (1..64) or NULL array with n = %zu", fn, nplanes, n);
    return EK_EINVAL;
  }
  return ek_batch_check(fn, n, (size_t)nplanes * sizeof(real), _Alignof(real), 2,
                        (const void *[]){in, out}, (const char *const[]){"input", "output"});
}

// Padding of a tail lane: identity for 3x3 matrices, zero otherwise.
static real pad_value(int nplanes, int k) { return nplanes == 9 && k % 4 == 0 ? 1 : 0; }

int EK_P(aosoa_pack)(size_t n, int nplanes, const real *aos, real *soa) {
  int rc = check("ek_aosoa_pack", n, nplanes, aos, soa);
  if (rc)
    return rc;
  size_t nb = EK_P(aosoa_blocks)(n);
  for (size_t b = 0; b < nb; b++) {
    real *blk = soa + b * (size_t)nplanes * EK_LANES;
    size_t base = b * EK_LANES;
    size_t full = n - base < EK_LANES ? n - base : EK_LANES;
    for (size_t l = 0; l < full; l++)
      for (int k = 0; k < nplanes; k++)
        blk[k * EK_LANES + l] = aos[(base + l) * nplanes + k];
    for (size_t l = full; l < EK_LANES; l++)
      for (int k = 0; k < nplanes; k++)
        blk[k * EK_LANES + l] = pad_value(nplanes, k);
  }
  return EK_OK;
}

int EK_P(aosoa_unpack)(size_t n, int nplanes, const real *soa, real *aos) {
  int rc = check("ek_aosoa_unpack", n, nplanes, soa, aos);
  if (rc)
    return rc;
  size_t nb = EK_P(aosoa_blocks)(n);
  for (size_t b = 0; b < nb; b++) {
    const real *blk = soa + b * (size_t)nplanes * EK_LANES;
    size_t base = b * EK_LANES;
    size_t full = n - base < EK_LANES ? n - base : EK_LANES;
    for (size_t l = 0; l < full; l++)
      for (int k = 0; k < nplanes; k++)
        aos[(base + l) * nplanes + k] = blk[k * EK_LANES + l];
  }
  return EK_OK;
}

real *EK_P(aosoa_alloc)(size_t n, int nplanes) {
  if (nplanes < 1 || nplanes > 64 ||
      ek_batch_check("ek_aosoa_alloc", n, (size_t)nplanes * sizeof(real), 1, 0, NULL, NULL))
    return NULL;
  size_t count = EK_P(aosoa_size)(n, nplanes);
  real *p = ek_alloc(count * sizeof(real));
  if (!p)
    return NULL;
  // Every lane initialised: tails padded, real lanes zeroed until packed.
  size_t nb = EK_P(aosoa_blocks)(n);
  for (size_t b = 0; b < nb; b++)
    for (int k = 0; k < nplanes; k++)
      for (int l = 0; l < EK_LANES; l++)
        p[(b * nplanes + k) * EK_LANES + l] = b * EK_LANES + l < n ? 0 : pad_value(nplanes, k);
  return p;
}

#if defined(EK_REAL_F32)
typedef ek_staged_chunk_f32_fn staged_chunk_fn;
#else
typedef ek_staged_chunk_f64_fn staged_chunk_fn;
#endif

typedef struct {
  staged_chunk_fn *run;
  void *ctx;
  size_t n, chunk;
  int nbuf;
  real *bufs[EK_STAGED_MAX_BUFS]; // each worker's part: chunk * planes[k] reals
  const int *planes;
} staged_job;

static void staged_chunk(void *ctx, size_t c, int worker) {
  const staged_job *j = ctx;
  real *bufs[EK_STAGED_MAX_BUFS] = {0};
  for (int k = 0; k < j->nbuf; k++)
    if (j->bufs[k])
      bufs[k] = j->bufs[k] + (size_t)worker * j->chunk * (size_t)j->planes[k];
  size_t i0 = c * j->chunk;
  j->run(j->ctx, i0, j->n - i0 < j->chunk ? j->n - i0 : j->chunk, bufs);
}

// The chunks on the helper team (team.h), with staging buffers for every
// worker allocated up front: a failed allocation runs no chunk, as the
// OpenMP region this replaces did (each thread allocated its own, and a
// barrier made every thread see a failure before any ran a chunk).
int EK_P(staged_chunks)(const char *fn, size_t n, size_t chunk_blocks, int nbuf, const int *planes,
                        staged_chunk_fn *run, void *ctx) {
  const size_t chunk = chunk_blocks * EK_LANES;
  const size_t nchunks = (n + chunk - 1) / chunk;
  const int workers = nchunks > 1 ? ek_team_threads() : 1;
  staged_job j = {.run = run, .ctx = ctx, .n = n, .chunk = chunk, .nbuf = nbuf, .planes = planes};
  int ok = 1;
  for (int k = 0; k < nbuf; k++)
    if (planes[k] > 0)
      ok = ok && (j.bufs[k] = ek_alloc((size_t)workers * chunk * (size_t)planes[k] * sizeof(real)));
  if (ok)
    ek_team_run_ranges(nchunks, staged_chunk, &j);
  for (int k = 0; k < nbuf; k++)
    ek_free(j.bufs[k]);
  if (!ok) {
    ek_set_error("%s: out of memory for staging buffers", fn);
    return EK_ENOMEM;
  }
  return EK_OK;
}
