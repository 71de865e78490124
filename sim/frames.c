// Simulation frames: HDF5 (rest mesh once, then per frame positions and
// per-element and per-vertex fields) with an XDMF companion that ParaView
// and meshio read as a temporal collection of tetrahedral or triangle grids.
//
// Crash safety without SWMR: the file at `path` is always a closed HDF5
// file. Every frame is written into a scratch copy (`path.scratch`, opened,
// extended, closed), and the scratch copy and `path` then swap names in one
// atomic rename (renameat2 RENAME_EXCHANGE; hard link + rename where the
// file system lacks it). A writer killed at any moment therefore leaves at
// `path` the last committed file: it opens in any reader without h5clear,
// and holds every frame this writer reported complete. The old `path` is
// now the scratch copy, one frame behind; the next frame first replays the
// frame it lacks (kept in memory), so each frame is written twice: the I/O
// grows linearly with the frame count, at twice the data of one copy. A
// reader that still holds the old file open (HDF5's lock refuses the
// writer) keeps it: the scratch name then gets a fresh byte copy.
// In-place alternatives were rejected: a flush after each frame leaves a
// window inside the flush (and HDF5 may reuse space the on-disk metadata
// still points to) where a kill corrupts the file; SWMR avoids that but
// leaves a file every reader refuses until `h5clear -s`.
//
// The XDMF is committed the same way, as text: two copies, the committed
// file at its name and a scratch copy (that name + ".scratch") one frame
// behind. A frame appends the grid the scratch copy lacks, its own grid and
// the fixed closing tail at the scratch copy's end of body (one write over
// its old tail), and the two then swap names atomically. The file at the
// XDMF's name is therefore never written to: a writer killed at any
// moment, even inside a write (a SIGKILL cuts a write to a file between
// pages: CI once found an appended-in-place XDMF cut at 73728 bytes),
// leaves it whole and closed. Each frame costs two grids' text, so the
// cost grows linearly with the frame count (a rewrite of the whole file
// per frame would grow with its square; measured on a busy machine: 1000
// frames of an 81-vertex beam, wall minimum 1.35 s with the XDMF appended
// in place and 1.35 s this way: the HDF5 commits dominate). A frame's grid
// is committed after its HDF5 commit, so the XDMF never lists a frame the
// HDF5 file lacks (after a kill it may list one frame fewer). There is no
// XDMF only while the HDF5 file has no frame (between the HDF5 file's
// creation and the XDMF's; with force the old XDMF is replaced by an empty
// one first, atomically). No fsync: like the HDF5 side this is safe
// against the process dying, not the machine.
//
// The XDMF's data items are plain whole-dataset HDF references, one dataset
// per frame and field: meshio's TimeSeriesReader (5.3) reads only those
// (not HyperSlab items), and ParaView's Xdmf3 reader reads them too.
#define _GNU_SOURCE // renameat2 (glibc >= 2.28)
#include "errbuf.h"
#include "h5_quiet.h"
#include "not_regular.h"
#include <ek/sim/sim.h>

#include <errno.h>
#include <fcntl.h>
#include <hdf5.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

// The fields of a frame (sim.h, ek_frame_fields, in its order): values per
// element (or per vertex), the XDMF attribute type.
typedef struct {
  const char *name;
  int comps;
  int per_vertex;
  const char *xdmf_type;
} field_spec;
enum { NFIELDS = 8, FIELD_SMAX = 3 };
static const field_spec fields_spec[NFIELDS] = {{"J", 1, 0, "Scalar"},
                                                {"smin", 1, 0, "Scalar"},
                                                {"energy_density_from_rest", 1, 0, "Scalar"},
                                                {"smax", 1, 0, "Scalar"},
                                                {"D", 9, 0, "Tensor"},
                                                {"W", 9, 0, "Tensor"},
                                                {"strain_rates", 3, 0, "Vector"},
                                                {"vertex_rotation", 9, 1, "Tensor"}};

struct ek_frames {
  size_t nverts, ntets;    // ntets: elements (tets or triangles)
  int nodes;               // per element: 4 (tets) or 3 (triangles)
  int has[NFIELDS];        // smax only for triangles
  long nframes;            // frames committed to h5path (and listed in the XDMF)
  long scratch_frames;     // frames in the scratch copy: nframes or nframes - 1
  int failed;              // a write failed: the scratch copy is in an unknown state
  double *last_x;          // the last committed frame, replayed into the scratch
  double *last_f[NFIELDS]; // copy (its fields; NaN when not given)
  double last_time;
  int64_t last_step;
  int xmf_fd[2];        // the committed XDMF (xdmf_path) and its scratch copy
  off_t xmf_end[2];     // where each one's closing tail starts
  char *last_grid;      // the last committed frame's grid (no tail), replayed
  size_t last_grid_len; // into the scratch XDMF
  long test_kill_frame; // EK_FRAMES_TEST_KILL_XMF (tests only), else -1
  int test_no_exchange; // EK_FRAMES_TEST_NO_EXCHANGE (tests only): the fallback swap
  char *h5name_xml;     // the HDF5 file's base name, XML-escaped
  char h5path[EK_SCENE_PATH_MAX];
  char scratch_path[EK_SCENE_PATH_MAX + 16];
  char swap_path[EK_SCENE_PATH_MAX + 16]; // the hard-link fallback's third name
  char xdmf_path[EK_SCENE_PATH_MAX];
  char xmf_scratch_path[EK_SCENE_PATH_MAX + 16];
  char xmf_swap_path[EK_SCENE_PATH_MAX + 16];
};

