// Invariants of the gradient and Hessian kernels (include/ek/hessian.h):
//   1. every model x available ISA x product precision x scatter strategy x
//      projection (none, clamp, abs): the gradient equals minus the reference force and the
//      energy the reference energy (EK_FVM_TOL_F64); the product K p
//      equals the reference (the material reference's 9x9 Hessian,
//      projected by LAPACK when asked) within EK_HESSIAN_TOL_F32/_F64, on
//      jittered, renumbered meshes with tails;
//   2. unprojected, K p equals the central difference of the gradient
//      (every model), EK_HESSIAN_FD_TOL;
//   3. projected (clamp and abs), K is symmetric (q.Kp = p.Kq) and PSD (p.Kp >= 0) on
//      random directions;
//   4. the diagonal blocks equal the vertex blocks of K read off products
//      with unit vectors;
//   5. gradient, energy, products and diagonal blocks have the same bits
//      at 1, 2 and 3 threads (every strategy but ATOMIC), on a mesh above the
//      one-thread grains; the gradient of an f32-cache Hessian has the bits
//      of an f64-cache one's;
//   7. the assembled K (check_assembly): entries = the plain assembly of
//      the double reference, CSR K p = the product, symmetric to the bit,
//      projected PSD (LAPACK eigenvalues); same bits at 1, 2 and 3 threads;
//      its upper block triangle in the cache's precision
//      (ek_fvm_hessian_assemble_upper_*): entries = the same reference
//      within the same budgets, same bits at 1, 2 and 3 threads;
//   8. the force's thread buffers reused across meshes after a diagonal
//      pass give a fresh call's bits (check_buffer_reuse);
//   6. neo-Hookean with an inverted tet: energy +inf; bad arguments are
//      refused (products before a caching gradient, wrong precision,
//      corotated linear without R); ISAs the CPU lacks are reported as
//      skipped.
#include <ek/elements.h>
#include <ek/hessian.h>
#include <omp.h>

#include "cli.h"
#include "test_fvm_common.h"
#include "test_tolerances.h"

// Central differences of the kernel's own gradient with step h = 1e-6 of
// the cell size (1e-7): rounding ~1e-16 / h = 1e-9 relative to the
// contribution scale, truncation ~h^2 far below; the same budget as the
// force's (EK_FVM_FD_TOL).
#define EK_HESSIAN_FD_TOL EK_FVM_FD_TOL
// Symmetry and PSD: |q.Kp - p.Kq| and max(0, -p.Kp) relative to
// |p| |Kp| (f64 products).
#define EK_HESSIAN_SYM_TOL 1e-12

static int failures = 0;
static const ek_scatter strategies[] = {EK_SCATTER_AUTO, EK_SCATTER_COLORED,
                                        EK_SCATTER_THREAD_BUFFERS, EK_SCATTER_GATHER,
                                        EK_SCATTER_ATOMIC};
#define NSTRAT ((int)(sizeof strategies / sizeof strategies[0]))

static void fail_if(int bad, const char *what) {
  if (bad) {
    failures++;
    printf("%s: FAIL\n", what);
  }
}

typedef struct {
  ek_tets *el;
  ek_tet_state *R_state;
  const double *R;
} setup;

static ek_fvm_hessian *make(const setup *s, const ek_material *mat, ek_isa isa, ek_scatter sc,
                            int prec, ek_projection pr) {
  ek_fvm_hessian_opts o = {.scatter = sc, .isa = isa, .precision = prec, .projection = pr};
  ek_fvm_hessian *h = ek_fvm_hessian_create(s->el, mat, &o);
  if (!h) {
    printf("ek_fvm_hessian_create: %s\nFAIL\n", ek_last_error());
    failures++;
  }
  return h;
}

// y = K p with the product of the Hessian's precision.
static int apply(const ek_fvm_hessian *h, int prec, size_t n3, const double *p, double *y) {
  if (prec == 64)
    return ek_fvm_hessian_apply_f64(h, p, y);
  float *pf = calloc(n3, sizeof(float)), *yf = malloc(n3 * sizeof(float));
  for (size_t i = 0; i < n3; i++)
    pf[i] = (float)p[i];
  int rc = ek_fvm_hessian_apply_f32(h, pf, yf);
  for (size_t i = 0; i < n3; i++)
    y[i] = yf[i];
  free(pf);
  free(yf);
  return rc;
}

static double dot(size_t n, const double *a, const double *b) {
  double s = 0;
  for (size_t i = 0; i < n; i++)
    s += a[i] * b[i];
  return s;
}

