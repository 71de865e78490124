// Where ek-sim and ek-bench find the scenes shipped with ek (scenes/*.json
// and their meshes), from the build tree and from an installed tree alike.
// Not part of the installed library: a program of the user's has its own
// place for its scenes (the installed ones are ek_SCENES_DIR in CMake,
// `pkg-config --variable=scenesdir ek`).
//
// Folders tried, in this order:
//   1. $EK_SCENES_DIR when it is set and not empty, and then only it: an
//      override, not a hint, so a wrong value is an error, never a silent
//      fallback to another copy;
//   2. the installed tree: <folder of the running program>/../share/ek/scenes
//      (bin/ -> <datadir>/ek/scenes as installed), the program's folder read
//      from /proc/self/exe, so an installed tree can be moved as a whole;
//   3. the source tree's scenes/ (programs run from the build tree).
#ifndef EK_SIM_SCENE_FIND_H
#define EK_SIM_SCENE_FIND_H

#include <stddef.h>

// The shipped scene `name` ("drop" or "drop.json"): 0 and its path in
// `path`, or -1 and a message naming every path tried in `err`.
int ek_shipped_scene(const char *name, char *path, size_t pathlen, char *err, size_t errlen);

// A scene named on a command line: the file as given when it exists or the
// argument has a '/', else (a bare name such as "drop") the shipped scene of
// that name. 0 and the path to load in `path`, or -1 and a message naming
// every path tried in `err`.
int ek_scene_arg(const char *arg, char *path, size_t pathlen, char *err, size_t errlen);

#endif
