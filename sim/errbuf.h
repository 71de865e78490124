// libek_sim's one error convention (core.h): a public function returns its
// code (or NULL) and leaves the message for ek_last_error(). Inside the
// library the functions keep their message buffer: NAME_errbuf is NAME's
// body with (err, errlen), called by the library itself and by the wrapper
// NAME in sim/errors.c, which records the message. Not installed.
#ifndef EK_SIM_ERRBUF_H
#define EK_SIM_ERRBUF_H

#include <ek/sim/sim.h>

// Room for a message: a path of EK_SCENE_PATH_MAX bytes and its context.
#define EK_ERRBUF_LEN 2048

// libek's recorder of ek_last_error's message (kernels/kernels.h).
void ek_set_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

ek_mesh *ek_mesh_create_errbuf(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                               char *err, size_t errlen);
ek_mesh *ek_mesh_create_ex_errbuf(size_t nverts, const double *X, size_t ntets, const int32_t *tets,
                                  const ek_mesh_opts *opts, char *err, size_t errlen);
ek_mesh *ek_mesh_load_errbuf(const char *path, char *err, size_t errlen);
ek_mesh *ek_mesh_load_ex_errbuf(const char *path, const ek_mesh_opts *opts, char *err,
                                size_t errlen);
ek_mesh *ek_mesh_box_errbuf(int nx, int ny, int nz, double lx, double ly, double lz, char *err,
                            size_t errlen);
ek_trimesh *ek_trimesh_create_errbuf(size_t nverts, const double *X, size_t ntris,
                                     const int32_t *tris, char *err, size_t errlen);
ek_trimesh *ek_trimesh_load_errbuf(const char *path, char *err, size_t errlen);
ek_trimesh *ek_trimesh_grid_errbuf(int nx, int ny, double lx, double ly, const char *plane,
                                   char *err, size_t errlen);
int ek_scene_load_errbuf(const char *path, ek_scene *scene, char *err, size_t errlen);
int ek_scene_parse_errbuf(const char *text, const char *name, const char *base_dir, ek_scene *scene,
                          char *err, size_t errlen);
ek_mesh *ek_scene_mesh_errbuf(const ek_scene *scene, char *err, size_t errlen);
ek_trimesh *ek_scene_trimesh_errbuf(const ek_scene *scene, char *err, size_t errlen);
ek_sim *ek_sim_create_errbuf(const ek_scene *scene, const ek_mesh *mesh, char *err, size_t errlen);
ek_sim *ek_sim_create_cloth_errbuf(const ek_scene *scene, const ek_trimesh *mesh, char *err,
                                   size_t errlen);
ek_frames *ek_frames_create_errbuf(const char *path, int force, size_t nverts, const double *X,
                                   size_t ntets, const int32_t *tets, char *err, size_t errlen);
ek_frames *ek_frames_create_ex_errbuf(const char *path, int force, size_t nverts, const double *X,
                                      size_t nelems, int nodes, const int32_t *elems, char *err,
                                      size_t errlen);
int ek_frames_write_errbuf(ek_frames *fr, double time, long step, const double *x, const double *J,
                           const double *smin, const double *psi, char *err, size_t errlen);
int ek_frames_write_fields_errbuf(ek_frames *fr, double time, long step, const double *x,
                                  const ek_frame_fields *fields, char *err, size_t errlen);
int ek_frames_close_errbuf(ek_frames *fr, char *err, size_t errlen);
int ek_frames_set_info_errbuf(ek_frames *fr, const ek_frames_info *info, char *err, size_t errlen);

#endif