// 1: one model against the reference, every ISA x precision x strategy x
// projection.
static void check_model(const test_model *tm, const test_mesh *t, const setup *s, const double *x,
                        ek_rng *rng) {
  size_t nv = t->nverts, n3 = nv * 3;
  ek_material_ref mref = test_ref_material(&tm->mat);
  double *fref = malloc(n3 * sizeof(double)), *fs = malloc(n3 * sizeof(double));
  double *g = malloc(n3 * sizeof(double)), *p = malloc(n3 * sizeof(double));
  double *y = malloc(n3 * sizeof(double)), *yref = malloc(n3 * sizeof(double));
  double *ys = malloc(n3 * sizeof(double));
  ek_fvm_forces_ref(nv, t->X, t->ntets, t->T, &mref, s->R, x, fref, fs);
  for (size_t i = 0; i < n3; i++)
    fref[i] = -fref[i];
  double Eref = ek_fvm_energy_ref(nv, t->X, t->ntets, t->T, &mref, s->R, x), Escale = 0;
  for (size_t e = 0; e < t->ntets; e++) {
    double F[9], Dmi[9];
    double V0 = ek_fvm_tet_F_ref(t->X, x, t->T + e * 4, F, Dmi);
    Escale += V0 * fabs(ek_psi_ref(&mref, F, s->R ? s->R + e * 9 : NULL));
  }
  for (size_t i = 0; i < n3; i++)
    p[i] = 0.1 * (2 * ek_rng_uniform(rng) - 1); // a cell's size
  double worst_g = 0, worst_E = 0, worst[2][3] = {{0}};
  int cases = 0;
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
    if (!ek_isa_available((ek_isa)isa))
      continue;
    for (int si = 0; si < NSTRAT; si++)
      for (int prec = 32; prec <= 64; prec += 32)
        for (int proj = 0; proj < 3; proj++) { // the reference's: 0 none, 1 clamp, 2 abs
          ek_fvm_hessian *h = make(s, &tm->mat, (ek_isa)isa, strategies[si], prec,
                                   proj == 0   ? EK_PROJECT_NONE
                                   : proj == 1 ? EK_PROJECT_CLAMP
                                               : EK_PROJECT_ABS);
          if (!h)
            continue;
          double E;
          int rc = ek_fvm_hessian_gradient_f64(h, x, s->R_state, g, &E, 1);
          // The f32 product reads p rounded to float: so does its reference.
          double *pp = malloc(n3 * sizeof(double));
          for (size_t i = 0; i < n3; i++)
            pp[i] = prec == 32 ? (double)(float)p[i] : p[i];
          ek_fvm_hessian_apply_ref(nv, t->X, t->ntets, t->T, &mref, s->R, x, pp, proj, yref, ys);
          if (rc == 0)
            rc = apply(h, prec, n3, pp, y);
          free(pp);
          char label[160];
          snprintf(label, sizeof label, "%-17s %-6s f%d %-14s %s", tm->name,
                   ek_isa_name((ek_isa)isa), prec, ek_scatter_name(strategies[si]),
                   proj == 0   ? "exact"
                   : proj == 1 ? "clamp"
                               : "abs");
          if (rc != 0) {
            printf("%s: rc %d (%s)\nFAIL\n", label, rc, ek_last_error());
            failures++;
            ek_fvm_hessian_destroy(h);
            continue;
          }
          size_t wi;
          worst_g = fmax(worst_g, test_force_error(n3, g, fref, fs, &wi));
          worst_E = fmax(worst_E, fabs(E - Eref) / Escale);
          double e = test_force_error(n3, y, yref, ys, &wi);
          double tol = prec == 32 ? EK_HESSIAN_TOL_F32 : EK_HESSIAN_TOL_F64;
          if (!(e <= tol)) {
            printf("%s: K p error %.3g > %g at vertex %zu component %zu (kernel %.9g, reference "
                   "%.17g)\nFAIL\n",
                   label, e, tol, wi / 3, wi % 3, y[wi], yref[wi]);
            failures++;
          }
          worst[prec == 64][proj] = fmax(worst[prec == 64][proj], e);
          cases++;
          ek_fvm_hessian_destroy(h);
        }
  }
  char label[200];
  snprintf(label, sizeof label, "%-17s gradient = -force ref (%d cases)", tm->name, cases);
  failures += ek_check_report(label, worst_g, EK_FVM_TOL_F64);
  snprintf(label, sizeof label, "%-17s energy = ref", tm->name);
  failures += ek_check_report(label, worst_E, EK_FVM_TOL_F64);
  for (int prec = 0; prec < 2; prec++)
    for (int proj = 0; proj < 3; proj++) {
      snprintf(label, sizeof label, "%-17s K p f%d %s", tm->name, prec ? 64 : 32,
               proj == 0   ? "exact"
               : proj == 1 ? "clamp"
                           : "abs");
      failures +=
          ek_check_report(label, worst[prec][proj], prec ? EK_HESSIAN_TOL_F64 : EK_HESSIAN_TOL_F32);
    }
  free(fref);
  free(fs);
  free(g);
  free(p);
  free(y);
  free(yref);
  free(ys);
}