// Values of field i in one frame.
static size_t field_count(const ek_frames *fr, int i) {
  return (fields_spec[i].per_vertex ? fr->nverts : fr->ntets) * (size_t)fields_spec[i].comps;
}

static const char xmf_tail[] = "  </Grid>\n </Domain>\n</Xdmf>\n";

void ek_frames_xdmf_path(const char *h5path, char *out, size_t outlen) {
  size_t n = strlen(h5path);
  if (n > 3 && strcmp(h5path + n - 3, ".h5") == 0)
    snprintf(out, outlen, "%.*s.xmf", (int)(n - 3), h5path);
  else
    snprintf(out, outlen, "%s.xmf", h5path);
}

static int file_exists(const char *path) {
  struct stat st;
  return lstat(path, &st) == 0;
}

// Every name the writer creates, renames over or unlinks (the file, its
// XDMF, their scratch, swap and temporary names) must be free or a regular
// file, with or without force: the commits rename over these names, which
// would replace a device, a FIFO or a link by an HDF5 file (issue 28: run
// as root, --out /dev/null --force replaced the device node) and unlink
// would remove them. A symbolic link is refused too: the rename replaces
// the link, not the file it names. Returns 0, or -1 with the reason in err.
static int check_output_names(const ek_frames *fr, char *err, size_t errlen) {
  const char *names[] = {fr->h5path,    fr->xdmf_path,        fr->scratch_path,
                         fr->swap_path, fr->xmf_scratch_path, fr->xmf_swap_path};
  for (size_t i = 0; i < sizeof names / sizeof *names; ++i) {
    const char *what = not_regular(names[i]);
    if (what) {
      if (err && errlen)
        snprintf(err, errlen,
                 "%s: is %s, not a regular file; refusing to write frames there (the output "
                 "is committed by renaming over this name)",
                 names[i], what);
      return -1;
    }
  }
  return 0;
}

// The XDMF names the HDF5 file by its base name inside XML text and splits
// "file:/dataset" at the colon (meshio: exactly one colon). Refuses what
// cannot be written there: a colon, control characters, bytes that are not
// UTF-8 (the XML's encoding), leading or trailing blanks (readers strip
// them). Returns 0, or -1 with the reason in err.
static int check_xml_name(const char *path, const char *name, char *err, size_t errlen) {
  const unsigned char *s = (const unsigned char *)name;
  size_t n = strlen(name), at = 0;
  const char *why = NULL;
  int printable = 1; // the name may be echoed in the message
  for (size_t i = 0; i < n && !why; ++i) {
    unsigned char c = s[i];
    at = i;
    if (c == ':') {
      why = "a colon (XDMF separates the file from the dataset with one)";
    } else if (c < 0x20 || c == 0x7f) {
      why = "a control character";
      printable = 0;
    } else if (c >= 0x80) {
      // UTF-8: a lead byte 110xxxxx / 1110xxxx / 11110xxx and 1-3
      // continuation bytes 10xxxxxx (RFC 3629 sec. 3; overlongs and
      // surrogates are left to the XML parser, which rejects them).
      size_t extra = (c & 0xe0) == 0xc0 ? 1 : (c & 0xf0) == 0xe0 ? 2 : (c & 0xf8) == 0xf0 ? 3 : 0;
      int valid = extra > 0;
      for (size_t k = 1; k <= extra && valid; ++k)
        valid = i + k < n && (s[i + k] & 0xc0) == 0x80;
      if (!valid) {
        why = "a byte that is not UTF-8";
        printable = 0;
      }
      i += extra;
    }
  }
  if (!why && n > 0 && (name[0] == ' ' || name[n - 1] == ' ')) {
    why = "a leading or trailing blank (readers strip them)";
    at = name[0] == ' ' ? 0 : n - 1;
  }
  if (!why)
    return 0;
  // Bytes that are not printable text are shown by position and value only.
  if (err && errlen)
    snprintf(err, errlen,
             "%s: the XDMF file cannot name this HDF5 file: its base name holds %s "
             "(byte %zu, 0x%02x)",
             printable ? path : "output file", why, at, s[at]);
  return -1;
}

// `name` with & < > " ' replaced by their XML entities (malloc'ed).
static char *xml_escape(const char *name) {
  size_t n = 1;
  for (const char *p = name; *p; ++p)
    n += *p == '&' || *p == '"' || *p == '\'' ? 6 : *p == '<' || *p == '>' ? 4 : 1;
  char *out = malloc(n), *o = out;
  if (!out)
    return NULL;
  for (const char *p = name; *p; ++p) {
    const char *ent = *p == '&'    ? "&amp;"
                      : *p == '<'  ? "&lt;"
                      : *p == '>'  ? "&gt;"
                      : *p == '"'  ? "&quot;"
                      : *p == '\'' ? "&apos;"
                                   : NULL;
    if (ent) {
      memcpy(o, ent, strlen(ent));
      o += strlen(ent);
    } else {
      *o++ = *p;
    }
  }
  *o = '\0';
  return out;
}

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

