// ek umbrella header: everything public.
#ifndef EK_EK_H
#define EK_EK_H
#include "batch.h"
#include "cloth.h"
#include "core.h"
#include "elements.h"
#include "fvm.h"
#include "hessian.h"
#include "material.h"
#include "mesh.h"
#include "polar.h"
#include "sim.h"
#include "svd3.h"
#include "xpbd.h"
#endif