// 2 and 3: finite differences of the gradient (exact Hessian); symmetry
// and PSD (projected).
static void check_fd_sym(const test_model *tm, const test_mesh *t, const setup *s, const double *x,
                         ek_rng *rng) {
  size_t n3 = t->nverts * 3;
  double *p = malloc(n3 * sizeof(double)), *q = malloc(n3 * sizeof(double));
  double *y = malloc(n3 * sizeof(double)), *yq = malloc(n3 * sizeof(double));
  double *gp = malloc(n3 * sizeof(double)), *gm = malloc(n3 * sizeof(double));
  double *xs = malloc(n3 * sizeof(double)), *sc = malloc(n3 * sizeof(double));
  ek_material_ref mref = test_ref_material(&tm->mat);
  for (size_t i = 0; i < n3; i++)
    p[i] = 2 * ek_rng_uniform(rng) - 1;
  ek_fvm_hessian *h = make(s, &tm->mat, EK_ISA_AUTO, EK_SCATTER_AUTO, 64, EK_PROJECT_NONE);
  const double step = 1e-6 * 0.1;
  ek_fvm_hessian_gradient_f64(h, x, s->R_state, gp, NULL, 1);
  ek_fvm_hessian_apply_f64(h, p, y);
  ek_fvm_hessian_apply_ref(t->nverts, t->X, t->ntets, t->T, &mref, s->R, x, p, 0, yq, sc);
  for (size_t i = 0; i < n3; i++)
    xs[i] = x[i] + step * p[i];
  ek_fvm_hessian_gradient_f64(h, xs, s->R_state, gp, NULL, 0);
  for (size_t i = 0; i < n3; i++)
    xs[i] = x[i] - step * p[i];
  ek_fvm_hessian_gradient_f64(h, xs, s->R_state, gm, NULL, 0);
  for (size_t i = 0; i < n3; i++)
    gp[i] = (gp[i] - gm[i]) / (2 * step);
  size_t wi;
  char label[160];
  snprintf(label, sizeof label, "%-17s K p = central difference of the gradient", tm->name);
  failures += ek_check_report(label, test_force_error(n3, y, gp, sc, &wi), EK_HESSIAN_FD_TOL);
  ek_fvm_hessian_destroy(h);

  double sym = 0, psd = 0;
  for (int pr = EK_PROJECT_CLAMP; pr <= EK_PROJECT_ABS; pr++) {
    h = make(s, &tm->mat, EK_ISA_AUTO, EK_SCATTER_AUTO, 64, (ek_projection)pr);
    ek_fvm_hessian_gradient_f64(h, x, s->R_state, gp, NULL, 1);
    for (int r = 0; r < 8; r++) {
      for (size_t i = 0; i < n3; i++) {
        p[i] = 2 * ek_rng_uniform(rng) - 1;
        q[i] = 2 * ek_rng_uniform(rng) - 1;
      }
      ek_fvm_hessian_apply_f64(h, p, y);
      ek_fvm_hessian_apply_f64(h, q, yq);
      double ny = sqrt(dot(n3, y, y)), np = sqrt(dot(n3, p, p)), nq = sqrt(dot(n3, q, q));
      double nyq = sqrt(dot(n3, yq, yq));
      sym = fmax(sym, fabs(dot(n3, q, y) - dot(n3, p, yq)) / fmax(nq * ny, np * nyq));
      psd = fmax(psd, fmax(0, -dot(n3, p, y)) / (np * ny));
    }
    ek_fvm_hessian_destroy(h);
  }
  snprintf(label, sizeof label, "%-17s clamp/abs K symmetric (q.Kp - p.Kq)", tm->name);
  failures += ek_check_report(label, sym, EK_HESSIAN_SYM_TOL);
  snprintf(label, sizeof label, "%-17s clamp/abs K PSD (-p.Kp)", tm->name);
  failures += ek_check_report(label, psd, EK_HESSIAN_SYM_TOL);
  free(p);
  free(q);
  free(y);
  free(yq);
  free(gp);
  free(gm);
  free(xs);
  free(sc);
}

// 4: diagonal blocks = K's vertex blocks from unit products, both
// precisions (each against the products of its own precision).
static void check_diagonal(const test_model *tm, const test_mesh *t, const setup *s,
                           const double *x) {
  size_t nv = t->nverts, n3 = nv * 3;
  double *e = calloc(n3, sizeof(double)), *y = malloc(n3 * sizeof(double));
  double *B = malloc(nv * 6 * sizeof(double)), *g = malloc(n3 * sizeof(double));
  static const int row[6] = {0, 0, 0, 1, 1, 2}, col[6] = {0, 1, 2, 1, 2, 2};
  for (int prec = 32; prec <= 64; prec += 32) {
    ek_fvm_hessian *h = make(s, &tm->mat, EK_ISA_AUTO, EK_SCATTER_AUTO, prec, EK_PROJECT_CLAMP);
    ek_fvm_hessian_gradient_f64(h, x, s->R_state, g, NULL, 1);
    int rc = ek_fvm_hessian_diagonal_f64(h, B);
    double err = rc == 0 ? 0 : INFINITY, scale = 0;
    for (size_t v = 0; v < nv && rc == 0; v++)
      for (int k = 0; k < 3; k++) {
        e[v * 3 + k] = 1;
        apply(h, prec, n3, e, y);
        e[v * 3 + k] = 0;
        for (int c = 0; c < 6; c++) {
          if (col[c] != k)
            continue;
          err = fmax(err, fabs(B[v * 6 + c] - y[v * 3 + row[c]]));
        }
        scale = fmax(scale, fabs(y[v * 3 + k]));
      }
    char label[160];
    snprintf(label, sizeof label, "%-17s diagonal blocks = K e_i, f%d", tm->name, prec);
    failures += ek_check_report(label, err / scale, prec == 32 ? EK_HESSIAN_TOL_F32 : 1e-12);
    ek_fvm_hessian_destroy(h);
  }
  free(e);
  free(y);
  free(B);
  free(g);
}

// 7: the assembled matrix (ek_fvm_hessian_assemble), every ISA x precision x
// strategy (auto, coloured: the two slot orders) x projection: entries equal
// the plain dense assembly of the double reference (reference/fvm/
// hessian_ref.c) within EK_HESSIAN_TOL_*, K p of the CSR equals the
// matrix-free product of the same cache within the same budget, K is
// symmetric to the bit, and projected (clamp, abs) its smallest eigenvalue
// (LAPACK dsyev) is >= -tol times the largest.
extern void dsyev_(const char *jobz, const char *uplo, const int *n, double *a, const int *lda,
                   double *w, double *work, const int *lwork, int *info);

static double min_eig_rel(int n, const double *K) {
  double *a = malloc((size_t)n * n * sizeof(double)), *w = malloc((size_t)n * sizeof(double));
  int lwork = 8 * n, info = 0;
  double *work = malloc((size_t)lwork * sizeof(double));
  memcpy(a, K, (size_t)n * n * sizeof(double));
  dsyev_("N", "U", &n, a, &n, w, work, &lwork, &info);
  double r = info == 0 ? w[0] / fmax(fabs(w[n - 1]), 1e-300) : -INFINITY;
  free(a);
  free(w);
  free(work);
  return r;
}

