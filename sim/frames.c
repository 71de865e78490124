// Simulation frames: HDF5 (rest mesh once, then per frame positions and
// per-tet fields) with an XDMF companion that ParaView reads as a temporal
// collection of tetrahedral grids.
//
// Crash safety: the file is created with the latest format and switched to
// single-writer/multiple-reader (SWMR) mode before the first frame. In that
// mode HDF5 orders its metadata writes (flush dependencies) so that the file
// on disk is consistent at every moment, and each frame ends with
// H5Fflush; a writer killed at any point therefore leaves every completed
// frame readable (HDF5 user guide, "Single Writer/Multiple Reader"). Frames
// are appended by extending chunked datasets; /frames/time is extended last,
// so its length is the number of complete frames.
#include <ek/sim.h>

#include <errno.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

struct ek_frames {
  hid_t file;
  hid_t positions, J, smin, psi, step, time; // extendible datasets
  hid_t smax;                                // triangles only: the larger stretch
  hid_t D, W, rates; // the velocity gradient's parts: nelems x 9, 9 and 3 per frame
  hid_t vrot;        // per-vertex Kabsch rotations: nverts x 9 per frame
  size_t nverts, ntets;
  int nodes; // per element: 4 (tets, /mesh/tets) or 3 (triangles, /mesh/triangles)
  long nframes;
  double *nan_fill; // 9 max(ntets, nverts) NaNs for fields the caller did not give
  double *times;    // per frame, for the XDMF
  size_t times_cap;
  char h5path[EK_SCENE_PATH_MAX];
  char xdmf_path[EK_SCENE_PATH_MAX];
};

void ek_frames_xdmf_path(const char *h5path, char *out, size_t outlen) {
  size_t n = strlen(h5path);
  if (n > 3 && strcmp(h5path + n - 3, ".h5") == 0)
    snprintf(out, outlen, "%.*s.xmf", (int)(n - 3), h5path);
  else
    snprintf(out, outlen, "%s.xmf", h5path);
}

static int file_exists(const char *path) {
  struct stat st;
  return stat(path, &st) == 0;
}

// HDF5 prints its error stack by default; ek reports its own messages.
typedef struct {
  H5E_auto2_t func;
  void *data;
} h5_quiet;
static void quiet_on(h5_quiet *q) {
  H5Eget_auto2(H5E_DEFAULT, &q->func, &q->data);
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
}
static void quiet_off(const h5_quiet *q) { H5Eset_auto2(H5E_DEFAULT, q->func, q->data); }

