// Invariant: every malformed input of issue 14 is refused, never half-used:
//   - meshes: huge coordinates (6V beyond a double, or an edge vector that
//     overflows) and rest volumes out of range are refused naming the tet
//     and its 6V, never loaded with a NaN or infinite V0; the shape tests
//     are scale-free (a cube at 1e-100 or 1e100 loads, exact to
//     EK_MESH_TOL); a header declaring 2e9 items is refused at its line
//     before anything is allocated for it; a directory is reported as one;
//     NUL and binary bytes are refused and never echoed raw; a file of
//     another format (x.vtk) is named as one, not as a missing x.vtk.node;
//     a token beyond what a line holds (TetGen: the attributes and marker
//     its header declares; Gmsh: a line's fields; OBJ: v x y z [w | r g b])
//     is refused naming FILE:LINE and the token, what the formats allow
//     loads, and through a scene the message starts at mesh.file's place;
//   - scenes: a key twice in one object is refused naming the key and both
//     places; errors found after parsing name FILE:LINE:COLUMN of the
//     value (of an unknown key; of the object a required key is missing
//     from), and invalid JSON the byte where it stops being JSON ("unexpected
//     end of file" when cut short, naming what is left open); E = 1e308 is
//     refused naming material.E; a directory as the
//     mesh is reported as one; messages never carry raw control or non-ASCII
//     bytes;
//   - batches: a count whose byte count overflows (n = SIZE_MAX) gives
//     EK_EINVAL from every batch entry point and writes nothing; an array not
//     aligned to its element type gives EK_EINVAL; element-aligned arrays
//     that are not 64-byte aligned work and give the same bits.
//   - faults (issue 28): frames are never written over a directory, FIFO
//     or symbolic link (nor over a scratch name that is one), even with
//     force; the same tet (TetGen, in memory) or triangle (OBJ) twice is
//     refused naming both places; Gmsh v4.1 element blocks must add up to
//     the header's count; a triangle at 1e+-70 loads and one at 1e+-100 is
//     "outside the supported range", never "degenerate ... inf" nor loaded
//     with an infinite area (the element layer squares 2A); the CFL
//     limit scales exactly under power-of-two changes of length and
//     density and is finite at 1e+-100 m and 1e-300 kg/m^3; a state that
//     goes non-finite fails the step that made it ("non-finite", never
//     "invertible"), the state kept finite; the stop flag leaves the bits
//     of a run unchanged and, set, stops a step without applying it; cloth
//     thickness 1e300 is refused naming cloth.thickness; XPBD clusters
//     build and run at 1e+-30 m (f64).
// Run under the asan preset it also checks that every error path frees
// what it took (ctest --preset asan -R bad_input).
#include <ek/batch.h>
#include <ek/cloth.h>
#include <ek/elements.h>
#include <ek/material.h>
#include <ek/sim/mesh.h>
#include <ek/sim/sim.h>
#include <ek/sim/trimesh.h>
#include <ek/svd3.h>

#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "cli.h"

static int failures = 0;
static char tmp_dir[256];

static void verdict(const char *what, int ok, const char *detail) {
  printf("%-52s %s  %s\n", what, ok ? "PASS" : "FAIL", detail);
  if (!ok)
    failures++;
}

static void write_file(const char *name, const char *text, size_t len) {
  char path[512];
  snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
  FILE *f = fopen(path, "wb");
  if (!f || fwrite(text, 1, len, f) != len) {
    printf("cannot write %s\n", path);
    exit(2);
  }
  fclose(f);
}

static void write_text(const char *name, const char *text) { write_file(name, text, strlen(text)); }

// Every byte of a message printable ASCII (binary input never echoed raw).
static int printable(const char *s) {
  for (; *s; s++)
    if ((unsigned char)*s < 0x20 || (unsigned char)*s >= 0x7f)
      return 0;
  return 1;
}

static int contains_all(const char *s, const char *w1, const char *w2, const char *w3) {
  const char *w[3] = {w1, w2, w3};
  for (int k = 0; k < 3; k++)
    if (w[k] && !strstr(s, w[k]))
      return 0;
  return 1;
}

// A mesh that must be refused: NULL, the pieces in the message, no raw
// bytes, and no pieces that must not be there (`never`).
static void mesh_refused(const char *what, ek_mesh *m, const char *err, const char *w1,
                         const char *w2, const char *w3, const char *never) {
  int ok = m == NULL && contains_all(err, w1, w2, w3) && printable(err) &&
           !(never && strstr(err, never));
  verdict(what, ok, err);
  if (!ok) {
    printf("  expected NULL and a printable message with '%s' '%s' '%s'%s%s\n", w1 ? w1 : "",
           w2 ? w2 : "", w3 ? w3 : "", never ? ", without " : "", never ? never : "");
    if (m)
      printf("  loaded: %zu tets, V0[0] = %g\n", ek_mesh_ntets(m), ek_mesh_rest_volumes(m)[0]);
  }
  ek_mesh_destroy(m);
}

static ek_mesh *load(const char *name) {
  char path[512];
  snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
  return ek_mesh_load(path);
}

// The unit cube as 6 Kuhn tets (as ek_mesh_box(1,1,1)), scaled by s.
static ek_mesh *cube(double s) {
  double X[8 * 3];
  for (int v = 0; v < 8; v++)
    for (int k = 0; k < 3; k++)
      X[v * 3 + k] = s * (double)(v >> k & 1);
  ek_mesh *box = ek_mesh_box(1, 1, 1, 1, 1, 1);
  if (!box)
    return NULL;
  // ek_mesh_box numbers vertices x fastest, as above.
  ek_mesh *m = ek_mesh_create(8, X, 6, ek_mesh_tets(box));
  ek_mesh_destroy(box);
  return m;
}

// Loaded at scale s: 6 tets, V0 = s^3 / 6 each, Dm Dm^-1 = I, all to
// EK_MESH_TOL relative.
static void cube_loads(double s) {
  char what[96];
  snprintf(what, sizeof what, "cube of edge %g loads, V0 = s^3/6, Dm Dm^-1 = I", s);
  ek_mesh *m = cube(s);
  if (!m) {
    verdict(what, 0, ek_last_error());
    return;
  }
  double worst = 0;
  const double *X = ek_mesh_rest_positions(m);
  for (size_t t = 0; t < ek_mesh_ntets(m); t++) {
    double V0 = ek_mesh_rest_volumes(m)[t], want = s * s * s / 6;
    worst = fmax(worst, fabs(V0 - want) / want);
    const int32_t *T = ek_mesh_tets(m) + t * 4;
    const double *Dmi = ek_mesh_dm_inv(m) + t * 9;
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) {
        double sum = 0; // (Dm Dm^-1)_rc with Dm's columns X_j - X_0
        for (int j = 0; j < 3; j++)
          sum += (X[T[j + 1] * 3 + r] - X[T[0] * 3 + r]) * Dmi[j * 3 + c];
        worst = fmax(worst, fabs(sum - (r == c)));
      }
  }
  char detail[128];
  snprintf(detail, sizeof detail, "worst relative error %.3g (budget %g)", worst, EK_MESH_TOL);
  verdict(what, worst <= EK_MESH_TOL && isfinite(ek_mesh_min_edge(m)), detail);
  ek_mesh_destroy(m);
}

