// Invariants of the element layer (include/ek/elements.h,
// kernels/elements/tets.c): both slot orders are permutations of the tets
// (padding -1) whose packed planes equal the caller-order data in both
// precisions; in the coloured order every bound (phase, chunk, colour
// group) is a whole f32 block, tets of one colour group share no vertex,
// and chunks of one phase share no vertex (so a coloured sweep may run
// them on different threads); the vertex lists are sorted and complete.
// ek_tets_create refuses bad arrays with the tet and value named. Checked
// on box meshes from one cell to 384 000 tets (many chunks and phases) and
// on a randomly renumbered box built from plain arrays. Per-element state
// round-trips through the Morton slots.
#include <ek/elements.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../kernels/elements/tets.h"
#include "check.h"
#include "check_box.h"
#include "cli.h"

static int failures = 0;

static void verdict(const char *label, const char *what, int ok) {
  printf("%s: %s: %s\n", label, what, ok ? "PASS" : "FAIL");
  if (!ok)
    failures++;
}

// One slot order: a permutation of the tets (each exactly once, padding
// -1) and packed planes equal to the caller-order data, padding inert.
static void check_blocks(const char *label, const char *order, const ek_tets *el,
                         const ek_tet_blocks *bl) {
  size_t nt = el->ntets, ns = bl->nslots;
  const size_t W32 = EK_LANES_F32, W64 = EK_LANES_F64;
  int perm = ns % W32 == 0 && ns >= nt, planes = 1;
  int *seen = calloc(nt, sizeof *seen);
  for (size_t s = 0; s < ns; s++) {
    int32_t t = bl->slot_tet[s];
    if (t >= 0 && ((size_t)t >= nt || seen[t]++))
      perm = 0;
  }
  for (size_t t = 0; t < nt; t++)
    perm &= seen[t] == 1;
  free(seen);
  for (size_t s = 0; perm && s < ns; s++) {
    int32_t t = bl->slot_tet[s];
    size_t b32 = s / W32, l32 = s % W32, b64 = s / W64, l64 = s % W64;
    for (int c = 0; c < 4; c++) {
      int32_t want = t >= 0 ? el->tets[(size_t)t * 4 + c] : -1;
      planes &= bl->idx_f32[(b32 * 4 + c) * W32 + l32] == want &&
                bl->idx_f64[(b64 * 4 + c) * W64 + l64] == want;
    }
    for (int k = 0; k < 9; k++) {
      double want = t >= 0 ? el->Dm_inv[(size_t)t * 9 + k] : 0;
      planes &= bl->dm_inv_f64[(b64 * 9 + k) * W64 + l64] == want &&
                bl->dm_inv_f32[(b32 * 9 + k) * W32 + l32] == (float)want;
    }
    double v0 = t >= 0 ? el->V0[t] : 0;
    planes &= bl->v0_f64[b64 * W64 + l64] == v0 && bl->v0_f32[b32 * W32 + l32] == (float)v0;
  }
  char what[96];
  snprintf(what, sizeof what, "%s order is a permutation of the tets", order);
  verdict(label, what, perm);
  snprintf(what, sizeof what, "%s packed planes equal the caller data", order);
  verdict(label, what, perm && planes);
}

// The slots [s0, s1) of the coloured order share no vertex; stamp[v] ==
// mark means v was seen in this set. Returns 1 if they do not.
static int vertex_disjoint(const ek_tets *el, size_t s0, size_t s1, size_t *stamp, size_t mark) {
  int ok = 1;
  for (size_t s = s0; s < s1; s++) {
    int32_t t = el->colored.slot_tet[s];
    if (t < 0)
      continue;
    for (int c = 0; c < 4; c++) {
      int32_t v = el->tets[(size_t)t * 4 + c];
      ok &= stamp[v] != mark;
      stamp[v] = mark;
    }
  }
  return ok;
}

