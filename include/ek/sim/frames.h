// ek simulation library (libek_sim, ek::sim): HDF5 frames.
//
// Frames (ek_frames_*): one HDF5 file with the rest mesh once and, per
// output frame, positions and per-tet fields (J, smallest singular value,
// energy density measured from the rest shape) and the time, committed
// whole every frame, plus an XDMF file beside it (same name, extension
// .xmf) so ParaView and meshio open the time series.
#ifndef EK_SIM_FRAMES_H
#define EK_SIM_FRAMES_H

#include <stddef.h>
#include <stdint.h>

#include <ek/core.h>

#ifdef __cplusplus
extern "C" {
#endif

// ---------------------------------------------------------------- frames

typedef struct ek_frames ek_frames;

// Create `path` (HDF5) and its XDMF companion and write the rest mesh.
// Refuses (NULL, message in ek_last_error) if either exists unless `force`; even with `force`
// if either, or a scratch or swap name below, is anything but a regular
// file (a directory, device, FIFO, socket or symbolic link: the commits
// rename over these names and would replace it); or if the XDMF cannot
// name the file (its base name holds a colon, a control character,
// bytes that are not UTF-8 or a leading/trailing blank). Layout:
//   /mesh/vertices   nverts x 3 double     /mesh/tets  ntets x 4 int32
//   /frames/time     nframes double        /frames/step nframes int64
//   /frames/positions/NNNNNN               nverts x 3 double
//   /frames/J/NNNNNN, /frames/smin/NNNNNN  ntets double
//   /frames/energy_density_from_rest/NNNNNN ntets double
// with NNNNNN the frame index (0-based, at least 6 digits); every field of
// ek_frame_fields has its group; each group and mesh dataset has the string
// attributes "units" and "description", the root "ek_version" and
// "element" (docs/outputs.md lists them all). The XDMF (3.0)
// is a temporal collection of one grid per frame whose data items are
// these whole datasets, the positions also as a point vector "positions";
// it names the HDF5 file by its base name, XML-escaped. The energy density
// is the `psi` ek_frames_write is given; ek-sim writes ek_sim_tet_fields'
// (from the rest shape: 0 at rest, and it sums to the elastic energy).
// `path` is always a closed, whole HDF5 file: each frame is written into a
// scratch copy (`path`.scratch, one frame behind) that then swaps names
// with `path` atomically, so a writer killed at any moment leaves every
// frame it completed readable with plain read-only access. The XDMF is
// committed the same way after each HDF5 commit (its scratch copy is the
// XDMF's name + ".scratch"; swap names ".swap"), so after a kill at any
// moment it is whole and lists the file's frames or all but the last.
// A write that fails (a full disk) is reported and the file keeps its
// frames; with HDF5 before 1.14.1 the failed close leaves an ID that
// HDF5's own exit handler then crashes on, so a program that may hit a full
// disk calls H5dont_atexit() before its first HDF5 call (ek-sim does).
ek_frames *ek_frames_create(const char *path, int force, size_t nverts, const double *X,
                            size_t ntets, const int32_t *tets);
// The same for any element kind: nodes = 4 (tets, /mesh/tets, XDMF
// Tetrahedron) or 3 (cloth triangles: /mesh/triangles, XDMF Triangle, and
// one more per-element field /frames/smax, the larger stretch; J is then
// the area ratio and smin the smaller stretch).
ek_frames *ek_frames_create_ex(const char *path, int force, size_t nverts, const double *X,
                               size_t nelems, int nodes, const int32_t *elems);
// Append one frame; J, smin, psi (energy density from the rest shape) may
// be NULL (written as NaN).
int ek_frames_write(ek_frames *fr, double time, long step, const double *x, const double *J,
                    const double *smin, const double *psi);
// Every per-element field of a frame (any may be NULL: written as NaN):
// J, smin, psi as above; smax (triangles only, the larger stretch); the
// velocity gradient's rate of strain D and spin W (nelems x 9 row-major,
// /frames/D, /frames/W: XDMF Tensor attributes) and the principal strain
// rates (nelems x 3, /frames/strain_rates: a Vector attribute), from
// ek_sim_rate_fields.
// vertex_R: the per-vertex rotations of ek_sim_vertex_rotations (nverts x
// 9, /frames/vertex_rotation, a Node-centred Tensor in the XDMF).
typedef struct {
  const double *J, *smin, *psi, *smax, *D, *W, *strain_rates;
  const double *vertex_R;
} ek_frame_fields;
int ek_frames_write_fields(ek_frames *fr, double time, long step, const double *x,
                           const ek_frame_fields *fields);
long ek_frames_count(const ek_frames *fr);
// Close the XDMF and remove the scratch copies (every frame is already in
// `path` and the XDMF). 0 on success.
int ek_frames_close(ek_frames *fr);
// The run, as string attributes on the file's root (docs/outputs.md; the
// units and description of every dataset are written at creation). NULL
// members are not written. Call before the first frame: 0, EK_EINVAL
// (frames already written) or EK_EIO, the message in ek_last_error.
typedef struct {
  const char *program, *scene, *model, *precision, *integrator, *git_revision;
} ek_frames_info;
int ek_frames_set_info(ek_frames *fr, const ek_frames_info *info);
// Path of the XDMF companion of an HDF5 path (".h5" replaced by ".xmf", or
// ".xmf" appended).
void ek_frames_xdmf_path(const char *h5path, char *out, size_t outlen);

#ifdef __cplusplus
}
#endif
#endif
