// Triangle meshes (include/ek/sim/trimesh.h): the OBJ and Gmsh 2D readers, the
// grid, and their errors:
//   a. OBJ: triangles, quads (fan-triangulated), "i/t/n" index forms,
//      negative (relative) indices, comments and ignored statements; unused
//      vertices dropped;
//   b. Gmsh v2 and v4.1 ASCII: 3-node triangles kept, other elements
//      skipped, node tags mapped;
//   c. the grid: counts, area, both planes;
//   d. errors name file:line and the value: bad numbers, index 0 or out of
//      range, short faces, a zero-area triangle, truncated files, counts
//      that the data does not match, undefined nodes; nothing half-loads.
#include <ek/sim/trimesh.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
static int failures = 0;

static void check(const char *what, int ok, const char *detail) {
  printf("%-60s %s  %s\n", what, ok ? "PASS" : "FAIL", detail ? detail : "");
  if (!ok)
    failures++;
}

static char dir[256];

static const char *write_file(const char *name, const char *text) {
  static char path[512];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  FILE *f = fopen(path, "w");
  fputs(text, f);
  fclose(f);
  return path;
}

static double total_area(const ek_trimesh *m) {
  const double *A = ek_cloth_rest_areas(ek_trimesh_cloth(m));
  double s = 0;
  for (size_t t = 0; t < ek_trimesh_ntris(m); ++t)
    s += A[t];
  return s;
}

// Load `text` as `name`: expect failure with every string of `want` in the
// message.
static void expect_error(const char *what, const char *name, const char *text,
                         const char *const *want) {
  const char *path = write_file(name, text);
  ek_trimesh *m = ek_trimesh_load(path);
  int ok = m == NULL && ek_last_error()[0];
  for (int i = 0; want[i] && ok; ++i)
    ok = strstr(ek_last_error(), want[i]) != NULL;
  check(what, ok, ek_last_error());
  ek_trimesh_destroy(m);
}

