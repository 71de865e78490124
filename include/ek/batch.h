// AoSoA batches: the data layout every vector kernel reads and writes.
//
// A batch of n items with `nplanes` scalars each (9 for a row-major 3x3
// matrix, 3 for a vector) is stored in blocks of EK_LANES_F32 (float) or
// EK_LANES_F64 (double) items. Block b holds nplanes planes of LANES values:
//   soa[(b * nplanes + k) * LANES + l] = aos[(b * LANES + l) * nplanes + k].
// A plane is 64 bytes, one cache line and one AVX-512 vector; narrower ISAs
// walk a plane in several vectors. The layout is fixed for all ISAs so a
// batch packed once can be handed to any kernel variant.
// Tail lanes (n not a multiple of LANES) are padded with a safe value: the
// identity for 9-plane (3x3) batches, zero otherwise.
#ifndef EK_BATCH_H
#define EK_BATCH_H

#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EK_LANES_F32 16
#define EK_LANES_F64 8

// Number of blocks for n items, and scalars needed for the packed batch
// (ek_aosoa_size_*: 0 when nplanes is not in 1..64 or the byte count would
// overflow). Alignment and size rules of the arrays: core.h.
size_t ek_aosoa_blocks_f32(size_t n);
size_t ek_aosoa_blocks_f64(size_t n);
size_t ek_aosoa_size_f32(size_t n, int nplanes);
size_t ek_aosoa_size_f64(size_t n, int nplanes);

// Allocate a packed batch (64-byte aligned, tail padded); free with ek_free.
// NULL for a bad nplanes, a size that overflows, or out of memory.
float *ek_aosoa_alloc_f32(size_t n, int nplanes);
double *ek_aosoa_alloc_f64(size_t n, int nplanes);

// AoS (n x nplanes, item-major) <-> AoSoA. pack writes every lane, tails
// padded; unpack writes only the n real items. 1 <= nplanes <= 64.
int ek_aosoa_pack_f32(size_t n, int nplanes, const float *aos, float *soa);
int ek_aosoa_pack_f64(size_t n, int nplanes, const double *aos, double *soa);
int ek_aosoa_unpack_f32(size_t n, int nplanes, const float *soa, float *aos);
int ek_aosoa_unpack_f64(size_t n, int nplanes, const double *soa, double *aos);

#ifdef __cplusplus
}
#endif
#endif