static void check_layout(const char *label, const ek_tets *el) {
  const size_t W = EK_LANES_F32, nv = el->nverts;
  check_blocks(label, "Morton", el, &el->morton);
  check_blocks(label, "coloured", el, &el->colored);
  verdict(label, "Morton slots = tets rounded up to a block",
          el->morton.nslots == (el->ntets + W - 1) / W * W);

  // Bounds: phases cover the chunks, chunks the groups and slots, in order,
  // every slot bound a whole block.
  int bounds = el->phase_chunk[0] == 0 && el->phase_chunk[el->nphases] == el->nchunks &&
               el->chunk_slot[0] == 0 && el->chunk_slot[el->nchunks] == el->colored.nslots &&
               el->chunk_group[0] == 0 && el->chunk_group[el->nchunks] == el->ngroups &&
               el->group_slot[el->ngroups] == el->colored.nslots;
  for (int p = 0; p < el->nphases; p++)
    bounds &= el->phase_chunk[p] < el->phase_chunk[p + 1];
  for (size_t k = 0; bounds && k < el->nchunks; k++) {
    bounds &= el->chunk_slot[k] % W == 0 && el->chunk_slot[k] < el->chunk_slot[k + 1];
    bounds &= el->group_slot[el->chunk_group[k]] == el->chunk_slot[k];
  }
  for (size_t g = 0; bounds && g < el->ngroups; g++)
    bounds &= el->group_slot[g] % W == 0 && el->group_slot[g] < el->group_slot[g + 1];
  verdict(label, "coloured order bounds are whole blocks, in order", bounds);

  size_t *stamp = malloc(nv * sizeof *stamp);
  for (size_t v = 0; v < nv; v++)
    stamp[v] = (size_t)-1;
  int groups = 1, phases = 1;
  for (size_t g = 0; bounds && g < el->ngroups; g++)
    groups &= vertex_disjoint(el, el->group_slot[g], el->group_slot[g + 1], stamp, g);
  for (size_t v = 0; v < nv; v++)
    stamp[v] = (size_t)-1;
  for (int p = 0; bounds && p < el->nphases; p++)
    for (size_t k = el->phase_chunk[p]; k < el->phase_chunk[p + 1]; k++) {
      // Chunk k against the chunks of the phase before it: stamp by phase,
      // and a chunk may reuse its own vertices.
      for (size_t s = el->chunk_slot[k]; s < el->chunk_slot[k + 1]; s++) {
        int32_t t = el->colored.slot_tet[s];
        for (int c = 0; t >= 0 && c < 4; c++) {
          int32_t v = el->tets[(size_t)t * 4 + c];
          phases &= stamp[v] == (size_t)-1 || stamp[v] == k ||
                    stamp[v] < el->phase_chunk[p]; // an earlier phase's chunk
          stamp[v] = k;
        }
      }
    }
  free(stamp);
  verdict(label, "tets of one colour group share no vertex", bounds && groups);
  verdict(label, "chunks of one phase share no vertex", bounds && phases);

  // Vertex lists over the Morton order: ascending, each entry a tet corner
  // at that vertex, as many entries as the vertex has tet corners.
  int lists = 1;
  size_t total = 0;
  for (size_t v = 0; v < nv; v++) {
    for (int32_t e = el->vert_start[v]; e < el->vert_start[v + 1]; e++) {
      int32_t slot = el->vert_entries[e] >> 2, c = el->vert_entries[e] & 3;
      int32_t t = el->morton.slot_tet[slot];
      lists &= t >= 0 && el->tets[(size_t)t * 4 + c] == (int32_t)v;
      lists &= e == el->vert_start[v] || el->vert_entries[e] > el->vert_entries[e - 1];
    }
    total += (size_t)(el->vert_start[v + 1] - el->vert_start[v]);
  }
  verdict(label, "vertex lists sorted and complete", lists && total == el->ntets * 4);
  printf("%s: %zu tets, %zu chunks in %d phases, %d tet colours, %zu coloured slots (%.1f%% "
         "padding)\n",
         label, el->ntets, el->nchunks, el->nphases, el->ncolors, el->colored.nslots,
         100.0 * (double)(el->colored.nslots - el->ntets) / (double)el->colored.nslots);
}

static void check_box(int nx, int ny, int nz) {
  char label[64];
  snprintf(label, sizeof label, "box %dx%dx%d", nx, ny, nz);
  ek_check_box m;
  if (ek_check_box_create(&m, nx, ny, nz, nx, ny, nz) != 0) {
    printf("%s: %s\n", label, ek_last_error());
    verdict(label, "builds", 0);
    return;
  }
  check_layout(label, m.el);
  ek_check_box_destroy(&m);
}

// ek_tets_create on plain arrays: the box's tets with the vertices
// renumbered at random (the Morton order must not depend on the numbering).
static void check_renumbered(ek_rng *rng) {
  ek_check_box b;
  if (ek_check_box_create(&b, 12, 9, 7, 1.2, 0.9, 0.7) != 0) {
    verdict("renumbered box", "box builds", 0);
    return;
  }
  size_t nv = b.nverts, nt = b.ntets;
  double *X = malloc(nv * 3 * sizeof(double));
  int32_t *T = malloc(nt * 4 * sizeof(int32_t)), *perm = malloc(nv * sizeof(int32_t));
  for (size_t v = 0; v < nv; v++)
    perm[v] = (int32_t)v;
  for (size_t v = nv - 1; v > 0; v--) {
    size_t j = (size_t)(ek_rng_uniform(rng) * (double)(v + 1));
    int32_t tmp = perm[v];
    perm[v] = perm[j];
    perm[j] = tmp;
  }
  for (size_t v = 0; v < nv; v++)
    memcpy(X + (size_t)perm[v] * 3, b.X + v * 3, 3 * sizeof(double));
  for (size_t i = 0; i < nt * 4; i++)
    T[i] = perm[b.T[i]];
  ek_tets *el = ek_tets_create(nv, X, nt, T);
  if (!el) {
    printf("renumbered box: %s\n", ek_last_error());
    verdict("renumbered box", "builds", 0);
  } else {
    check_layout("renumbered box (plain arrays)", el);
    ek_tets_destroy(el);
  }
  ek_check_box_destroy(&b);
  free(X);
  free(T);
  free(perm);
}