int main(int argc, char **argv) {
  ek_cli_test_args(argc, argv, 1, NULL); // deterministic: the seed is unused
  snprintf(dir, sizeof dir, "/tmp/ek_test_trimesh_%ld", (long)getpid());
  char cmd[300];
  snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
  if (system(cmd) != 0)
    return 1;
  char detail[1100];

  // a. OBJ: a unit square as one quad (fan: 2 triangles) plus a triangle
  // on top written with relative indices and slashes; vertex 7 unused.
  const char *obj = "# a test\nmtllib x.mtl\no square\n"
                    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                    "vt 0 0\nvn 0 0 1\n"
                    "f 1/1/1 2/1/1 3//1 4\n"
                    "v 0.5 2 0\nv 9 9 9\n"
                    "s off\ng top\n"
                    "f -2/1 3 4 # relative: vertex 5\n"
                    "l 1 2\n";
  ek_trimesh *m = ek_trimesh_load(write_file("a.obj", obj));
  snprintf(detail, sizeof detail, "%s", m ? "" : ek_last_error());
  check("a. OBJ loads", m != NULL, detail);
  if (m) {
    snprintf(detail, sizeof detail, "%zu vertices, %zu triangles, area %g", ek_trimesh_nverts(m),
             ek_trimesh_ntris(m), total_area(m));
    check("a. OBJ: quad fan-triangulated, relative index, unused vertex dropped",
          ek_trimesh_nverts(m) == 5 && ek_trimesh_ntris(m) == 3 &&
              fabs(total_area(m) - 1.5) < 1e-15,
          detail);
    const int32_t *T = ek_trimesh_tris(m);
    check("a. OBJ: fan from the first vertex, order kept",
          T[0] == 0 && T[1] == 1 && T[2] == 2 && T[3] == 0 && T[4] == 2 && T[5] == 3 && T[6] == 4 &&
              T[7] == 2 && T[8] == 3,
          NULL);
    check("a. OBJ: hinges at the two shared edges", ek_cloth_nhinges(ek_trimesh_cloth(m)) == 2,
          NULL);
  }
  ek_trimesh_destroy(m);

  // b. Gmsh v2: 4 nodes with sparse tags, a line element (skipped), 2 triangles.
  const char *v2 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n"
                   "10 0 0 0\n20 1 0 0\n30 1 1 0\n40 0 1 0\n$EndNodes\n"
                   "$Elements\n3\n1 1 2 0 1 10 20\n2 2 2 0 1 10 20 30\n3 2 2 0 1 10 30 40\n"
                   "$EndElements\n";
  m = ek_trimesh_load(write_file("b2.msh", v2));
  snprintf(detail, sizeof detail, "%s", m ? "" : ek_last_error());
  check("b. Gmsh v2 loads (line element skipped)",
        m && ek_trimesh_ntris(m) == 2 && ek_trimesh_nverts(m) == 4 &&
            fabs(total_area(m) - 1) < 1e-15,
        detail);
  ek_trimesh_destroy(m);
  const char *v4 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                   "$Nodes\n2 4 1 4\n0 1 0 1\n1\n0 0 0\n2 1 0 3\n2\n3\n4\n1 0 0\n1 1 0\n0 1 0\n"
                   "$EndNodes\n$Elements\n2 3 1 3\n1 1 1 1\n1 1 2\n2 1 2 2\n2 1 2 3\n3 1 3 4\n"
                   "$EndElements\n";
  m = ek_trimesh_load(write_file("b4.msh", v4));
  snprintf(detail, sizeof detail, "%s", m ? "" : ek_last_error());
  check("b. Gmsh v4.1 loads (blocks, line block skipped)",
        m && ek_trimesh_ntris(m) == 2 && ek_trimesh_nverts(m) == 4 &&
            fabs(total_area(m) - 1) < 1e-15,
        detail);
  ek_trimesh_destroy(m);

  // c. the grid.
  m = ek_trimesh_grid(4, 3, 2.0, 1.5, "xz");
  check("c. grid 4 x 3: 20 vertices, 24 triangles, area 3, in y = 0",
        m && ek_trimesh_nverts(m) == 20 && ek_trimesh_ntris(m) == 24 &&
            fabs(total_area(m) - 3) < 1e-14 && ek_trimesh_rest_positions(m)[3 * 19 + 1] == 0 &&
            ek_trimesh_rest_positions(m)[3 * 19 + 2] == 1.5,
        m ? "" : ek_last_error());
  ek_trimesh_destroy(m);
  m = ek_trimesh_grid(4, 3, 2.0, 1.5, "yz");
  check("c. grid: plane \"yz\" refused", m == NULL && strstr(ek_last_error(), "yz"),
        ek_last_error());
  m = ek_trimesh_grid(0, 3, 2.0, 1.5, "xy");
  check("c. grid: 0 cells refused", m == NULL && ek_last_error()[0], ek_last_error());

  // d. errors.
  expect_error("d. OBJ bad number names file:line and value", "d1.obj", "v 0 0 0\nv 1 zero 0\n",
               (const char *const[]){"d1.obj:2", "'zero'", NULL});
  expect_error("d. OBJ index 0 refused", "d2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
               (const char *const[]){"d2.obj:4", "index 0", NULL});
  expect_error("d. OBJ index beyond the vertices so far", "d3.obj",
               "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n",
               (const char *const[]){"d3.obj:3", "index 3", NULL});
  expect_error("d. OBJ relative index before the first vertex", "d4.obj",
               "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
               (const char *const[]){"d4.obj:4", "-4", NULL});
  expect_error("d. OBJ face with 2 vertices", "d5.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n",
               (const char *const[]){"d5.obj:3", "2 vertices", NULL});
  expect_error("d. OBJ zero-area triangle named with its line", "d6.obj",
               "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
               (const char *const[]){"d6.obj:6", "triangle 1", "zero-area", NULL});
  expect_error("d. OBJ repeated vertex in a face", "d7.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n",
               (const char *const[]){"d7.obj:4", "repeats", NULL});
  expect_error("d. OBJ non-finite coordinate", "d8.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
               (const char *const[]){"d8.obj:2", "not finite", NULL});
  expect_error("d. OBJ without faces", "d9.obj", "v 0 0 0\n",
               (const char *const[]){"d9.obj", "no triangles", NULL});
  expect_error("d. Gmsh: fewer nodes than declared (truncated)", "e1.msh",
               "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n",
               (const char *const[]){"e1.msh:7", "truncated", NULL});
  expect_error("d. Gmsh: undefined node", "e2.msh",
               "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"
               "$EndNodes\n$Elements\n1\n1 2 0 1 2 9\n$EndElements\n",
               (const char *const[]){"e2.msh:12", "node tag 9", NULL});
  expect_error("d. Gmsh: v4 block larger than declared", "e3.msh",
               "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 3\n2 1 0 5\n",
               (const char *const[]){"e3.msh:6", "block of 5 nodes", NULL});
  expect_error("d. Gmsh: no triangles", "e4.msh",
               "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 0 0\n"
               "$EndNodes\n$Elements\n1\n1 1 0 1 2\n$EndElements\n",
               (const char *const[]){"e4.msh", "no 3-node triangles", NULL});
  expect_error("d. Gmsh: binary refused", "e5.msh", "$MeshFormat\n4.1 1 8\n",
               (const char *const[]){"e5.msh:2", "ASCII", NULL});
  expect_error("d. unknown extension", "f.stl", "solid\n",
               (const char *const[]){"f.stl", "unknown", NULL});
  m = ek_trimesh_load("/nonexistent/x.obj");
  check("d. missing file names the path",
        m == NULL && strstr(ek_last_error(), "/nonexistent/x.obj"), ek_last_error());

  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0)
    printf("could not remove %s\n", dir);
  printf("%s (%d failures)\n", failures ? "FAIL" : "PASS", failures);
  return failures != 0;
}