static void check_assembly(const test_model *tm, const test_mesh *t, const setup *s,
                           const double *x, ek_rng *rng) {
  const size_t nv = t->nverts, n3 = nv * 3;
  ek_material_ref mref = test_ref_material(&tm->mat);
  double *K = malloc(n3 * n3 * sizeof(double)), *Kref = malloc(n3 * n3 * sizeof(double));
  double *Ks = malloc(n3 * n3 * sizeof(double)), *g = malloc(n3 * sizeof(double));
  double *p = malloc(n3 * sizeof(double)), *y = malloc(n3 * sizeof(double));
  double *yk = malloc(n3 * sizeof(double)), *ys = malloc(n3 * sizeof(double));
  for (size_t i = 0; i < n3; i++)
    p[i] = 0.1 * (2 * ek_rng_uniform(rng) - 1);
  static const ek_scatter orders[2] = {EK_SCATTER_AUTO, EK_SCATTER_COLORED};
  static const ek_projection projs[3] = {EK_PROJECT_NONE, EK_PROJECT_CLAMP, EK_PROJECT_ABS};
  double worst_ref[2] = {0}, worst_kp[2] = {0}, worst_up[2] = {0}, worst_eig = INFINITY;
  double *Ku = malloc(n3 * n3 * sizeof(double));
  int cases = 0, asym = 0;
  for (int proj = 0; proj < 3; proj++) {
    ek_fvm_hessian_assemble_ref(nv, t->X, t->ntets, t->T, &mref, s->R, x, proj, Kref, Ks);
    double kscale = 0;
    for (size_t i = 0; i < n3 * n3; i++)
      kscale = fmax(kscale, Ks[i]);
    for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++) {
      if (!ek_isa_available((ek_isa)isa))
        continue;
      for (int oi = 0; oi < 2; oi++)
        for (int prec = 32; prec <= 64; prec += 32) {
          ek_fvm_hessian *h = make(s, &tm->mat, (ek_isa)isa, orders[oi], prec, projs[proj]);
          if (!h)
            continue;
          ek_csr_pattern pat;
          int rc = ek_fvm_hessian_gradient_f64(h, x, s->R_state, g, NULL, 1);
          if (rc == 0)
            rc = ek_fvm_hessian_pattern(h, &pat);
          double *v = rc == 0 ? malloc(pat.nnz * sizeof(double)) : NULL;
          if (rc == 0)
            rc = ek_fvm_hessian_assemble(h, v);
          if (rc == 0)
            rc = apply(h, prec, n3, p, y);
          char label[160];
          snprintf(label, sizeof label, "%-17s %-6s f%d %s assembled, %s", tm->name,
                   ek_isa_name((ek_isa)isa), prec, ek_scatter_name(orders[oi]),
                   ek_projection_name(projs[proj]));
          if (rc != 0 || pat.nrows != n3) {
            printf("%s: rc %d (%s)\nFAIL\n", label, rc, ek_last_error());
            failures++;
            free(v);
            ek_fvm_hessian_destroy(h);
            continue;
          }
          memset(K, 0, n3 * n3 * sizeof(double));
          for (size_t r = 0; r < n3; r++)
            for (int32_t k = pat.row_ptr[r]; k < pat.row_ptr[r + 1]; k++)
              K[r * n3 + (size_t)pat.col[k]] = v[k];
          double eref = 0, ekp = 0, yscale = 0;
          for (size_t r = 0; r < n3; r++) {
            double acc = 0, sc = 0;
            for (size_t c = 0; c < n3; c++) {
              eref = fmax(eref, fabs(K[r * n3 + c] - Kref[r * n3 + c]));
              asym += memcmp(&K[r * n3 + c], &K[c * n3 + r], sizeof(double)) != 0;
              acc += K[r * n3 + c] * (prec == 32 ? (double)(float)p[c] : p[c]);
              sc += fabs(K[r * n3 + c] * p[c]);
            }
            yk[r] = acc;
            ys[r] = sc;
            yscale = fmax(yscale, sc);
          }
          for (size_t r = 0; r < n3; r++)
            ekp = fmax(ekp, fabs(yk[r] - y[r]));
          eref /= kscale;
          ekp /= yscale;
          const double tol = prec == 32 ? EK_HESSIAN_TOL_F32 : EK_HESSIAN_TOL_F64;
          if (!(eref <= tol) || !(ekp <= tol)) {
            printf("%s: entries vs reference %.3g, K p vs product %.3g > %g\nFAIL\n", label, eref,
                   ekp, tol);
            failures++;
          }
          worst_ref[prec == 64] = fmax(worst_ref[prec == 64], eref);
          worst_kp[prec == 64] = fmax(worst_kp[prec == 64], ekp);
          // The upper block triangle (ek_fvm_hessian_assemble_upper_*), in
          // the cache's precision, mirrored into a dense K: the same budget
          // against the reference.
          ek_bsr_pattern up;
          rc = ek_fvm_hessian_pattern_upper(h, &up);
          void *uv = rc == 0 ? malloc(9 * up.nblocks * (prec == 32 ? 4 : 8)) : NULL;
          if (rc == 0)
            rc = prec == 32 ? ek_fvm_hessian_assemble_upper_f32(h, uv)
                            : ek_fvm_hessian_assemble_upper_f64(h, uv);
          double eup = INFINITY;
          if (rc == 0 && up.nbrows == nv) {
            memset(Ku, 0, n3 * n3 * sizeof(double));
            int shape = 1;
            for (size_t v = 0; v < nv; v++)
              for (int32_t q = up.bptr[v]; q < up.bptr[v + 1]; q++) {
                const size_t w = (size_t)up.bcol[q];
                shape &= w >= v && (q > up.bptr[v] || w == v);
                for (int i = 0; i < 3; i++)
                  for (int m = 0; m < 3; m++) {
                    const size_t k = 9 * (size_t)q + (size_t)(3 * i + m);
                    const double e = prec == 32 ? ((float *)uv)[k] : ((double *)uv)[k];
                    Ku[(3 * v + i) * n3 + 3 * w + m] = e;
                    Ku[(3 * w + m) * n3 + 3 * v + i] = e;
                  }
              }
            eup = 0;
            for (size_t i = 0; i < n3 * n3; i++)
              eup = fmax(eup, fabs(Ku[i] - Kref[i]));
            eup = shape ? eup / kscale : INFINITY;
          }
          if (!(eup <= tol)) {
            printf("%s: upper triangle: rc %d (%s), entries vs reference %.3g > %g\nFAIL\n", label,
                   rc, rc ? ek_last_error() : "", eup, tol);
            failures++;
          }
          worst_up[prec == 64] = fmax(worst_up[prec == 64], eup);
          free(uv);
          if (projs[proj] != EK_PROJECT_NONE) {
            double me = min_eig_rel((int)n3, K);
            if (!(me >= -tol)) {
              printf("%s: smallest eigenvalue / largest %.3g < -%g\nFAIL\n", label, me, tol);
              failures++;
            }
            worst_eig = fmin(worst_eig, me);
          }
          cases++;
          free(v);
          ek_fvm_hessian_destroy(h);
        }
    }
  }
  printf("%-17s assembled K (%d cases): entries vs ref f32 %.3g f64 %.3g; CSR K p vs product f32 "
         "%.3g f64 %.3g; asymmetric entries %d; projected min eig / max %.3g: %s\n",
         tm->name, cases, worst_ref[0], worst_ref[1], worst_kp[0], worst_kp[1], asym, worst_eig,
         asym ? "FAIL" : "PASS");
  printf("%-17s upper block triangle (%d cases): entries vs ref f32 %.3g (/ budget %.3g) f64 "
         "%.3g (/ budget %.3g)\n",
         tm->name, cases, worst_up[0], worst_up[0] / EK_HESSIAN_TOL_F32, worst_up[1],
         worst_up[1] / EK_HESSIAN_TOL_F64);
  failures += asym != 0;
  free(Ku);
  free(K);
  free(Kref);
  free(Ks);
  free(g);
  free(p);
  free(y);
  free(yk);
  free(ys);
}