// A fixed dataset written in one go.
static int write_fixed(hid_t loc, const char *name, hid_t type, int rank, const hsize_t *dims,
                       const void *data) {
  hid_t space = H5Screate_simple(rank, dims, NULL);
  hid_t dset = H5Dcreate2(loc, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  herr_t rc = dset < 0 ? -1 : H5Dwrite(dset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  if (dset >= 0)
    H5Dclose(dset);
  H5Sclose(space);
  return rc < 0 ? -1 : 0;
}

// An extendible dataset [0 x inner...], one frame per chunk row.
static hid_t create_series(hid_t loc, const char *name, hid_t type, int inner_rank,
                           const hsize_t *inner) {
  hsize_t dims[3] = {0, 0, 0}, maxdims[3] = {H5S_UNLIMITED, 0, 0}, chunk[3] = {1, 1, 1};
  for (int i = 0; i < inner_rank; ++i) {
    dims[i + 1] = maxdims[i + 1] = chunk[i + 1] = inner[i];
  }
  // Scalars per frame (time, step): several frames per chunk.
  if (inner_rank == 0)
    chunk[0] = 256;
  hid_t space = H5Screate_simple(inner_rank + 1, dims, maxdims);
  hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(dcpl, inner_rank + 1, chunk);
  hid_t dset = H5Dcreate2(loc, name, type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  H5Pclose(dcpl);
  H5Sclose(space);
  return dset;
}

// Extend a series to `frames` rows and write row frames-1.
static int append_row(hid_t dset, hid_t type, int inner_rank, const hsize_t *inner, long frames,
                      const void *data) {
  hsize_t dims[3] = {(hsize_t)frames, 0, 0}, start[3] = {(hsize_t)frames - 1, 0, 0},
          count[3] = {1, 1, 1};
  for (int i = 0; i < inner_rank; ++i)
    dims[i + 1] = count[i + 1] = inner[i];
  if (H5Dset_extent(dset, dims) < 0)
    return -1;
  hid_t fspace = H5Dget_space(dset);
  hid_t mspace = H5Screate_simple(inner_rank + 1, count, NULL);
  herr_t rc = H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, NULL, count, NULL);
  if (rc >= 0)
    rc = H5Dwrite(dset, type, mspace, fspace, H5P_DEFAULT, data);
  H5Sclose(mspace);
  H5Sclose(fspace);
  if (rc >= 0)
    rc = H5Dflush(dset);
  return rc < 0 ? -1 : 0;
}

static void close_all(ek_frames *fr) {
  hid_t *ds[] = {&fr->positions, &fr->J, &fr->smin, &fr->psi,   &fr->step, &fr->time,
                 &fr->smax,      &fr->D, &fr->W,    &fr->rates, &fr->vrot};
  for (size_t i = 0; i < sizeof ds / sizeof ds[0]; ++i)
    if (*ds[i] >= 0) {
      H5Dclose(*ds[i]);
      *ds[i] = -1;
    }
  if (fr->file >= 0) {
    H5Fclose(fr->file);
    fr->file = -1;
  }
}

static void destroy(ek_frames *fr) {
  if (!fr)
    return;
  close_all(fr);
  free(fr->nan_fill);
  free(fr->times);
  free(fr);
}

// Write the XDMF for the frames so far: into a temporary file, then renamed
// over the old one, so a reader (or a kill) never sees a half-written XDMF.
static int write_xdmf(const ek_frames *fr, char *err, size_t errlen) {
  char tmp[EK_SCENE_PATH_MAX + 8];
  snprintf(tmp, sizeof tmp, "%s.tmp", fr->xdmf_path);
  FILE *f = fopen(tmp, "w");
  if (!f) {
    if (err && errlen)
      snprintf(err, errlen, "%s: cannot write: %s", tmp, strerror(errno));
    return EK_EIO;
  }
  // The XDMF names the HDF5 file relative to itself (same directory).
  const char *h5name = strrchr(fr->h5path, '/');
  h5name = h5name ? h5name + 1 : fr->h5path;
  size_t nv = fr->nverts, nt = fr->ntets;
  long nf = fr->nframes;
  fprintf(f, "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
             "<Xdmf Version=\"3.0\">\n <Domain>\n"
             "  <Grid Name=\"frames\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
  static const char *fields[] = {"J", "smin", "energy_density_from_rest", "smax"};
  const int nfields = fr->nodes == 3 ? 4 : 3;
  const char *topology = fr->nodes == 3 ? "Triangle" : "Tetrahedron",
             *elements = fr->nodes == 3 ? "triangles" : "tets";
  for (long i = 0; i < nf; ++i) {
    fprintf(f, "   <Grid Name=\"frame_%06ld\" GridType=\"Uniform\">\n", i);
    fprintf(f, "    <Time Value=\"%.17g\"/>\n", fr->times[i]);
    fprintf(f,
            "    <Topology TopologyType=\"%s\" NumberOfElements=\"%zu\">\n"
            "     <DataItem Dimensions=\"%zu %d\" NumberType=\"Int\" Precision=\"4\" "
            "Format=\"HDF\">%s:/mesh/%s</DataItem>\n    </Topology>\n",
            topology, nt, nt, fr->nodes, h5name, elements);
    fprintf(f,
            "    <Geometry GeometryType=\"XYZ\">\n"
            "     <DataItem ItemType=\"HyperSlab\" Dimensions=\"1 %zu 3\" Type=\"HyperSlab\">\n"
            "      <DataItem Dimensions=\"3 3\" Format=\"XML\">%ld 0 0 1 1 1 1 %zu 3</DataItem>\n"
            "      <DataItem Dimensions=\"%ld %zu 3\" NumberType=\"Float\" Precision=\"8\" "
            "Format=\"HDF\">%s:/frames/positions</DataItem>\n"
            "     </DataItem>\n    </Geometry>\n",
            nv, i, nv, nf, nv, h5name);
    for (int k = 0; k < nfields; ++k)
      fprintf(f,
              "    <Attribute Name=\"%s\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
              "     <DataItem ItemType=\"HyperSlab\" Dimensions=\"1 %zu\" Type=\"HyperSlab\">\n"
              "      <DataItem Dimensions=\"3 2\" Format=\"XML\">%ld 0 1 1 1 %zu</DataItem>\n"
              "      <DataItem Dimensions=\"%ld %zu\" NumberType=\"Float\" Precision=\"8\" "
              "Format=\"HDF\">%s:/frames/%s</DataItem>\n"
              "     </DataItem>\n    </Attribute>\n",
              fields[k], nt, i, nt, nf, nt, h5name, fields[k]);
    // The velocity gradient's parts (sim.h): D and W as 3x3 tensors, the
    // principal strain rates as a 3-vector per element.
    static const char *rate_fields[] = {"D", "W", "strain_rates"};
    static const char *rate_types[] = {"Tensor", "Tensor", "Vector"};
    static const int rate_comps[] = {9, 9, 3};
    for (int k = 0; k < 3; ++k)
      fprintf(
          f,
          "    <Attribute Name=\"%s\" AttributeType=\"%s\" Center=\"Cell\">\n"
          "     <DataItem ItemType=\"HyperSlab\" Dimensions=\"1 %zu %d\" Type=\"HyperSlab\">\n"
          "      <DataItem Dimensions=\"3 3\" Format=\"XML\">%ld 0 0 1 1 1 1 %zu %d</DataItem>\n"
          "      <DataItem Dimensions=\"%ld %zu %d\" NumberType=\"Float\" Precision=\"8\" "
          "Format=\"HDF\">%s:/frames/%s</DataItem>\n"
          "     </DataItem>\n    </Attribute>\n",
          rate_fields[k], rate_types[k], nt, rate_comps[k], i, nt, rate_comps[k], nf, nt,
          rate_comps[k], h5name, rate_fields[k]);
    fprintf(f,
            "    <Attribute Name=\"vertex_rotation\" AttributeType=\"Tensor\" Center=\"Node\">\n"
            "     <DataItem ItemType=\"HyperSlab\" Dimensions=\"1 %zu 9\" Type=\"HyperSlab\">\n"
            "      <DataItem Dimensions=\"3 3\" Format=\"XML\">%ld 0 0 1 1 1 1 %zu 9</DataItem>\n"
            "      <DataItem Dimensions=\"%ld %zu 9\" NumberType=\"Float\" Precision=\"8\" "
            "Format=\"HDF\">%s:/frames/vertex_rotation</DataItem>\n"
            "     </DataItem>\n    </Attribute>\n",
            nv, i, nv, nf, nv, h5name);
    fprintf(f, "   </Grid>\n");
  }
  fprintf(f, "  </Grid>\n </Domain>\n</Xdmf>\n");
  int bad = ferror(f);
  bad |= fclose(f) != 0;
  if (bad || rename(tmp, fr->xdmf_path) != 0) {
    if (err && errlen)
      snprintf(err, errlen, "%s: write failed: %s", fr->xdmf_path, strerror(errno));
    remove(tmp);
    return EK_EIO;
  }
  return 0;
}

ek_frames *ek_frames_create(const char *path, int force, size_t nverts, const double *X,
                            size_t ntets, const int32_t *tets, char *err, size_t errlen) {
  return ek_frames_create_ex(path, force, nverts, X, ntets, 4, tets, err, errlen);
}

ek_frames *ek_frames_create_ex(const char *path, int force, size_t nverts, const double *X,
                               size_t ntets, int nodes, const int32_t *tets, char *err,
                               size_t errlen) {
  if (nodes != 3 && nodes != 4) {
    if (err && errlen)
      snprintf(err, errlen, "ek_frames_create_ex: %d nodes per element: 3 or 4", nodes);
    return NULL;
  }
  if (err && errlen)
    err[0] = '\0';
  if (!path || !path[0] || !X || !tets || nverts == 0 || ntets == 0) {
    if (err && errlen)
      snprintf(err, errlen, "ek_frames_create: empty path or mesh");
    return NULL;
  }
  if (strlen(path) + 6 >= EK_SCENE_PATH_MAX) {
    if (err && errlen)
      snprintf(err, errlen, "%s: path too long", path);
    return NULL;
  }
  ek_frames *fr = calloc(1, sizeof *fr);
  if (!fr)
    return NULL;
  fr->file = fr->positions = fr->J = fr->smin = fr->psi = fr->step = fr->time = fr->smax = -1;
  fr->D = fr->W = fr->rates = fr->vrot = -1;
  fr->nodes = nodes;
  fr->nverts = nverts;
  fr->ntets = ntets;
  snprintf(fr->h5path, sizeof fr->h5path, "%s", path);
  ek_frames_xdmf_path(path, fr->xdmf_path, sizeof fr->xdmf_path);
  // Never overwrite results unless asked: check both files before touching
  // either.
  if (!force) {
    const char *existing = file_exists(fr->h5path)      ? fr->h5path
                           : file_exists(fr->xdmf_path) ? fr->xdmf_path
                                                        : NULL;
    if (existing) {
      if (err && errlen)
        snprintf(err, errlen, "%s: exists; refusing to overwrite (use --force)", existing);
      destroy(fr);
      return NULL;
    }
  }
  size_t nfill = 9 * (ntets > nverts ? ntets : nverts);
  fr->nan_fill = malloc(nfill * sizeof(double));
  fr->times_cap = 64;
  fr->times = malloc(fr->times_cap * sizeof(double));
  if (!fr->nan_fill || !fr->times) {
    destroy(fr);
    return NULL;
  }
  for (size_t i = 0; i < nfill; ++i)
    fr->nan_fill[i] = NAN;

  h5_quiet q;
  quiet_on(&q);
  const char *what = "create";
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  // SWMR needs the latest file format.
  H5Pset_libver_bounds(fapl, H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  fr->file = H5Fcreate(path, force ? H5F_ACC_TRUNC : H5F_ACC_EXCL, H5P_DEFAULT, fapl);
  H5Pclose(fapl);
  int ok = fr->file >= 0;
  if (ok) {
    what = "write the rest mesh to";
    hid_t mesh = H5Gcreate2(fr->file, "mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    hsize_t vdims[2] = {nverts, 3}, tdims[2] = {ntets, (hsize_t)nodes};
    ok =
        mesh >= 0 && write_fixed(mesh, "vertices", H5T_NATIVE_DOUBLE, 2, vdims, X) == 0 &&
        write_fixed(mesh, nodes == 3 ? "triangles" : "tets", H5T_NATIVE_INT32, 2, tdims, tets) == 0;
    if (mesh >= 0)
      H5Gclose(mesh);
  }
  if (ok) {
    what = "create the frame datasets in";
    hid_t frames = H5Gcreate2(fr->file, "frames", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    hsize_t pos_inner[2] = {nverts, 3}, tet_inner[1] = {ntets};
    fr->positions = create_series(frames, "positions", H5T_NATIVE_DOUBLE, 2, pos_inner);
    fr->J = create_series(frames, "J", H5T_NATIVE_DOUBLE, 1, tet_inner);
    fr->smin = create_series(frames, "smin", H5T_NATIVE_DOUBLE, 1, tet_inner);
    fr->psi = create_series(frames, "energy_density_from_rest", H5T_NATIVE_DOUBLE, 1, tet_inner);
    fr->step = create_series(frames, "step", H5T_NATIVE_INT64, 0, NULL);
    fr->time = create_series(frames, "time", H5T_NATIVE_DOUBLE, 0, NULL);
    if (nodes == 3)
      fr->smax = create_series(frames, "smax", H5T_NATIVE_DOUBLE, 1, tet_inner);
    hsize_t t9[2] = {ntets, 9}, t3[2] = {ntets, 3};
    fr->D = create_series(frames, "D", H5T_NATIVE_DOUBLE, 2, t9);
    fr->W = create_series(frames, "W", H5T_NATIVE_DOUBLE, 2, t9);
    fr->rates = create_series(frames, "strain_rates", H5T_NATIVE_DOUBLE, 2, t3);
    hsize_t v9[2] = {nverts, 9};
    fr->vrot = create_series(frames, "vertex_rotation", H5T_NATIVE_DOUBLE, 2, v9);
    ok = frames >= 0 && fr->positions >= 0 && fr->J >= 0 && fr->smin >= 0 && fr->psi >= 0 &&
         fr->step >= 0 && fr->time >= 0 && (nodes == 4 || fr->smax >= 0) && fr->D >= 0 &&
         fr->W >= 0 && fr->rates >= 0 && fr->vrot >= 0;
    if (frames >= 0)
      H5Gclose(frames);
  }
  if (ok) {
    what = "switch to single-writer/multiple-reader mode";
    ok = H5Fstart_swmr_write(fr->file) >= 0 && H5Fflush(fr->file, H5F_SCOPE_GLOBAL) >= 0;
  }
  quiet_off(&q);
  if (!ok) {
    if (err && errlen)
      snprintf(err, errlen, "%s: cannot %s the HDF5 file%s", path, what,
               fr->file < 0 && !force && file_exists(path) ? " (it exists)" : "");
    int created = fr->file >= 0;
    destroy(fr);
    if (created)
      remove(path); // no partial output
    return NULL;
  }
  if (write_xdmf(fr, err, errlen) != 0) {
    destroy(fr);
    remove(path);
    return NULL;
  }
  return fr;
}

int ek_frames_write(ek_frames *fr, double time, long step, const double *x, const double *J,
                    const double *smin, const double *psi, char *err, size_t errlen) {
  const ek_frame_fields ff = {.J = J, .smin = smin, .psi = psi};
  return ek_frames_write_fields(fr, time, step, x, &ff, err, errlen);
}

int ek_frames_write_fields(ek_frames *fr, double time, long step, const double *x,
                           const ek_frame_fields *ff, char *err, size_t errlen) {
  static const ek_frame_fields none = {0};
  if (!ff)
    ff = &none;
  const double *J = ff->J, *smin = ff->smin, *psi = ff->psi, *smax = ff->smax;
  if (!fr || fr->file < 0 || !x) {
    if (err && errlen)
      snprintf(err, errlen, "ek_frames_write: no open file or no positions");
    return EK_EINVAL;
  }
  if ((size_t)fr->nframes == fr->times_cap) {
    double *t = realloc(fr->times, 2 * fr->times_cap * sizeof(double));
    if (!t)
      return EK_ENOMEM;
    fr->times = t;
    fr->times_cap *= 2;
  }
  long n = fr->nframes + 1;
  hsize_t pos_inner[2] = {fr->nverts, 3}, tet_inner[1] = {fr->ntets};
  hsize_t t9[2] = {fr->ntets, 9}, t3[2] = {fr->ntets, 3}, v9[2] = {fr->nverts, 9};
  int64_t step64 = step;
  h5_quiet q;
  quiet_on(&q);
  // Time goes last: its length counts the complete frames.
  int ok =
      append_row(fr->positions, H5T_NATIVE_DOUBLE, 2, pos_inner, n, x) == 0 &&
      append_row(fr->J, H5T_NATIVE_DOUBLE, 1, tet_inner, n, J ? J : fr->nan_fill) == 0 &&
      append_row(fr->smin, H5T_NATIVE_DOUBLE, 1, tet_inner, n, smin ? smin : fr->nan_fill) == 0 &&
      append_row(fr->psi, H5T_NATIVE_DOUBLE, 1, tet_inner, n, psi ? psi : fr->nan_fill) == 0 &&
      (fr->smax < 0 ||
       append_row(fr->smax, H5T_NATIVE_DOUBLE, 1, tet_inner, n, smax ? smax : fr->nan_fill) == 0) &&
      append_row(fr->D, H5T_NATIVE_DOUBLE, 2, t9, n, ff->D ? ff->D : fr->nan_fill) == 0 &&
      append_row(fr->W, H5T_NATIVE_DOUBLE, 2, t9, n, ff->W ? ff->W : fr->nan_fill) == 0 &&
      append_row(fr->rates, H5T_NATIVE_DOUBLE, 2, t3, n,
                 ff->strain_rates ? ff->strain_rates : fr->nan_fill) == 0 &&
      append_row(fr->vrot, H5T_NATIVE_DOUBLE, 2, v9, n,
                 ff->vertex_R ? ff->vertex_R : fr->nan_fill) == 0 &&
      append_row(fr->step, H5T_NATIVE_INT64, 0, NULL, n, &step64) == 0 &&
      append_row(fr->time, H5T_NATIVE_DOUBLE, 0, NULL, n, &time) == 0 &&
      H5Fflush(fr->file, H5F_SCOPE_GLOBAL) >= 0;
  quiet_off(&q);
  if (!ok) {
    if (err && errlen)
      snprintf(err, errlen, "%s: writing frame %ld failed", fr->h5path, fr->nframes);
    return EK_EIO;
  }
  fr->times[fr->nframes] = time;
  fr->nframes = n;
  return write_xdmf(fr, err, errlen);
}

long ek_frames_count(const ek_frames *fr) { return fr ? fr->nframes : 0; }

int ek_frames_close(ek_frames *fr, char *err, size_t errlen) {
  if (!fr)
    return 0;
  h5_quiet q;
  quiet_on(&q);
  int rc = 0;
  hid_t *ds[] = {&fr->positions, &fr->J, &fr->smin, &fr->psi,   &fr->step, &fr->time,
                 &fr->smax,      &fr->D, &fr->W,    &fr->rates, &fr->vrot};
  for (size_t i = 0; i < sizeof ds / sizeof ds[0]; ++i)
    if (*ds[i] >= 0) {
      rc |= H5Dclose(*ds[i]) < 0;
      *ds[i] = -1;
    }
  if (fr->file >= 0) {
    rc |= H5Fclose(fr->file) < 0;
    fr->file = -1;
  }
  quiet_off(&q);
  if (rc && err && errlen)
    snprintf(err, errlen, "%s: closing failed", fr->h5path);
  destroy(fr);
  return rc ? EK_EIO : 0;
}
