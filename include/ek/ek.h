// ek umbrella header: the kernel library (libek, ek::ek), everything
// public. The simulation library (libek_sim, ek::sim: meshes, scenes, the
// loop, frames) has its own, <ek/sim/sim.h>.
#ifndef EK_EK_H
#define EK_EK_H
#include "batch.h"
#include "cloth.h"
#include "cloth_force.h"
#include "core.h"
#include "elements.h"
#include "fvm.h"
#include "hessian.h"
#include "material.h"
#include "polar.h"
#include "svd3.h"
#include "xpbd.h"
#endif