// 5: bits at 1, 2 and 3 threads (3: more threads than this machine's
// cores, the assembly's plan in 3 parts).
static void check_threads(ek_rng *rng) {
  test_mesh t = test_mesh_random(rng, 12, 10, 8, 0.2); // 5760 tets: above the grains
  ek_tets *el = ek_tets_create(t.nverts, t.X, t.ntets, t.T);
  size_t n3 = t.nverts * 3;
  double *x = malloc(n3 * sizeof(double)), *p = malloc(n3 * sizeof(double));
  test_deform(rng, &t, 0.2, 0.1, x);
  for (size_t i = 0; i < n3; i++)
    p[i] = 2 * ek_rng_uniform(rng) - 1;
  double *out[3][4];
  float *o32[3];
  for (int r = 0; r < 3; r++) {
    for (int k = 0; k < 4; k++)
      out[r][k] = malloc(t.nverts * 6 * sizeof(double));
    o32[r] = malloc(n3 * sizeof(float));
  }
  float *p32 = malloc(n3 * sizeof(float));
  for (size_t i = 0; i < n3; i++)
    p32[i] = (float)p[i];
  int same = 1, grad32 = 1, cases = 0;
  ek_material mats[2] = {{EK_MODEL_STABLE_NEO_HOOKEAN, 1, 2, 0},
                         {EK_MODEL_FIXED_COROTATED, 1, 2, 0}};
  for (int mi = 0; mi < 2; mi++)
    for (int si = 0; si < NSTRAT; si++) {
      if (strategies[si] == EK_SCATTER_ATOMIC)
        continue;
      double E[3];
      for (int r = 0; r < 3; r++) {
        omp_set_num_threads(r + 1);
        // Outputs poisoned (all overwritten, hessian.h): the buffers hold
        // the previous case's results, which a chunk that did not run
        // would leave.
        for (int k = 0; k < 4; k++)
          ek_check_poison(out[r][k], t.nverts * 6 * sizeof(double));
        ek_check_poison(o32[r], n3 * sizeof(float));
        ek_check_poison(&E[r], sizeof E[r]);
        ek_fvm_hessian_opts o = {.scatter = strategies[si]};
        ek_fvm_hessian *h = ek_fvm_hessian_create(el, &mats[mi], &o);
        ek_fvm_hessian_gradient_f64(h, x, NULL, out[r][0], &E[r], 1);
        ek_fvm_hessian_apply_f64(h, p, out[r][1]);
        ek_fvm_hessian_diagonal_f64(h, out[r][2]);
        ek_fvm_hessian_destroy(h);
        o.precision = 32;
        h = ek_fvm_hessian_create(el, &mats[mi], &o);
        ek_fvm_hessian_gradient_f64(h, x, NULL, out[r][3], NULL, 1);
        ek_fvm_hessian_apply_f32(h, p32, o32[r]);
        ek_fvm_hessian_destroy(h);
      }
      for (int r = 1; r < 3; r++) {
        same &= memcmp(&E[0], &E[r], sizeof(double)) == 0;
        same &= memcmp(out[0][0], out[r][0], n3 * sizeof(double)) == 0;
        same &= memcmp(out[0][1], out[r][1], n3 * sizeof(double)) == 0;
        same &= memcmp(out[0][2], out[r][2], t.nverts * 6 * sizeof(double)) == 0;
        same &= memcmp(o32[0], o32[r], n3 * sizeof(float)) == 0;
        same &= memcmp(out[0][3], out[r][3], n3 * sizeof(double)) == 0;
      }
      // The f32 cache's context gives the f64 one's gradient bits at every
      // thread count: the gradient pass is the same double kernel for
      // both precisions (hessian.h: "computed in double either way";
      // hessian.c), only the cache it writes differs.
      for (int r = 0; r < 3; r++)
        grad32 &= memcmp(out[r][0], out[r][3], n3 * sizeof(double)) == 0;
      cases++;
    }
  // The assembled matrix (f64 and f32 element kernels, both slot orders)
  // and the upper block triangle (in the cache's precision), each from one
  // context per thread count.
  int asame = 1, usame = 1;
  for (int oi = 0; oi < 2; oi++)
    for (int prec = 32; prec <= 64; prec += 32) {
      double *v[3] = {NULL, NULL, NULL};
      void *u[3] = {NULL, NULL, NULL};
      size_t nnz = 0, ub = 0;
      for (int r = 0; r < 3; r++) {
        omp_set_num_threads(r + 1);
        ek_fvm_hessian_opts o = {.scatter = oi ? EK_SCATTER_COLORED : EK_SCATTER_AUTO,
                                 .precision = prec};
        ek_fvm_hessian *h = ek_fvm_hessian_create(el, &mats[0], &o);
        ek_csr_pattern pat;
        ek_bsr_pattern up;
        ek_fvm_hessian_gradient_f64(h, x, NULL, out[r][0], NULL, 1);
        if (ek_fvm_hessian_pattern(h, &pat) == 0) {
          nnz = pat.nnz;
          v[r] = ek_check_poison(malloc(nnz * sizeof(double)), nnz * sizeof(double));
          if (ek_fvm_hessian_assemble(h, v[r]) != 0)
            asame = 0;
        }
        if (ek_fvm_hessian_pattern_upper(h, &up) == 0) {
          ub = 9 * up.nblocks * (prec == 32 ? 4 : 8);
          u[r] = ek_check_poison(malloc(ub), ub);
          if ((prec == 32 ? ek_fvm_hessian_assemble_upper_f32(h, u[r])
                          : ek_fvm_hessian_assemble_upper_f64(h, u[r])) != 0)
            usame = 0;
        }
        ek_fvm_hessian_destroy(h);
      }
      for (int r = 1; r < 3; r++) {
        asame &= v[0] && v[r] && memcmp(v[0], v[r], nnz * sizeof(double)) == 0;
        usame &= u[0] && u[r] && memcmp(u[0], u[r], ub) == 0;
      }
      for (int r = 0; r < 3; r++) {
        free(v[r]);
        free(u[r]);
      }
    }
  printf("1, 2 and 3 threads: same bits for the upper block triangle (f32, f64; both orders): %s\n",
         usame ? "PASS" : "FAIL");
  failures += !usame;
  printf("1, 2 and 3 threads: same bits for the assembled K (f32, f64 elements; both orders): %s\n",
         asame ? "PASS" : "FAIL");
  failures += !asame;
  omp_set_num_threads(2);
  printf("1, 2 and 3 threads: same bits for gradient (f64 and f32 caches), energy, K p (f64, f32), "
         "diagonal blocks, %zu tets, %d cases: %s\n",
         t.ntets, cases, same ? "PASS" : "FAIL");
  failures += !same;
  printf("gradient with the f32 cache = with the f64 cache, same bits (1, 2 and 3 threads, %d "
         "cases): %s\n",
         cases, grad32 ? "PASS" : "FAIL");
  failures += !grad32;
  for (int r = 0; r < 3; r++) {
    for (int k = 0; k < 4; k++)
      free(out[r][k]);
    free(o32[r]);
  }
  free(p32);
  free(x);
  free(p);
  ek_tets_destroy(el);
  test_mesh_free(&t);
}

