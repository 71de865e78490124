// The shipped scenes' folders and the lookup of a scene by name (see
// scene_find.h for the order and why).
#include "scene_find.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

// Both from sim/CMakeLists.txt: the scenes' folder relative to the installed
// programs' folder (e.g. "../share/ek/scenes") and the source tree's.
#if !defined(EK_SCENES_FROM_BINDIR) || !defined(EK_SCENES_SOURCE_DIR)
#error "EK_SCENES_FROM_BINDIR and EK_SCENES_SOURCE_DIR come from sim/CMakeLists.txt"
#endif

enum { PATH_LEN = 4096, TRIED_LEN = 3 * PATH_LEN + 256 };

typedef struct {
  const char *dir, *why;
} scene_folder;

static const char *env_dir(void) {
  const char *env = getenv("EK_SCENES_DIR");
  return env && env[0] ? env : NULL;
}

static const char *hint(void) {
  return env_dir() ? "" : "; set EK_SCENES_DIR to the folder that holds the scenes";
}

static int is_file(const char *path) {
  struct stat st;
  return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

// <folder of the running program>/EK_SCENES_FROM_BINDIR, its leading "../"
// taken off the program's folder (/proc/self/exe has no links or "..", so
// this is the canonical path). 0, or -1 where the program's path is unknown.
static int installed_dir(char *out, size_t outlen) {
  char exe[PATH_LEN];
  ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0 || (size_t)n >= sizeof exe - 1)
    return -1;
  exe[n] = '\0';
  char *slash = strrchr(exe, '/');
  if (!slash)
    return -1;
  *slash = '\0';
  const char *rel = EK_SCENES_FROM_BINDIR;
  while (strncmp(rel, "../", 3) == 0 && (slash = strrchr(exe, '/')) != NULL && slash != exe) {
    *slash = '\0';
    rel += 3;
  }
  int k = snprintf(out, outlen, "%s/%s", exe, rel);
  return k >= 0 && (size_t)k < outlen ? 0 : -1;
}

// Looks for <folder>/<name>[.json] in the folders of scene_find.h. 0 and the
// path, or -1 and the candidates tried (with why each folder) in `tried`.
static int find_shipped(const char *name, char *path, size_t pathlen, char *tried,
                        size_t triedlen) {
  const char *env = env_dir();
  char installed[PATH_LEN];
  scene_folder where[2];
  int nwhere = 0;
  size_t used = 0;
  tried[0] = '\0';
  if (env) {
    where[nwhere++] = (scene_folder){env, "$EK_SCENES_DIR"};
  } else {
    if (installed_dir(installed, sizeof installed) == 0)
      where[nwhere++] = (scene_folder){installed, "installed, beside this program"};
    else
      used +=
          (size_t)snprintf(tried, triedlen, "(the installed tree: /proc/self/exe unreadable), ");
    where[nwhere++] = (scene_folder){EK_SCENES_SOURCE_DIR, "source tree"};
  }
  size_t len = strlen(name);
  const char *ext = len >= 5 && strcmp(name + len - 5, ".json") == 0 ? "" : ".json";
  for (int i = 0; i < nwhere; ++i) {
    char candidate[PATH_LEN];
    int k = snprintf(candidate, sizeof candidate, "%s/%s%s", where[i].dir, name, ext);
    int fits = k >= 0 && (size_t)k < sizeof candidate && (size_t)k < pathlen;
    if (fits && is_file(candidate)) {
      memcpy(path, candidate, (size_t)k + 1);
      return 0;
    }
    if (used < triedlen)
      used += (size_t)snprintf(tried + used, triedlen - used, "%s%s (%s%s)", i ? ", " : "",
                               candidate, where[i].why, fits ? "" : "; path too long");
  }
  return -1;
}

int ek_shipped_scene(const char *name, char *path, size_t pathlen, char *err, size_t errlen) {
  char tried[TRIED_LEN];
  if (find_shipped(name, path, pathlen, tried, sizeof tried) == 0)
    return 0;
  snprintf(err, errlen, "scene \"%s\" not found; tried %s%s", name, tried, hint());
  return -1;
}

int ek_scene_arg(const char *arg, char *path, size_t pathlen, char *err, size_t errlen) {
  struct stat st;
  // A file that exists, or a path: the loader opens it and names it in
  // its own errors.
  if (!arg[0] || strchr(arg, '/') || stat(arg, &st) == 0) {
    if (strlen(arg) >= pathlen) {
      snprintf(err, errlen, "%.64s...: path longer than %zu bytes", arg, pathlen - 1);
      return -1;
    }
    snprintf(path, pathlen, "%s", arg);
    return 0;
  }
  char tried[TRIED_LEN];
  if (find_shipped(arg, path, pathlen, tried, sizeof tried) == 0)
    return 0;
  snprintf(err, errlen, "%s: no such file, nor a shipped scene of that name; tried ./%s, %s%s", arg,
           arg, tried, hint());
  return -1;
}
