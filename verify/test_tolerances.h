// Tolerances of ek's test scenarios (not installed): what tests/ and
// ek-verify hold a scenario's measured error to, named here and never
// written as literals in test bodies. The kernels' error
// budgets (EK_<CAP>_TOL_F32/_F64, EK_MESH_TOL) are part of each kernel's
// contract and stay in its public header; these bound a test's own
// construction (finite differences, a time integrator on a chosen scene).
#ifndef EK_TEST_TOLERANCES_H
#define EK_TEST_TOLERANCES_H

// ---- material.h: the reference models
// Budget of the reference's own consistency checks (tests/test_material_ref.c,
// double): P against central differences of psi and dP against central
// differences of P, best over the step sizes h = 1e-3 .. 1e-6, in the norms
// of material.h. Truncation (h^2) and rounding (eps/h) errors meet near
// 1e-8.
#define EK_MATERIAL_FD_TOL 1e-6

// ---- fvm.h: the FVM reference
// The double reference against central differences of its own energy
// (forces = -dE/dx), same norm; bounded by the differencing, not by the
// kernel.
#define EK_FVM_FD_TOL 1e-8

// ---- cloth_force.h (tests/test_cloth_force.c)
// Forces and Hessian products against central differences of the energy
// (of the forces), relative to the largest entry; eps swept, best kept.
#define EK_CLOTH_FORCE_FD_TOL 1e-6
// Sum of the forces relative to the sum of their magnitudes (momentum).
#define EK_CLOTH_FORCE_MOMENTUM_TOL_F64 1e-12

// ---- the simulation loop (include/ek/sim/)
// Invariants checked by tests/test_sim_explicit.c (named here, never
// literals in test bodies).
//
// Undamped, unpinned, gravity-free body, 1000 steps at dt = 0.02 h_min / c:
// max_t |E(t) - E(0)| / E(0), E = kinetic + elastic (from the rest shape,
// see ek_sim_energy).
// Symplectic Euler conserves a modified energy; for a harmonic mode of
// frequency omega the difference is (dt/2) omega^2 |x v| <= (dt omega / 2) E
// (Hairer, Lubich, Wanner, Geometric Numerical Integration, sec. IX.3), so
// the error is bounded, not drifting. With the CFL estimate of the fastest
// mode, omega_max = 2 c / h_min (dt_crit = 2 / omega_max = h_min / c), the
// bound is dt c / h_min = 0.02.
#define EK_SIM_ENERGY_TOL 2e-2
#define EK_SIM_ENERGY_DT_CFL 0.02
// Same run: |sum m v(t) - sum m v(0)| / sum m |v|(0 or t, the larger):
// internal forces sum to zero per tet, so momentum is kept to rounding.
#define EK_SIM_MOMENTUM_TOL_F64 1e-10
// Cantilever under gravity, damped to rest: |delta - delta_EB| / delta_EB,
// delta_EB = q L^4 / (8 E I) (Euler-Bernoulli, uniform load q).
#define EK_SIM_CANTILEVER_TOL 0.05
// Crushed and released cube (invertible model): |V - V0| / V0 at rest.
#define EK_SIM_VOLUME_TOL 0.01
// Checked by tests/test_sim_core.c: the frames' energy density
// (ek_sim_tet_fields, measured from the rest shape) against rounding. At
// rest, max_e |psi_e| / (mu + |lambda|) (a stress scale); after steps,
// |sum_e V0_e psi_e - elastic| / sum_e V0_e (|Psi(F_e)| + |Psi(F_rest,e)|)
// (the cancellation-free size of the sum), elastic from ek_sim_energy. Both
// sides evaluate the same Psi per tet; only the order of the sums differs.
#define EK_SIM_ENERGY_FIELD_TOL 1e-12

// tests/test_polar_warm.c: the cantilever and twist scenes (fixed
// corotated) with "polar": "warm" against "svd" after 300 steps. The warm
// polar's rotations are within EK_POLAR_WARM_TOL_* of the SVD's, far below
// the f32 force's own rounding, so in f32 the two runs may differ by no
// more than FACTOR x the distance between the f32 and f64 SVD runs
// (max |dx| over vertices), and in f64 by TOL x the body's length.
#define EK_POLAR_WARM_LOOP_F32_FACTOR 2
#define EK_POLAR_WARM_LOOP_TOL_F64 1e-12

// ---- ek-sim across MPI ranks (tests/mpi.sh, tests/frames_gap.c)
// An implicit scene run on N ranks against the same scene on one rank: the
// last frame's positions, mass-weighted RMS gap over the body size L
// (lumped masses, sim/body.h), per step run and per newton_tol. The runs'
// sums differ in order and their AMG hierarchies differ, so their Newton
// iterates differ; each step of each run stops at a residual r <=
// newton_tol, r = dt^2 |g|_{M^-1} / (sqrt(m_free) L) (ek_scene_implicit).
// The system matrix A = M (1 + c dt) / dt^2 + K >= M / dt^2 (K projected
// to PSD), so a step's distance from the exact minimiser, |A^-1 g|_M /
// (sqrt(m_free) L), is at most r to first order: the two runs' steps are
// within 2 newton_tol of each other, and backward Euler's dissipative step
// does not amplify an earlier gap. Budget: 2 newton_tol per step run.
#define EK_SIM_MPI_GAP_PER_STEP 2.0

#endif