static void meshes(void) {
  printf("-- meshes\n");
  // Scale: the shape tests hold at any scale; 6V must fit a double.
  cube_loads(1e-100);
  cube_loads(1e100);
  mesh_refused("cube of edge 1e120: outside the range, not 'zero volume'", cube(1e120),
               ek_last_error(), "tet 0", "6V = 1e+360", "outside the supported range",
               "zero volume");
  mesh_refused("cube of edge 1e-120: outside the range, not 'zero volume'", cube(1e-120),
               ek_last_error(), "tet 0", "6V = 1e-360", "outside the supported range",
               "zero volume");

  // Huge finite coordinates: 6V overflows (|x| ~ 1e160: it was NaN and
  // passed both the degenerate and the inverted test).
  write_text("huge.node", "4 3 0 0\n1 0 0 0\n2 1e160 0 0\n3 0 1e160 0\n4 0 0 1e160\n");
  write_text("huge.ele", "1 4 0\n1 1 2 3 4\n");
  mesh_refused("TetGen tet at 1e160: refused, file:line and 6V", load("huge"), ek_last_error(),
               "huge.ele:2: tet 0", "6V = 1e+480", "outside the supported range", "nan");
  // An edge vector that overflows: x = 1e308 and -1e308 in one tet.
  write_text("edge.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 -1e308 0 0\n"
                         "2 1e308 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n1\n"
                         "1 4 0 1 2 3 4\n$EndElements\n");
  mesh_refused("Gmsh edge from -1e308 to 1e308: overflow named", load("edge.msh"), ek_last_error(),
               "edge.msh:13: tet 0", "overflows", "x = 1e+308 - -1e+308", NULL);
  // A needle tet near DBL_MAX (edges 1e307 along x, 1 across): its 6V =
  // 1e307 is finite, so the element layer takes it; the Morton order's
  // centroid (sum of four 1.5e308) must not overflow into an infinite key,
  // whose conversion to an integer is undefined (UBSan, float-cast-overflow:
  // clang's -fsanitize=undefined, the fuzz build). The mesh layer refuses it
  // as degenerate (6V against (longest edge)^3, in scaled units).
  {
    double X[4 * 3] = {1.5e308, 0, 0, 1.6e308, 0, 0, 1.5e308, 1, 0, 1.5e308, 0, 1};
    int32_t T[4] = {0, 1, 2, 3};
    ek_tets *el = ek_tets_create(4, X, 1, T);
    int ok = el && fabs(ek_tets_rest_volumes(el)[0] - 1e307 / 6) <= EK_MESH_TOL * 1e307 / 6;
    verdict("element layer: needle tet at 1.5e308, V0 = 1e307/6", ok, el ? "" : ek_last_error());
    ek_tets_destroy(el);
    mesh_refused("mesh: the same needle is degenerate", ek_mesh_create(4, X, 1, T), ek_last_error(),
                 "tet 0", "degenerate", NULL, NULL);
  }
  // A tet translated far from the origin: edges 2^-40 of the coordinates.
  {
    const double T0 = 1e110, T1 = 1e110 * (1 + 0x1p-40);
    double X[4 * 3] = {T0, T0, T0, T1, T0, T0, T0, T1, T0, T0, T0, T1};
    int32_t T[4] = {0, 1, 2, 3};
    ek_mesh *m = ek_mesh_create(4, X, 1, T);
    double d = T1 - T0, want = d * d * d / 6;
    int ok = m && fabs(ek_mesh_rest_volumes(m)[0] - want) <= EK_MESH_TOL * want;
    verdict("tet of edge 9e97 at 1e110: loads, V0 = d^3/6", ok, m ? "" : ek_last_error());
    ek_mesh_destroy(m);
  }

  // Header counts: 2e9 items declared, a few bytes follow.
  write_text("count.node", "2000000000 3 0 0\n1 0 0 0\n2 1 0 0\n");
  write_text("count.ele", "1 4 0\n1 1 2 3 4\n");
  mesh_refused("TetGen header of 2e9 points: refused at its line", load("count.node"),
               ek_last_error(), "count.node:1", "declares 2000000000 points", NULL, NULL);
  write_text("count_ele.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  write_text("count_ele.ele", "499999999 4 0\n1 1 2 3 4\n");
  mesh_refused("TetGen header of 5e8 tets: refused at its line", load("count_ele"), ek_last_error(),
               "count_ele.ele:1", "declares 499999999 tetrahedrons", NULL, NULL);
  write_text("count_v2.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2000000000\n"
                             "1 0 0 0\n$EndNodes\n");
  mesh_refused("Gmsh v2 header of 2e9 nodes: refused at its line", load("count_v2.msh"),
               ek_last_error(), "count_v2.msh:5", "declares 2000000000 nodes", NULL, NULL);
  write_text("count_v4.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n"
                             "1 2000000000 1 2000000000\n0 1 0 1\n1\n0 0 0\n$EndNodes\n");
  mesh_refused("Gmsh v4 header of 2e9 nodes: refused at its line", load("count_v4.msh"),
               ek_last_error(), "count_v4.msh:5", "declares 2000000000 nodes", NULL, NULL);
  write_text("count_el.msh",
             "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"
             "4 0 0 1\n$EndNodes\n$Elements\n2000000000\n1 4 0 1 2 3 4\n$EndElements\n");
  mesh_refused("Gmsh v2 header of 2e9 elements: refused at its line", load("count_el.msh"),
               ek_last_error(), "count_el.msh:12", "declares 2000000000 elements", NULL, NULL);

  // A directory, as a .msh name and as a TetGen base name.
  char path[512];
  snprintf(path, sizeof path, "%s/dir.msh", tmp_dir);
  mkdir(path, 0700);
  snprintf(path, sizeof path, "%s/dir.node", tmp_dir);
  mkdir(path, 0700);
  mesh_refused("directory dir.msh: 'is a directory'", load("dir.msh"), ek_last_error(),
               "dir.msh: is a directory", NULL, NULL, "truncated");
  mesh_refused("TetGen base whose .node is a directory", load("dir"), ek_last_error(),
               "dir.node: is a directory", NULL, NULL, "truncated");

  // A file of another format (no .msh/.node/.ele suffix, no BASE.node):
  // named as such, not as the missing "x.vtk.node".
  write_text("other.vtk", "# vtk DataFile Version 3.0\n");
  mesh_refused("file of another format (.vtk): 'not a mesh format'", load("other.vtk"),
               ek_last_error(), "other.vtk: not a mesh format ek reads", NULL, NULL,
               "other.vtk.node");

  // Binary bytes: a NUL, and raw bytes in a number, escaped in the message.
  write_file("nul.node", "2 3 0 0\n1 0 0 0\n2 1\0 0 0\n", 25);
  write_text("nul.ele", "1 4 0\n1 1 2 3 4\n");
  mesh_refused("NUL byte in a .node: refused at its line", load("nul"), ek_last_error(),
               "nul.node:3", "NUL byte", NULL, NULL);
  write_text("bytes.node", "2 3 0 0\n1 0 0 0\n2 1\x1b[31m\xff 0 0\n");
  write_text("bytes.ele", "1 4 0\n1 1 2 3 4\n");
  mesh_refused("raw bytes in a number: escaped in the message", load("bytes"), ek_last_error(),
               "bytes.node:3", "bad number '1\\x1b[31m\\xff'", NULL, NULL);
  write_text("bytes.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n0\n\x01\x02\n");
  mesh_refused("raw bytes for $EndNodes: escaped", load("bytes.msh"), ek_last_error(),
               "bytes.msh:6", "found '\\x01\\x02'", NULL, NULL);
}

// ---- scenes

#define MESH "\"mesh\": {\"box\": [2, 2, 2], \"size\": [1, 1, 1]}"
#define MAT "\"material\": {\"model\": \"arap\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000}"
#define TAIL "\"dt\": 1e-4, \"steps\": 10"

static void scene_refused(const char *what, const char *json, const char *w1, const char *w2,
                          const char *w3) {
  ek_scene s;
  int rc = ek_scene_parse(json, "bad.json", ".", &s);
  int ok =
      rc == EK_EINVAL && contains_all(ek_last_error(), w1, w2, w3) && printable(ek_last_error());
  verdict(what, ok, ek_last_error());
  if (!ok)
    printf("  rc %d; expected EK_EINVAL and a printable message with '%s' '%s' '%s'\n", rc, w1,
           w2 ? w2 : "", w3 ? w3 : "");
}

static void scenes(void) {
  printf("-- scenes\n");
  scene_refused("\"dt\" twice: refused, both places named",
                "{" MESH ", " MAT ",\n \"dt\": 1e-4,\n \"dt\": -1, \"steps\": 10}",
                "bad.json:3:2: duplicate key \"dt\"", "first at line 2, column 2", NULL);
  scene_refused("\"material\" twice: refused",
                "{" MESH ", " MAT ", " TAIL ",\n \"material\": {\"model\": \"snh\"}}",
                "bad.json:2:2: duplicate key \"material\"", "first at line 1", NULL);
  scene_refused("\"E\" twice inside material: path named",
                "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1e5, \"nu\": 0.3, "
                "\"E\": 2e5, \"density\": 1}, " TAIL "}",
                "duplicate key \"material.E\"", "first at line 1", NULL);
  scene_refused("escaped duplicate (\\u0064t = dt): refused",
                "{" MESH ", " MAT ", \"dt\": 1e-4, \"\\u0064t\": 1, \"steps\": 10}",
                "duplicate key \"dt\"", NULL, NULL);
  scene_refused("duplicate inside boundary[1]: path named",
                "{" MESH ", " MAT ", " TAIL ", \"boundary\": [{\"type\": \"pin\", \"region\": "
                "{\"min\": [0,0,0], \"max\": [1,1,1]}}, {\"type\": \"pin\", \"type\": \"pin\"}]}",
                "duplicate key \"boundary[1].type\"", NULL, NULL);
  scene_refused("E = 1e308 (lambda = inf): refused naming material.E",
                "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1e308, \"nu\": 0.49, "
                "\"density\": 1}, " TAIL "}",
                "material.E = 1e+308", "lambda = inf", NULL);
  scene_refused("raw bytes in an unknown key: escaped",
                "{" MESH ", " MAT ", " TAIL ", \"\x1b[2J\xc3\": 1}", "unknown key", "\\x1b[2J\\xc3",
                NULL);
  scene_refused("raw bytes in a string value: escaped",
                "{" MESH ", \"material\": {\"model\": \"\x07\xfe\", \"E\": 1, \"nu\": 0.3, "
                "\"density\": 1}, " TAIL "}",
                "material.model = \"\\x07\\xfe\"", NULL, NULL);
  // (cJSON skips every byte <= 32 as whitespace, so the error is at \xfe.)
  scene_refused("raw bytes in invalid JSON: escaped", "{\"mesh\": \xfe\x1b\x7f}",
                "invalid JSON near \"\\xfe\\x1b\\x7f}\"", NULL, NULL);
  scene_refused("control character in mesh.file: refused",
                "{\"mesh\": {\"file\": \"a\\nb.msh\"}, " MAT ", " TAIL "}", "mesh.file",
                "control character", NULL);
  // Placed at FILE:LINE:COLUMN: the value, the unknown key, the object a
  // required key is missing from; and where the text stops being JSON
  // (cJSON's own position is one byte late after a bad key, and only the
  // end of the text when it is cut short).
#define ZEROS10 "0000000000"
#define ZEROS100 ZEROS10 ZEROS10 ZEROS10 ZEROS10 ZEROS10 ZEROS10 ZEROS10 ZEROS10 ZEROS10 ZEROS10
#define LINES(mat)                                                                                 \
  "{\"mesh\": {\"box\": [2, 2, 2], \"size\": [1, 1, 1]},\n"                                        \
  " \"material\": {\"model\": \"arap\",\n" mat "\n \"dt\": 1e-4, \"steps\": 10}"
  scene_refused("E = -100000 on line 3: at its value",
                LINES("   \"E\": -100000, \"nu\": 0.3, \"density\": 1},"),
                "bad.json:3:9: material.E = -100000: Young's modulus must be > 0", NULL, NULL);
  scene_refused("unknown key on line 3: at the key",
                LINES("   \"E\": 1e5, \"nu\": 0.3, \"densty\": 1},"),
                "bad.json:3:25: material.densty = 1: unknown key", NULL, NULL);
  scene_refused("missing key: at its object's '{' (line 2)", LINES("   \"E\": 1e5, \"nu\": 0.3},"),
                "bad.json:2:14: material.density: missing (required)", NULL, NULL);
  scene_refused("bad enum on line 2: at its value",
                "{" MESH ",\n \"material\": {\"model\": \"neo\", \"E\": 1e5, \"nu\": 0.3, "
                "\"density\": 1},\n " TAIL "}",
                "bad.json:2:24: material.model = \"neo\": unknown model", NULL, NULL);
  scene_refused("missing top-level key: at the scene's '{'",
                "\n  {" MESH ",\n " MAT ",\n \"steps\": 10}",
                "bad.json:2:3: dt: missing (required)", NULL, NULL);
  scene_refused("array item on line 3: at the item",
                "{" MESH ", " MAT ", " TAIL ",\n \"boundary\": [{\"type\": \"pin\", \"region\": "
                "{\"min\": [0, 0, 0],\n \"max\": [1, -1e400, 0]}}]}",
                "bad.json:3:13: boundary[0].region.max[1] = -inf: must be a finite number", NULL,
                NULL);
  scene_refused(
      "a number of 101 digits: placed (the scan takes it whole, as cJSON)",
      "{\"mesh\": {\"box\": [2, 2" ZEROS100 ", 2], \"size\": [1, 1, 1]},\n " MAT ", " TAIL "}",
      "bad.json:1:22: mesh.box[1] = 2e+100: must be a whole number in [1, 4096]", NULL, NULL);
  scene_refused("invalid JSON: a bare key, at the key (cJSON: one byte late)", "{\n  mesh: 1}",
                "bad.json:2:3: invalid JSON near \"mesh: 1}\"", "expected a key", NULL);
  scene_refused("invalid JSON: a comma before '}', at the '}' (cJSON: at the end)",
                "{\"dt\": 1,\n}\n", "bad.json:2:1: invalid JSON near \"}\\x0a\"", NULL, NULL);
  scene_refused("invalid JSON: cut short, 'unexpected end of file'", "{\"mesh\": {\"box\": [2,\n",
                "bad.json:2:1: invalid JSON: unexpected end of file",
                "the array opened at line 1, column 18 is not closed", NULL);
  scene_refused("invalid JSON: cut short in a string", "{\"description\": \"a beam\n",
                "bad.json:2:1: invalid JSON: unexpected end of file",
                "the string opened at line 1, column 17", NULL);
  scene_refused("invalid JSON: empty text", "",
                "bad.json:1:1: invalid JSON: unexpected end of file", "no JSON value", NULL);
#undef LINES
#undef ZEROS100
#undef ZEROS10
  {
    // A NUL in the file: cJSON would stop there and take the first part.
    const char text[] = "{" MESH ", " MAT ", " TAIL "}\0, \"dt\": -1}";
    write_file("nul.json", text, sizeof text - 1);
    ek_scene s;
    char path[512];
    snprintf(path, sizeof path, "%s/nul.json", tmp_dir);
    int rc = ek_scene_load(path, &s);
    verdict("NUL byte in a scene file: refused", rc < 0 && strstr(ek_last_error(), "NUL byte"),
            ek_last_error());
    snprintf(path, sizeof path, "%s/dir.msh", tmp_dir);
    rc = ek_scene_load(path, &s);
    verdict("directory as the scene: 'is a directory'",
            rc < 0 && strstr(ek_last_error(), "is a directory"), ek_last_error());
  }
  {
    // A directory as the mesh.
    write_text("dirmesh.json", "{\"mesh\": {\"file\": \"dir.msh\"}, " MAT ", " TAIL "}");
    ek_scene s;
    char path[512];
    snprintf(path, sizeof path, "%s/dirmesh.json", tmp_dir);
    int rc = ek_scene_load(path, &s);
    ek_mesh *m = rc == 0 ? ek_scene_mesh(&s) : NULL;
    verdict("directory as the scene's mesh: 'is a directory'",
            rc == 0 && !m && strstr(ek_last_error(), "dir.msh: is a directory") &&
                !strstr(ek_last_error(), "truncated"),
            ek_last_error());
    ek_mesh_destroy(m);
  }
}

// ---- faults and hostile input (issue 28)

// The box's bottom face held: gravity then strains it.
#define PIN                                                                                        \
  "\"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": [0, 0, 0], \"max\": [1, 1, 0]}}]"

// Output names that are not regular files: refused with what they are, even
// with force, and left as they were.
static void frames_outputs(void) {
  printf("-- output paths\n");
  double X[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  int32_t tet[4] = {0, 1, 2, 3};
  char path[512];
  struct stat st;
  // A directory, a FIFO and a symbolic link at the frames' own name.
  snprintf(path, sizeof path, "%s/out_dir.h5", tmp_dir);
  mkdir(path, 0700);
  ek_frames *fr = ek_frames_create(path, 1, 4, X, 1, tet);
  verdict("frames to a directory, --force: refused",
          !fr && strstr(ek_last_error(), "is a directory") && stat(path, &st) == 0 &&
              S_ISDIR(st.st_mode),
          ek_last_error());
  ek_frames_close(fr);
  snprintf(path, sizeof path, "%s/out_fifo.h5", tmp_dir);
  int made = mkfifo(path, 0600) == 0;
  fr = ek_frames_create(path, 1, 4, X, 1, tet);
  verdict("frames to a FIFO, --force: refused, still a FIFO",
          made && !fr && strstr(ek_last_error(), "is a FIFO") && lstat(path, &st) == 0 &&
              S_ISFIFO(st.st_mode),
          ek_last_error());
  ek_frames_close(fr);
  write_text("target.txt", "not ek's\n");
  char target[512];
  snprintf(target, sizeof target, "%s/target.txt", tmp_dir);
  snprintf(path, sizeof path, "%s/out_link.h5", tmp_dir);
  made = symlink(target, path) == 0;
  fr = ek_frames_create(path, 1, 4, X, 1, tet);
  verdict("frames to a symbolic link, --force: refused",
          made && !fr && strstr(ek_last_error(), "symbolic link") && lstat(path, &st) == 0 &&
              S_ISLNK(st.st_mode) && stat(target, &st) == 0 && st.st_size == 9,
          ek_last_error());
  ek_frames_close(fr);
  // The scratch name (renamed over at each frame) as a directory.
  snprintf(path, sizeof path, "%s/out_scratch.h5.scratch", tmp_dir);
  mkdir(path, 0700);
  snprintf(path, sizeof path, "%s/out_scratch.h5", tmp_dir);
  fr = ek_frames_create(path, 1, 4, X, 1, tet);
  verdict("frames whose scratch name is a directory: refused",
          !fr && strstr(ek_last_error(), "out_scratch.h5.scratch: is a directory") &&
              lstat(path, &st) != 0,
          ek_last_error());
  ek_frames_close(fr);
}

// The same element twice, and element counts that the blocks do not match.
static void duplicates(void) {
  printf("-- duplicate elements\n");
  write_text("dup.node", "5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n");
  write_text("dup.ele", "3 4 0\n1 1 2 3 4\n2 2 3 4 5\n3 2 3 1 4\n");
  // Tet 3 is tet 1 with its first three vertices rotated (same
  // orientation: the same element in another order).
  mesh_refused("TetGen: the same tet twice (any order): refused", load("dup"), ek_last_error(),
               "dup.ele:4: tet 2", "duplicate element: vertices 2 3 1 4", "the same set as", NULL);
  {
    double X[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    int32_t T[8] = {0, 1, 2, 3, 3, 2, 1, 0};
    ek_mesh *m = ek_mesh_create(5, X, 2, T);
    mesh_refused("in memory: the same tet twice: refused", m, ek_last_error(), "tet 1",
                 "duplicate element", "tet 0", NULL);
  }
  write_text("dup.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\nf 3 1 2\n");
  char path[512];
  snprintf(path, sizeof path, "%s/dup.obj", tmp_dir);
  ek_trimesh *tm = ek_trimesh_load(path);
  verdict("OBJ: the same triangle twice: refused, both lines",
          !tm &&
              contains_all(ek_last_error(), "dup.obj:7", "duplicate element: triangle (3 1 2)",
                           "the same vertices as") &&
              strstr(ek_last_error(), "dup.obj:5") && printable(ek_last_error()),
          ek_last_error());
  ek_trimesh_destroy(tm);
  // Three triangles on the edge (1 2): no bending hinge could join them.
  write_text("fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 2 2 2\n"
                        "f 1 2 3\nf 2 1 4\nf 2 6 3\nf 1 2 5\n");
  snprintf(path, sizeof path, "%s/fin.obj", tmp_dir);
  tm = ek_trimesh_load(path);
  verdict("OBJ: a non-manifold edge (three triangles): refused, the three lines named",
          !tm &&
              contains_all(ek_last_error(), "fin.obj:10", "non-manifold edge (1 2)", "fin.obj:7") &&
              strstr(ek_last_error(), "fin.obj:8") && printable(ek_last_error()),
          ek_last_error());
  ek_trimesh_destroy(tm);
  // Gmsh v4.1: two element blocks of 2 tets under a header of 3.
  write_text("blocks.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 1 5\n3 1 0 5\n"
                           "1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
                           "$Elements\n2 3 1 4\n3 1 4 2\n1 1 2 3 4\n2 2 3 4 5\n"
                           "3 2 4 2\n3 1 2 3 5\n4 1 2 4 5\n$EndElements\n");
  mesh_refused("Gmsh v4.1: blocks hold more elements than declared", load("blocks.msh"),
               ek_last_error(), "blocks.msh:23",
               "element block of 2 elements exceeds the 3 "
               "declared",
               NULL, NULL);
  write_text("blocks2.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 1 5\n3 1 0 5\n"
                            "1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
                            "$Elements\n1 3 1 4\n3 1 4 2\n1 1 2 3 4\n2 2 3 4 5\n$EndElements\n");
  mesh_refused("Gmsh v4.1: blocks hold fewer elements than declared", load("blocks2.msh"),
               ek_last_error(), "2 elements in blocks, 3 declared", NULL, NULL, NULL);
}

// ---- tokens beyond what a mesh format puts on a line

static const char *const cube_xyz[8] = {"0 0 0", "1 0 0", "0 1 0", "1 1 0",
                                        "0 0 1", "1 0 1", "0 1 1", "1 1 1"};
static const char *const cube_tets[6] = {"1 2 4 8", "1 3 7 8", "1 5 6 8",
                                         "1 6 2 8", "1 4 3 8", "1 7 5 8"};

// NAME.node (the unit cube, 1-based, after `header`) and NAME.ele (its 6
// tets after `ele_header`): each point line "i x y z" + node_tail, each
// tet line "i a b c d" + ele_tail; line `bad_point` / `bad_tet` (1-based;
// 0: none) gets bad_tail instead.
static void write_cube(const char *name, const char *header, const char *node_tail, int bad_point,
                       const char *ele_header, const char *ele_tail, int bad_tet,
                       const char *bad_tail) {
  char text[2048], file[300];
  int n = snprintf(text, sizeof text, "%s\n", header);
  for (int i = 0; i < 8; i++)
    n += snprintf(text + n, sizeof text - (size_t)n, "%d %s%s\n", i + 1, cube_xyz[i],
                  i + 1 == bad_point ? bad_tail : node_tail);
  snprintf(file, sizeof file, "%s.node", name);
  write_text(file, text);
  n = snprintf(text, sizeof text, "%s\n", ele_header);
  for (int e = 0; e < 6; e++)
    n += snprintf(text + n, sizeof text - (size_t)n, "%d %s%s\n", e + 1, cube_tets[e],
                  e + 1 == bad_tet ? bad_tail : ele_tail);
  snprintf(file, sizeof file, "%s.ele", name);
  write_text(file, text);
}

static void mesh_loads(const char *what, ek_mesh *m, size_t ntets) {
  char detail[1200];
  snprintf(detail, sizeof detail, "%s", m ? "loaded" : ek_last_error());
  verdict(what, m && ek_mesh_ntets(m) == ntets, detail);
  ek_mesh_destroy(m);
}

static void trimesh_loads(const char *what, ek_trimesh *m) {
  char detail[1200];
  snprintf(detail, sizeof detail, "%s", m ? "loaded" : ek_last_error());
  verdict(what, m != NULL, detail);
  ek_trimesh_destroy(m);
}

static void trimesh_refused(const char *what, ek_trimesh *m, const char *w1, const char *w2) {
  const char *err = m ? "(loaded)" : ek_last_error();
  verdict(what, !m && contains_all(err, w1, w2, NULL) && printable(err), err);
  ek_trimesh_destroy(m);
}

static ek_trimesh *load_tri(const char *name) {
  char path[512];
  snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
  return ek_trimesh_load(path);
}

#define V2_HEAD "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n"
#define V2_NODES                                                                                   \
  "101 0 0 0\n102 1 0 0\n103 0 1 0\n104 1 1 0\n105 0 0 1\n106 1 0 1\n107 0 1 1\n108 1 1 1\n"
#define V2_TETS                                                                                    \
  "1 15 2 0 1 101\n2 4 2 1 1 101 102 104 108\n3 4 2 1 1 101 103 107 108\n"                         \
  "4 4 2 1 1 101 105 106 108\n5 4 2 1 1 101 106 102 108\n6 4 2 1 1 101 104 103 108\n"              \
  "7 4 2 1 1 101 107 105 108\n"

// Every token a reader leaves on a line is refused naming FILE:LINE and the
// token (they were ignored: "1 0 0 0 0.5" under a header of no attributes
// loaded); what the format and the header's counts put there loads.
static void extra_tokens(void) {
  printf("-- tokens beyond a line's content\n");
  // TetGen: attributes and markers as the headers declare them.
  write_cube("attrs", "8 3 2 1", " 0.5 7 1", 0, "6 4 1", " 3", 0, "");
  mesh_loads("TetGen: 2 attributes and a marker per point, 1 attribute per tet", load("attrs"), 6);
  write_cube("bare", "8 3", "", 0, "6 4", "  # a comment", 0, "");
  mesh_loads("TetGen: headers without attribute or marker counts", load("bare"), 6);
  write_cube("quad", "8 3 0 0", "", 0, "6 10", " 2 3 4 5 6 7", 0, "");
  mesh_loads("TetGen: 10-node tets (the corners kept)", load("quad"), 6);
  write_cube("x1", "8 3 0 0 9", "", 0, "6 4 0", "", 0, "");
  mesh_refused("TetGen: .node header with a fifth number", load("x1"), ek_last_error(),
               "x1.node:1:", "unexpected '9'", "marker count", NULL);
  write_cube("x2", "8 3 0 0", "", 3, "6 4 0", "", 0, " 0.5");
  mesh_refused("TetGen: an attribute the header does not declare", load("x2"), ek_last_error(),
               "x2.node:4:", "unexpected '0.5'", "0 attributes and 0 boundary markers", NULL);
  write_cube("x3", "8 3 1 1", " 0.5 1", 8, "6 4 0", "", 0, " 0.5 1 2");
  mesh_refused("TetGen: a token beyond the declared attribute and marker", load("x3"),
               ek_last_error(), "x3.node:9:", "unexpected '2'", "1 attribute and 1 boundary marker",
               NULL);
  write_cube("x4", "8 3 1 1", " 0.5 1", 2, "6 4 0", "", 0, " 0.5");
  mesh_refused("TetGen: a declared marker missing", load("x4"), ek_last_error(),
               "x4.node:3:", "missing boundary marker", NULL, NULL);
  write_cube("x5", "8 3 0 2", "", 0, "6 4 0", "", 0, "");
  mesh_refused("TetGen: 2 boundary markers per point", load("x5"), ek_last_error(),
               "x5.node:1:", "0 or 1", NULL, NULL);
  write_cube("x6", "8 3 0 0", "", 0, "6 4 0 7", "", 0, "");
  mesh_refused("TetGen: .ele header with a fourth number", load("x6"), ek_last_error(),
               "x6.ele:1:", "unexpected '7'", NULL, NULL);
  write_cube("x7", "8 3 0 0", "", 0, "6 4 0", "", 5, " 9");
  mesh_refused("TetGen: a fifth node on a 4-node tet's line", load("x7"), ek_last_error(),
               "x7.ele:6:", "unexpected '9'", "4 nodes and 0 attributes", NULL);
  write_cube("x8", "8 3 0 0", "", 0, "6 4 1", " 2", 2, " 2 x");
  mesh_refused("TetGen: a word after a tet's attribute", load("x8"), ek_last_error(),
               "x8.ele:3:", "unexpected 'x'", NULL, NULL);
  write_cube("x9", "8 3 0 0", "", 0, "6 10", " 2 3 4 5 6 7", 1, " 2 3 4");
  mesh_refused("TetGen: a 10-node tet with 7 nodes", load("x9"), ek_last_error(),
               "x9.ele:2:", "missing vertex index", NULL, NULL);
  // Through a scene: the scene's place of mesh.file, then the mesh's line.
  write_text("x9.json", "{\"mesh\": {\"file\": \"x7.ele\"}, " MAT ", " TAIL "}");
  ek_scene sc;
  char path[512];
  snprintf(path, sizeof path, "%s/x9.json", tmp_dir);
  ek_mesh *m = ek_scene_load(path, &sc) == 0 ? ek_scene_mesh(&sc) : NULL;
  char want[1200];
  snprintf(want, sizeof want, "%s:1:19: mesh.file: %s/x7.ele:6: unexpected '9'", path, tmp_dir);
  mesh_refused("TetGen through a scene: the scene's place, then the mesh's line", m,
               ek_last_error(), want, NULL, NULL, NULL);

  // Gmsh: every line read whole; lines of element types not read are
  // skipped (cube_v2.msh's point element carries its own tags).
  write_text("ok2.msh", V2_HEAD V2_NODES "$EndNodes\n$Elements\n7\n" V2_TETS "$EndElements\n");
  mesh_loads("Gmsh v2: the cube", load("ok2.msh"), 6);
  write_text("g1.msh", V2_HEAD "101 0 0 0 7\n" V2_NODES); // the lines after it never read
  mesh_refused("Gmsh v2: a fourth coordinate", load("g1.msh"), ek_last_error(),
               "g1.msh:6:", "unexpected '7'", "tag and 3 coordinates", NULL);
  write_text("g2.msh", V2_HEAD V2_NODES "$EndNodes\n$Elements\n8\n" V2_TETS
                                        "8 4 2 1 1 101 102 104 108 105\n$EndElements\n");
  mesh_refused("Gmsh v2: a fifth node on a tet", load("g2.msh"), ek_last_error(),
               "g2.msh:24:", "unexpected '105'", "element 8's tag and 4 nodes", NULL);
  write_text("g3.msh",
             V2_HEAD V2_NODES "$EndNodes\n$Elements\n7\n" V2_TETS "$EndElements trailing\n");
  mesh_refused("Gmsh v2: a word after $EndElements", load("g3.msh"), ek_last_error(),
               "g3.msh:24:", "unexpected 'trailing' after $EndElements", NULL, NULL);
  write_text("g4.msh", "$MeshFormat\n2.2 0 8 1\n$EndMeshFormat\n");
  mesh_refused("Gmsh: a fourth number on the format line", load("g4.msh"), ek_last_error(),
               "g4.msh:2:", "unexpected '1'", NULL, NULL);
  write_text("g5.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n"
                       "4\n0 0 0\n1 0 0 0\n0 1 0\n0 0 1\n$EndNodes\n");
  mesh_refused("Gmsh v4.1: a fourth number on a coordinate line", load("g5.msh"), ek_last_error(),
               "g5.msh:12:", "unexpected '0'", "3 coordinates", NULL);
  write_text("g6.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4 5\n");
  mesh_refused("Gmsh v4.1: a fifth number in the node header", load("g6.msh"), ek_last_error(),
               "g6.msh:5:", "unexpected '5'", "tag range", NULL);

  // OBJ: "v x y z", "v x y z w" and "v x y z r g b"; nothing else.
  write_text("w.obj", "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n");
  trimesh_loads("OBJ: v x y z w", load_tri("w.obj"));
  write_text("rgb.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n");
  trimesh_loads("OBJ: v x y z r g b (vertex colours)", load_tri("rgb.obj"));
  write_text("o1.obj", "v 0 0 0\nv 1 0 0 1 2\nv 0 1 0\nf 1 2 3\n");
  trimesh_refused("OBJ: 5 numbers on a v line", load_tri("o1.obj"), "o1.obj:2:", "5 numbers");
  write_text("o2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0 junk\nf 1 2 3\n");
  trimesh_refused("OBJ: a word after x y z", load_tri("o2.obj"), "o2.obj:3:", "unexpected 'junk'");
  write_text("o3.obj", "v 0 0 0 1 1 1 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  trimesh_refused("OBJ: 7 numbers on a v line", load_tri("o3.obj"),
                  "o3.obj:1:", "unexpected '1' after the vertex's x y z r g b");
}

// The line (from 1) of a file's text where `marker` begins.
static int line_of(const char *text, const char *marker) {
  const char *at = strstr(text, marker);
  int line = 1;
  for (const char *p = text; at && p < at; p++)
    line += *p == '\n';
  return at ? line : -1;
}

// A Gmsh file whose element line `bad` (its text, in `text`) is wrong for
// its type: refused at that line, saying how many node tags it has and how
// many its type has (Gmsh's element types: 15 point 1, 1 line 2, 2
// triangle 3, 4 tetrahedron 4).
static void gmsh_line_refused(const char *what, const char *name, const char *text, const char *bad,
                              long elem, int tags, int type, int nodes, int tri) {
  write_text(name, text);
  char want[256];
  snprintf(want, sizeof want, "%s:%d: element %ld has %d node tag%s; its type, %d, has %d node%s",
           name, line_of(text, bad), elem, tags, tags == 1 ? "" : "s", type, nodes,
           nodes == 1 ? "" : "s");
  if (tri)
    trimesh_refused(what, load_tri(name), want, NULL);
  else
    mesh_refused(what, load(name), ek_last_error(), want, NULL, NULL, NULL);
}

// Element lines of types the readers skip are checked against their type's
// node count (they were skipped unread: a point with 2 nodes loaded), and a
// type Gmsh does not define is refused at its line, never skipped.
static void gmsh_skipped_types(void) {
  printf("-- Gmsh: element types not kept\n");
  static const char ok[] = V2_HEAD V2_NODES "$EndNodes\n$Elements\n9\n8 1 2 0 1 101 102\n"
                                            "9 2 2 0 1 101 102 104\n" V2_TETS "$EndElements\n";
  write_text("gs1.msh", ok);
  mesh_loads("Gmsh v2: a line and a triangle beside the tets (skipped)", load("gs1.msh"), 6);
  static const char point2[] =
      V2_HEAD V2_NODES "$EndNodes\n$Elements\n8\n1 15 2 0 1 101 102\n" V2_TETS "$EndElements\n";
  // V2_TETS' own point line follows: the first one read is the bad one.
  gmsh_line_refused("Gmsh v2: a point (type 15) with 2 nodes", "gs2.msh", point2,
                    "1 15 2 0 1 101 102\n", 1, 2, 15, 1, 0);
  static const char tri2[] =
      V2_HEAD V2_NODES "$EndNodes\n$Elements\n8\n8 2 2 0 1 101 102\n" V2_TETS "$EndElements\n";
  gmsh_line_refused("Gmsh v2: a triangle (type 2) with 2 nodes", "gs3.msh", tri2,
                    "8 2 2 0 1 101 102\n", 8, 2, 2, 3, 0);
  static const char line3[] =
      V2_HEAD V2_NODES "$EndNodes\n$Elements\n8\n" V2_TETS "8 1 2 0 1 101 102 103\n$EndElements\n";
  gmsh_line_refused("Gmsh v2: a line (type 1) with 3 nodes, after the tets", "gs4.msh", line3,
                    "8 1 2 0 1 101 102 103\n", 8, 3, 1, 2, 0);
  char want[256];
  static const char unknown[] =
      V2_HEAD V2_NODES "$EndNodes\n$Elements\n8\n8 200 2 0 1 101\n" V2_TETS "$EndElements\n";
  write_text("gs5.msh", unknown);
  snprintf(want, sizeof want, "gs5.msh:%d: element type 200: not a Gmsh element type",
           line_of(unknown, "8 200"));
  mesh_refused("Gmsh v2: element type 200 (not Gmsh's)", load("gs5.msh"), ek_last_error(), want,
               NULL, NULL, NULL);
  static const char poly[] = V2_HEAD V2_NODES
      "$EndNodes\n$Elements\n8\n8 34 2 0 1 101 102 103 104\n" V2_TETS "$EndElements\n";
  write_text("gs6.msh", poly);
  snprintf(want, sizeof want, "gs6.msh:%d: element type 34: a polygon or polyhedron",
           line_of(poly, "8 34"));
  mesh_refused("Gmsh v2: a polygon (type 34, no fixed node count)", load("gs6.msh"),
               ek_last_error(), want, NULL, NULL, NULL);
  // v4.1: the type is the block's; one tet after a block of one point.
#define V41_TET_NODES                                                                              \
  "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n"     \
  "0 1 0\n0 0 1\n$EndNodes\n$Elements\n2 2 1 2\n"
  static const char v4ok[] = V41_TET_NODES "0 1 15 1\n1 1\n3 1 4 1\n2 1 2 3 4\n$EndElements\n";
  write_text("gs7.msh", v4ok);
  mesh_loads("Gmsh v4.1: a point block beside the tet (skipped)", load("gs7.msh"), 1);
  static const char v4pt[] = V41_TET_NODES "0 1 15 1\n1 1 2\n3 1 4 1\n2 1 2 3 4\n$EndElements\n";
  gmsh_line_refused("Gmsh v4.1: a point with 2 nodes", "gs8.msh", v4pt, "1 1 2\n", 1, 2, 15, 1, 0);
  static const char v4type[] = V41_TET_NODES "0 1 0 1\n1 1\n3 1 4 1\n2 1 2 3 4\n$EndElements\n";
  write_text("gs9.msh", v4type);
  snprintf(want, sizeof want, "gs9.msh:%d: element type 0: not a Gmsh element type",
           line_of(v4type, "0 1 0 1\n"));
  mesh_refused("Gmsh v4.1: a block of element type 0", load("gs9.msh"), ek_last_error(), want, NULL,
               NULL, NULL);
#undef V41_TET_NODES
  // The triangle reader: a tet line (skipped there) with 3 nodes.
  static const char tri_tet3[] = V2_HEAD V2_NODES "$EndNodes\n$Elements\n2\n1 4 2 0 1 101 102 "
                                                  "104\n2 2 2 0 1 101 102 103\n$EndElements\n";
  gmsh_line_refused("Gmsh v2 triangles: a tet (type 4) with 3 nodes", "gs10.msh", tri_tet3,
                    "1 4 2 0 1 101 102 104\n", 1, 3, 4, 4, 1);
}

// One triangle of size s: loads with the area s^2 / 2 (scale-free shape
// test; within EK_MESH_TOL) or is refused as outside the supported range,
// never as "degenerate", never loaded with an infinite area.
static void triangle_at(double s, int loads) {
  double X[9] = {0, 0, 0, s, 0, 0, 0, s, 0};
  int32_t T[3] = {0, 1, 2};
  char what[96], detail[1200];
  ek_trimesh *m = ek_trimesh_create(3, X, 1, T);
  double A = m ? ek_cloth_rest_areas(ek_trimesh_cloth(m))[0] : NAN;
  double rel = fabs(A / (0.5 * s * s) - 1);
  snprintf(what, sizeof what, "triangle of size %g: %s", s,
           loads ? "loads, area s^2 / 2" : "refused as out of range");
  snprintf(detail, sizeof detail, "area %g (relative error %.3g, budget %g) %s", A, rel,
           EK_MESH_TOL, ek_last_error());
  verdict(what,
          loads ? m && rel <= EK_MESH_TOL
                : !m && strstr(ek_last_error(), "outside the supported range") &&
                      !strstr(ek_last_error(), "degenerate") && !strstr(ek_last_error(), "inf") &&
                      printable(ek_last_error()),
          detail);
  ek_trimesh_destroy(m);
}

// The explicit limit of a 2x2x2 box of edge L and density rho.
static double box_cfl(double L, double rho) {
  ek_scene sc;
  if (ek_scene_parse("{" MESH ", " MAT ", " TAIL "}", "cfl.json", ".", &sc))
    return NAN;
  sc.density = rho;
  ek_mesh *m = ek_mesh_box(2, 2, 2, L, L, L);
  ek_sim *sim = m ? ek_sim_create(&sc, m) : NULL;
  double dt = sim ? ek_sim_cfl_dt(sim) : NAN;
  if (!sim)
    printf("  box %g, density %g: %s\n", L, rho, ek_last_error());
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
  return dt;
}

static void clusters_at(double L);

static void scales(void) {
  printf("-- extreme but valid scales\n");
  triangle_at(1e-70, 1);
  triangle_at(1e70, 1);
  triangle_at(1e100, 0);
  triangle_at(1e-100, 0);
  triangle_at(1e200, 0);
  // The CFL limit scales as length * sqrt(density / stiffness): scaling by
  // powers of two gives exactly the scaled limit (sim_core.c computes it
  // scale-free), and it is finite and > 0 at 1e+-100 and density 1e-300.
  double base = box_cfl(1, 1000);
  char detail[256];
  const int k = 330;
  double big = box_cfl(ldexp(1, k), 1000), small = box_cfl(ldexp(1, -k), 1000);
  double light = box_cfl(1, ldexp(1000, -2 * k));
  snprintf(detail, sizeof detail, "dt(1) %.17g, dt(2^%d) / 2^%d %.17g, dt(2^-%d) * 2^%d %.17g",
           base, k, k, ldexp(big, -k), k, k, ldexp(small, k));
  verdict("CFL of a box of edge 2^+-330: exactly scaled",
          isfinite(base) && base > 0 && big == ldexp(base, k) && small == ldexp(base, -k), detail);
  snprintf(detail, sizeof detail, "dt(rho 1000 * 2^-%d) %.17g = dt(rho 1000) * 2^-%d: %.17g", 2 * k,
           light, k, ldexp(base, -k));
  verdict("CFL at density 1000 * 2^-660: exactly scaled", light == ldexp(base, -k), detail);
  double d1 = box_cfl(1e100, 1000), d2 = box_cfl(1e-100, 1000), d3 = box_cfl(1, 1e-300);
  snprintf(detail, sizeof detail, "edge 1e100: %g, edge 1e-100: %g, density 1e-300: %g", d1, d2,
           d3);
  verdict("CFL finite and > 0 at 1e+-100 m and 1e-300 kg/m^3",
          isfinite(d1) && d1 > 0 && isfinite(d2) && d2 > 0 && isfinite(d3) && d3 > 0, detail);
  clusters_at(1);
  clusters_at(1e30);
  clusters_at(1e-30);
}

// XPBD clusters on a 2x2x2 box of edge L (f64): Q = sum m rbar rbar^T
// scales as L^5 here, its determinant as L^15, which overflows at 1e30 and
// underflows at 1e-30; the singularity test and the inverse are
// scale-free, so the clusters are built and two steps stay finite.
static void clusters_at(double L) {
  char json[1024];
  snprintf(json, sizeof json,
           "{\"mesh\": {\"box\": [2, 2, 2], \"size\": [%g, %g, %g]}, \"material\": "
           "{\"model\": \"stvk\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000}, "
           "\"precision\": \"f64\", \"dt\": 0.01, \"steps\": 2, \"integrator\": {\"type\": "
           "\"xpbd\", \"substeps\": 2, \"iterations\": 2, \"elements\": \"clusters\"}}",
           L, L, L);
  ek_scene sc;
  ek_mesh *m = NULL;
  ek_sim *sim = NULL;
  if (ek_scene_parse(json, "clusters.json", ".", &sc) == 0 && (m = ek_scene_mesh(&sc)))
    sim = ek_sim_create(&sc, m);
  char detail[1200], what[96];
  snprintf(detail, sizeof detail, "%s", sim ? "" : ek_last_error());
  int rc = sim ? ek_sim_step(sim) : -1;
  rc = rc == 0 ? ek_sim_step(sim) : rc;
  int finite = sim && rc == 0;
  for (size_t i = 0; finite && i < 3 * ek_mesh_nverts(m); i++)
    finite = isfinite(ek_sim_positions(sim)[i]);
  if (sim && !finite)
    snprintf(detail, sizeof detail, "rc %d: %s", rc, ek_last_error());
  snprintf(what, sizeof what, "XPBD clusters on a box of edge %g (f64): built, 2 finite steps", L);
  verdict(what, finite, detail);
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

// A run whose state goes non-finite fails at the step that made it, with a
// message naming a non-finite state (not inverted elements or an invertible
// model), and the state stays the last finite one.
static void nonfinite_run(const char *what, const char *json, const char *said, long at) {
  ek_scene sc;
  ek_mesh *m = NULL;
  ek_sim *sim = NULL;
  if (ek_scene_parse(json, "nan.json", ".", &sc) == 0 && (m = ek_scene_mesh(&sc)))
    sim = ek_sim_create(&sc, m);
  int rc = 0;
  long n = 0;
  for (; sim && n < 100 && (rc = ek_sim_step(sim)) == 0; n++) {
  }
  const char *msg = sim ? ek_last_error() : ek_last_error();
  int finite = sim != NULL;
  for (size_t i = 0; sim && i < 3 * ek_mesh_nverts(m); i++)
    finite = finite && isfinite(ek_sim_positions(sim)[i]) && isfinite(ek_sim_velocities(sim)[i]);
  // Where in the run, first: the failed step (counted from 1) and its
  // interval from the state it left as it was.
  char where[128] = "";
  if (sim)
    snprintf(where, sizeof where, "step %ld (t = %g s to %g s): ", n + 1, ek_sim_time(sim),
             ek_sim_time(sim) + sc.dt);
  char detail[1400];
  snprintf(detail, sizeof detail,
           "failed at step %ld, rc %d, state finite %d: %s (want it to begin '%s')", n + 1, rc,
           finite, msg, where);
  verdict(what,
          sim && rc != 0 && rc != EK_SIM_EINVERTED && finite && strstr(msg, said) &&
              !strstr(msg, "invertible") && ek_sim_steps_done(sim) == n &&
              (at == 0 || n + 1 == at) && strncmp(msg, where, strlen(where)) == 0,
          detail);
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

// Gravity 1e308 at dt 10 from rest: after the first step every free vertex
// falls to -inf. Each loop's message names where in the run (step 1, t = 0
// to 10 s) and the first such vertex, the first of the box not held by the
// pin at z = 0 (its rest position from the mesh), with its value (inf).
static void first_vertex_named(const char *loop, const char *integrator, const char *said) {
  char json[1024];
  snprintf(json, sizeof json,
           "{" MESH ", \"material\": {\"model\": \"stvk\", \"E\": 1e5, \"nu\": 0.3, "
           "\"density\": 1000}, \"integrator\": %s, " PIN ", \"gravity\": [0, 0, -1e308], "
           "\"dt\": 10, \"steps\": 1}",
           integrator);
  ek_scene sc;
  ek_mesh *m = NULL;
  ek_sim *sim = NULL;
  if (ek_scene_parse(json, "fall.json", ".", &sc) == 0 && (m = ek_scene_mesh(&sc)))
    sim = ek_sim_create(&sc, m);
  const int rc = sim ? ek_sim_step(sim) : -1;
  const char *msg = ek_last_error();
  size_t k = 0;
  const double *X = m ? ek_mesh_rest_positions(m) : NULL;
  while (X && k < ek_mesh_nverts(m) && !(X[3 * k + 2] > 0))
    k++;
  char want[256], what[128], detail[1400];
  snprintf(want, sizeof want, "step 1 (t = 0 s to 10 s): %s", said);
  char *v = strstr(want, "%zu");
  if (v) { // the vertex index in `said`
    char tail[256];
    snprintf(tail, sizeof tail, "%s", v + 3);
    snprintf(v, sizeof want - (size_t)(v - want), "%zu%s", k, tail);
  }
  snprintf(what, sizeof what, "%s: gravity 1e308 names step 1 and vertex %zu", loop, k);
  snprintf(detail, sizeof detail, "rc %d: '%s' (want it to begin '%s')", rc, msg, want);
  verdict(what, sim && rc != 0 && strncmp(msg, want, strlen(want)) == 0 && strstr(msg, "inf"),
          detail);
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
}

// The stop flag: read only, so a run with it installed gives the same bits;
// set, it ends a step of any length at the next check, state unchanged.
static void stop_flag(void) {
  printf("-- stop flag\n");
  static const char *json[2] = {
      "{" MESH ", \"material\": {\"model\": \"stvk\", \"E\": 1e5, \"nu\": 0.3, "
      "\"density\": 1000}, \"integrator\": {\"type\": \"xpbd\", \"substeps\": 3, "
      "\"iterations\": 150}, " PIN ", \"gravity\": [0, 0, -9.81], " TAIL "}",
      "{" MESH ", \"material\": {\"model\": \"fixed_corotated\", \"E\": 1e5, \"nu\": 0.3, "
      "\"density\": 1000}, \"integrator\": {\"type\": \"implicit\"}, " PIN ", \"gravity\": "
      "[0, 0, -9.81], \"dt\": 1e-2, \"steps\": 10}"};
  for (int j = 0; j < 2; j++) {
    ek_scene sc;
    ek_mesh *m = NULL;
    ek_sim *a = NULL, *b = NULL;
    if (ek_scene_parse(json[j], "stop.json", ".", &sc) == 0 && (m = ek_scene_mesh(&sc))) {
      a = ek_sim_create(&sc, m);
      b = ek_sim_create(&sc, m);
    }
    if (!a || !b) {
      verdict("stop flag: scene", 0, ek_last_error());
      ek_sim_destroy(a);
      ek_sim_destroy(b);
      ek_mesh_destroy(m);
      continue;
    }
    volatile sig_atomic_t flag = 0;
    ek_sim_set_stop_flag(b, &flag);
    int rc = 0;
    for (int n = 0; n < 2 && rc == 0; n++)
      rc = ek_sim_step(a) | ek_sim_step(b);
    const size_t n3 = 3 * ek_mesh_nverts(m);
    int same = rc == 0 &&
               memcmp(ek_sim_positions(a), ek_sim_positions(b), n3 * sizeof(double)) == 0 &&
               memcmp(ek_sim_velocities(a), ek_sim_velocities(b), n3 * sizeof(double)) == 0;
    char what[96], detail[700];
    snprintf(what, sizeof what, "%s: flag installed, unset: same bits", j ? "implicit" : "xpbd");
    snprintf(detail, sizeof detail, "rc %d, 2 steps, positions and velocities %s", rc,
             same ? "identical" : "DIFFER");
    verdict(what, same, detail);
    double *x = malloc(n3 * sizeof(double));
    memcpy(x, ek_sim_positions(b), n3 * sizeof(double));
    flag = SIGINT;
    rc = ek_sim_step(b);
    int kept =
        memcmp(x, ek_sim_positions(b), n3 * sizeof(double)) == 0 && ek_sim_steps_done(b) == 2;
    snprintf(what, sizeof what, "%s: flag set: step stopped, not applied", j ? "implicit" : "xpbd");
    snprintf(detail, sizeof detail, "rc %d (want %d), state kept %d: %s", rc, EK_SIM_ESTOPPED, kept,
             ek_last_error());
    char where[128];
    snprintf(where, sizeof where, "step 3 (t = %g s to %g s): stopped inside the step",
             ek_sim_time(b), ek_sim_time(b) + sc.dt);
    verdict(what,
            rc == EK_SIM_ESTOPPED && kept && strncmp(ek_last_error(), where, strlen(where)) == 0,
            detail);
    free(x);
    ek_sim_destroy(a);
    ek_sim_destroy(b);
    ek_mesh_destroy(m);
  }
}

static void faults(void) {
  frames_outputs();
  duplicates();
  scales();
  printf("-- non-finite state\n");
  nonfinite_run("dt = 1e3 (far above CFL): fails at the blow-up",
                "{" MESH ", \"material\": {\"model\": \"fixed_corotated\", \"E\": 1e5, "
                "\"nu\": 0.3, \"density\": 1000}, " PIN ", \"gravity\": [0, 0, -9.81], "
                "\"dt\": 1e3, \"steps\": 10}",
                "non-finite", 0);
  // Issue 26: a diverged explicit run read as "model ... is undefined
  // there"; the message must say the state blew up.
  nonfinite_run("fixed corotated at ~4x CFL: fails saying the state blew up",
                "{" MESH ", \"material\": {\"model\": \"fixed_corotated\", \"E\": 1e5, "
                "\"nu\": 0.3, \"density\": 1000}, " PIN ", \"gravity\": [0, 0, -9.81], "
                "\"dt\": 0.1, \"steps\": 100}",
                "blew up", 0);
  nonfinite_run("gravity 1e308: fails at the overflow",
                "{" MESH ", " MAT ", " PIN ", \"gravity\": [0, 0, -1e308], \"dt\": 1e-3, "
                "\"steps\": 10}",
                "non-finite", 0);
  nonfinite_run("gravity 1e308, dt 10: velocity inf after step 1",
                "{" MESH ", " MAT ", " PIN ", \"gravity\": [0, 0, -1e308], \"dt\": 10, "
                "\"steps\": 1}",
                "non-finite state after the step", 1);
  first_vertex_named("explicit", "{\"type\": \"explicit\"}",
                     "non-finite state after the step: vertex %zu has position (");
  first_vertex_named("xpbd", "{\"type\": \"xpbd\", \"substeps\": 2, \"iterations\": 2}",
                     "XPBD gave vertex %zu a non-finite position (");
  first_vertex_named("implicit", "{\"type\": \"implicit\"}",
                     "the objective is not finite at the start point: vertex %zu's inertia and "
                     "gravity term is inf");
  stop_flag();
  scene_refused("cloth thickness 1e300: refused naming the key",
                "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": {\"model\": "
                "\"stvk\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000}, \"cloth\": "
                "{\"thickness\": 1e300}, " TAIL "}",
                "cloth.thickness = 1e+300", "bending stiffness", "not finite");
  scene_refused("cloth thickness 1e306 (mass per area inf): refused naming the key",
                "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": {\"model\": "
                "\"stvk\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000}, \"cloth\": "
                "{\"thickness\": 1e306, \"bending_stiffness\": 1}, " TAIL "}",
                "cloth.thickness = 1e+306", "per unit area", "density h = inf");
}

// ---- batches

static void rc_is(const char *what, int rc, int want) {
  char detail[160];
  snprintf(detail, sizeof detail, "rc %d (want %d) %s", rc, want, rc < 0 ? ek_last_error() : "");
  verdict(what, rc == want, detail);
}

// Sentinels stay where nothing may be written.
static int untouched(const double *a, size_t n) {
  for (size_t i = 0; i < n; i++)
    if (a[i] != -7.0)
      return 0;
  return 1;
}

static void batches(void) {
  printf("-- batches\n");
  // Big enough for a real call on 20 matrices (+ an offset of one float).
  enum { N = 20 };
  double *buf = malloc((N * 81 + 8) * sizeof(double) * 4);
  float *fbuf = malloc((N * 81 + 8) * sizeof(float) * 4);
  double *A = buf, *U = buf + N * 81 + 8, *S = U + N * 81, *V = S + N * 81;
  float *Af = fbuf, *Uf = fbuf + N * 81 + 8, *Sf = Uf + N * 81, *Vf = Sf + N * 81;
  for (size_t i = 0; i < (N * 81 + 8) * 4; i++) {
    buf[i] = -7.0;
    fbuf[i] = -7.0f;
  }
  ek_material mat = {.model = EK_MODEL_FIXED_COROTATED, .mu = 1, .lambda = 1};
  ek_material_op ops[] = {EK_MAT_ENERGY, EK_MAT_PK1, EK_MAT_PK1_DIFF, EK_MAT_HESSIAN};
  const size_t huge[] = {SIZE_MAX, SIZE_MAX / 2, SIZE_MAX / 9 + 1};
  for (int h = 0; h < 3; h++) {
    size_t n = huge[h];
    char what[96];
#define HUGE_CASE(name, call)                                                                      \
  do {                                                                                             \
    snprintf(what, sizeof what, "%s, n = %zu", name, n);                                           \
    rc_is(what, call, EK_EINVAL);                                                                  \
  } while (0)
    HUGE_CASE("ek_svd3_f64", ek_svd3_f64(n, A, U, S, V, NULL));
    HUGE_CASE("ek_svd3_f32", ek_svd3_f32(n, Af, Uf, Sf, Vf, NULL));
    HUGE_CASE("ek_svd3_aosoa_f64", ek_svd3_aosoa_f64(n, A, U, S, V, NULL));
    HUGE_CASE("ek_svd3_aosoa_f32", ek_svd3_aosoa_f32(n, Af, Uf, Sf, Vf, NULL));
    HUGE_CASE("ek_polar3_f64", ek_polar3_f64(n, A, U, S, NULL));
    HUGE_CASE("ek_polar3_f32", ek_polar3_f32(n, Af, Uf, Sf, NULL));
    HUGE_CASE("ek_polar3_aosoa_f64", ek_polar3_aosoa_f64(n, A, U, S, NULL));
    HUGE_CASE("ek_polar3_aosoa_f32", ek_polar3_aosoa_f32(n, Af, Uf, Sf, NULL));
    HUGE_CASE("ek_pk1_f64", ek_pk1_f64(&mat, n, A, NULL, U));
    HUGE_CASE("ek_pk1_f32", ek_pk1_f32(&mat, n, Af, NULL, Uf));
    HUGE_CASE("ek_pk1_diff_f64", ek_pk1_diff_f64(&mat, n, A, NULL, S, U, 1));
    HUGE_CASE("ek_pk1_hessian_f32", ek_pk1_hessian_f32(&mat, n, Af, NULL, Uf, 0));
    HUGE_CASE("ek_energy_f64", ek_energy_f64(&mat, n, A, NULL, U));
    HUGE_CASE("ek_pk1_aosoa_f64", ek_pk1_aosoa_f64(&mat, n, A, NULL, U));
    HUGE_CASE("ek_pk1_diff_aosoa_f32", ek_pk1_diff_aosoa_f32(&mat, n, Af, NULL, Sf, Uf, 0));
    for (int o = 0; o < 4; o++) {
      HUGE_CASE("ek_material_eval_f64",
                ek_material_eval_f64(&mat, ops[o], EK_ISA_AUTO, n, A, NULL, S, U, 0));
      HUGE_CASE("ek_material_eval_aosoa_f32",
                ek_material_eval_aosoa_f32(&mat, ops[o], EK_ISA_AUTO, n, Af, NULL, Sf, Uf, 0));
    }
    HUGE_CASE("ek_tri_rest_f64", ek_tri_rest_f64(n, A, U, S));
    HUGE_CASE("ek_tri_deformation_f64", ek_tri_deformation_f64(n, A, S, U));
    HUGE_CASE("ek_tri_deformation_aosoa_f32", ek_tri_deformation_aosoa_f32(n, Af, Sf, Uf, NULL));
    HUGE_CASE("ek_polar32_f32", ek_polar32_f32(n, Af, Uf, Sf));
    HUGE_CASE("ek_polar32_aosoa_f64", ek_polar32_aosoa_f64(n, A, U, S, NULL));
    HUGE_CASE("ek_tri_velocity_gradient_f64",
              ek_tri_velocity_gradient_f64(n, A, S, U, NULL, NULL, NULL));
    HUGE_CASE("ek_kabsch_f64", ek_kabsch_f64(n, (const size_t *)(void *)A, A, S, NULL, U));
    HUGE_CASE("ek_aosoa_pack_f64", ek_aosoa_pack_f64(n, 9, A, U));
    HUGE_CASE("ek_aosoa_unpack_f32", ek_aosoa_unpack_f32(n, 9, Af, Uf));
#undef HUGE_CASE
  }
  verdict("nothing written by the refused calls", untouched(U, (N * 81) * 3), "");
  {
    double *p = ek_aosoa_alloc_f64(SIZE_MAX, 9);
    verdict("ek_aosoa_alloc_f64(SIZE_MAX): NULL", p == NULL, "");
    ek_free(p);
    verdict("ek_aosoa_size_f64(SIZE_MAX, 9): 0 (no such batch)",
            ek_aosoa_size_f64(SIZE_MAX, 9) == 0, "");
    verdict("ek_aosoa_blocks_f64(SIZE_MAX) = SIZE_MAX / 8 + 1",
            ek_aosoa_blocks_f64(SIZE_MAX) == SIZE_MAX / 8 + 1, "");
    void *q = ek_alloc(SIZE_MAX);
    verdict("ek_alloc(SIZE_MAX): NULL", q == NULL, "");
    ek_free(q);
  }

  // Alignment: a double array at a 4-byte offset, a float array at 2.
  {
    char *raw = malloc(N * 9 * sizeof(double) + 64);
    double *mis = (double *)(void *)(raw + 4); // never dereferenced by the test
    float *misf = (float *)(void *)(raw + 2);
    rc_is("ek_svd3_f64, A at a 4-byte offset", ek_svd3_f64(N, mis, U, S, V, NULL), EK_EINVAL);
    rc_is("ek_svd3_f64, S at a 4-byte offset", ek_svd3_f64(N, A, U, mis, V, NULL), EK_EINVAL);
    rc_is("ek_svd3_f32, A at a 2-byte offset", ek_svd3_f32(N, misf, Uf, Sf, Vf, NULL), EK_EINVAL);
    rc_is("ek_pk1_f64, F at a 4-byte offset", ek_pk1_f64(&mat, N, mis, NULL, U), EK_EINVAL);
    rc_is("ek_pk1_f64, P at a 4-byte offset", ek_pk1_f64(&mat, N, A, NULL, mis), EK_EINVAL);
    rc_is("ek_pk1_aosoa_f64, F at a 4-byte offset", ek_pk1_aosoa_f64(&mat, 1, mis, NULL, U),
          EK_EINVAL);
    rc_is("ek_aosoa_pack_f64, AoS at a 4-byte offset", ek_aosoa_pack_f64(N, 9, mis, U), EK_EINVAL);
    rc_is("ek_aosoa_unpack_f32, AoS at a 2-byte offset", ek_aosoa_unpack_f32(N, 9, Uf, misf),
          EK_EINVAL);
    verdict("nothing written by the refused calls", untouched(U, (N * 81) * 3), "");
    free(raw);
  }
  // Element-aligned, not 64-byte aligned: supported, same bits as aligned.
  {
    double *F64 = ek_alloc(N * 9 * sizeof(double)), *P64 = ek_alloc(N * 9 * sizeof(double));
    double *Fodd = buf + 1, *Podd = U + 1; // 8-byte aligned, not 16
    ek_rng rng;
    ek_rng_seed(&rng, 14);
    for (int i = 0; i < N * 9; i++)
      F64[i] = Fodd[i] = (i % 4 == 0) + 0.3 * (2 * ek_rng_uniform(&rng) - 1);
    int rc1 = ek_pk1_f64(&mat, N, F64, NULL, P64), rc2 = ek_pk1_f64(&mat, N, Fodd, NULL, Podd);
    int same = rc1 == 0 && rc2 == 0 && memcmp(P64, Podd, N * 9 * sizeof(double)) == 0;
    verdict("ek_pk1_f64 on 8-byte aligned arrays: same bits", same, "");
    rc1 = ek_svd3_f64(N, F64, NULL, P64, NULL, NULL);
    rc2 = ek_svd3_f64(N, Fodd, NULL, Podd, NULL, NULL);
    same = rc1 == 0 && rc2 == 0 && memcmp(P64, Podd, N * 3 * sizeof(double)) == 0;
    verdict("ek_svd3_f64 on 8-byte aligned arrays: same bits", same, "");
    ek_free(F64);
    ek_free(P64);
  }
  free(buf);
  free(fbuf);
}

static void remove_tree(void) {
  static const char *names[] = {"huge.node",    "huge.ele",       "edge.msh",      "count.node",
                                "count.ele",    "count_ele.node", "count_ele.ele", "count_v2.msh",
                                "count_v4.msh", "count_el.msh",   "nul.node",      "nul.ele",
                                "bytes.node",   "bytes.ele",      "bytes.msh",     "nul.json",
                                "dirmesh.json", "out_fifo.h5",    "out_link.h5",   "target.txt",
                                "dup.node",     "dup.ele",        "dup.obj",       "blocks.msh",
                                "blocks2.msh",  "other.vtk"};
  char path[512];
  for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
    snprintf(path, sizeof path, "%s/%s", tmp_dir, names[i]);
    remove(path);
  }
  snprintf(path, sizeof path, "%s/dir.msh", tmp_dir);
  rmdir(path);
  snprintf(path, sizeof path, "%s/dir.node", tmp_dir);
  rmdir(path);
  const char *dirs[] = {"out_dir.h5", "out_scratch.h5.scratch"};
  for (size_t i = 0; i < 2; i++) {
    snprintf(path, sizeof path, "%s/%s", tmp_dir, dirs[i]);
    rmdir(path);
  }
  rmdir(tmp_dir);
}

int main(int argc, char **argv) {
  ek_cli_test_args(argc, argv, 1, NULL); // deterministic: the seed is unused
  const char *base = getenv("TMPDIR");
  snprintf(tmp_dir, sizeof tmp_dir, "%s/ek_bad_input_XXXXXX", base && base[0] ? base : "/tmp");
  if (!mkdtemp(tmp_dir)) {
    perror("mkdtemp");
    return 2;
  }
  meshes();
  extra_tokens();
  gmsh_skipped_types();
  scenes();
  faults();
  batches();
  remove_tree();
  printf("test_bad_input: %s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures ? 1 : 0;
}
