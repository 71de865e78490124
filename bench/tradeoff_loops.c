// The loop maps of the speed/accuracy map: a stub until they land.
#include "tradeoff.h"

// loop maps: see issue 12
int ek_tradeoff_loops(ek_tradeoff *t) {
  (void)t;
  return 0;
}
