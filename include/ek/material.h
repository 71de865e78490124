// Hyperelastic material models: energy density Psi(F), first Piola-Kirchhoff
// stress P(F) = dPsi/dF and its differential dP(F; dF) = (d^2 Psi/dF^2) : dF,
// batched, vectorised, verified against reference/material/ (issue 3).
//
// Notation: F, R, P, dF, dP are row-major 3x3 matrices; I_C = tr(F^T F),
// J = det F, R(F) = U V^T from the rotation-variant SVD (svd3.h: det U =
// det V = +1, sigma_3 < 0 for inverted F). mu and lambda are the Lame
// parameters exactly as given (no re-parametrisation).
//
// | model                       | Psi(F)                                              | needs   |
// |-----------------------------|-----------------------------------------------------|---------|
// | EK_MODEL_LINEAR             | mu e:e + lambda/2 tr(e)^2, e = (F + F^T)/2 - I      | nothing |
// | EK_MODEL_STVK               | mu E:E + lambda/2 tr(E)^2, E = (F^T F - I)/2        | nothing |
// | EK_MODEL_COROTATED_LINEAR   | Psi_LINEAR(R^T F), R given per element (seed 000)   | R input |
// | EK_MODEL_FIXED_COROTATED    | mu |F - R(F)|^2 + lambda/2 (J - 1)^2 (Stomakhin 12) | polar   |
// | EK_MODEL_ARAP               | mu |F - R(F)|^2                                     | polar   |
// | EK_MODEL_PSI_R              | mu/4 |F^T F - I|^2 (seed 000)                       | nothing |
// | EK_MODEL_NEO_HOOKEAN        | mu/2 (I_C - 3) - mu log J + lambda/2 (log J)^2      | J       |
// | EK_MODEL_STABLE_NEO_HOOKEAN | mu/2 (I_C - 3) + lambda/2 (J - a)^2                 | J       |
// |                             |   - mu/2 log(I_C + 1), a = 1 + 3 mu / (4 lambda)    |         |
// |                             |   (Smith et al. 2018, sec. 3.4, log term kept)      |         |
//
// Domain and singularities (the budgets below hold away from them):
// - Neo-Hookean without clamp is defined for J > 0 only: an element with
//   J <= 0 gets psi = +inf, P = NaN and dP = NaN, and is counted in the
//   return value. Every other model is finite for every finite F.
// - Non-finite input: an element whose F (or R, for corotated linear) holds
//   a NaN or an infinity gets NaN in every entry of psi, P, dP and H, as
//   the SVD gives NaN in all of U, S, V (svd3.h); other elements are not
//   affected.
// - Fixed corotated and ARAP: R(F) is not differentiable where two signed
//   singular values sum to zero (sigma_i + sigma_j = 0, e.g. a flat or
//   inverted element); dP contains 1/(sigma_i + sigma_j) there.
// - Stable neo-Hookean needs lambda != 0 (a = 1 + 3 mu / (4 lambda)).
//
// Invertible evaluation, clamp > 0 (Irving et al. 2004, sec. 5), for the
// models evaluated through singular values: fixed corotated, ARAP,
// neo-Hookean, stable neo-Hookean (the others ignore clamp). With
// F = U diag(sigma) V^T and sigma_hat_i = max(sigma_i, clamp),
// F_hat = U diag(sigma_hat) V^T:
//   P  = P_model(F_hat) = U P_hat(sigma_hat) V^T    (Irving 2004, sec. 5)
//   dP = dP_model(F_hat; dF): the model's Hessian at the clamped F_hat, in
//        the U, V frame of Teran et al. 2005: symmetric, and equal
//        to the exact dP wherever no singular value is clamped.
//   psi = Psi_model(F_hat) + P:(F - F_hat): the energy extended to first
//        order past the clamp, so it is finite, continuous, and equal to
//        Psi_model(F) wherever no singular value is clamped.
//        Where a singular value is clamped, P is not the gradient of this
//        psi (nor of any energy) when the model couples its singular
//        values (P_hat_i depends on the other sigma_hat_j: fixed
//        corotated's J term, neo-Hookean's log J): a solver that needs an
//        energy consistent with P must not rely on psi there (the implicit
//        loop's line search uses the residual where an element is clamped,
//        sim/implicit.c).
// So with clamp > 0 neo-Hookean is finite for every finite F (inverted and
// flat elements get finite, restoring forces) and the return value is 0.
//
// project != 0: dP uses the element's 9x9 Hessian with its negative
// eigenvalues set to zero (not their absolute value, not a floor), so an
// already positive semi-definite Hessian is unchanged. Kernels use the
// analytic eigensystem in the U, V frame (Teran et al. 2005; Smith
// et al. 2019): a 3x3 block on the diagonal entries and three 2x2 blocks
// (eigenvalues (p_i - p_j)/(sigma_i - sigma_j) and (p_i + p_j)/(sigma_i +
// sigma_j) in closed, cancellation-free form per model). Linear and
// corotated linear Hessians are always PSD (eigenvalues 2 mu, 2 mu +
// 3 lambda, 0), so project changes nothing for them; the other SVD-free
// models take an SVD only when project != 0.
//
// SVD use: a model that needs no SVD never computes one for P or psi
// (linear, StVK, Psi_R, and neo-Hookean / stable neo-Hookean without clamp;
// corotated linear uses the given R). Fixed corotated and ARAP need R(F);
// the clampable models (fixed corotated, ARAP, neo-Hookean, stable
// neo-Hookean) need the full SVD when clamp > 0 (ek_model_need). Each
// model's descriptor (ek_model_describe) is in kernels/material/<name>.c.
//
// Invalid arguments (rc = EK_EINVAL, message in ek_last_error(), nothing
// written): unknown model, mu <= 0, a non-finite mu/lambda/clamp,
// lambda <= -2 mu / 3, clamp < 0, stable neo-Hookean with lambda == 0,
// R == NULL for corotated linear, a NULL array with n > 0.
//
// Threads: chunks of blocks on the library's helper threads, as many as
// omp_get_max_threads(), the calling thread alone inside an OpenMP parallel
// region; results are bitwise identical for any thread count. Batches
// below EK_MATERIAL_PARALLEL_MIN elements run on the calling thread (a few
// us of work: less than waking a second one costs).
#ifndef EK_MATERIAL_H
#define EK_MATERIAL_H

