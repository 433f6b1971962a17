/* Screen: MUMPS (casadi's libcoinmumps, IPOPT's settings) against MKL PARDISO (through the
 * pardiso-project shim, IPOPT's iparm) on the KKT matrices IPOPT wrote (IPOPT_WRITE_MAT).
 * usage: kkt_screen SHIM.so REPS file1.iajaa file2.iajaa ...   (the files of one solve, in order)
 * Both solvers: analysis once on the first matrix, then numeric factorisation + one solve of the
 * file's right-hand side for every matrix in order (as IPOPT does within a solve); the sequence
 * is repeated REPS times, the solvers alternating. CPU time of this process.
 * $GAITSMITH_PARDISO_IPARM reaches the shim (MKL iparm slots set after its translation).
 * Residual: ||A x - b||_inf / ||b||_inf of the single solve, without IPOPT's refinement. */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dmumps_c.h"

typedef void (*pinit_fn)(void *, const int *, const int *, int *, double *, int *);
typedef void (*pardiso_fn)(void **, const int *, const int *, const int *, const int *,
                           const int *, const double *, const int *, const int *, const int *,
                           const int *, int *, const int *, double *, double *, int *, double *);

typedef struct {
  int n, nnz;
  int *ia, *ja;
  double *a, *b;
} Mat;