// An extendible 1-D dataset of scalars per frame (time, step).
static int create_series(hid_t loc, const char *name, hid_t type) {
  hsize_t dims[1] = {0}, maxdims[1] = {H5S_UNLIMITED}, chunk[1] = {256};
  hid_t space = H5Screate_simple(1, dims, maxdims);
  hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(dcpl, 1, chunk);
  hid_t dset = H5Dcreate2(loc, name, type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  H5Pclose(dcpl);
  H5Sclose(space);
  if (dset < 0)
    return -1;
  H5Dclose(dset);
  return 0;
}

// Extend a 1-D series to `frames` entries and write the last one.
static int append_scalar(hid_t file, const char *name, hid_t type, long frames, const void *value) {
  hid_t dset = H5Dopen2(file, name, H5P_DEFAULT);
  if (dset < 0)
    return -1;
  hsize_t dims[1] = {(hsize_t)frames}, start[1] = {(hsize_t)frames - 1}, count[1] = {1};
  herr_t rc = H5Dset_extent(dset, dims);
  if (rc >= 0) {
    hid_t fspace = H5Dget_space(dset);
    hid_t mspace = H5Screate_simple(1, count, NULL);
    rc = H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, NULL, count, NULL);
    if (rc >= 0)
      rc = H5Dwrite(dset, type, mspace, fspace, H5P_DEFAULT, value);
    H5Sclose(mspace);
    H5Sclose(fspace);
  }
  H5Dclose(dset);
  return rc < 0 ? -1 : 0;
}

static hid_t file_access(void) {
  // Formats of HDF5 1.8 (link-indexed groups scale to many frames) and no
  // newer, so that readers built on 1.8 open the file too.
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, H5F_LIBVER_V18);
  return fapl;
}

// ------------------------------------------------------------ attributes
// What a reader needs to interpret the file without ek's sources
// (docs/outputs.md lists the same): "units" and "description" on each
// dataset group and mesh dataset, ek's version and the element kind on the
// file at creation, and the run (scene, model, precision, ...) from
// ek_frames_set_info. Attributes only: the datasets' bytes are the same with
// or without them (tools/hash_scenes.sh hashes datasets).
#ifndef EK_VERSION_STRING
#define EK_VERSION_STRING "unknown"
#endif