#include "batch.h"
#include "core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
  EK_MODEL_LINEAR,
  EK_MODEL_STVK,
  EK_MODEL_COROTATED_LINEAR,
  EK_MODEL_FIXED_COROTATED,
  EK_MODEL_ARAP,
  EK_MODEL_PSI_R,
  EK_MODEL_NEO_HOOKEAN,
  EK_MODEL_STABLE_NEO_HOOKEAN
} ek_model;
#define EK_MODEL_COUNT 8
#define EK_MATERIAL_PARALLEL_MIN 4096

typedef struct {
  ek_model model;
  double mu, lambda;
  double clamp;
} ek_material;

// Error budgets for P, dP and the Hessian against the double reference,
// max over elements, away from each model's own singularities (above):
//   |P - P_ref|_max / max(|P_ref|_max, (mu + |lambda|) s^3)
//   |dP - dP_ref|_max / max(|dP_ref|_max, (mu + |lambda|) s^2 |dF|_max)
//   |H - H_ref|_max / max(|H_ref|_max, (mu + |lambda|) s^2)
// with s = max(1, |F|_max) (the scale of the largest terms the models
// form: StVK and Psi_R are cubic in F). Measured by ek-verify and asserted
// by tests/test_material.c on F with singular values in [0.2, 5].
// The energy (ek_energy_f64, EK_MAT_ENERGY) is held to the same budgets with
//   |psi - psi_ref| / max(|psi_ref|, (mu + |lambda|) s^4).
#define EK_PK1_TOL_F32 1e-4
#define EK_PK1_TOL_F64 1e-10

// At F = I every model's dP is linear elasticity, dP = mu' (dF + dF^T) +
// lambda' tr(dF) I, with (mu', lambda') = (mu, lambda) except ARAP and
// Psi_R: (mu, 0), and stable neo-Hookean: (3 mu / 4, lambda - 5 mu / 8)
// (ek takes mu and lambda as given; Smith et al. 2018 sec. 3.4 instead
// re-parametrise so that the two match).

