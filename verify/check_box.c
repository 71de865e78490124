// A box of tets at the kernel level (check_box.h): ek_mesh_box's vertices
// and tets, from the same code (sim/mesh_box.h, header-only), without the
// simulation library.
#include "check_box.h"

#include <ek/core.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../sim/mesh_box.h"

int ek_check_box_create(ek_check_box *b, int nx, int ny, int nz, double lx, double ly, double lz) {
  memset(b, 0, sizeof *b);
  if (nx < 1 || ny < 1 || nz < 1 || !(lx > 0 && isfinite(lx)) || !(ly > 0 && isfinite(ly)) ||
      !(lz > 0 && isfinite(lz)))
    return EK_EINVAL;
  int rc = mesh_box_arrays(nx, ny, nz, lx, ly, lz, &b->X, &b->T, &b->nverts, &b->ntets);
  if (rc)
    return rc;
  b->el = ek_tets_create(b->nverts, b->X, b->ntets, b->T);
  if (!b->el) {
    ek_check_box_destroy(b);
    return EK_EINVAL;
  }
  return 0;
}

void ek_check_box_destroy(ek_check_box *b) {
  if (!b)
    return;
  ek_tets_destroy(b->el);
  free(b->X);
  free(b->T);
  memset(b, 0, sizeof *b);
}