static double cpu(void) {
  struct timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

static Mat readmat(const char *path) {
  Mat m;
  FILE *f = fopen(path, "r");
  if (!f) { perror(path); exit(1); }
  if (fscanf(f, "%d %d", &m.n, &m.nnz) != 2) exit(2);
  m.ia = malloc((m.n + 1) * sizeof(int));
  m.ja = malloc(m.nnz * sizeof(int));
  m.a = malloc(m.nnz * sizeof(double));
  m.b = malloc(m.n * sizeof(double));
  for (int i = 0; i <= m.n; ++i) if (fscanf(f, "%d", &m.ia[i]) != 1) exit(3);
  for (int i = 0; i < m.nnz; ++i) if (fscanf(f, "%d", &m.ja[i]) != 1) exit(3);
  for (int i = 0; i < m.nnz; ++i) if (fscanf(f, "%lf", &m.a[i]) != 1) exit(3);
  for (int i = 0; i < m.n; ++i) if (fscanf(f, "%lf", &m.b[i]) != 1) exit(4);
  fclose(f);
  return m;
}

/* ||A x - b||_inf / ||b||_inf with A symmetric, upper CSR 1-based */
static double resid(const Mat *m, const double *x) {
  double *r = calloc(m->n, sizeof(double));
  for (int i = 0; i < m->n; ++i)
    for (int k = m->ia[i] - 1; k < m->ia[i + 1] - 1; ++k) {
      int j = m->ja[k] - 1;
      r[i] += m->a[k] * x[j];
      if (j != i) r[j] += m->a[k] * x[i];
    }
  double num = 0, den = 0;
  for (int i = 0; i < m->n; ++i) {
    num = fmax(num, fabs(r[i] - m->b[i]));
    den = fmax(den, fabs(m->b[i]));
  }
  free(r);
  return num / (den > 0 ? den : 1);
}

int main(int argc, char **argv) {
  if (argc < 4) {
    fprintf(stderr, "usage: kkt_screen SHIM.so REPS FILE.iajaa...\n");
    return 1;
  }
  void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
  if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 1; }
  pinit_fn pinit = (pinit_fn)dlsym(lib, "pardisoinit");
  pardiso_fn pard = (pardiso_fn)dlsym(lib, "pardiso");
  int reps = atoi(argv[2]);
  int nm = argc - 3;
  Mat *ms = malloc(nm * sizeof(Mat));
  for (int k = 0; k < nm; ++k) ms[k] = readmat(argv[3 + k]);
  int n = ms[0].n, nnz = ms[0].nnz;
  double *x = malloc(n * sizeof(double));
  /* MUMPS triplets from the upper CSR */
  int *irn = malloc(nnz * sizeof(int)), *jcn = malloc(nnz * sizeof(int));
  for (int i = 0; i < n; ++i)
    for (int k = ms[0].ia[i] - 1; k < ms[0].ia[i + 1] - 1; ++k) { irn[k] = i + 1; jcn[k] = ms[0].ja[k]; }

  double t_mu_ana = 0, t_mu_fac = 0, t_mu_sol = 0, t_mk_ana = 0, t_mk_fac = 0, t_mk_sol = 0;
  int agree = 0, perturbed = 0;
  double worst_mu = 0, worst_mk = 0;
  long mk_lnnz = 0, mu_lnnz = 0;
  for (int rep = 0; rep < reps; ++rep) {
    /* ---- MUMPS ---- */
    DMUMPS_STRUC_C id;
    memset(&id, 0, sizeof id);
    id.job = -1; id.par = 1; id.sym = 2; id.comm_fortran = -987654;
    dmumps_c(&id);
    id.icntl[0] = -1; id.icntl[1] = -1; id.icntl[2] = -1; id.icntl[3] = 0;
    id.n = n; id.nnz = nnz; id.irn = irn; id.jcn = jcn; id.a = ms[0].a;
    id.icntl[5] = 7; id.icntl[6] = 5; id.icntl[7] = 77; id.icntl[9] = 0; id.icntl[12] = 1;
    id.icntl[13] = 100; id.cntl[0] = 1e-6;
    double t0 = cpu();
    id.job = 1; dmumps_c(&id);
    t_mu_ana += cpu() - t0;
    if (id.info[0] < 0) { fprintf(stderr, "mumps ana %d\n", id.info[0]); return 1; }
    int *mu_neg = malloc(nm * sizeof(int));
    for (int k = 0; k < nm; ++k) {
      id.a = ms[k].a;
      t0 = cpu();
      id.job = 2; dmumps_c(&id);
      t_mu_fac += cpu() - t0;
      if (id.info[0] == -10) { mu_neg[k] = -1; if (rep == 0) fprintf(stderr, "  mat %d: MUMPS says singular\n", k); continue; }
      if (id.info[0] < 0) { fprintf(stderr, "mumps fac %d (mat %d)\n", id.info[0], k); return 1; }
      mu_neg[k] = id.infog[11];
      mu_lnnz = id.infog[28];
      memcpy(x, ms[k].b, n * sizeof(double));
      id.rhs = x; id.nrhs = 1; id.lrhs = n;
      t0 = cpu();
      id.job = 3; dmumps_c(&id);
      t_mu_sol += cpu() - t0;
      worst_mu = fmax(worst_mu, resid(&ms[k], x));
    }
    id.job = -2; dmumps_c(&id);
    /* ---- MKL PARDISO through the shim, IPOPT's iparm ---- */
    void *pt[64] = {0};
    int iparm[64] = {0};
    double dparm[64] = {0};
    int mtype = -2, solver = 0, err = 0, one = 1, msg = 0, nrhs = 1, perm = 0, phase;
    pinit(pt, &mtype, &solver, iparm, dparm, &err);
    iparm[0] = 1; iparm[1] = 2; iparm[2] = 1; iparm[5] = 1; iparm[7] = 0; iparm[9] = 12;
    iparm[10] = 2; iparm[12] = 2; iparm[20] = 3; iparm[23] = 1; iparm[24] = 1; iparm[28] = 0;
    iparm[29] = 80;
    double bd, xd;
    phase = 11;
    t0 = cpu();
    pard(pt, &one, &one, &mtype, &phase, &n, ms[0].a, ms[0].ia, ms[0].ja, &perm, &nrhs, iparm,
         &msg, &bd, &xd, &err, dparm);
    t_mk_ana += cpu() - t0;
    if (err) { fprintf(stderr, "mkl ana %d\n", err); return 1; }
    mk_lnnz = iparm[17];
    double *xx = malloc(n * sizeof(double));
    for (int k = 0; k < nm; ++k) {
      phase = 22;
      t0 = cpu();
      pard(pt, &one, &one, &mtype, &phase, &n, ms[k].a, ms[k].ia, ms[k].ja, &perm, &nrhs, iparm,
           &msg, &bd, &xd, &err, dparm);
      t_mk_fac += cpu() - t0;
      if (err) { fprintf(stderr, "mkl fac %d (mat %d)\n", err, k); return 1; }
      if (rep == 0) {
        agree += iparm[22] == mu_neg[k];
        perturbed += iparm[13] != 0;
        if (iparm[22] != mu_neg[k])
          fprintf(stderr, "  mat %d: negative eigenvalues MKL %d MUMPS %d (perturbed %d)\n", k,
                  iparm[22], mu_neg[k], iparm[13]);
      }
      memcpy(x, ms[k].b, n * sizeof(double));
      phase = 33;
      t0 = cpu();
      pard(pt, &one, &one, &mtype, &phase, &n, ms[k].a, ms[k].ia, ms[k].ja, &perm, &nrhs, iparm,
           &msg, x, xx, &err, dparm);
      t_mk_sol += cpu() - t0;
      worst_mk = fmax(worst_mk, resid(&ms[k], x));
    }
    phase = -1;
    pard(pt, &one, &one, &mtype, &phase, &n, ms[0].a, ms[0].ia, ms[0].ja, &perm, &nrhs, iparm,
         &msg, &bd, &xd, &err, dparm);
    free(xx);
    free(mu_neg);
  }
  printf("n %d nnz(upper) %d matrices %d reps %d\n", n, nnz, nm, reps);
  printf("MUMPS: analysis %.2f ms, numeric %.2f ms/matrix, solve %.2f ms/matrix, nnz(L) %ld, worst residual %.1e\n",
         1e3 * t_mu_ana / reps, 1e3 * t_mu_fac / reps / nm, 1e3 * t_mu_sol / reps / nm, mu_lnnz, worst_mu);
  printf("MKL:   analysis %.2f ms, numeric %.2f ms/matrix, solve %.2f ms/matrix, nnz(L) %ld, worst residual %.1e\n",
         1e3 * t_mk_ana / reps, 1e3 * t_mk_fac / reps / nm, 1e3 * t_mk_sol / reps / nm, mk_lnnz, worst_mk);
  printf("numeric MUMPS/MKL %.2fx, numeric+solve %.2fx; inertia agrees %d/%d, MKL perturbed pivots on %d\n",
         t_mu_fac / t_mk_fac, (t_mu_fac + t_mu_sol) / (t_mk_fac + t_mk_sol), agree, nm, perturbed);
  return 0;
}