// F, R, P, dF, dP: n row-major 3x3 matrices; R only for
// EK_MODEL_COROTATED_LINEAR (else NULL allowed, never read). Returns the
// number of elements outside the model's domain (J <= 0 for neo-Hookean
// without clamp: their psi is +inf and P is NaN), or < 0 for an invalid
// argument (among them an array not aligned to its element type, 4 / 8
// bytes, or an n whose byte count overflows: core.h).
int ek_energy_f64(const ek_material *m, size_t n, const double *F, const double *R, double *psi);
int ek_pk1_f32(const ek_material *m, size_t n, const float *F, const float *R, float *P);
int ek_pk1_f64(const ek_material *m, size_t n, const double *F, const double *R, double *P);
// dP = (d^2 Psi / dF^2) : dF. project != 0: the per-element Hessian is first
// projected to positive semi-definite (analytic eigensystems, see above).
int ek_pk1_diff_f32(const ek_material *m, size_t n, const float *F, const float *R, const float *dF,
                    float *dP, int project);
int ek_pk1_diff_f64(const ek_material *m, size_t n, const double *F, const double *R,
                    const double *dF, double *dP, int project);

// Element Hessians d^2 Psi / dF^2 (projected to PSD when project != 0), for
// implicit solvers and their preconditioners: H is n x 81, element e's
// H[e*81 + a*9 + b] = d P_a / d F_b with a = 3 i + j (row-major entries).
// Symmetric. Same return value as ek_pk1_*.
int ek_pk1_hessian_f32(const ek_material *m, size_t n, const float *F, const float *R, float *H,
                       int project);
int ek_pk1_hessian_f64(const ek_material *m, size_t n, const double *F, const double *R, double *H,
                       int project);

// What one evaluation computes.
typedef enum {
  EK_MAT_ENERGY,   // out: psi, 1 value (1 plane) per element
  EK_MAT_PK1,      // out: P, 9 values (9 planes)
  EK_MAT_PK1_DIFF, // out: dP, 9 values (9 planes); reads dF
  EK_MAT_HESSIAN   // out: H, 81 values (81 planes)
} ek_material_op;

// General forms with a forced ISA (EK_ISA_AUTO or a target; one the CPU
// lacks gives EK_EISA): the functions above are these with EK_ISA_AUTO.
// dF is read for EK_MAT_PK1_DIFF only; project for PK1_DIFF and HESSIAN.
int ek_material_eval_f32(const ek_material *m, ek_material_op op, ek_isa isa, size_t n,
                         const float *F, const float *R, const float *dF, float *out, int project);
int ek_material_eval_f64(const ek_material *m, ek_material_op op, ek_isa isa, size_t n,
                         const double *F, const double *R, const double *dF, double *out,
                         int project);

// AoSoA-native forms (layout in batch.h): nblocks blocks of EK_LANES_F32 /
// EK_LANES_F64 elements; F, R, dF, P, dP 9 planes, psi 1 plane, H 81
// planes. Padded tail lanes are evaluated like any other (pad F with the
// identity, as the packer does) and counted if outside the domain.
int ek_material_eval_aosoa_f32(const ek_material *m, ek_material_op op, ek_isa isa, size_t nblocks,
                               const float *F, const float *R, const float *dF, float *out,
                               int project);
int ek_material_eval_aosoa_f64(const ek_material *m, ek_material_op op, ek_isa isa, size_t nblocks,
                               const double *F, const double *R, const double *dF, double *out,
                               int project);
int ek_pk1_aosoa_f32(const ek_material *m, size_t nblocks, const float *F, const float *R,
                     float *P);
int ek_pk1_aosoa_f64(const ek_material *m, size_t nblocks, const double *F, const double *R,
                     double *P);
int ek_pk1_diff_aosoa_f32(const ek_material *m, size_t nblocks, const float *F, const float *R,
                          const float *dF, float *dP, int project);
int ek_pk1_diff_aosoa_f64(const ek_material *m, size_t nblocks, const double *F, const double *R,
                          const double *dF, double *dP, int project);

