// The ek_mesh forms of the FVM API (include/ek/sim/mesh.h): the kernels
// (fvm.h) work on the mesh's element layer (kernels/fvm/fvm.c), these
// forward to them.
#include <ek/fvm.h>
#include <ek/sim/sim.h>

int ek_mesh_fvm_forces_ex_f32(const ek_mesh *m, const ek_material *mat, const float *x, float *f,
                              const ek_fvm_opts *opts) {
  return ek_fvm_tet_forces_ex_f32(ek_mesh_elements(m), mat, x, f, opts);
}

int ek_mesh_fvm_forces_ex_f64(const ek_mesh *m, const ek_material *mat, const double *x, double *f,
                              const ek_fvm_opts *opts) {
  return ek_fvm_tet_forces_ex_f64(ek_mesh_elements(m), mat, x, f, opts);
}

int ek_mesh_fvm_forces_f32(const ek_mesh *m, const ek_material *mat, const float *x, float *f) {
  return ek_fvm_tet_forces_ex_f32(ek_mesh_elements(m), mat, x, f, NULL);
}

int ek_mesh_fvm_forces_f64(const ek_mesh *m, const ek_material *mat, const double *x, double *f) {
  return ek_fvm_tet_forces_ex_f64(ek_mesh_elements(m), mat, x, f, NULL);
}

double ek_mesh_fvm_energy_ex_f64(const ek_mesh *m, const ek_material *mat, const double *x,
                                 const double *R) {
  return ek_fvm_tet_energy_f64(ek_mesh_elements(m), mat, x, R);
}

double ek_mesh_fvm_energy_f64(const ek_mesh *m, const ek_material *mat, const double *x) {
  return ek_fvm_tet_energy_f64(ek_mesh_elements(m), mat, x, NULL);
}

int ek_mesh_deformation_gradients_f64(const ek_mesh *m, const double *x, double *F) {
  return ek_fvm_tet_deformation_gradients_f64(ek_mesh_elements(m), x, F);
}