// The product in parts (ek_fvm_hessian_apply_part / _rows, sim/implicit.c's
// CG): the parts run in reverse order or on a parallel loop, the rows in
// uneven ranges, against ek_fvm_hessian_apply_* at 2 threads: the same bits
// (f32, f64, two models); with the coloured scatter there are no parts and
// a part's call is refused.
static void check_parts(ek_rng *rng) {
  test_mesh t = test_mesh_random(rng, 12, 10, 8, 0.2); // 5760 tets: above the grains
  ek_tets *el = ek_tets_create(t.nverts, t.X, t.ntets, t.T);
  const size_t n3 = t.nverts * 3, cut = t.nverts / 3;
  double *x = malloc(n3 * sizeof(double)), *p = malloc(n3 * sizeof(double));
  double *y = malloc(n3 * sizeof(double)), *yp = malloc(n3 * sizeof(double));
  float *p32 = malloc(n3 * sizeof(float)), *y32 = malloc(n3 * sizeof(float));
  float *yp32 = malloc(n3 * sizeof(float));
  test_deform(rng, &t, 0.2, 0.1, x);
  for (size_t i = 0; i < n3; i++) {
    p[i] = 2 * ek_rng_uniform(rng) - 1;
    p32[i] = (float)p[i];
  }
  const ek_material mats[2] = {{EK_MODEL_STABLE_NEO_HOOKEAN, 1, 2, 0},
                               {EK_MODEL_FIXED_COROTATED, 1, 2, 0}};
  int same = 1, cases = 0, refused = 1;
  omp_set_num_threads(2);
  for (int mi = 0; mi < 2; mi++)
    for (int prec = 32; prec <= 64; prec += 32)
      for (int order = 0; order < 2; order++) {
        ek_fvm_hessian_opts o = {.precision = prec};
        ek_fvm_hessian *h = ek_fvm_hessian_create(el, &mats[mi], &o);
        int par = 0, np = ek_fvm_hessian_apply_parts(h, &par);
        ek_fvm_hessian_gradient_f64(h, x, NULL, y, NULL, 1);
        if (prec == 64)
          ek_fvm_hessian_apply_f64(h, p, y);
        else
          ek_fvm_hessian_apply_f32(h, p32, y32);
        int rc = 0;
        if (order == 0)
          for (int k = np - 1; k >= 0; k--)
            rc |= prec == 64 ? ek_fvm_hessian_apply_part_f64(h, p, k)
                             : ek_fvm_hessian_apply_part_f32(h, p32, k);
        else {
#pragma omp parallel for schedule(dynamic, 1) reduction(| : rc)
          for (int k = 0; k < np; k++)
            rc |= prec == 64 ? ek_fvm_hessian_apply_part_f64(h, p, k)
                             : ek_fvm_hessian_apply_part_f32(h, p32, k);
        }
        if (prec == 64) {
          ek_fvm_hessian_apply_rows_f64(h, cut, t.nverts, yp);
          ek_fvm_hessian_apply_rows_f64(h, 0, cut, yp);
          same &= memcmp(y, yp, n3 * sizeof(double)) == 0;
        } else {
          ek_fvm_hessian_apply_rows_f32(h, cut, t.nverts, yp32);
          ek_fvm_hessian_apply_rows_f32(h, 0, cut, yp32);
          same &= memcmp(y32, yp32, n3 * sizeof(float)) == 0;
        }
        same &= rc == 0 && np == EK_FVM_PARTS && par == 1;
        ek_fvm_hessian_destroy(h);
        cases++;
      }
  ek_fvm_hessian_opts oc = {.scatter = EK_SCATTER_COLORED};
  ek_fvm_hessian *h = ek_fvm_hessian_create(el, &mats[0], &oc);
  int par = 0;
  ek_fvm_hessian_gradient_f64(h, x, NULL, y, NULL, 1);
  refused &= ek_fvm_hessian_apply_parts(h, &par) == 0;
  refused &= ek_fvm_hessian_apply_part_f64(h, p, 0) == EK_EINVAL;
  ek_fvm_hessian_destroy(h);
  printf("K p in parts: same bits as the product, %zu tets, %d cases: %s\n", t.ntets, cases,
         same ? "PASS" : "FAIL");
  printf("K p in parts: none with the coloured scatter, a part refused: %s\n",
         refused ? "PASS" : "FAIL");
  failures += !same + !refused;
  free(x);
  free(p);
  free(y);
  free(yp);
  free(p32);
  free(y32);
  free(yp32);
  ek_tets_destroy(el);
  test_mesh_free(&t);
}