// Checks a material (the rules above): EK_OK or EK_EINVAL with a message.
int ek_material_check(const ek_material *m);
// Short names: "linear", "stvk", "corot_linear", "fixed_corot", "arap",
// "psi_r", "nh", "snh"; "invalid" otherwise.
const char *ek_model_name(ek_model model);
// Long names (scene files): "linear", "stvk", "corotated_linear",
// "fixed_corotated", "arap", "psi_r", "neo_hookean", "stable_neo_hookean";
// "invalid" otherwise.
const char *ek_model_long_name(ek_model model);
// Either name -> the model: EK_OK, or EK_EINVAL (no message) if unknown.
int ek_model_from_name(const char *name, ek_model *model);

// What a model needs per element, given the clamp.
typedef enum {
  EK_NEEDS_NOTHING, // polynomial in F
  EK_NEEDS_J,       // det F and F^-T (neo-Hookean family without clamp)
  EK_NEEDS_POLAR,   // R(F) from an SVD (fixed corotated, ARAP without clamp)
  EK_NEEDS_R_INPUT, // a given rotation per element
  EK_NEEDS_SVD      // the full SVD: a clampable model with clamp > 0
} ek_model_needs;
ek_model_needs ek_model_need(ek_model model, double clamp);

// What a run saw of its elements (max / min over elements and frames), for
// a model's validity rule: the advisor (sim/advise.c) fills it from a trial.
typedef struct {
  double max_strain;        // |F^T F - I|_max
  double max_rotation;      // angle of R(F) (rad)
  double max_rotation_step; // change of R(F) over one step (rad)
  double min_sigma;         // smallest singular value of F
  double min_J;             // smallest det F
} ek_model_run_stats;

// A model's descriptor: one row per model, written in the model's own file
// (kernels/material/<name>.c) beside its kernels, so that bench, verify,
// the advisor and the tests iterate over models without naming them.
typedef struct {
  ek_model model;
  const char *name;      // ek_model_name: "snh"
  const char *long_name; // scene files: "stable_neo_hookean"
  ek_model_needs needs;  // per element, without clamp
  // 1: P goes through singular values under a clamp > 0 (Irving et al.
  // 2004 sec. 5; then the model needs the full SVD); 0: clamp is ignored.
  int clampable;
  // 1: isotropic, so the Hessian has the U, V-frame eigensystem (Teran et
  // al. 2005) through which dP is projected; 0: linear in F's rotation.
  int isotropic;
  int volume_term;  // 0: lambda is ignored (ARAP, Psi_R)
  int cache_planes; // per-element planes the Hessian caches (hessian.h)
  int j_domain;     // 1: defined for J > 0 only, unless clamped
  // 1: the model has a cloth membrane of the same energy, `membrane` (an
  // ek_membrane_model of cloth_force.h: StVK, ARAP)
  int has_membrane, membrane;
  // A parameter rule of the model's own beyond ek_material_check's common
  // ones (NULL: none): the message, or NULL if (mu, lambda) is valid.
  const char *(*param_error)(double mu, double lambda);
  // The linearisation at F = I (above): (mu, lambda) -> (mu', lambda'),
  // and its inverse: EK_OK, or EK_EINVAL with why (no (mu, lambda) gives
  // these small-strain parameters, e.g. lambda' != 0 without a volume term).
  void (*linearise)(double mu, double lambda, double *mu_lin, double *lambda_lin);
  int (*from_linear)(double mu_lin, double lambda_lin, double *mu, double *lambda, char *why,
                     size_t whylen);
  // Whether a run is outside the model's range of validity (small_strain:
  // the strain bound for small-strain models): NULL, or why (written to
  // why[0 .. whylen)).
  const char *(*excluded)(const ek_model_run_stats *r, double clamp, double small_strain, char *why,
                          size_t whylen);
} ek_model_desc;
// The descriptor of a model; NULL if model is not one.
const ek_model_desc *ek_model_describe(ek_model model);

// Young's modulus E > 0 and Poisson ratio -1 < nu < 0.5 -> Lame parameters:
// mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu)(1 - 2 nu)). Anything
// else (or non-finite) is EK_EINVAL with a message; nothing written.
int ek_lame_from_young_poisson(double E, double nu, double *mu, double *lambda);
// The inverse, for mu > 0, lambda > -2 mu / 3: E = mu (3 lambda + 2 mu) /
// (lambda + mu), nu = lambda / (2 (lambda + mu)).
int ek_young_poisson_from_lame(double mu, double lambda, double *E, double *nu);

#ifdef __cplusplus
}
#endif
#endif
