// Shared by the libFuzzer harnesses: a private directory for the files the
// readers open (they read paths, not buffers), and the check every loaded
// mesh must pass. Built only with -DEK_FUZZ=ON (tests/fuzz/CMakeLists.txt).
#ifndef EK_FUZZ_COMMON_H
#define EK_FUZZ_COMMON_H

#include <ek/sim/mesh.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char fuzz_dir[256];

// The directory, made once per process (removed by the CI script's
// TMPDIR cleanup, not here: libFuzzer may exit from any point).
static const char *fuzz_path(const char *name, char *buf, size_t len) {
  if (!fuzz_dir[0]) {
    const char *base = getenv("TMPDIR");
    snprintf(fuzz_dir, sizeof fuzz_dir, "%s/ek_fuzz_XXXXXX", base && base[0] ? base : "/tmp");
    if (!mkdtemp(fuzz_dir)) {
      perror("mkdtemp");
      abort();
    }
  }
  snprintf(buf, len, "%s/%s", fuzz_dir, name);
  return buf;
}

static void fuzz_write(const char *path, const uint8_t *data, size_t size) {
  FILE *f = fopen(path, "wb");
  if (!f || (size && fwrite(data, 1, size, f) != size)) {
    perror(path);
    abort();
  }
  fclose(f);
}

// A mesh that loaded must be whole: positive finite rest volumes, finite
// Dm^-1 and lumped volumes, at least one tet. Anything else is a bug the
// fuzzer must report, so it aborts.
__attribute__((unused)) static void fuzz_check_mesh(const ek_mesh *m) {
  size_t nt = ek_mesh_ntets(m), nv = ek_mesh_nverts(m);
  const double *V0 = ek_mesh_rest_volumes(m), *Dmi = ek_mesh_dm_inv(m);
  const double *L = ek_mesh_lumped_volume(m);
  if (nt == 0) {
    fprintf(stderr, "fuzz: a mesh with no tets loaded\n");
    abort();
  }
  for (size_t t = 0; t < nt; t++) {
    if (!(V0[t] > 0) || !isfinite(V0[t])) {
      fprintf(stderr, "fuzz: tet %zu loaded with rest volume %g\n", t, V0[t]);
      abort();
    }
    for (int k = 0; k < 9; k++)
      if (!isfinite(Dmi[t * 9 + k])) {
        fprintf(stderr, "fuzz: tet %zu loaded with Dm^-1[%d] = %g\n", t, k, Dmi[t * 9 + k]);
        abort();
      }
  }
  for (size_t v = 0; v < nv; v++)
    if (!isfinite(L[v])) {
      fprintf(stderr, "fuzz: vertex %zu loaded with lumped volume %g\n", v, L[v]);
      abort();
    }
}

// An error message must be printable ASCII (bytes from the file escaped).
static void fuzz_check_message(const char *err) {
  for (const char *p = err; *p; p++)
    if ((unsigned char)*p < 0x20 || (unsigned char)*p >= 0x7f) {
      fprintf(stderr, "fuzz: raw byte 0x%02x in the message: %s\n", (unsigned char)*p, err);
      abort();
    }
}

#endif
