// Internal: HDF5 prints its error stack for every failed call (a full disk
// gave ~180 lines); ek reports its own messages. Shared by the frames
// writer (sim/frames.c) and ek-bench's results (bench/results.c).
// Header-only, as text_escape.h: nothing to link.
#ifndef EK_SIM_H5_QUIET_H
#define EK_SIM_H5_QUIET_H

#include <hdf5.h>

typedef struct {
  H5E_auto2_t func;
  void *data;
} h5_quiet;

// Mute HDF5's automatic error printing, keeping the handler in *q.
static inline void h5_quiet_on(h5_quiet *q) {
  H5Eget_auto2(H5E_DEFAULT, &q->func, &q->data);
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
}

// Put back the handler h5_quiet_on kept.
static inline void h5_quiet_off(const h5_quiet *q) { H5Eset_auto2(H5E_DEFAULT, q->func, q->data); }

#endif
