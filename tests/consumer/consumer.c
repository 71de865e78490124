// Invariant: a program built out of tree against an installed ek (CMake's
// find_package(ek) or pkg-config, nothing else by hand) links and runs the
// kernels (ek_svd3_f32 recovers known singular values), the scene and mesh
// readers (the installed drop scene and cube mesh load, with the cube's
// rest volume) and the HDF5 frames (one frame written and closed).
//
//   ek-consumer OUT.h5
// EK_CONSUMER_SCENES: the installed scenes' folder, from the build (CMake's
// ek_SCENES_DIR, or `pkg-config --variable=scenesdir ek`).
#include <ek/ek.h>
#include <ek/sim/sim.h>

#include <float.h>
#include <math.h>
#include <stdio.h>

#ifndef EK_CONSUMER_SCENES
#error "build with -DEK_CONSUMER_SCENES=\"<the installed scenes' folder>\""
#endif

// A = Rz(90 deg) diag(3, 2, 1): singular values 3, 2, 1 exactly.
static int check_svd(void) {
  const float A[9] = {0, -2, 0, 3, 0, 0, 0, 0, 1}, expected[3] = {3, 2, 1};
  float U[9], S[3], V[9];
  int rc = ek_svd3_f32(1, A, U, S, V, NULL);
  if (rc != 0) {
    fprintf(stderr, "ek_svd3_f32: returned %d: %s\n", rc, ek_last_error());
    return 1;
  }
  // Budget relative to the largest singular value (include/ek/svd3.h).
  double worst = 0;
  for (int i = 0; i < 3; ++i)
    worst = fmax(worst, fabs((double)S[i] - expected[i]) / expected[0]);
  printf("svd3 f32: S = %.7g %.7g %.7g, error %.3g (budget %g)\n", S[0], S[1], S[2], worst,
         EK_SVD3_TOL_F32);
  return !(worst <= EK_SVD3_TOL_F32);
}

// The installed drop scene (JSON, cJSON) and the cube mesh (TetGen): the
// cube is the unit cube, so its rest volumes sum to 1.
static int check_scene_and_mesh(ek_mesh **mesh_out) {
  static ek_scene scene;
  if (ek_scene_load(EK_CONSUMER_SCENES "/drop.json", &scene) != 0) {
    fprintf(stderr, "ek_scene_load: %s\n", ek_last_error());
    return 1;
  }
  ek_mesh *box = ek_scene_mesh(&scene);
  if (!box) {
    fprintf(stderr, "ek_scene_mesh: %s\n", ek_last_error());
    return 1;
  }
  printf("scene %s: model %s, %zu tets\n", scene.path, scene.model_name, ek_mesh_ntets(box));
  ek_mesh_destroy(box);

  ek_mesh *cube = ek_mesh_load(EK_CONSUMER_SCENES "/meshes/cube.node");
  if (!cube) {
    fprintf(stderr, "ek_mesh_load: %s\n", ek_last_error());
    return 1;
  }
  const double *V0 = ek_mesh_rest_volumes(cube);
  double volume = 0;
  for (size_t e = 0; e < ek_mesh_ntets(cube); ++e)
    volume += V0[e];
  printf("mesh cube: %zu vertices, %zu tets, volume %.17g (expected 1)\n", ek_mesh_nverts(cube),
         ek_mesh_ntets(cube), volume);
  // Each V0 within EK_MESH_TOL of its own (include/ek/sim/mesh.h), plus the
  // sum's rounding.
  if (!(fabs(volume - 1) <= EK_MESH_TOL + (double)ek_mesh_ntets(cube) * DBL_EPSILON)) {
    ek_mesh_destroy(cube);
    return 1;
  }
  *mesh_out = cube;
  return 0;
}

// One frame of the rest shape through HDF5.
static int check_frames(const ek_mesh *mesh, const char *out) {
  ek_frames *fr = ek_frames_create(out, 1, ek_mesh_nverts(mesh), ek_mesh_rest_positions(mesh),
                                   ek_mesh_ntets(mesh), ek_mesh_tets(mesh));
  if (!fr) {
    fprintf(stderr, "ek_frames_create: %s\n", ek_last_error());
    return 1;
  }
  int failed = ek_frames_write(fr, 0.0, 0, ek_mesh_rest_positions(mesh), NULL, NULL, NULL) != 0;
  if (failed)
    fprintf(stderr, "ek_frames_write: %s\n", ek_last_error());
  long frames = ek_frames_count(fr);
  if (ek_frames_close(fr) != 0) {
    fprintf(stderr, "ek_frames_close: %s\n", ek_last_error());
    failed = 1;
  }
  printf("frames %s: %ld written\n", out, frames);
  return failed || frames != 1;
}

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s OUT.h5\n", argv[0]);
    return 2;
  }
  ek_mesh *cube = NULL;
  int failed = check_svd();
  failed |= check_scene_and_mesh(&cube);
  if (cube)
    failed |= check_frames(cube, argv[1]);
  ek_mesh_destroy(cube);
  printf("%s\n", failed ? "FAIL" : "PASS");
  return failed;
}
