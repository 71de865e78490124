// Invariant: ek_aosoa_pack / unpack move every item bit for bit between AoS
// (n x nplanes) and AoSoA (blocks of EK_LANES_F32 / _F64 lanes, plane
// k of block b at soa[(b * nplanes + k) * LANES + l]); unpack(pack(x)) = x;
// tail lanes are padded with the identity for 9 planes and zero otherwise;
// unpack writes nothing past item n; ek_aosoa_alloc gives 64-byte aligned,
// fully initialised storage; bad arguments return EK_EINVAL.
//
// Usage: test_aosoa [--seed N]
#include <ek/batch.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "cli.h"

static int failures;

static void fail(const char *what, int bits, size_t n, int nplanes, size_t item, int k,
                 double expected, double actual) {
  if (failures++ < 10)
    printf("FAIL f%d n=%zu nplanes=%d: %s at item/lane %zu plane %d: expected %.17g, got "
           "%.17g\n",
           bits, n, nplanes, what, item, k, expected, actual);
}

// Both precisions go through one body: values are read and written as
// double (exact for float), buffers are typed by `bits` (no function body in
// a macro).
static double get(const void *p, size_t i, int bits) {
  return bits == 32 ? ((const float *)p)[i] : ((const double *)p)[i];
}
static void set(void *p, size_t i, int bits, double v) {
  if (bits == 32)
    ((float *)p)[i] = (float)v;
  else
    ((double *)p)[i] = v;
}
static int same_bits(const void *p, size_t i, int bits, double v) {
  if (bits == 32) {
    float f = (float)v;
    return memcmp((const float *)p + i, &f, sizeof f) == 0;
  }
  return memcmp((const double *)p + i, &v, sizeof v) == 0;
}

static void round_trip(ek_rng *rng, int bits, size_t n, int nplanes) {
  size_t elem = bits == 32 ? sizeof(float) : sizeof(double);
  size_t lanes = bits == 32 ? EK_LANES_F32 : EK_LANES_F64;
  void *aos = ek_check_malloc((n * nplanes + 1) * elem);
  void *back = ek_check_malloc((n * nplanes + 1) * elem);
  for (size_t i = 0; i < n * nplanes; i++)
    set(aos, i, bits, ek_rng_gauss(rng));
  void *soa =
      bits == 32 ? (void *)ek_aosoa_alloc_f32(n, nplanes) : (void *)ek_aosoa_alloc_f64(n, nplanes);
  size_t nb = bits == 32 ? ek_aosoa_blocks_f32(n) : ek_aosoa_blocks_f64(n);
  size_t size = bits == 32 ? ek_aosoa_size_f32(n, nplanes) : ek_aosoa_size_f64(n, nplanes);
  if (nb != (n + lanes - 1) / lanes || size != nb * nplanes * lanes)
    fail("blocks/size", bits, n, nplanes, nb, 0, (double)((n + lanes - 1) / lanes), (double)nb);
  if (((uintptr_t)soa & 63) != 0)
    fail("alignment", bits, n, nplanes, 0, 0, 0, (double)((uintptr_t)soa & 63));
  int rc = bits == 32 ? ek_aosoa_pack_f32(n, nplanes, aos, soa)
                      : ek_aosoa_pack_f64(n, nplanes, aos, soa);
  if (rc)
    fail("pack rc", bits, n, nplanes, 0, 0, 0, rc);
  for (size_t b = 0; b < nb; b++)
    for (int k = 0; k < nplanes; k++)
      for (size_t l = 0; l < lanes; l++) {
        size_t item = b * lanes + l, at = (b * nplanes + k) * lanes + l;
        double want = item < n                       ? get(aos, item * nplanes + k, bits)
                      : (nplanes == 9 && k % 4 == 0) ? 1.0
                                                     : 0.0;
        if (!same_bits(soa, at, bits, want))
          fail(item < n ? "packed value" : "tail padding", bits, n, nplanes, item, k, want,
               get(soa, at, bits));
      }
  const double sentinel = -777.5;
  set(back, n * nplanes, bits, sentinel);
  rc = bits == 32 ? ek_aosoa_unpack_f32(n, nplanes, soa, back)
                  : ek_aosoa_unpack_f64(n, nplanes, soa, back);
  if (rc)
    fail("unpack rc", bits, n, nplanes, 0, 0, 0, rc);
  if (n && memcmp(aos, back, n * nplanes * elem) != 0)
    fail("round trip", bits, n, nplanes, 0, 0, 0, 0);
  if (get(back, n * nplanes, bits) != sentinel)
    fail("unpack wrote past item n", bits, n, nplanes, n, 0, sentinel,
         get(back, n * nplanes, bits));
  ek_free(soa);
  free(aos), free(back);
}

static void bad_arguments(void) {
  float f[16 * 9] = {0};
  double d[8 * 9] = {0};
  struct {
    const char *what;
    int rc;
  } cases[] = {
      {"pack_f32 nplanes 0", ek_aosoa_pack_f32(1, 0, f, f)},
      {"pack_f32 nplanes 65", ek_aosoa_pack_f32(1, 65, f, f)},
      {"pack_f32 NULL in", ek_aosoa_pack_f32(1, 9, NULL, f)},
      {"unpack_f32 NULL out", ek_aosoa_unpack_f32(1, 9, f, NULL)},
      {"pack_f64 nplanes -1", ek_aosoa_pack_f64(1, -1, d, d)},
      {"pack_f64 NULL out", ek_aosoa_pack_f64(1, 9, d, NULL)},
      {"unpack_f64 nplanes 0", ek_aosoa_unpack_f64(1, 0, d, d)},
  };
  for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++)
    if (cases[c].rc != EK_EINVAL) {
      printf("FAIL %s: rc %d, expected EK_EINVAL (%d)\n", cases[c].what, cases[c].rc, EK_EINVAL);
      failures++;
    }
  if (ek_aosoa_alloc_f32(4, 0) != NULL || ek_aosoa_alloc_f64(4, 65) != NULL) {
    printf("FAIL alloc with nplanes outside 1..64 returned storage\n");
    failures++;
  }
  // n = 0 with NULL arrays is a valid empty batch.
  if (ek_aosoa_pack_f32(0, 9, NULL, NULL) != EK_OK || ek_aosoa_unpack_f64(0, 3, NULL, NULL)) {
    printf("FAIL n = 0 with NULL arrays is not accepted\n");
    failures++;
  }
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 1, NULL);
  printf("test_aosoa: seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  const size_t sizes[] = {0, 1, 7, 8, 9, 15, 16, 17, 1000};
  const int planes[] = {1, 3, 9, 64};
  for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
    for (size_t p = 0; p < sizeof planes / sizeof planes[0]; p++) {
      round_trip(&rng, 32, sizes[s], planes[p]);
      round_trip(&rng, 64, sizes[s], planes[p]);
    }
  printf("pack/unpack round trip, layout and tail padding, n = 0 1 7 8 9 15 16 17 1000, "
         "nplanes = 1 3 9 64, f32 and f64: %s\n",
         failures ? "FAIL" : "PASS");
  int before = failures;
  bad_arguments();
  printf("bad arguments rejected with EK_EINVAL: %s\n", failures > before ? "FAIL" : "PASS");
  printf("test_aosoa: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
