// Invariant: every shipped scene (scenes/*.json) parses into the values its
// file states, and every kind of bad scene is refused (rc < 0, nothing
// half-built) with a message that names the file, the line and column of
// the offending value (of an unknown key; of the object a required key is
// missing from), the key path and the value; unknown keys are errors, never
// silently ignored.
#include <ek/sim/sim.h>

#include "cli.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

static void verdict(const char *what, int ok, const char *detail) {
  printf("%-44s %s  %s\n", what, ok ? "PASS" : "FAIL", detail);
  if (!ok)
    failures++;
}

// Scenes live in ../scenes relative to this file (CMake compiles with an
// absolute __FILE__); --scenes DIR overrides.
static char scenes_dir[1024];

#define MESH "\"mesh\": {\"box\": [2, 2, 2], \"size\": [1, 1, 1]}"
#define MAT                                                                                        \
  "\"material\": {\"model\": \"fixed_corotated\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000}"
#define TAIL "\"dt\": 1e-4, \"steps\": 10"

typedef struct {
  const char *what;
  const char *json;
  const char *expect[3]; // substrings the message must contain
} bad_case;

static const bad_case bad_cases[] = {
    {"Poisson ratio 0.5",
     "{" MESH
     ", \"material\": {\"model\": \"arap\", \"E\": 1e5, \"nu\": 0.5, \"density\": 1}, " TAIL "}",
     {"material.nu = 0.5", "Poisson ratio must be < 0.5"}},
    {"Poisson ratio -1",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1e5, \"nu\": -1, \"density\": 1}, " TAIL
     "}",
     {"material.nu = -1", "> -1"}},
    {"negative Young's modulus",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": -1, \"nu\": 0.3, \"density\": 1}, " TAIL
     "}",
     {"material.E = -1", "must be > 0"}},
    {"E and mu mixed",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1, \"mu\": 1, \"density\": 1}, " TAIL
     "}",
     {"material.E = 1", "not a mix"}},
    {"lambda <= -2 mu / 3",
     "{" MESH
     ", \"material\": {\"model\": \"arap\", \"mu\": 3, \"lambda\": -2, \"density\": 1}, " TAIL "}",
     {"material.lambda = -2", "-2 mu / 3"}},
    {"mu <= 0",
     "{" MESH
     ", \"material\": {\"model\": \"arap\", \"mu\": 0, \"lambda\": 1, \"density\": 1}, " TAIL "}",
     {"material.mu = 0", "> 0"}},
    {"unknown model",
     "{" MESH ", \"material\": {\"model\": \"neo\", \"E\": 1, \"nu\": 0.3, \"density\": 1}, " TAIL
     "}",
     {"material.model = \"neo\"", "unknown model", "stable_neo_hookean"}},
    {"missing density",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1, \"nu\": 0.3}, " TAIL "}",
     {"material.density", "missing"}},
    {"negative density",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1, \"nu\": 0.3, \"density\": -5}, " TAIL
     "}",
     {"material.density = -5", "> 0"}},
    {"clamp out of range",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1, \"nu\": 0.3, \"density\": 1, "
     "\"clamp\": 1.5}, " TAIL "}",
     {"material.clamp = 1.5"}},
    {"unknown material key",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"E\": 1, \"nu\": 0.3, \"densty\": 1}, " TAIL
     "}",
     {"material.densty = 1", "unknown key"}},
    {"unknown top-level key",
     "{" MESH ", " MAT ", " TAIL ", \"gravty\": [0, 0, -9.81]}",
     {"gravty = [0,0,-9.81]", "unknown key", "gravity"}},
    {"missing material", "{" MESH ", " TAIL "}", {"material", "missing"}},
    {"missing dt", "{" MESH ", " MAT ", \"steps\": 10}", {"dt", "missing"}},
    {"zero dt", "{" MESH ", " MAT ", \"dt\": 0, \"steps\": 10}", {"dt = 0", "> 0"}},
    {"fractional steps",
     "{" MESH ", " MAT ", \"dt\": 1e-4, \"steps\": 1.5}",
     {"steps = 1.5", "whole"}},
    {"string where a number goes",
     "{" MESH ", " MAT ", \"dt\": \"fast\", \"steps\": 1}",
     {"dt = \"fast\"", "number"}},
    {"mesh file and box",
     "{\"mesh\": {\"file\": \"a.node\", \"box\": [1, 1, 1], \"size\": [1, 1, 1]}, " MAT ", " TAIL
     "}",
     {"mesh.box = [1,1,1]", "either"}},
    {"mesh without file or box",
     "{\"mesh\": {}, " MAT ", " TAIL "}",
     {"mesh.file or mesh.box", "missing"}},
    {"zero box cells",
     "{\"mesh\": {\"box\": [2, 0, 2], \"size\": [1, 1, 1]}, " MAT ", " TAIL "}",
     {"mesh.box[1] = 0", "whole number"}},
    {"negative box size",
     "{\"mesh\": {\"box\": [2, 2, 2], \"size\": [1, -1, 1]}, " MAT ", " TAIL "}",
     {"mesh.size[1] = -1", "> 0"}},
    {"box with 2 entries",
     "{\"mesh\": {\"box\": [2, 2], \"size\": [1, 1, 1]}, " MAT ", " TAIL "}",
     {"mesh.box = [2,2]", "3 numbers"}},
    {"bad precision",
     "{" MESH ", " MAT ", " TAIL ", \"precision\": \"f16\"}",
     {"precision = \"f16\"", "f32"}},
    {"bad isa", "{" MESH ", " MAT ", " TAIL ", \"isa\": \"sse\"}", {"isa = \"sse\""}},
    {"bad scatter",
     "{" MESH ", " MAT ", " TAIL ", \"scatter\": \"magic\"}",
     {"scatter = \"magic\"", "colored"}},
    {"bad polar",
     "{" MESH ", " MAT ", " TAIL ", \"polar\": \"exact\"}",
     {"polar = \"exact\"", "\"svd\" or \"warm\""}},
    {"svd sweeps out of range",
     "{" MESH ", " MAT ", " TAIL ", \"svd\": {\"sweeps\": 9}}",
     {"svd.sweeps = 9", "[0, 8]"}},
    {"bad rsqrt",
     "{" MESH ", " MAT ", " TAIL ", \"svd\": {\"rsqrt\": \"fast\"}}",
     {"svd.rsqrt = \"fast\""}},
    {"gravity with 2 entries",
     "{" MESH ", " MAT ", " TAIL ", \"gravity\": [0, -9.81]}",
     {"gravity = [0,-9.81]", "3 numbers"}},
    {"negative damping", "{" MESH ", " MAT ", " TAIL ", \"damping\": -1}", {"damping = -1"}},
    {"ground without height",
     "{" MESH ", " MAT ", " TAIL ", \"ground\": {}}",
     {"ground.height", "missing"}},
    {"unknown ground key",
     "{" MESH ", " MAT ", " TAIL ", \"ground\": {\"height\": 0, \"friction\": 0.5}}",
     {"ground.friction = 0.5", "unknown key"}},
    {"unknown boundary type",
     "{" MESH ", " MAT ", " TAIL
     ", \"boundary\": [{\"type\": \"glue\", \"region\": {\"min\": [0,0,0], \"max\": [1,1,0]}}]}",
     {"boundary[0].type = \"glue\""}},
    {"region min > max",
     "{" MESH ", " MAT ", " TAIL
     ", \"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": [0,0,1], \"max\": [1,1,0]}}]}",
     {"boundary[0].region.max[2] = 0", "min[2]"}},
    {"region missing",
     "{" MESH ", " MAT ", " TAIL ", \"boundary\": [{\"type\": \"pin\"}]}",
     {"boundary[0].region", "missing"}},
    {"twist with zero axis",
     "{" MESH ", " MAT ", " TAIL
     ", \"boundary\": [{\"type\": \"pin\", \"region\": {\"min\": [0,0,0], \"max\": [1,1,0]}}, "
     "{\"type\": \"twist\", \"axis\": [0,0,0], \"center\": [0,0,0], \"rate\": 1, \"region\": "
     "{\"min\": [0,0,1], \"max\": [1,1,1]}}]}",
     {"boundary[1].axis = [0,0,0]", "non-zero"}},
    {"twist without rate",
     "{" MESH ", " MAT ", " TAIL
     ", \"boundary\": [{\"type\": \"twist\", \"axis\": [1,0,0], \"center\": [0,0,0], "
     "\"region\": {\"min\": [0,0,1], \"max\": [1,1,1]}}]}",
     {"boundary[0].rate", "missing"}},
    {"pin with a velocity",
     "{" MESH ", " MAT ", " TAIL ", \"boundary\": [{\"type\": \"pin\", \"velocity\": [0,0,1], "
     "\"region\": {\"min\": [0,0,1], \"max\": [1,1,1]}}]}",
     {"boundary[0].velocity = [0,0,1]", "unknown key"}},
    {"release without until",
     "{" MESH ", " MAT ", " TAIL
     ", \"boundary\": [{\"type\": \"stretch\", \"velocity\": [0,0,1], \"release\": true, "
     "\"region\": {\"min\": [0,0,1], \"max\": [1,1,1]}}]}",
     {"boundary[0].release = true", "until"}},
    {"boundary not an array",
     "{" MESH ", " MAT ", " TAIL ", \"boundary\": {\"type\": \"pin\"}}",
     {"boundary = {\"type\":\"pin\"}", "array"}},
    {"output every 0",
     "{" MESH ", " MAT ", " TAIL ", \"output\": {\"file\": \"a.h5\", \"every\": 0}}",
     {"output.every = 0"}},
    {"output without file",
     "{" MESH ", " MAT ", " TAIL ", \"output\": {\"every\": 2}}",
     {"output.file", "missing"}},
    {"initial scale 0",
     "{" MESH ", " MAT ", " TAIL ", \"initial\": {\"scale\": [1, 0, 1]}}",
     {"initial.scale[1] = 0", "> 0"}},
    {"unknown integrator",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"rk4\"}}",
     {"integrator.type = \"rk4\"", "unknown integrator", "explicit"}},
    {"integrator without type",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {}}",
     {"integrator.type", "missing"}},
    {"integrator not an object",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": \"explicit\"}",
     {"integrator = \"explicit\"", "object"}},
    {"unknown integrator key",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"explicit\", \"substeps\": 2}}",
     {"integrator.substeps = 2", "unknown key"}},
    {"explicit with an implicit key",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"explicit\", \"cg_tol\": 0.1}}",
     {"integrator.cg_tol = 0.1", "unknown key"}},
    {"implicit cg_tol 1.5",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"implicit\", \"cg_tol\": 1.5}}",
     {"integrator.cg_tol = 1.5", "(0, 1)"}},
    {"implicit newton_tol 0",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"implicit\", \"newton_tol\": 0}}",
     {"integrator.newton_tol = 0", "> 0"}},
    {"implicit max_cg 2.5",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"implicit\", \"max_cg\": 2.5}}",
     {"integrator.max_cg = 2.5", "whole number"}},
    {"unknown preconditioner",
     "{" MESH ", " MAT ", " TAIL
     ", \"integrator\": {\"type\": \"implicit\", \"preconditioner\": \"ilu\"}}",
     {"integrator.preconditioner = \"ilu\"", "jacobi, block_jacobi"}},
    {"unknown projection",
     "{" MESH ", " MAT ", " TAIL
     ", \"integrator\": {\"type\": \"implicit\", \"projection\": \"flip\"}}",
     {"integrator.projection = \"flip\"", "clamp, abs"}},
    // The paths above cover every kind of error; these the rest of the keys.
    {"missing mesh", "{" MAT ", " TAIL "}", {"mesh", "missing"}},
    {"mesh not an object", "{\"mesh\": [1], " MAT ", " TAIL "}", {"mesh = [1]", "object"}},
    {"unknown mesh kind",
     "{\"mesh\": {\"file\": \"a.node\", \"kind\": \"hexes\"}, " MAT ", " TAIL "}",
     {"mesh.kind = \"hexes\"", "\"tets\" or \"triangles\""}},
    {"mesh kind without a file",
     "{\"mesh\": {\"box\": [1, 1, 1], \"size\": [1, 1, 1], \"kind\": \"tets\"}, " MAT ", " TAIL "}",
     {"mesh.kind = \"tets\"", "only meaningful"}},
    {"an .obj file as tets",
     "{\"mesh\": {\"file\": \"a.obj\", \"kind\": \"tets\"}, " MAT ", " TAIL "}",
     {"mesh.kind = \"tets\"", "holds triangles"}},
    {"mesh size with a file",
     "{\"mesh\": {\"file\": \"a.node\", \"size\": [1, 1, 1]}, " MAT ", " TAIL "}",
     {"mesh.size = [1,1,1]", "only meaningful"}},
    {"mesh plane without a grid",
     "{\"mesh\": {\"box\": [1, 1, 1], \"size\": [1, 1, 1], \"plane\": \"xy\"}, " MAT ", " TAIL "}",
     {"mesh.plane = \"xy\"", "only meaningful"}},
    {"grid of 0 cells",
     "{\"mesh\": {\"grid\": [0, 2], \"size\": [1, 1]}, " MAT ", " TAIL "}",
     {"mesh.grid[0] = 0", "[1, 8192]"}},
    {"grid plane yz",
     "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1], \"plane\": \"yz\"}, \"material\": "
     "{\"model\": \"stvk\", \"E\": 1, \"nu\": 0.3, \"density\": 1}, \"cloth\": {\"thickness\": "
     "0.001}, " TAIL "}",
     {"mesh.plane = \"yz\"", "\"xy\" or \"xz\""}},
    {"grid size 0",
     "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 0]}, " MAT ", " TAIL "}",
     {"mesh.size[1] = 0", "> 0"}},
    {"cloth with tets",
     "{" MESH ", " MAT ", " TAIL ", \"cloth\": {\"thickness\": 0.001}}",
     {"cloth = {\"thickness\":0.001}", "triangle mesh"}},
    {"cloth of a volume model",
     "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, " MAT ", \"cloth\": {\"thickness\": "
     "0.001}, " TAIL "}",
     {"material.model = \"fixed_corotated\"", "membranes only"}},
    {"grid without cloth",
     "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": {\"model\": \"stvk\", "
     "\"E\": 1, \"nu\": 0.3, \"density\": 1}, " TAIL "}",
     {"cloth", "missing"}},
    {"cloth thickness 0",
     "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": {\"model\": \"stvk\", "
     "\"E\": 1, \"nu\": 0.3, \"density\": 1}, \"cloth\": {\"thickness\": 0}, " TAIL "}",
     {"cloth.thickness = 0", "> 0"}},
    {"negative bending stiffness",
     "{\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}, \"material\": {\"model\": \"stvk\", "
     "\"E\": 1, \"nu\": 0.3, \"density\": 1}, \"cloth\": {\"thickness\": 0.001, "
     "\"bending_stiffness\": -1}, " TAIL "}",
     {"cloth.bending_stiffness = -1", ">= 0"}},
    {"material without E or mu",
     "{" MESH ", \"material\": {\"model\": \"arap\", \"density\": 1}, " TAIL "}",
     {"material.E and material.nu", "missing"}},
    {"description not a string",
     "{\"description\": 3, " MESH ", " MAT ", " TAIL "}",
     {"description = 3", "string"}},
    {"allow.inverted not a bool",
     "{" MESH ", " MAT ", " TAIL ", \"allow\": {\"inverted\": 1}}",
     {"allow.inverted = 1", "true or false"}},
    {"advise.reference_dt 0",
     "{" MESH ", " MAT ", " TAIL ", \"advise\": {\"reference_dt\": 0}}",
     {"advise.reference_dt = 0", "> 0"}},
    {"stretch until 0",
     "{" MESH ", " MAT ", " TAIL ", \"boundary\": [{\"type\": \"stretch\", \"velocity\": [0,0,1], "
     "\"until\": 0, \"region\": {\"min\": [0,0,1], \"max\": [1,1,1]}}]}",
     {"boundary[0].until = 0", "> 0"}},
    {"boundary without type",
     "{" MESH ", " MAT ", " TAIL ", \"boundary\": [{\"region\": {\"min\": [0,0,1], "
     "\"max\": [1,1,1]}}]}",
     {"boundary[0].type", "missing"}},
    {"region min not numbers",
     "{" MESH ", " MAT ", " TAIL ", \"boundary\": [{\"type\": \"pin\", \"region\": "
     "{\"min\": [0,\"a\",1], \"max\": [1,1,1]}}]}",
     {"boundary[0].region.min[1] = \"a\"", "finite number"}},
    {"unknown xpbd solver",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"xpbd\", \"solver\": \"sor\"}}",
     {"integrator.solver = \"sor\"", "gauss_seidel, jacobi"}},
    {"unknown xpbd elements",
     "{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"xpbd\", \"elements\": \"hexes\"}}",
     {"integrator.elements = \"hexes\"", "tets, clusters"}},
    {"unknown linear solver",
     "{" MESH ", " MAT ", " TAIL
     ", \"integrator\": {\"type\": \"implicit\", \"linear_solver\": \"lu\"}}",
     {"integrator.linear_solver = \"lu\"", "matrix_free"}},
    {"steps true",
     "{" MESH ", " MAT ", \"dt\": 1e-4, \"steps\": true}",
     {"steps = true", "number"}},
    {"empty output file",
     "{" MESH ", " MAT ", " TAIL ", \"output\": {\"file\": \"\"}}",
     {"output.file = \"\"", "non-empty string"}},
    {"invalid JSON (line 2)", "{" MESH ",\n  " MAT " " TAIL "}", {"test.json:2:", "invalid JSON"}},
    {"not an object", "[1, 2, 3]", {"(top level) = [1,2,3]", "object"}},
};

static int contains_all(const char *msg, const char *const *expect) {
  for (int i = 0; i < 3 && expect[i]; ++i)
    if (!strstr(msg, expect[i]))
      return 0;
  return 1;
}

// The message's "test.json:LINE:COL: " names a place in `json` that holds
// what the message is about: the value shown after " = " (its first byte;
// a number, a string, an array...), the key of an unknown key, the '{' of
// the object a required key is missing from. NULL when it fits, else why.
static const char *place_fits(const char *json, const char *msg) {
  int line = 0, col = 0, n = 0;
  if (sscanf(msg, "test.json:%d:%d: %n", &line, &col, &n) != 2 || n == 0)
    return "no test.json:LINE:COL: in the message";
  const char *at = json;
  for (int l = 1; l < line && at; l++)
    at = strchr(at, '\n') ? strchr(at, '\n') + 1 : NULL;
  if (!at || col < 1 || (size_t)(col - 1) > strlen(at))
    return "the line and column are outside the text";
  at += col - 1;
  const char *eq = strstr(msg + n, " = ");
  if (strstr(msg, "invalid JSON"))
    return NULL; // where the text stops being JSON: checked in test_bad_input
  if (strstr(msg, ": missing (required)"))
    return *at == '{' ? NULL : "not at the '{' of the object the key is missing from";
  if (strstr(msg, "unknown key"))
    return *at == '"' ? NULL : "not at the key";
  if (!eq)
    return "no ' = ' in the message";
  char shown = eq[3], there = *at;
  int num_shown = shown == '-' || (shown >= '0' && shown <= '9');
  int num_there = there == '-' || (there >= '0' && there <= '9');
  return (num_shown && num_there) || shown == there ? NULL : "not at the value shown";
}

// Checks after parsing (ek_sim_create, ek_scene_mesh) name the place of the
// value they refuse: "test.json:LINE:COL: " with LINE:COL the first byte
// after the first `marker` in the text (a key and its ": ").
typedef enum { LATER_SIM, LATER_MESH, LATER_WARNING } later_stage;
typedef struct {
  const char *what;
  later_stage stage;
  const char *json;
  const char *marker;
  const char *expect[3];
} later_case;

#define CLOTH_MESH "\"mesh\": {\"grid\": [2, 2], \"size\": [1, 1]}"
#define CLOTH_MAT                                                                                  \
  "\"material\": {\"model\": \"stvk\", \"E\": 1e5, \"nu\": 0.3, \"density\": 100},\n"              \
  "\"cloth\": {\"thickness\": 0.001}"

static const later_case later_cases[] = {
    {"region holding no vertex (the second, line 4)",
     LATER_SIM,
     "{" MESH ",\n" MAT ",\n" TAIL ", \"boundary\": [\n"
     "  {\"type\": \"pin\", \"region\": {\"min\": [0,0,0], \"max\": [1,1,0]}},\n"
     "  {\"type\": \"pin\",    \"region\":  {\"min\": [5,5,5], \"max\": [6,6,6]}}]}",
     "\"region\":  ",
     {"boundary[1].region", "holds no vertex"}},
    {"XPBD with a model it has no constraint for",
     LATER_SIM,
     "{" MESH ",\n\"material\": {\"E\": 1e5, \"nu\": 0.3, \"density\": 1000,\n"
     "   \"model\": \"arap\"},\n" TAIL ", \"integrator\": {\"type\": \"xpbd\"}}",
     "\"model\": ",
     {"material.model = arap", "XPBD"}},
    {"cloth XPBD with clusters",
     LATER_SIM,
     "{" CLOTH_MESH ",\n" CLOTH_MAT ",\n" TAIL
     ",\n\"integrator\": {\"type\": \"xpbd\",\n \"elements\": \"clusters\"}}",
     "\"elements\": ",
     {"integrator.elements = \"clusters\"", "a cloth takes"}},
    {"cloth XPBD with the Jacobi solver",
     LATER_SIM,
     "{" CLOTH_MESH ",\n" CLOTH_MAT ",\n" TAIL
     ",\n\"integrator\": {\"type\": \"xpbd\", \"solver\": \"jacobi\"}}",
     "\"solver\": ",
     {"integrator.solver = \"jacobi\"", "a cloth takes"}},
    {"cloth with an assembled linear solver",
     LATER_SIM,
     "{" CLOTH_MESH ",\n" CLOTH_MAT ",\n" TAIL
     ",\n\"integrator\": {\"type\": \"implicit\",\n\n   \"linear_solver\": \"direct\"}}",
     "\"linear_solver\": ",
     {"integrator.linear_solver = \"direct\"", "no assembled Hessian"}},
    {"missing mesh file",
     LATER_MESH,
     "{\n  \"mesh\": {\"file\": \"no_such_mesh.node\"},\n" MAT ", " TAIL "}",
     "\"file\": ",
     {"mesh.file", "no_such_mesh.node", "cannot open"}},
    {"missing cloth mesh file",
     LATER_MESH,
     "{\n\n  \"mesh\": {\"file\": \"no_such_cloth.obj\"},\n" CLOTH_MAT ", " TAIL "}",
     "\"file\": ",
     {"mesh.file", "no_such_cloth.obj", "cannot open"}},
    {"dt above the CFL limit (a warning)",
     LATER_WARNING,
     "{" MESH ",\n" MAT ",\n \"steps\": 10,\n   \"dt\": 0.5}",
     "\"dt\": ",
     {"dt = 0.5", "CFL limit"}},
};

// "test.json:LINE:COL" of the byte after the first `marker` in json.
static void place_after(const char *json, const char *marker, char *out, size_t n) {
  const char *at = strstr(json, marker);
  int line = 1, col = 1;
  for (const char *p = json; at && p < at + strlen(marker); p++) {
    col = *p == '\n' ? 1 : col + 1;
    line += *p == '\n';
  }
  snprintf(out, n, "test.json:%d:%d: ", line, col);
}

// Runs a later_case; the message (error or warning) into msg, 1 if refused
// (or warned) as the stage expects.
static int run_later(const later_case *c, char *msg, size_t n) {
  static ek_scene sc;
  msg[0] = '\0';
  if (ek_scene_parse(c->json, "test.json", "/nonexistent", &sc) != 0) {
    snprintf(msg, n, "parse failed: %s", ek_last_error());
    return 0;
  }
  ek_mesh *m = sc.triangles ? NULL : ek_scene_mesh(&sc);
  ek_trimesh *tm = sc.triangles ? ek_scene_trimesh(&sc) : NULL;
  if (!m && !tm) {
    snprintf(msg, n, "%s", ek_last_error());
    return c->stage == LATER_MESH;
  }
  ek_sim *sim = m ? ek_sim_create(&sc, m) : ek_sim_create_cloth(&sc, tm);
  int ok = 0;
  if (!sim) {
    snprintf(msg, n, "%s", ek_last_error());
    ok = c->stage == LATER_SIM;
  } else {
    const char *w = ek_sim_warning(sim);
    snprintf(msg, n, "%s", w ? w : "(created, no warning)");
    ok = c->stage == LATER_WARNING && w;
  }
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);
  ek_trimesh_destroy(tm);
  return ok;
}

