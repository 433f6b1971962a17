/* The pardiso-project.org interface IPOPT 3.14 loads at run time (linear_solver "pardiso",
 * option pardisolib), on top of Intel oneMKL PARDISO.
 *
 * IPOPT's PardisoSolverInterface (src/Algorithm/LinearSolvers/IpPardisoSolverInterface.cpp)
 * dlopens the library, loads the symbols pardisoinit and pardiso (the pardiso-project
 * signatures, with SOLVER, DPARM and ERROR), checks that pardiso_ipopt_newinterface exists and,
 * if pardiso_exist_parallel exists, puts $OMP_NUM_THREADS into IPARM(3). It sets the
 * pardiso-project meaning of IPARM; MKL reads some of those slots differently (MKL PARDISO
 * iparm reference), so every call hands MKL its own iparm, translated:
 *   iparm[2]  processors (pardiso-project)      -> 0 (reserved in MKL)
 *   iparm[10] scaling 2 (pardiso-project)       -> 1 (MKL: scaling on)
 *   iparm[12] matching 1..3 (pardiso-project)   -> 1 (MKL: weighted matching on)
 *   iparm[20] pivoting 3 (pardiso-project)      -> 1 (MKL: 1x1 and 2x2 Bunch-Kaufman)
 *   iparm[23], iparm[24] parallel fac./solve    -> 0 (MKL: classic factorisation, sequential
 *                                                  solve; this library runs MKL sequential)
 *   iparm[28..31]                               -> 0 (double precision; MKL reserved/outputs)
 * and copies back the outputs IPOPT reads: iparm[6] (refinement steps), iparm[13] (perturbed
 * pivots), iparm[14..16] (memory), iparm[21] and iparm[22] (the inertia: positive and negative
 * eigenvalues). MKL's default one-based CSR with the upper triangle is IPOPT's
 * CSR_Format_1_Offset.
 *
 * GS_MKL_RT is the path of libmkl_rt (set when compiling); it is opened RTLD_LOCAL at the
 * first pardisoinit, so MKL's BLAS symbols never reach the process's global scope (MUMPS and
 * CasADi keep their OpenBLAS). Unless $MKL_THREADING_LAYER says otherwise MKL runs sequential.
 *
 * A screening tool (benchmarks/pardiso_mkl_screen.py, docs/results/planner_speed_ipopt.md,
 * session 33), not part of gaitsmith.
 */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef GS_MKL_RT
#error "compile with -DGS_MKL_RT=\"/path/to/libmkl_rt.so.N\""
#endif

typedef void (*mkl_pardisoinit_fn)(void *pt, const int *mtype, int *iparm);
typedef void (*mkl_pardiso_fn)(void *pt, const int *maxfct, const int *mnum, const int *mtype,
                               const int *phase, const int *n, const void *a, const int *ia,
                               const int *ja, int *perm, const int *nrhs, int *iparm,
                               const int *msglvl, void *b, void *x, int *error);
typedef int (*mkl_set_layer_fn)(int layer);

/* IPOPT checks that these exist (values unused) */
int pardiso_ipopt_newinterface = 1;
int pardiso_exist_parallel = 1;

static mkl_pardisoinit_fn mkl_pardisoinit;
static int n_over = 0, over_i[64], over_v[64];
static mkl_pardiso_fn mkl_pardiso;

/* 0 when MKL is loaded, else -1 (the error pardisoinit returns; IPOPT then stops with
 * "Problem with Pardiso license (error -1 from pardisoinit)") */
static int load_mkl(void) {
  static int state = 1; /* 1: not tried */
  if (state != 1) return state;
  void *lib = dlopen(GS_MKL_RT, RTLD_NOW | RTLD_LOCAL);
  if (lib == NULL) {
    fprintf(stderr, "gaitsmith pardiso_mkl: cannot open %s: %s\n", GS_MKL_RT, dlerror());
    state = -1;
    return state;
  }
  mkl_set_layer_fn set_layer = (mkl_set_layer_fn)dlsym(lib, "MKL_Set_Threading_Layer");
  mkl_pardisoinit = (mkl_pardisoinit_fn)dlsym(lib, "pardisoinit");
  mkl_pardiso = (mkl_pardiso_fn)dlsym(lib, "pardiso");
  if (set_layer == NULL || mkl_pardisoinit == NULL || mkl_pardiso == NULL) {
    fprintf(stderr, "gaitsmith pardiso_mkl: %s lacks pardiso/pardisoinit\n", GS_MKL_RT);
    state = -1;
    return state;
  }
  if (getenv("MKL_THREADING_LAYER") == NULL) set_layer(1); /* MKL_THREADING_SEQUENTIAL */

  state = 0;
  return state;
}

void pardisoinit(void *pt, const int *mtype, const int *solver, int *iparm, double *dparm,
                 int *error) {
  (void)dparm;
  *error = load_mkl();
  if (*error != 0) return;
  if (*solver != 0) { /* pardiso-project's iterative solver: not in MKL */
    *error = -1;
    return;
  }
  /* $GAITSMITH_PARDISO_IPARM="i=v,...": MKL iparm slots (0-based) set after the translation,
   * read at every pardisoinit (IPOPT calls it once per solve) */
  n_over = 0;
  const char *ov = getenv("GAITSMITH_PARDISO_IPARM");
  if (ov != NULL) {
    char buf[256];
    strncpy(buf, ov, sizeof buf - 1);
    buf[sizeof buf - 1] = 0;
    for (char *tok = strtok(buf, ","); tok != NULL && n_over < 64; tok = strtok(NULL, ","))
      if (sscanf(tok, "%d=%d", &over_i[n_over], &over_v[n_over]) == 2 && over_i[n_over] >= 0 &&
          over_i[n_over] < 64)
        ++n_over;
  }
  mkl_pardisoinit(pt, mtype, iparm);
}

static void to_mkl(const int *iparm, int *mk) {
  memcpy(mk, iparm, 64 * sizeof(int));
  mk[0] = 1;
  mk[2] = 0;
  mk[10] = iparm[10] != 0;
  mk[12] = iparm[12] != 0;
  mk[20] = 1;
  mk[23] = 0;
  mk[24] = 0;
  mk[17] = -1; /* report the factor's non-zeros */
  mk[18] = 0;
  for (int i = 26; i < 64; ++i) mk[i] = 0;
  for (int k = 0; k < n_over; ++k) mk[over_i[k]] = over_v[k];
}

void pardiso(void **pt, const int *maxfct, const int *mnum, const int *mtype, const int *phase,
             const int *n, const double *a, const int *ia, const int *ja, const int *perm,
             const int *nrhs, int *iparm, const int *msglvl, double *b, double *x, int *error,
             double *dparm) {
  (void)dparm;
  if (load_mkl() != 0) {
    *error = -1;
    return;
  }
  int mk[64];
  to_mkl(iparm, mk);
  mkl_pardiso(pt, maxfct, mnum, mtype, phase, n, a, ia, ja, (int *)perm, nrhs, mk, msglvl, b, x,
              error);
  static const int outputs[] = {6, 13, 14, 15, 16, 17, 21, 22};
  for (size_t k = 0; k < sizeof(outputs) / sizeof(outputs[0]); ++k)
    iparm[outputs[k]] = mk[outputs[k]];
}
