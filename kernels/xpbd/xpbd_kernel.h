// Internal: the XPBD constraint blocks, the arguments of the block kernel
// (kernels/xpbd/xpbd_block.c) and the state behind ek_xpbd (include/ek/
// xpbd.h), shared by the kernel and its driver (kernels/xpbd/xpbd.c).
//
// Constraint blocks (AoSoA, LANES = 16 for f32, 8 for f64): block b holds
// LANES constraints with up to nmem[b] members each; its member planes
// start at plane moff[b]:
//   idx[(moff[b] + k) * L + l]           member k's vertex (-1: none)
//   bv[((moff[b] + k) * 3 + d) * L + l]  b_k (k >= 1; member 0's unused)
//   stiff[b * L + l]                     V_j E (StVK) or V_j (stable
//                                        neo-Hookean); 0: padding lane
//   lambda[b * L + l]                    the multiplier (snh: C_D's)
//   lambda_h[b * L + l]                  snh: C_H's multiplier
// A padding lane has every idx -1; a cluster smaller than nmem[b] has
// idx -1 and b = 0 for its missing members.
#ifndef EK_XPBD_KERNEL_H
#define EK_XPBD_KERNEL_H

#include <ek/xpbd.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernels.h"

// What one kernel call does for blocks [b0, b1):
//   XPBD_GS       project every constraint, x updated in place (the
//                 blocks' constraints share no vertex);
//   XPBD_JACOBI   dlambda with the n_i-weighted denominator, lambda
//                 updated, the position corrections w_k grad_k C dlambda
//                 written to corr (member-plane layout, 3 per member);
//   XPBD_RESIDUAL |C + lambda / (V E h^2)| and C to sink[(b*2 + 0/1)*L + l]
//                 (0 for skipped constraints); snh: the larger of its two
//                 constraints' |C + alpha~ lambda|, and |C_H|;
//   XPBD_F_ONLY   the deformation gradients alone (a sum of F to sink);
//   XPBD_EVAL     F, W, P, grad C and dlambda, dlambda to sink; nothing
//                 else written.
enum { XPBD_GS = 0, XPBD_JACOBI, XPBD_RESIDUAL, XPBD_F_ONLY, XPBD_EVAL };

// Clusters larger than this are refused (a vertex with more than 127
// neighbours).
#define XPBD_MAX_MEMBERS 128

#define EK_XPBD_ARGS(T, NAME)                                                                      \
  struct NAME {                                                                                    \
    int op;                                                                                        \
    int tets; /* every block has 4 members: the compile-time path */                               \
    int snh;  /* the stable neo-Hookean pair (xpbd.h); else StVK's one */                          \
    const int32_t *nmem;                                                                           \
    const size_t *moff;                                                                            \
    const int32_t *idx;                                                                            \
    const T *bv;                                                                                   \
    const T *stiff;                                                                                \
    T *lambda;                                                                                     \
    T *lambda_h; /* snh: the hydrostatic multipliers (the deviatoric in lambda) */                 \
    T mu, lam, inv_young, h2, c_min;                                                               \
    T rest_shift; /* snh: a = 1 + 3 mu / (4 lambda) */                                             \
    T *x;         /* positions, or displacements from xb */                                        \
    const T *xb;  /* base positions, or NULL */                                                    \
    const T *w;   /* inverse masses (nverts) */                                                    \
    const T *wd;  /* the denominator's: w (Gauss-Seidel) or n w (Jacobi) */                        \
    T *corr;      /* Jacobi */                                                                     \
    T *sink;      /* residual, profile */                                                          \
  }
EK_XPBD_ARGS(float, ek_xpbd_args_f32);
EK_XPBD_ARGS(double, ek_xpbd_args_f64);

// Behind ek_xpbd. Blocks in one precision (opts.precision): the *_f32 or
// *_f64 planes; bv64 always (ek_xpbd_members).
struct ek_xpbd {
  const ek_tets *el;
  ek_xpbd_elements elements;
  ek_xpbd_solver solver;
  ek_isa isa;
  const ek_kernel_table *kt;
  int precision, lanes;
  ek_model model; // EK_MODEL_STVK or EK_MODEL_STABLE_NEO_HOOKEAN
  double mu, lambda, young, h, stiff_scale;
  size_t nverts, ncons, nblocks, nplanes; // nplanes: member planes
  int ncolors, max_members;
  int32_t *nmem;
  size_t *moff;
  int32_t *idx;
  int32_t *cid;      // nblocks * L: constraint id per lane, -1 padding
  int32_t *con_slot; // ncons: block * L + lane of each constraint
  double *bv64;
  void *bv, *stiff, *lambda_planes, *lambda_h_planes, *w, *wd, *corr, *sink;
  // Schedule: phase p runs tasks [phase_task[p], phase_task[p+1]) in
  // parallel; task t is blocks [task_block[t], task_block[t+1]) in order.
  size_t nphases, ntasks;
  size_t *phase_task, *task_block;
  // Tets (task = chunk): task t's neighbours, the tasks sharing a vertex
  // with it, are task_dep[task_dep_start[t] .. task_dep_start[t+1]);
  // task_done[t] the sweeps it has done in the current ek_xpbd_iterate
  // call; task_order the order the team claims a sweep's tasks in, planned
  // for order_threads threads (xpbd.c, plan_order; 0: not yet).
  size_t *task_dep_start;
  int32_t *task_dep, *task_order;
  int order_threads;
  atomic_int *task_done;
  // Where a thread sleeps once its wait outlasts the spin (sleepers: how
  // many do).
  pthread_mutex_t flow_mutex;
  pthread_cond_t flow_cond;
  atomic_int flow_sleepers;
  int flow_ready; // mutex and cond initialised
  // Jacobi: vertex v's corrections are corr entries
  // vert_entries[vert_start[v] .. vert_start[v+1]) (plane offsets
  // (moff + k) * 3 * L + l, component d at + d * L), ascending; n_i =
  // vert_start[v+1] - vert_start[v].
  size_t *vert_start;
  size_t *vert_entries;
  int weights_set;
};

#endif
