// The ek_mesh forms of the tet velocity gradient (include/ek/sim/mesh.h):
// the kernel (cloth.h) works on the mesh's element layer
// (kernels/cloth/cloth.c).
#include <ek/cloth.h>
#include <ek/sim/sim.h>

int ek_mesh_velocity_gradient_f64(const ek_mesh *m, const double *x, const double *v, double *L,
                                  double *D, double *W) {
  return ek_tet_velocity_gradient_f64(m ? ek_mesh_elements(m) : NULL, x, v, L, D, W, NULL);
}

int ek_mesh_velocity_gradient_f32(const ek_mesh *m, const float *x, const float *v, float *L,
                                  float *D, float *W) {
  return ek_tet_velocity_gradient_f32(m ? ek_mesh_elements(m) : NULL, x, v, L, D, W, NULL);
}