// A variable-length UTF-8 string attribute on `loc` (replaced if present):
// h5py reads it as str, h5dump and ParaView show it as text.
static int attr_string(hid_t loc, const char *name, const char *value) {
  if (H5Aexists(loc, name) > 0 && H5Adelete(loc, name) < 0)
    return -1;
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t a = H5Acreate2(loc, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  herr_t rc = a < 0 ? -1 : H5Awrite(a, type, &value);
  if (a >= 0)
    H5Aclose(a);
  H5Sclose(space);
  H5Tclose(type);
  return rc < 0 ? -1 : 0;
}

// "units" and "description" on the object at `path` (a group or dataset).
static int attr_doc(hid_t file, const char *path, const char *units, const char *description) {
  hid_t o = H5Oopen(file, path, H5P_DEFAULT);
  if (o < 0)
    return -1;
  int rc = attr_string(o, "units", units) | attr_string(o, "description", description);
  H5Oclose(o);
  return rc ? -1 : 0;
}

// Units and descriptions of the frame fields (fields_spec's order), for
// tets and for triangles where they differ (sim.h: ek_sim_tet_fields,
// ek_sim_cloth_fields, ek_sim_rate_fields, ek_sim_vertex_rotations).
static const char *const field_units[NFIELDS] = {"1", "1", "J/m^3", "1", "1/s", "1/s", "1/s", "1"};
static const char *const field_text_tet[NFIELDS] = {
    "per tet: J = det F, the volume ratio (current / rest volume)",
    "per tet: the smallest signed singular value of F (negative when inverted)",
    "per tet: Psi(F) - Psi(F_rest), elastic energy per unit rest volume, 0 at rest; "
    "sum of V0 * value = the elastic energy",
    "",
    "per tet: rate of deformation D = (L + L^T) / 2 of the velocity gradient L = dF/dt F^-1, "
    "3x3 row-major",
    "per tet: spin W = (L - L^T) / 2 of the velocity gradient L, 3x3 row-major",
    "per tet: the principal strain rates, the eigenvalues of D, descending",
    "per vertex: the rotation (3x3 row-major) that best maps the vertex's one-ring from rest "
    "to current positions (Kabsch)"};
static const char *const field_text_tri[NFIELDS] = {
    "per triangle: the area ratio (current / rest area)",
    "per triangle: the smaller in-plane stretch (singular value of the 3x2 F)",
    "per triangle: membrane energy per unit rest area of the sheet (Psi h), from the rest "
    "shape",
    "per triangle: the larger in-plane stretch (singular value of the 3x2 F)",
    "per triangle: rate of deformation D = (L + L^T) / 2 of the surface velocity gradient "
    "L = dF/dt F^+, 3x3 row-major",
    "per triangle: spin W = (L - L^T) / 2 of the surface velocity gradient L, 3x3 row-major",
    "per triangle: the two in-plane principal strain rates (larger first), then 0",
    "per vertex: the rotation (3x3 row-major) that best maps the vertex's one-ring from rest "
    "to current positions (Kabsch)"};

// The attributes known at creation, on an open file that create_base built.
static int write_base_attrs(const ek_frames *fr, hid_t f) {
  const int tri = fr->nodes == 3;
  char path[96];
  int rc = attr_string(f, "ek_version", EK_VERSION_STRING) |
           attr_string(f, "element", tri ? "triangle" : "tetrahedron") |
           attr_string(f, "layout",
                       "/frames/<field>/<frame, 6 digits>: one dataset per frame "
                       "and field; docs/outputs.md") |
           attr_doc(f, "/mesh/vertices", "m", "rest positions, nverts x 3") |
           attr_doc(f, tri ? "/mesh/triangles" : "/mesh/tets", "1",
                    tri ? "vertex indices (0-based) of each triangle"
                        : "vertex indices (0-based) of each tet, positive orientation") |
           attr_doc(f, "/frames/time", "s", "simulated time of each frame") |
           attr_doc(f, "/frames/step", "1", "step number of each frame (0 = initial state)") |
           attr_doc(f, "/frames/positions", "m", "current vertex positions, nverts x 3");
  if (tri)
    rc |= attr_doc(f, "/frames/energy_density_from_rest", "J/m^2",
                   field_text_tri[2]); // per unit area
  for (int i = 0; i < NFIELDS; ++i) {
    if (!fr->has[i] || (tri && i == 2))
      continue;
    snprintf(path, sizeof path, "/frames/%s", fields_spec[i].name);
    rc |= attr_doc(f, path, field_units[i], tri ? field_text_tri[i] : field_text_tet[i]);
  }
  return rc ? -1 : 0;
}

// The run's attributes on one closed file; 0 or -1.
static int write_info_attrs(const char *file, const ek_frames_info *in) {
  hid_t f = H5Fopen(file, H5F_ACC_RDWR, H5P_DEFAULT);
  if (f < 0)
    return -1;
  const char *names[] = {"program", "scene", "model", "precision", "integrator", "git_revision"};
  const char *values[] = {in->program,   in->scene,      in->model,
                          in->precision, in->integrator, in->git_revision};
  int rc = 0;
  for (int i = 0; i < 6; ++i)
    if (values[i])
      rc |= attr_string(f, names[i], values[i]);
  if (H5Fclose(f) < 0)
    rc = -1;
  return rc ? -1 : 0;
}

// Create `file` (truncating) with the rest mesh and no frames; closed on
// return. Returns 0, or -1 with what failed in *what.
static int create_base(const ek_frames *fr, const char *file, const double *X, const int32_t *tets,
                       const char **what) {
  *what = "create";
  hid_t fapl = file_access();
  hid_t f = H5Fcreate(file, H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  H5Pclose(fapl);
  if (f < 0)
    return -1;
  *what = "write the rest mesh to";
  hid_t mesh = H5Gcreate2(f, "mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  hsize_t vdims[2] = {fr->nverts, 3}, tdims[2] = {fr->ntets, (hsize_t)fr->nodes};
  int ok = mesh >= 0 && write_fixed(mesh, "vertices", H5T_NATIVE_DOUBLE, 2, vdims, X) == 0 &&
           write_fixed(mesh, fr->nodes == 4 ? "tets" : "triangles", H5T_NATIVE_INT32, 2, tdims,
                       tets) == 0;
  if (mesh >= 0)
    H5Gclose(mesh);
  if (ok) {
    *what = "create the frame groups in";
    hid_t frames = H5Gcreate2(f, "frames", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ok = frames >= 0 && create_series(frames, "time", H5T_NATIVE_DOUBLE) == 0 &&
         create_series(frames, "step", H5T_NATIVE_INT64) == 0;
    for (int i = -1; i < NFIELDS && ok; ++i) {
      if (i >= 0 && !fr->has[i])
        continue;
      hid_t g = H5Gcreate2(frames, i < 0 ? "positions" : fields_spec[i].name, H5P_DEFAULT,
                           H5P_DEFAULT, H5P_DEFAULT);
      ok = g >= 0;
      if (g >= 0)
        H5Gclose(g);
    }
    if (frames >= 0)
      H5Gclose(frames);
  }
  if (ok) {
    *what = "write the attributes of";
    ok = write_base_attrs(fr, f) == 0;
  }
  if (H5Fclose(f) < 0 && ok) {
    *what = "close";
    ok = 0;
  }
  return ok ? 0 : -1;
}

// Write frame k (its datasets, then its time and step) into an open file.
static int write_frame(const ek_frames *fr, hid_t file, long k, double time, int64_t step,
                       const double *x, double *const *fields) {
  char name[96];
  hsize_t pdims[2] = {fr->nverts, 3};
  snprintf(name, sizeof name, "/frames/positions/%06ld", k);
  if (write_fixed(file, name, H5T_NATIVE_DOUBLE, 2, pdims, x) != 0)
    return -1;
  for (int i = 0; i < NFIELDS; ++i) {
    if (!fr->has[i])
      continue;
    const field_spec *f = &fields_spec[i];
    hsize_t dims[2] = {f->per_vertex ? fr->nverts : fr->ntets, (hsize_t)f->comps};
    snprintf(name, sizeof name, "/frames/%s/%06ld", f->name, k);
    if (write_fixed(file, name, H5T_NATIVE_DOUBLE, f->comps > 1 ? 2 : 1, dims, fields[i]) != 0)
      return -1;
  }
  if (append_scalar(file, "/frames/step", H5T_NATIVE_INT64, k + 1, &step) != 0)
    return -1;
  return append_scalar(file, "/frames/time", H5T_NATIVE_DOUBLE, k + 1, &time);
}

// Swap the names of a scratch copy and its committed file: one atomic
// rename where the file system supports it; otherwise a hard link (at
// `swap`) keeps the committed file reachable at its name throughout (link,
// rename over, rename the link). The files keep their inodes, so open
// descriptors follow them. `exchange` 0 (a test's EK_FRAMES_TEST_NO_EXCHANGE)
// takes the fallback on any file system.
static int swap_names(const char *scratch, const char *committed, const char *swap, int exchange) {
#ifdef RENAME_EXCHANGE
  if (exchange && renameat2(AT_FDCWD, scratch, AT_FDCWD, committed, RENAME_EXCHANGE) == 0)
    return 0;
  if (exchange && errno != EINVAL && errno != ENOSYS && errno != EOPNOTSUPP)
    return -1;
#else
  (void)exchange;
#endif
  unlink(swap);
  if (link(committed, swap) != 0)
    return -1;
  if (rename(scratch, committed) != 0)
    return -1;
  return rename(swap, scratch);
}

static int swap_files(const ek_frames *fr) {
  return swap_names(fr->scratch_path, fr->h5path, fr->swap_path, !fr->test_no_exchange);
}

// Write all of buf at offset off (one call in practice: a grid is small).
static int pwrite_all(int fd, const char *buf, size_t len, off_t off) {
  while (len > 0) {
    ssize_t w = pwrite(fd, buf, len, off);
    if (w < 0 && errno == EINTR)
      continue;
    if (w <= 0)
      return -1;
    buf += w;
    len -= (size_t)w;
    off += w;
  }
  return 0;
}

// Replace the scratch copy by a byte copy of the committed file. Needed
// when the scratch copy (the previously committed file) does not open for
// writing: a reader that opened it while it was committed still holds it
// (HDF5 locks the files it opens). That reader's file is left as it is,
// unlinked; the scratch name gets a new file. Once per reader that holds
// a file open across frames, not once per frame.
static int scratch_from_committed(const ek_frames *fr) {
  int in = open(fr->h5path, O_RDONLY | O_CLOEXEC);
  if (in < 0)
    return -1;
  unlink(fr->scratch_path);
  int out = open(fr->scratch_path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (out < 0) {
    close(in);
    return -1;
  }
  enum { CHUNK = 1 << 20 };
  char *buf = malloc(CHUNK);
  int rc = buf ? 0 : -1;
  off_t off = 0;
  while (rc == 0) {
    ssize_t r = read(in, buf, CHUNK);
    if (r < 0 && errno == EINTR)
      continue;
    if (r <= 0) {
      rc = r < 0 ? -1 : 0;
      break;
    }
    rc = pwrite_all(out, buf, (size_t)r, off);
    off += r;
  }
  free(buf);
  close(in);
  if (close(out) != 0)
    rc = -1;
  return rc;
}

// One frame's grid followed by the closing tail (malloc'ed); *grid_len is
// the length of the grid alone.
static char *xmf_grid(const ek_frames *fr, long k, double time, size_t *grid_len) {
  const char *h5 = fr->h5name_xml;
  size_t cap = 8192 + 12 * strlen(h5);
  char *buf = malloc(cap);
  if (!buf)
    return NULL;
  size_t nv = fr->nverts, nt = fr->ntets;
  int n = snprintf(buf, cap,
                   "   <Grid Name=\"frame_%06ld\" GridType=\"Uniform\">\n"
                   "    <Time Value=\"%.17g\"/>\n"
                   "    <Topology TopologyType=\"%s\" NumberOfElements=\"%zu\">\n"
                   "     <DataItem Dimensions=\"%zu %d\" DataType=\"Int\" Precision=\"4\" "
                   "Format=\"HDF\">%s:/mesh/%s</DataItem>\n"
                   "    </Topology>\n"
                   "    <Geometry GeometryType=\"XYZ\">\n"
                   "     <DataItem Dimensions=\"%zu 3\" DataType=\"Float\" Precision=\"8\" "
                   "Format=\"HDF\">%s:/frames/positions/%06ld</DataItem>\n"
                   "    </Geometry>\n"
                   // The positions again as a point vector: meshio's time
                   // series reader returns attributes only, not geometry.
                   "    <Attribute Name=\"positions\" AttributeType=\"Vector\" Center=\"Node\">\n"
                   "     <DataItem Dimensions=\"%zu 3\" DataType=\"Float\" Precision=\"8\" "
                   "Format=\"HDF\">%s:/frames/positions/%06ld</DataItem>\n"
                   "    </Attribute>\n",
                   k, time, fr->nodes == 4 ? "Tetrahedron" : "Triangle", nt, nt, fr->nodes, h5,
                   fr->nodes == 4 ? "tets" : "triangles", nv, h5, k, nv, h5, k);
  for (int i = 0; i < NFIELDS && n > 0 && (size_t)n < cap; ++i) {
    const field_spec *f = &fields_spec[i];
    if (!fr->has[i])
      continue;
    char dims[48];
    size_t rows = f->per_vertex ? nv : nt;
    if (f->comps > 1)
      snprintf(dims, sizeof dims, "%zu %d", rows, f->comps);
    else
      snprintf(dims, sizeof dims, "%zu", rows);
    n += snprintf(buf + n, cap - (size_t)n,
                  "    <Attribute Name=\"%s\" AttributeType=\"%s\" Center=\"%s\">\n"
                  "     <DataItem Dimensions=\"%s\" DataType=\"Float\" Precision=\"8\" "
                  "Format=\"HDF\">%s:/frames/%s/%06ld</DataItem>\n"
                  "    </Attribute>\n",
                  f->name, f->xdmf_type, f->per_vertex ? "Node" : "Cell", dims, h5, f->name, k);
  }
  if (n > 0 && (size_t)n < cap)
    n += snprintf(buf + n, cap - (size_t)n, "   </Grid>\n");
  *grid_len = (size_t)n;
  if (n > 0 && (size_t)n < cap)
    n += snprintf(buf + n, cap - (size_t)n, "%s", xmf_tail);
  if (n <= 0 || (size_t)n >= cap) {
    free(buf);
    return NULL;
  }
  return buf;
}

static const char xmf_head[] =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<Xdmf Version=\"3.0\">\n <Domain>\n"
    "  <Grid Name=\"frames\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";

// Copy i (0: committed, 1: scratch) of the XDMF with an empty collection.
// Built under the scratch name (a new file: one a killed run left is
// unlinked, never written into); copy 0 is then renamed to the XDMF's name,
// so a kill never leaves half a header there. Returns 0, or -1 with errno
// set and nothing left at the scratch name.
static int xmf_empty(ek_frames *fr, int i) {
  unlink(fr->xmf_scratch_path);
  int fd = open(fr->xmf_scratch_path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0)
    return -1;
  const off_t head_len = (off_t)(sizeof xmf_head - 1);
  if (pwrite_all(fd, xmf_head, sizeof xmf_head - 1, 0) != 0 ||
      pwrite_all(fd, xmf_tail, sizeof xmf_tail - 1, head_len) != 0 ||
      (i == 0 && rename(fr->xmf_scratch_path, fr->xdmf_path) != 0)) {
    int e = errno;
    close(fd);
    unlink(fr->xmf_scratch_path);
    errno = e;
    return -1;
  }
  fr->xmf_fd[i] = fd;
  fr->xmf_end[i] = head_len;
  return 0;
}

// Create both copies of the XDMF (the committed one may already be there:
// with force it replaced the old XDMF before the HDF5 commit).
static int xmf_create(ek_frames *fr, char *err, size_t errlen) {
  for (int i = 0; i < 2; ++i)
    if (fr->xmf_fd[i] < 0 && xmf_empty(fr, i) != 0) {
      if (err && errlen)
        snprintf(err, errlen, "%s: cannot write: %s", i == 0 ? fr->xdmf_path : fr->xmf_scratch_path,
                 strerror(errno));
      return -1;
    }
  return 0;
}

// Write the XDMF text of frame k at offset `at` of the scratch copy.
// EK_FRAMES_TEST_KILL_XMF=k (tests/test_frames_sim.c only) makes the writer
// SIGKILL itself halfway through this write: the moment that tore the XDMF
// when it was appended to in place, which a timed kill hits only by chance.
static int xmf_write(const ek_frames *fr, const char *text, size_t len, off_t at, long k) {
  if (k == fr->test_kill_frame && pwrite_all(fr->xmf_fd[1], text, len / 2, at) == 0)
    raise(SIGKILL);
  return pwrite_all(fr->xmf_fd[1], text, len, at);
}

static void destroy(ek_frames *fr) {
  if (!fr)
    return;
  for (int i = 0; i < 2; ++i)
    if (fr->xmf_fd[i] >= 0)
      close(fr->xmf_fd[i]);
  free(fr->last_grid);
  free(fr->last_x);
  for (int i = 0; i < NFIELDS; ++i)
    free(fr->last_f[i]);
  free(fr->h5name_xml);
  free(fr);
}

ek_frames *ek_frames_create_errbuf(const char *path, int force, size_t nverts, const double *X,
                                   size_t ntets, const int32_t *tets, char *err, size_t errlen) {
  return ek_frames_create_ex_errbuf(path, force, nverts, X, ntets, 4, tets, err, errlen);
}

ek_frames *ek_frames_create_ex_errbuf(const char *path, int force, size_t nverts, const double *X,
                                      size_t ntets, int nodes, const int32_t *tets, char *err,
                                      size_t errlen) {
  if (err && errlen)
    err[0] = '\0';
  if (!path || !path[0] || !X || !tets || nverts == 0 || ntets == 0 || (nodes != 3 && nodes != 4)) {
    if (err && errlen)
      snprintf(err, errlen, "ek_frames_create: empty path or mesh, or %d nodes per element", nodes);
    return NULL;
  }
  if (strlen(path) + 6 >= EK_SCENE_PATH_MAX) {
    if (err && errlen)
      snprintf(err, errlen, "%s: path too long", path);
    return NULL;
  }
  const char *base = strrchr(path, '/');
  base = base ? base + 1 : path;
  if (!base[0]) {
    if (err && errlen)
      snprintf(err, errlen, "%s: names a directory, not a file", path);
    return NULL;
  }
  if (check_xml_name(path, base, err, errlen) != 0)
    return NULL;
  ek_frames *fr = calloc(1, sizeof *fr);
  if (!fr)
    return NULL;
  fr->xmf_fd[0] = fr->xmf_fd[1] = -1;
  const char *kill_at = getenv("EK_FRAMES_TEST_KILL_XMF");
  fr->test_kill_frame = kill_at && kill_at[0] ? strtol(kill_at, NULL, 10) : -1;
  const char *no_exchange = getenv("EK_FRAMES_TEST_NO_EXCHANGE");
  fr->test_no_exchange = no_exchange && no_exchange[0] == '1';
  fr->nverts = nverts;
  fr->ntets = ntets;
  fr->nodes = nodes;
  for (int i = 0; i < NFIELDS; ++i)
    fr->has[i] = i != FIELD_SMAX || nodes == 3;
  snprintf(fr->h5path, sizeof fr->h5path, "%s", path);
  snprintf(fr->scratch_path, sizeof fr->scratch_path, "%s.scratch", path);
  snprintf(fr->swap_path, sizeof fr->swap_path, "%s.swap", path);
  ek_frames_xdmf_path(path, fr->xdmf_path, sizeof fr->xdmf_path);
  snprintf(fr->xmf_scratch_path, sizeof fr->xmf_scratch_path, "%s.scratch", fr->xdmf_path);
  snprintf(fr->xmf_swap_path, sizeof fr->xmf_swap_path, "%s.swap", fr->xdmf_path);
  if (check_output_names(fr, err, errlen) != 0) {
    destroy(fr);
    return NULL;
  }
  // Never overwrite results unless asked: check both files before touching
  // either. The scratch copy a killed run leaves is ours to overwrite.
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
  fr->h5name_xml = xml_escape(base);
  fr->last_x = malloc(3 * nverts * sizeof(double));
  int ok = fr->h5name_xml && fr->last_x;
  for (int i = 0; i < NFIELDS; ++i)
    if (fr->has[i]) {
      fr->last_f[i] = malloc(field_count(fr, i) * sizeof(double));
      ok = ok && fr->last_f[i];
    }
  if (!ok) {
    if (err && errlen)
      snprintf(err, errlen, "%s: out of memory for one frame (%zu vertices, %zu tets)", path,
               nverts, ntets);
    destroy(fr);
    return NULL;
  }

  // The empty file is built under the scratch name and then committed:
  // h5path never names a file that is not whole. Without force the commit
  // is a hard link, which fails if h5path appeared meanwhile.
  h5_quiet q;
  h5_quiet_on(&q);
  const char *what = "create";
  errno = 0;
  ok = create_base(fr, fr->scratch_path, X, tets, &what) == 0;
  // With force the old XDMF lists frames the new file lacks: an empty one
  // replaces it (a rename, so that an XDMF is there throughout).
  if (ok && force && xmf_empty(fr, 0) != 0) {
    ok = 0;
    what = "xdmf";
  }
  if (ok) {
    what = "commit";
    ok = force ? rename(fr->scratch_path, fr->h5path) == 0
               : link(fr->scratch_path, fr->h5path) == 0 && unlink(fr->scratch_path) == 0;
    if (ok) {
      // A second empty copy is the scratch the first frame extends.
      ok = create_base(fr, fr->scratch_path, X, tets, &what) == 0;
      if (!ok)
        unlink(fr->h5path);
    }
  }
  h5_quiet_off(&q);
  if (!ok) {
    int e = errno;
    if (err && errlen) {
      if (strcmp(what, "commit") == 0)
        snprintf(err, errlen, "%s: cannot create: %s%s", path, strerror(e),
                 e == EEXIST ? " (refusing to overwrite; use --force)" : "");
      else if (strcmp(what, "xdmf") == 0)
        snprintf(err, errlen, "%s: cannot write: %s", fr->xdmf_path, strerror(e));
      else
        snprintf(err, errlen, "%s: cannot %s the HDF5 file %s%s%s%s", path, what, fr->scratch_path,
                 e ? " (" : "", e ? strerror(e) : "", e ? ")" : "");
    }
    unlink(fr->scratch_path);
    if (fr->xmf_fd[0] >= 0)
      unlink(fr->xdmf_path); // the empty XDMF that replaced the old one
    destroy(fr);
    return NULL;
  }
  if (xmf_create(fr, err, errlen) != 0) {
    unlink(fr->h5path);
    if (fr->xmf_fd[0] >= 0)
      unlink(fr->xdmf_path);
    unlink(fr->scratch_path);
    destroy(fr);
    return NULL;
  }
  return fr;
}

int ek_frames_write_errbuf(ek_frames *fr, double time, long step, const double *x, const double *J,
                           const double *smin, const double *psi, char *err, size_t errlen) {
  const ek_frame_fields f = {.J = J, .smin = smin, .psi = psi};
  return ek_frames_write_fields_errbuf(fr, time, step, x, &f, err, errlen);
}

int ek_frames_write_fields_errbuf(ek_frames *fr, double time, long step, const double *x,
                                  const ek_frame_fields *ff, char *err, size_t errlen) {
  if (!fr || !x || !ff) {
    if (err && errlen)
      snprintf(err, errlen, "ek_frames_write: no open frames or no positions");
    return EK_EINVAL;
  }
  if (fr->failed) {
    if (err && errlen)
      snprintf(err, errlen, "%s: an earlier frame failed; %ld frames are kept", fr->h5path,
               fr->nframes);
    return EK_EIO;
  }
  const long k = fr->nframes;
  const int64_t step64 = step;
  // The fields as written: NaN where the caller gave none.
  const double *given[NFIELDS] = {ff->J, ff->smin, ff->psi,          ff->smax,
                                  ff->D, ff->W,    ff->strain_rates, ff->vertex_R};
  double *fields[NFIELDS] = {0};
  for (int i = 0; i < NFIELDS; ++i) {
    if (!fr->has[i])
      continue;
    size_t count = field_count(fr, i);
    fields[i] = malloc(count * sizeof(double));
    if (!fields[i]) {
      for (int j = 0; j < i; ++j)
        free(fields[j]);
      if (err && errlen)
        snprintf(err, errlen, "%s: out of memory for frame %ld", fr->h5path, k);
      return EK_ENOMEM;
    }
    for (size_t e = 0; e < count; ++e)
      fields[i][e] = given[i] ? given[i][e] : NAN;
  }
  // The XDMF text for the scratch copy (it lists k - 1 frames, or none
  // when k = 0): the last committed frame's grid, this frame's, the tail.
  size_t grid_len = 0, replay = k > 0 ? fr->last_grid_len : 0;
  char *grid = xmf_grid(fr, k, time, &grid_len);
  size_t text_len = replay + grid_len + sizeof xmf_tail - 1;
  char *text = grid ? malloc(text_len) : NULL;
  if (text) {
    if (replay > 0) // last_grid is NULL before the first frame
      memcpy(text, fr->last_grid, replay);
    memcpy(text + replay, grid, grid_len + sizeof xmf_tail - 1);
  }

  // The scratch copy: replay the frame it lacks, add this one, close.
  h5_quiet q;
  h5_quiet_on(&q);
  errno = 0;
  int ok = text != NULL;
  const char *what = "write";
  if (ok) {
    hid_t file = H5Fopen(fr->scratch_path, H5F_ACC_RDWR, H5P_DEFAULT);
    if (file < 0 && scratch_from_committed(fr) == 0) {
      fr->scratch_frames = k; // now a copy of the committed file
      file = H5Fopen(fr->scratch_path, H5F_ACC_RDWR, H5P_DEFAULT);
    }
    ok = file >= 0;
    if (ok && fr->scratch_frames < k)
      ok = write_frame(fr, file, k - 1, fr->last_time, fr->last_step, fr->last_x, fr->last_f) == 0;
    if (ok)
      ok = write_frame(fr, file, k, time, step64, x, fields) == 0;
    if (file >= 0 && H5Fclose(file) < 0)
      ok = 0;
  }
  h5_quiet_off(&q);
  if (ok) {
    what = "commit";
    ok = swap_files(fr) == 0;
  }
  if (!ok) {
    fr->failed = 1;
    if (err && errlen)
      snprintf(err, errlen, "%s: cannot %s frame %ld (%s); %s", fr->h5path, what, k,
               errno ? strerror(errno) : "HDF5 error",
               k > 0 ? "the file keeps the frames before it" : "the file holds the mesh, no frame");
    for (int i = 0; i < NFIELDS; ++i)
      free(fields[i]);
    free(grid);
    free(text);
    return EK_EIO;
  }
  // Committed: the old file is now the scratch copy, one frame behind.
  fr->nframes = k + 1;
  fr->scratch_frames = k;
  memcpy(fr->last_x, x, 3 * fr->nverts * sizeof(double));
  for (int i = 0; i < NFIELDS; ++i)
    if (fr->has[i]) {
      memcpy(fr->last_f[i], fields[i], field_count(fr, i) * sizeof(double));
      free(fields[i]);
    }
  fr->last_time = time;
  fr->last_step = step64;
  // The XDMF: the text into the scratch copy over its old tail, then the
  // copies swap names (the committed copy is never written to).
  const off_t at = fr->xmf_end[1];
  errno = 0;
  ok = xmf_write(fr, text, text_len, at, k) == 0 &&
       swap_names(fr->xmf_scratch_path, fr->xdmf_path, fr->xmf_swap_path, !fr->test_no_exchange) ==
           0;
  free(text);
  if (!ok) {
    free(grid);
    fr->failed = 1;
    if (err && errlen)
      snprintf(err, errlen, "%s: cannot add frame %ld: %s", fr->xdmf_path, k,
               errno ? strerror(errno) : "short write");
    return EK_EIO;
  }
  // The old committed copy, one frame behind, is the scratch copy now.
  const int fd = fr->xmf_fd[0];
  const off_t end = fr->xmf_end[0];
  fr->xmf_fd[0] = fr->xmf_fd[1];
  fr->xmf_end[0] = at + (off_t)(replay + grid_len);
  fr->xmf_fd[1] = fd;
  fr->xmf_end[1] = end;
  free(fr->last_grid);
  fr->last_grid = grid;
  fr->last_grid_len = grid_len;
  return 0;
}

long ek_frames_count(const ek_frames *fr) { return fr ? fr->nframes : 0; }

int ek_frames_close_errbuf(ek_frames *fr, char *err, size_t errlen) {
  if (!fr)
    return 0;
  int rc = 0;
  for (int i = 0; i < 2; ++i)
    if (fr->xmf_fd[i] >= 0) {
      rc |= close(fr->xmf_fd[i]) != 0;
      fr->xmf_fd[i] = -1;
    }
  // Every frame is committed at h5path and xdmf_path; the scratch copies
  // are no longer needed.
  unlink(fr->scratch_path);
  unlink(fr->xmf_scratch_path);
  if (rc && err && errlen)
    snprintf(err, errlen, "%s: closing failed: %s", fr->xdmf_path, strerror(errno));
  destroy(fr);
  return rc ? EK_EIO : 0;
}

int ek_frames_set_info_errbuf(ek_frames *fr, const ek_frames_info *info, char *err, size_t errlen) {
  if (err && errlen)
    err[0] = '\0';
  if (!fr || !info || fr->nframes != 0 || fr->failed) {
    if (err && errlen)
      snprintf(err, errlen, "ek_frames_set_info: no open frames, or frames already written");
    return EK_EINVAL;
  }
  // As a frame is committed: into the scratch copy (never yet at `path`,
  // so no reader holds it), swap, then the other copy, now the scratch. A
  // reader may hold that one open (HDF5's lock refuses the writer): then,
  // as for a frame, the scratch becomes a fresh byte copy of `path`, which
  // has the attributes. `path` is a closed, whole file throughout.
  h5_quiet q;
  h5_quiet_on(&q);
  errno = 0;
  int wrote = write_info_attrs(fr->scratch_path, info) == 0;
  int ok = wrote && swap_files(fr) == 0;
  if (ok && write_info_attrs(fr->scratch_path, info) != 0)
    ok = scratch_from_committed(fr) == 0;
  // Not written: the scratch copy may hold a partial attribute; a copy of
  // `path` replaces it, and the frames go on without the attributes.
  int e = errno;
  int usable = ok || (!wrote && scratch_from_committed(fr) == 0);
  h5_quiet_off(&q);
  if (!ok) {
    fr->failed = !usable;
    if (err && errlen)
      snprintf(err, errlen, "%s: cannot write its attributes (%s)%s", fr->h5path,
               e ? strerror(e) : "HDF5 error", usable ? "" : "; no frames can follow");
    return EK_EIO;
  }
  return 0;
}
