// Internal: OpenMP environment defaults of ek's programs (ek-bench, ek-sim).
// Not installed.
#ifndef EK_SIM_OMP_ENV_H
#define EK_SIM_OMP_ENV_H

// Call first thing in main. For each of these the user has not set, set it:
//   OMP_PROC_BIND=close, OMP_PLACES=cores: one thread per core, thread k on
//     core k, so a thread keeps its caches and two never share a core;
// The wait policy stays libgomp's (spin a while, then sleep): with
// OMP_WAIT_POLICY=passive every fork woke a sleeping thread, 60-90 us on
// the 2-core machine, which made the small scenes 2.6-3.5x slower at 2
// threads (tools/scene_threads.sh; issue 8's closing note).
// libgomp reads OMP_* variables once, when it loads, before main runs, so
// setting them takes effect only in a fresh process image: if any was set,
// the program re-executes itself (/proc/self/exe, same argv) once. Returns
// when nothing had to be set, or when the re-execution failed (a note on
// stderr names `program`; it then runs with libgomp's defaults).
void omp_env_defaults(const char *program, char **argv);

// OMP_NUM_THREADS with an item of its list that is not a whole number in
// 1..4096 (--threads' limit): libgomp warns about "0", "x" or "-1" and runs
// on every core; a number too large it takes (99999999999 wrapped to
// 1215752191) and aborts at the first parallel region, "out of memory",
// never naming the variable. Returns 0, or EK_EXIT_USAGE with a message
// naming the variable and value.
int omp_env_check_threads(const char *program);

#endif
