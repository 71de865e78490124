// Included by each model file (kernels/material/<name>.c) after its traits
// (models.h lists them): what the file's two builds need. The kernel build
// (per ISA x precision) gets the vector API and the shared matrix math; the
// descriptor build (EK_MODEL_DESCRIPTOR, baseline ISA) the descriptor type.
#ifndef EK_KERNELS_MATERIAL_MODEL_H
#define EK_KERNELS_MATERIAL_MODEL_H

#include <math.h>
#include <stdio.h>

#include "models.h"

#ifndef EK_MODEL_DESCRIPTOR
#include "../simd/simd.h"
// simd.h first: the headers below are written against it.
#include "material_math.h"
#endif

#endif
