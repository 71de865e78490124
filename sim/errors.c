// The public forms of libek_sim's functions that fail with a message: each
// runs its NAME_errbuf body (sim/errbuf.h) and records the same message for
// ek_last_error() (core.h), the one error convention of ek's API.
#include "errbuf.h"

ek_mesh *ek_mesh_create(size_t nverts, const double *X, size_t ntets, const int32_t *tets) {
  char err[EK_ERRBUF_LEN] = "";
  ek_mesh *r = ek_mesh_create_errbuf(nverts, X, ntets, tets, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_mesh *ek_mesh_create_ex(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                           const ek_mesh_opts *opts) {
  char err[EK_ERRBUF_LEN] = "";
  ek_mesh *r = ek_mesh_create_ex_errbuf(nverts, X, ntets, tets, opts, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_mesh *ek_mesh_load(const char *path) {
  char err[EK_ERRBUF_LEN] = "";
  ek_mesh *r = ek_mesh_load_errbuf(path, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_mesh *ek_mesh_load_ex(const char *path, const ek_mesh_opts *opts) {
  char err[EK_ERRBUF_LEN] = "";
  ek_mesh *r = ek_mesh_load_ex_errbuf(path, opts, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_mesh *ek_mesh_box(int nx, int ny, int nz, double lx, double ly, double lz) {
  char err[EK_ERRBUF_LEN] = "";
  ek_mesh *r = ek_mesh_box_errbuf(nx, ny, nz, lx, ly, lz, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_trimesh *ek_trimesh_create(size_t nverts, const double *X, size_t ntris, const int32_t *tris) {
  char err[EK_ERRBUF_LEN] = "";
  ek_trimesh *r = ek_trimesh_create_errbuf(nverts, X, ntris, tris, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_trimesh *ek_trimesh_load(const char *path) {
  char err[EK_ERRBUF_LEN] = "";
  ek_trimesh *r = ek_trimesh_load_errbuf(path, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_trimesh *ek_trimesh_grid(int nx, int ny, double lx, double ly, const char *plane) {
  char err[EK_ERRBUF_LEN] = "";
  ek_trimesh *r = ek_trimesh_grid_errbuf(nx, ny, lx, ly, plane, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

int ek_scene_load(const char *path, ek_scene *scene) {
  char err[EK_ERRBUF_LEN] = "";
  int rc = ek_scene_load_errbuf(path, scene, err, sizeof err);
  if (rc != 0)
    ek_set_error("%s", err);
  return rc;
}

int ek_scene_parse(const char *text, const char *name, const char *base_dir, ek_scene *scene) {
  char err[EK_ERRBUF_LEN] = "";
  int rc = ek_scene_parse_errbuf(text, name, base_dir, scene, err, sizeof err);
  if (rc != 0)
    ek_set_error("%s", err);
  return rc;
}

ek_mesh *ek_scene_mesh(const ek_scene *scene) {
  char err[EK_ERRBUF_LEN] = "";
  ek_mesh *r = ek_scene_mesh_errbuf(scene, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_trimesh *ek_scene_trimesh(const ek_scene *scene) {
  char err[EK_ERRBUF_LEN] = "";
  ek_trimesh *r = ek_scene_trimesh_errbuf(scene, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_sim *ek_sim_create(const ek_scene *scene, const ek_mesh *mesh) {
  char err[EK_ERRBUF_LEN] = "";
  ek_sim *r = ek_sim_create_errbuf(scene, mesh, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_sim *ek_sim_create_cloth(const ek_scene *scene, const ek_trimesh *mesh) {
  char err[EK_ERRBUF_LEN] = "";
  ek_sim *r = ek_sim_create_cloth_errbuf(scene, mesh, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_frames *ek_frames_create(const char *path, int force, size_t nverts, const double *X,
                            size_t ntets, const int32_t *tets) {
  char err[EK_ERRBUF_LEN] = "";
  ek_frames *r = ek_frames_create_errbuf(path, force, nverts, X, ntets, tets, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

ek_frames *ek_frames_create_ex(const char *path, int force, size_t nverts, const double *X,
                               size_t nelems, int nodes, const int32_t *elems) {
  char err[EK_ERRBUF_LEN] = "";
  ek_frames *r =
      ek_frames_create_ex_errbuf(path, force, nverts, X, nelems, nodes, elems, err, sizeof err);
  if (!r)
    ek_set_error("%s", err);
  return r;
}

int ek_frames_write(ek_frames *fr, double time, long step, const double *x, const double *J,
                    const double *smin, const double *psi) {
  char err[EK_ERRBUF_LEN] = "";
  int rc = ek_frames_write_errbuf(fr, time, step, x, J, smin, psi, err, sizeof err);
  if (rc != 0)
    ek_set_error("%s", err);
  return rc;
}

int ek_frames_write_fields(ek_frames *fr, double time, long step, const double *x,
                           const ek_frame_fields *fields) {
  char err[EK_ERRBUF_LEN] = "";
  int rc = ek_frames_write_fields_errbuf(fr, time, step, x, fields, err, sizeof err);
  if (rc != 0)
    ek_set_error("%s", err);
  return rc;
}

int ek_frames_set_info(ek_frames *fr, const ek_frames_info *info) {
  char err[EK_ERRBUF_LEN] = "";
  int rc = ek_frames_set_info_errbuf(fr, info, err, sizeof err);
  if (rc != 0)
    ek_set_error("%s", err);
  return rc;
}

int ek_frames_close(ek_frames *fr) {
  char err[EK_ERRBUF_LEN] = "";
  int rc = ek_frames_close_errbuf(fr, err, sizeof err);
  if (rc != 0)
    ek_set_error("%s", err);
  return rc;
}