// A refused input: NULL, and the expected piece in the message.
static void expect_refused(const char *label, ek_tets *el, const char *err, const char *want) {
  int ok = el == NULL && strstr(err, want) != NULL;
  printf("refuses %s: \"%s\"\n", label, err);
  verdict("ek_tets_create", label, ok);
  ek_tets_destroy(el);
}

static void check_refusals(void) {
  const double X[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const int32_t good[] = {0, 1, 2, 3}, flipped[] = {0, 2, 1, 3}, range[] = {0, 1, 2, 4},
                flat[] = {0, 1, 1, 3};
  expect_refused("NULL arrays", ek_tets_create(4, NULL, 1, good), ek_last_error(), "NULL");
  expect_refused("no tets", ek_tets_create(4, X, 0, good), ek_last_error(), "no tetra");
  expect_refused("index out of range", ek_tets_create(4, X, 1, range), ek_last_error(),
                 "tet 0: vertex index 4 out of range");
  expect_refused("inverted tet", ek_tets_create(4, X, 1, flipped), ek_last_error(),
                 "tet 0: det(Dm) = 6V = -1");
  expect_refused("zero-volume tet", ek_tets_create(4, X, 1, flat), ek_last_error(),
                 "tet 0: det(Dm) = 6V = 0");
  double Xnan[12];
  memcpy(Xnan, X, sizeof Xnan);
  Xnan[7] = NAN;
  expect_refused("NaN coordinate", ek_tets_create(4, Xnan, 1, good), ek_last_error(),
                 "vertex 2: coordinate y = nan");
  ek_tets *el = ek_tets_create(4, X, 1, good);
  verdict("ek_tets_create", "one unit tet: V0 = 1/6, Dm^-1 = I",
          el && ek_tets_rest_volumes(el)[0] == 1.0 / 6 && ek_tets_dm_inv(el)[0] == 1 &&
              ek_tets_dm_inv(el)[4] == 1 && ek_tets_dm_inv(el)[8] == 1 &&
              ek_tets_dm_inv(el)[1] == 0);
  ek_tets_destroy(el);
}

// Per-element state: set / get round trip through the Morton slots (f64
// exact, f32 the float rounding), padding slots left at the identity.
static void check_state(ek_rng *rng) {
  ek_check_box m;
  if (ek_check_box_create(&m, 5, 4, 3, 1, 1, 1) != 0) {
    verdict("per-element state", "box builds", 0);
    return;
  }
  const ek_tets *el = m.el;
  size_t nt = el->ntets;
  double *in = malloc(nt * 9 * sizeof(double)), *out = malloc(nt * 9 * sizeof(double));
  for (size_t i = 0; i < nt * 9; i++)
    in[i] = ek_rng_gauss(rng);
  int ok64 = 0, ok32 = 1, pad = 1;
  ek_tet_state *s64 = ek_tet_state_create(el, 9, 1), *s32 = ek_tet_state_create(el, 9, 0);
  if (s64 && s32 && ek_tet_state_set_f64(s64, in) == 0 && ek_tet_state_get_f64(s64, out) == 0)
    ok64 = memcmp(in, out, nt * 9 * sizeof(double)) == 0;
  if (s64 && s32 && ek_tet_state_set_f64(s32, in) == 0 && ek_tet_state_get_f64(s32, out) == 0)
    for (size_t i = 0; i < nt * 9; i++)
      ok32 &= out[i] == (double)(float)in[i];
  for (size_t sl = nt; s32 && sl < el->morton.nslots; sl++)
    for (int k = 0; k < 9; k++)
      pad &= ((const float *)s32->data)[((sl / 16) * 9 + (size_t)k) * 16 + sl % 16] ==
             (k % 4 == 0 ? 1.0f : 0.0f);
  verdict("per-element state", "f64 set/get round trip is exact", ok64);
  verdict("per-element state", "f32 set/get gives the float rounding", ok32);
  verdict("per-element state", "padding slots stay the identity", pad);
  verdict("per-element state", "bad arguments refused",
          !ek_tet_state_create(el, 0, 0) && !ek_tet_state_create(el, 9, 2) &&
              !ek_tet_state_create(NULL, 9, 0) && ek_tet_state_set_f64(s32, NULL) == EK_EINVAL);
  ek_tet_state_destroy(s64);
  ek_tet_state_destroy(s32);
  free(in);
  free(out);
  ek_check_box_destroy(&m);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 5, NULL);
  printf("test_elements: seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  check_refusals();
  check_box(1, 1, 1);
  check_box(6, 6, 6);
  check_box(100, 1, 10);
  check_box(40, 40, 40);
  check_renumbered(&rng);
  check_state(&rng);
  printf("test_elements: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
