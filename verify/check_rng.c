// Seeded random numbers and random 3x3 matrices for tests and ek-verify.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

#define TWO_PI 6.283185307179586476925

// splitmix64 (Steele, Lea & Flood 2014): turns one seed into well-mixed
// words for the xoshiro state (never all zero).
static uint64_t splitmix64(uint64_t *x) {
  uint64_t z = (*x += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

void ek_rng_seed(ek_rng *rng, uint64_t seed) {
  uint64_t x = seed;
  for (int i = 0; i < 4; i++)
    rng->s[i] = splitmix64(&x);
}

static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

// xoshiro256** 1.0 (Blackman & Vigna 2021, section 3).
uint64_t ek_rng_next(ek_rng *rng) {
  uint64_t *s = rng->s;
  uint64_t result = rotl(s[1] * 5, 7) * 9;
  uint64_t t = s[1] << 17;
  s[2] ^= s[0];
  s[3] ^= s[1];
  s[1] ^= s[2];
  s[0] ^= s[3];
  s[2] ^= t;
  s[3] = rotl(s[3], 45);
  return result;
}

// Top 53 bits as a double in [0, 1).
double ek_rng_uniform(ek_rng *rng) { return (double)(ek_rng_next(rng) >> 11) * 0x1p-53; }

// Box-Muller (Box & Muller 1958); one of the pair is dropped so the stream
// has no hidden state besides the xoshiro words.
double ek_rng_gauss(ek_rng *rng) {
  double u1 = 1.0 - ek_rng_uniform(rng); // (0, 1], so log is finite
  double u2 = ek_rng_uniform(rng);
  return sqrt(-2.0 * log(u1)) * cos(TWO_PI * u2);
}

void ek_rng_gauss_matrix(ek_rng *rng, double A[9]) {
  for (int i = 0; i < 9; i++)
    A[i] = ek_rng_gauss(rng);
}

// A normalised Gaussian 4-vector is uniform on S^3, and the unit quaternion
// map S^3 -> SO(3) carries that to the Haar measure (Shoemake, "Uniform
// random rotations", Graphics Gems III, 1992).
void ek_rng_rotation(ek_rng *rng, double R[9]) {
  double w, x, y, z, n2;
  do {
    w = ek_rng_gauss(rng), x = ek_rng_gauss(rng), y = ek_rng_gauss(rng), z = ek_rng_gauss(rng);
    n2 = w * w + x * x + y * y + z * z;
  } while (n2 < 1e-12);
  double inv = 1.0 / sqrt(n2);
  w *= inv, x *= inv, y *= inv, z *= inv;
  double M[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                 2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                 2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
  memcpy(R, M, sizeof M);
}

void ek_rng_with_sigma(ek_rng *rng, const double sigma[3], double A[9]) {
  double U[9], V[9], US[9];
  ek_rng_rotation(rng, U);
  ek_rng_rotation(rng, V);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      US[3 * i + j] = U[3 * i + j] * sigma[j];
  ek_mul3_bt(US, V, A);
}

void ek_rng_deformation(ek_rng *rng, double g, double A[9]) {
  double Q[9], G[9];
  ek_rng_rotation(rng, Q);
  ek_rng_gauss_matrix(rng, G);
  for (int k = 0; k < 9; k++)
    G[k] = (k % 4 == 0) + g * G[k];
  ek_mul3(Q, G, A);
}

// FNV-1a of the name, mixed with the seed: a family's stream does not move
// when rows are added to or reordered in a table.
uint64_t ek_check_stream_seed(uint64_t seed, const char *name) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (const char *c = name; *c; c++)
    h = (h ^ (unsigned char)*c) * 0x100000001b3ull;
  uint64_t x = seed ^ h;
  return splitmix64(&x);
}

double ek_det3(const double M[9]) {
  return M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) +
         M[2] * (M[3] * M[7] - M[4] * M[6]);
}

void ek_mul3(const double A[9], const double B[9], double C[9]) {
  double T[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      T[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
  memcpy(C, T, sizeof T);
}

void ek_mul3_bt(const double A[9], const double B[9], double C[9]) {
  double T[9];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      T[3 * i + j] =
          A[3 * i] * B[3 * j] + A[3 * i + 1] * B[3 * j + 1] + A[3 * i + 2] * B[3 * j + 2];
  memcpy(C, T, sizeof T);
}

void ek_print3(const char *label, const double M[9]) {
  printf("  %-10s [% .17g % .17g % .17g;\n  %-10s  % .17g % .17g % .17g;\n  %-10s  % .17g % .17g "
         "% .17g]\n",
         label, M[0], M[1], M[2], "", M[3], M[4], M[5], "", M[6], M[7], M[8]);
}

void ek_check_to_f32(size_t count, const double *in, float *out) {
  for (size_t i = 0; i < count; i++)
    out[i] = (float)in[i];
}

float *ek_check_f32_copy(size_t count, const double *in) {
  float *f = ek_check_malloc((count ? count : 1) * sizeof(float));
  if (in)
    ek_check_to_f32(count, in, f);
  else
    ek_check_poison(f, count * sizeof(float));
  return f;
}

void ek_check_from_f32(size_t count, const float *in, double *out) {
  for (size_t i = 0; i < count; i++)
    out[i] = in[i];
}

int ek_check_finite9(const double A[9]) {
  for (int i = 0; i < 9; i++)
    if (!isfinite(A[i]))
      return 0;
  return 1;
}
