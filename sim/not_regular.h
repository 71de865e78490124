// Internal: what is at an output path that ek's writers must never replace
// (issue 28: run as root, --out /dev/null --force replaced the device
// node). Shared by the frames writer (sim/frames.c), ek-bench's results
// (bench/results.c, bench/ek_bench.c) and ek-verify's --json
// (verify/ek_verify.c). Header-only, as text_escape.h: nothing to link.
#ifndef EK_SIM_NOT_REGULAR_H
#define EK_SIM_NOT_REGULAR_H

#include <stddef.h>
#include <sys/stat.h>

// What lstat says is at path when it is not a regular file ("a directory",
// "a character device", "a FIFO", "a symbolic link", ...), else NULL
// (nothing there, or a regular file).
static inline const char *not_regular(const char *path) {
  struct stat st;
  if (lstat(path, &st) != 0 || S_ISREG(st.st_mode))
    return NULL;
  return S_ISDIR(st.st_mode)    ? "a directory"
         : S_ISCHR(st.st_mode)  ? "a character device"
         : S_ISBLK(st.st_mode)  ? "a block device"
         : S_ISFIFO(st.st_mode) ? "a FIFO"
         : S_ISSOCK(st.st_mode) ? "a socket"
         : S_ISLNK(st.st_mode)  ? "a symbolic link"
                                : "not a regular file";
}

#endif