static int close_to(double a, double b) { return fabs(a - b) <= 1e-12 * fmax(1.0, fabs(b)); }

int main(int argc, char **argv) {
  snprintf(scenes_dir, sizeof scenes_dir, "%s", __FILE__);
  char *slash = strrchr(scenes_dir, '/');
  if (slash)
    snprintf(slash, sizeof scenes_dir - (size_t)(slash - scenes_dir), "/../scenes");
  else
    snprintf(scenes_dir, sizeof scenes_dir, "../scenes");
  const char *scenes = NULL;
  unsigned long long seed = ek_cli_test_args(argc, argv, 1, &scenes);
  if (scenes)
    snprintf(scenes_dir, sizeof scenes_dir, "%s", scenes);
  // Deterministic test (no random inputs); the seed is accepted and printed
  // for uniformity with the other tests.
  printf("test_scene --seed %llu (scenes from %s)\n", seed, scenes_dir);
  char path[1200], detail[1400];
  static ek_scene s;

  // 1. Shipped scenes parse, with the values their files state.
  const char *shipped[] = {"cantilever",
                           "twist",
                           "drop",
                           "crush",
                           "cantilever_implicit",
                           "twist_implicit",
                           "stiff_bar_implicit",
                           "crush_implicit",
                           "crush_nh_implicit",
                           "bracket"};
  for (int i = 0; i < (int)(sizeof shipped / sizeof shipped[0]); ++i) {
    snprintf(path, sizeof path, "%s/%s.json", scenes_dir, shipped[i]);
    int rc = ek_scene_load(path, &s);
    snprintf(detail, sizeof detail, "%s", rc ? ek_last_error() : "");
    char what[64];
    snprintf(what, sizeof what, "shipped scene %s parses", shipped[i]);
    verdict(what, rc == 0 && s.dt > 0 && s.steps > 0 && s.output_file[0], detail);
  }
  // No "integrator" key: explicit.
  snprintf(path, sizeof path, "%s/drop.json", scenes_dir);
  if (ek_scene_load(path, &s) == 0)
    verdict("integrator defaults to explicit", s.integrator == EK_INTEGRATOR_EXPLICIT,
            ek_scene_integrator_name(s.integrator));
  // The implicit integrator's defaults (sim.h, ek_scene_implicit) and keys.
  snprintf(path, sizeof path, "%s/cantilever_implicit.json", scenes_dir);
  if (ek_scene_load(path, &s) == 0) {
    const ek_scene_implicit *im = &s.implicit;
    verdict("implicit defaults",
            s.integrator == EK_INTEGRATOR_IMPLICIT && close_to(im->newton_tol, 1e-6) &&
                im->max_newton == 50 && close_to(im->cg_tol, 1e-4) && im->max_cg == 1000 &&
                im->preconditioner == EK_PRECOND_BLOCK_JACOBI && im->projection == EK_PROJECT_CLAMP,
            ek_scene_integrator_name(s.integrator));
  }
  {
    const char *json =
        "{\"mesh\": {\"box\": [1, 1, 1], \"size\": [1, 1, 1]}, \"material\": {\"model\": "
        "\"stvk\", \"E\": 1e5, \"nu\": 0.3, \"density\": 1000}, \"dt\": 0.01, \"steps\": 1,"
        " \"integrator\": {\"type\": \"implicit\", \"newton_tol\": 1e-8, \"max_newton\": 7,"
        " \"cg_tol\": 0.01, \"max_cg\": 99, \"preconditioner\": \"jacobi\", \"projection\": "
        "\"abs\"}}";
    int rc = ek_scene_parse(json, "implicit.json", ".", &s);
    const ek_scene_implicit *im = &s.implicit;
    verdict("implicit keys read",
            rc == 0 && close_to(im->newton_tol, 1e-8) && im->max_newton == 7 &&
                close_to(im->cg_tol, 0.01) && im->max_cg == 99 &&
                im->preconditioner == EK_PRECOND_JACOBI && im->projection == EK_PROJECT_ABS,
            rc ? ek_last_error() : "");
  }
  snprintf(path, sizeof path, "%s/cantilever.json", scenes_dir);
  if (ek_scene_load(path, &s) == 0) {
    // E = 1e8, nu = 0: mu = E / 2, lambda = 0.
    int ok = s.box_cells[0] == 100 && s.box_cells[1] == 1 && s.box_cells[2] == 10 &&
             close_to(s.box_size[0], 1.0) && s.material.model == EK_MODEL_FIXED_COROTATED &&
             close_to(s.material.mu, 5e7) && close_to(s.material.lambda, 0.0) &&
             close_to(s.density, 1000.0) && s.nbc == 1 && s.bc[0].kind == EK_BC_PIN &&
             close_to(s.gravity[2], -9.81) && s.precision == 32 && close_to(s.dt, 1.7e-5) &&
             s.steps == 15000 && s.output_every == 500 &&
             strcmp(s.output_file, "cantilever.h5") == 0 && !s.has_ground;
    snprintf(detail, sizeof detail, "mu %.17g lambda %.17g dt %.17g steps %ld", s.material.mu,
             s.material.lambda, s.dt, s.steps);
    verdict("cantilever values", ok, detail);
  }
  snprintf(path, sizeof path, "%s/crush.json", scenes_dir);
  if (ek_scene_load(path, &s) == 0) {
    int ok = s.nbc == 2 && s.bc[1].kind == EK_BC_STRETCH && close_to(s.bc[1].velocity[2], -0.36) &&
             close_to(s.bc[1].until, 0.5) && s.bc[1].release == 1 && s.bc[0].release == 0 &&
             isinf(s.bc[0].until) && close_to(s.material.clamp, 0.05);
    verdict("crush values (stretch, until, release)", ok, "");
  }
  snprintf(path, sizeof path, "%s/twist.json", scenes_dir);
  if (ek_scene_load(path, &s) == 0) {
    int ok = s.bc[0].kind == EK_BC_TWIST && close_to(s.bc[0].axis[0], 1.0) &&
             close_to(s.bc[0].rate, -1.0) && close_to(s.bc[1].rate, 1.0) && s.precision == 32 &&
             s.material.model == EK_MODEL_STABLE_NEO_HOOKEAN;
    verdict("twist values (axis, rates, f32)", ok, "");
  }
  // A relative mesh file resolves against the scene's directory.
  int rc = ek_scene_parse("{\"mesh\": {\"file\": \"meshes/bar.node\"}, " MAT ", " TAIL "}",
                          "x/test.json", "x", &s);
  verdict("mesh file relative to the scene",
          rc == 0 && strcmp(s.mesh_file, "x/meshes/bar.node") == 0,
          rc ? ek_last_error() : s.mesh_file);
  // The twist axis is normalised.
  rc = ek_scene_parse("{" MESH ", " MAT ", " TAIL
                      ", \"boundary\": [{\"type\": \"twist\", \"axis\": [0, 3, 4], "
                      "\"center\": [0,0,0], \"rate\": 2, \"region\": {\"min\": [0,0,0], "
                      "\"max\": [1,1,0]}}]}",
                      "test.json", ".", &s);
  verdict("twist axis normalised",
          rc == 0 && close_to(s.bc[0].axis[1], 0.6) && close_to(s.bc[0].axis[2], 0.8),
          ek_last_error());
  rc = ek_scene_parse("{" MESH ", " MAT ", " TAIL ", \"integrator\": {\"type\": \"explicit\"}}",
                      "test.json", ".", &s);
  verdict("integrator.type explicit",
          rc == 0 && s.integrator == EK_INTEGRATOR_EXPLICIT &&
              strcmp(ek_scene_integrator_name(s.integrator), "explicit") == 0,
          ek_last_error());

  // 2. Bad scenes: each refused with file, key path and value.
  int nbad = (int)(sizeof bad_cases / sizeof bad_cases[0]);
  for (int i = 0; i < nbad; ++i) {
    const bad_case *b = &bad_cases[i];
    rc = ek_scene_parse(b->json, "test.json", ".", &s);
    const char *misplaced = place_fits(b->json, ek_last_error());
    int ok = rc < 0 && contains_all(ek_last_error(), b->expect) && !misplaced;
    snprintf(detail, sizeof detail, "%s", ek_last_error());
    verdict(b->what, ok, detail);
    if (!ok)
      printf("    input: %s\n    expected message with: \"%s\" \"%s\" \"%s\"%s%s\n", b->json,
             b->expect[0], b->expect[1] ? b->expect[1] : "", b->expect[2] ? b->expect[2] : "",
             misplaced ? "; place: " : "", misplaced ? misplaced : "");
  }

  // 3. File-level errors.
  rc = ek_scene_load("/nonexistent/dir/scene.json", &s);
  verdict("missing scene file",
          rc < 0 && strstr(ek_last_error(), "/nonexistent/dir/scene.json") &&
              strstr(ek_last_error(), "cannot open"),
          ek_last_error());
  rc = ek_scene_parse("{\"mesh\": {\"file\": \"no_such_mesh.node\"}, " MAT ", " TAIL "}",
                      "test.json", "/nonexistent", &s);
  ek_mesh *m = rc == 0 ? ek_scene_mesh(&s) : NULL;
  verdict("missing mesh file -> no mesh, file named",
          rc == 0 && !m && strstr(ek_last_error(), "no_such_mesh"), ek_last_error());
  ek_mesh_destroy(m);

  // 4. Checks after parsing (a region that holds no vertex, caught when
  // the sim is built; a mesh file that does not load; ...) name the scene
  // file, the line and column of the value, and the key path.
  int nlater = (int)(sizeof later_cases / sizeof later_cases[0]);
  for (int i = 0; i < nlater; ++i) {
    const later_case *c = &later_cases[i];
    char msg[1400], at[64];
    place_after(c->json, c->marker, at, sizeof at);
    int ok = run_later(c, msg, sizeof msg) && strncmp(msg, at, strlen(at)) == 0 &&
             contains_all(msg, c->expect);
    verdict(c->what, ok, msg);
    if (!ok)
      printf("    expected the message to start with \"%s\" and hold \"%s\" \"%s\" \"%s\"\n", at,
             c->expect[0], c->expect[1] ? c->expect[1] : "", c->expect[2] ? c->expect[2] : "");
  }
  // A linear solver this build lacks (no PETSc): refused at its place.
  if (!ek_linear_solver_available(EK_LINSOLVE_AMG)) {
    const later_case c = {
        "linear_solver amg without PETSc",
        LATER_SIM,
        "{" MESH ",\n" MAT ",\n" TAIL
        ",\n\"integrator\": {\"type\": \"implicit\", \"linear_solver\": \"amg\"}}",
        "\"linear_solver\": ",
        {"integrator.linear_solver = \"amg\"", "PETSc"}};
    char msg[1400], at[64];
    place_after(c.json, c.marker, at, sizeof at);
    verdict(c.what,
            run_later(&c, msg, sizeof msg) && strncmp(msg, at, strlen(at)) == 0 &&
                contains_all(msg, c.expect),
            msg);
  } else {
    printf("linear_solver amg without PETSc: skipped (this build has PETSc)\n");
  }
  // A scene built in code (no places known) is named by its path alone.
  rc = ek_scene_parse(later_cases[0].json, "test.json", ".", &s);
  memset(&s.where, 0, sizeof s.where);
  m = rc == 0 ? ek_scene_mesh(&s) : NULL;
  ek_sim *sim = m ? ek_sim_create(&s, m) : NULL;
  verdict("region holding no vertex, no places known",
          m && !sim &&
              strstr(ek_last_error(), "test.json: boundary[1].region = ") == ek_last_error(),
          ek_last_error());
  ek_sim_destroy(sim);
  ek_mesh_destroy(m);

  printf("%s\n", failures ? "FAILED" : "ALL PASSED");
  return failures ? 1 : 0;
}