// 6: the domain and bad arguments.
static void check_errors(void) {
  double X[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, x[12], g[12], y[12];
  int32_t T[4] = {0, 1, 2, 3};
  ek_tets *el = ek_tets_create(4, X, 1, T);
  memcpy(x, X, sizeof x);
  x[3 * 3 + 2] = -0.5; // inverted
  ek_material nh = {EK_MODEL_NEO_HOOKEAN, 1, 2, 0}, cl = {EK_MODEL_COROTATED_LINEAR, 1, 2, 0};
  ek_fvm_hessian *h = ek_fvm_hessian_create(el, &nh, NULL);
  int rc = ek_fvm_hessian_apply_f64(h, x, y);
  fail_if(rc != EK_EINVAL, "a product before any caching gradient is refused");
  double uv[9 * 10]; // the upper pattern of one tet: 10 blocks
  float uf[9 * 10];
  fail_if(ek_fvm_hessian_assemble_upper_f64(h, uv) != EK_EINVAL,
          "the upper assembly before any caching gradient is refused");
  double E = 0;
  rc = ek_fvm_hessian_gradient_f64(h, x, NULL, g, &E, 1);
  printf("neo-Hookean, inverted tet: rc %d, energy %g (expected +inf)\n", rc, E);
  fail_if(rc != 0 || !(isinf(E) && E > 0), "inverted neo-Hookean energy is +inf");
  float pf[12] = {0}, yf[12];
  fail_if(ek_fvm_hessian_apply_f32(h, pf, yf) != EK_EINVAL, "f32 product on an f64 cache refused");
  fail_if(ek_fvm_hessian_assemble_upper_f32(h, uf) != EK_EINVAL,
          "f32 upper assembly on an f64 cache refused");
  fail_if(ek_fvm_hessian_assemble_upper_f64(h, NULL) != EK_EINVAL,
          "the upper assembly into NULL refused");
  ek_fvm_hessian_destroy(h);
  h = ek_fvm_hessian_create(el, &cl, NULL);
  fail_if(ek_fvm_hessian_gradient_f64(h, X, NULL, g, NULL, 1) != EK_EINVAL,
          "corotated linear without R refused");
  ek_fvm_hessian_destroy(h);
  ek_fvm_hessian_opts bad = {.precision = 16};
  fail_if(ek_fvm_hessian_create(el, &nh, &bad) != NULL, "precision 16 refused");
  for (int isa = EK_ISA_SCALAR; isa < EK_ISA_COUNT; isa++)
    if (!ek_isa_available((ek_isa)isa)) {
      ek_fvm_hessian_opts o = {.isa = (ek_isa)isa};
      h = ek_fvm_hessian_create(el, &nh, &o);
      printf("skipped %s: not available on this CPU/build (create refused: %s)\n",
             ek_isa_name((ek_isa)isa), h ? "FAIL" : "PASS");
      failures += h != NULL;
      ek_fvm_hessian_destroy(h);
    }
  printf("errors and domain: %s\n", failures ? "(see above)" : "PASS");
  ek_tets_destroy(el);
}

// 8. The force's thread buffers are kept zero between calls (scatter.c):
// a diagonal pass (rows of 6) on a mesh A leaves its rows beyond the
// force's extent on A; a force on A, then on a mesh B whose extent reaches
// past A's (nv_A < nv_B < 1.5 nv_A), must still give the bits of B's force
// taken before (the same strategy and thread count). Zeroing only A's
// extent before setting the "zero" flag failed this (and twist in
// test_scenes_hold blew up).
static void check_buffer_reuse(ek_rng *rng) {
  test_mesh ta = test_mesh_random(rng, 6, 5, 4, 0.2), tb = test_mesh_random(rng, 7, 5, 4, 0.2);
  ek_tets *ea = ek_tets_create(ta.nverts, ta.X, ta.ntets, ta.T);
  ek_tets *eb = ek_tets_create(tb.nverts, tb.X, tb.ntets, tb.T);
  double *xa = malloc(ta.nverts * 3 * sizeof(double)), *xb = malloc(tb.nverts * 3 * sizeof(double));
  double *fa = malloc(ta.nverts * 3 * sizeof(double)),
         *diag = malloc(ta.nverts * 6 * sizeof(double));
  double *fb = malloc(tb.nverts * 3 * sizeof(double)),
         *fb_ref = malloc(tb.nverts * 3 * sizeof(double));
  test_deform(rng, &ta, 0.2, 0.1, xa);
  test_deform(rng, &tb, 0.2, 0.1, xb);
  const ek_material mat = {EK_MODEL_STABLE_NEO_HOOKEAN, 1, 2, 0};
  ek_fvm_opts buffers = {.scatter = EK_SCATTER_THREAD_BUFFERS};
  int rc = ek_fvm_tet_forces_ex_f64(eb, &mat, xb, fb_ref, &buffers);
  ek_fvm_hessian_opts ho = {.scatter = EK_SCATTER_THREAD_BUFFERS};
  ek_fvm_hessian *h = ek_fvm_hessian_create(ea, &mat, &ho);
  rc |= !h || ek_fvm_hessian_gradient_f64(h, xa, NULL, fa, NULL, 1);
  rc |= !h || ek_fvm_hessian_diagonal_f64(h, diag);
  rc |= ek_fvm_tet_forces_ex_f64(ea, &mat, xa, fa, &buffers);
  rc |= ek_fvm_tet_forces_ex_f64(eb, &mat, xb, fb, &buffers);
  const int same = memcmp(fb, fb_ref, tb.nverts * 3 * sizeof(double)) == 0;
  printf("thread buffers reused across meshes (%zu then %zu vertices, a diagonal pass "
         "between): %s\n",
         ta.nverts, tb.nverts,
         rc     ? "call failed"
         : same ? "same bits as before"
                : "differ");
  fail_if(rc || !same, "thread buffers reused across meshes");
  ek_fvm_hessian_destroy(h);
  ek_tets_destroy(ea);
  ek_tets_destroy(eb);
  free(xa);
  free(xb);
  free(fa);
  free(diag);
  free(fb);
  free(fb_ref);
  test_mesh_free(&ta);
  test_mesh_free(&tb);
}

int main(int argc, char **argv) {
  uint64_t seed = ek_cli_test_args(argc, argv, 2026, NULL);
  printf("test_hessian: seed %llu\n", (unsigned long long)seed);
  ek_rng rng;
  ek_rng_seed(&rng, seed);
  check_errors();
  // A tail: 3*3*2*6 = 108 tets (not a multiple of 16).
  test_mesh t = test_mesh_random(&rng, 3, 3, 2, 0.2);
  ek_tets *el = ek_tets_create(t.nverts, t.X, t.ntets, t.T);
  double *x = malloc(t.nverts * 3 * sizeof(double));
  test_deform(&rng, &t, 0.25, 0.1, x);
  double *R = test_rotations(&rng, t.ntets);
  ek_tet_state *Rs = ek_tet_state_create(el, 9, 1);
  ek_tet_state_set_f64(Rs, R);
  for (int mi = 0; mi < test_nmodels; mi++) {
    const test_model *tm = &test_models[mi];
    int corot = tm->mat.model == EK_MODEL_COROTATED_LINEAR;
    setup s = {el, corot ? Rs : NULL, corot ? R : NULL};
    check_model(tm, &t, &s, x, &rng);
    check_fd_sym(tm, &t, &s, x, &rng);
    check_diagonal(tm, &t, &s, x);
    check_assembly(tm, &t, &s, x, &rng);
  }
  check_threads(&rng);
  check_parts(&rng);
  check_buffer_reuse(&rng);
  ek_tet_state_destroy(Rs);
  ek_tets_destroy(el);
  free(R);
  free(x);
  test_mesh_free(&t);
  printf("%s\n", failures ? "FAIL" : "PASS");
  return failures != 0;
}
