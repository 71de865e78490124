// Internal: OpenMP environment defaults of ek's programs (ek-bench, ek-sim).
// Not installed.
#ifndef EK_SIM_OMP_ENV_H
#define EK_SIM_OMP_ENV_H

// Call first thing in main. For each of these the user has not set, set it:
//   OMP_PROC_BIND=close, OMP_PLACES=cores: one thread per core, thread k on
//     core k, so a thread keeps its caches and two never share a core;
//   OMP_WAIT_POLICY=passive (when passive_wait): a thread that waits at a
//     barrier sleeps instead of spinning. On a shared machine a spinning
//     thread can hold the core that the thread it waits for needs.
// libgomp reads OMP_* variables once, when it loads, before main runs, so
// setting them takes effect only in a fresh process image: if any was set,
// the program re-executes itself (/proc/self/exe, same argv) once. Returns
// when nothing had to be set, or when the re-execution failed (a note on
// stderr names `program`; it then runs with libgomp's defaults).
void omp_env_defaults(const char *program, char **argv, int passive_wait);

#endif
