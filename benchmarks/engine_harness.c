/* The FMU calls of the compiled engine's per-instant loop, from C: the physical limit of a master.
 *
 * benchmarks/engine.py writes a plan (whitespace-separated text) with the FMUs (shared library,
 * instantiation token, parameters), the engine's port / routing / ME-to-ME tables
 * (cosim.master.ckernel) and the held FMU inputs of every instant recorded from a compiled-engine
 * run. This program dlopens each FMU's .so, sets it up, then repeats exactly the FMU calls and the RK4
 * arithmetic of cosim.master.ckernel.run_chunk (sampling, ME-to-ME routing at every stage, held
 * inputs, RK4 with the first stage reusing the sampled state), without controllers: the inputs are
 * replayed. Prints the wall seconds of the loop, the number of instants, the first port's last value and the
 * loop's CPU seconds (the thread's).
 *
 *   gcc -O2 -I<fmpy>/c-code engine_harness.c -o harness -ldl && ./harness plan.txt
 */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "fmi3Functions.h"

#define MAXF 8

typedef struct {
  fmi3Instance c;
  fmi3SetTimeTYPE* set_time;
  fmi3SetContinuousStatesTYPE* set_x;
  fmi3GetContinuousStateDerivativesTYPE* get_dx;
  fmi3GetFloat64TYPE* get;
  fmi3SetFloat64TYPE* set;
  long x_off, nx;
} Fmu;

static Fmu F[MAXF];
static long nF, nX, nP, nG, nR, nRG, nL, nME, k_stop, num, den, nper, per[16], n_in, *in_slot;
static long *p_f, *p_n, *p_off, **p_vr, *g_a, *g_b, *r_src, *r_dst, *rg_a, *rg_b, *lv, *me;
static double *r_gain, *r_off, t0, h_max, *buf, *W, *inputs;
static FILE* fp;

static long rl(void) { long v; if (fscanf(fp, "%ld", &v) != 1) { fprintf(stderr, "bad plan\n"); exit(2); } return v; }
static double rd(void) { double v; if (fscanf(fp, "%lf", &v) != 1) { fprintf(stderr, "bad plan\n"); exit(2); } return v; }
static void fail(const char* what) { fprintf(stderr, "FMI call failed: %s\n", what); exit(3); }

static void io(long g, int setter) {
  for (long j = g_a[g]; j < g_b[g]; ++j) {
    Fmu* f = &F[p_f[j]];
    fmi3ValueReference vr[64];
    for (long i = 0; i < p_n[j]; ++i) vr[i] = (fmi3ValueReference)p_vr[j][i];
    fmi3Status s = setter ? f->set(f->c, vr, p_n[j], buf + p_off[j], p_n[j]) : f->get(f->c, vr, p_n[j], buf + p_off[j], p_n[j]);
    if (s > fmi3Warning) fail(setter ? "SetFloat64" : "GetFloat64");
  }
}

static void route(long g) {
  for (long j = rg_a[g]; j < rg_b[g]; ++j) buf[r_dst[j]] = r_gain[j] * buf[r_src[j]] + r_off[j];
}

static void eval(double t, int push) {
  if (push)
    for (long i = 0; i < nME; ++i) {
      Fmu* f = &F[me[i]];
      if (f->set_time(f->c, t) > fmi3Warning) fail("SetTime");
      if (f->set_x(f->c, W + f->x_off, f->nx) > fmi3Warning) fail("SetContinuousStates");
    }
  for (long l = 0; l < nL; ++l) { io(lv[3 * l], 0); route(lv[3 * l + 1]); io(lv[3 * l + 2], 1); }
}

static void deriv(double t, int push) {
  eval(t, push);
  for (long i = 0; i < nME; ++i) {
    Fmu* f = &F[me[i]];
    if (f->get_dx(f->c, W + 2 * nX + f->x_off, f->nx) > fmi3Warning) fail("GetContinuousStateDerivatives");
  }
}

static void stage(int s, double c) {
  for (long i = 0; i < nX; ++i) { W[(3 + s) * nX + i] = W[2 * nX + i]; W[i] = W[nX + i] + c * W[2 * nX + i]; }
}

int main(int argc, char** argv) {
  if (argc < 2 || !(fp = fopen(argv[1], "r"))) { fprintf(stderr, "usage: harness plan.txt\n"); return 2; }
  char path[4096], token[512];
  nF = rl();
  for (long i = 0; i < nF; ++i) {
    if (fscanf(fp, "%4095s %511s", path, token) != 2) return 2;
    void* lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 1; }
    fmi3InstantiateModelExchangeTYPE* inst = (fmi3InstantiateModelExchangeTYPE*)dlsym(lib, "fmi3InstantiateModelExchange");
    fmi3EnterInitializationModeTYPE* enter = (fmi3EnterInitializationModeTYPE*)dlsym(lib, "fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE* leave = (fmi3ExitInitializationModeTYPE*)dlsym(lib, "fmi3ExitInitializationMode");
    fmi3EnterContinuousTimeModeTYPE* cont = (fmi3EnterContinuousTimeModeTYPE*)dlsym(lib, "fmi3EnterContinuousTimeMode");
    Fmu* f = &F[i];
    f->set_time = (fmi3SetTimeTYPE*)dlsym(lib, "fmi3SetTime");
    f->set_x = (fmi3SetContinuousStatesTYPE*)dlsym(lib, "fmi3SetContinuousStates");
    f->get_dx = (fmi3GetContinuousStateDerivativesTYPE*)dlsym(lib, "fmi3GetContinuousStateDerivatives");
    f->get = (fmi3GetFloat64TYPE*)dlsym(lib, "fmi3GetFloat64");
    f->set = (fmi3SetFloat64TYPE*)dlsym(lib, "fmi3SetFloat64");
    f->c = inst("harness", token, NULL, fmi3False, fmi3False, NULL, NULL);
    if (!f->c) fail("fmi3InstantiateModelExchange");
    f->x_off = rl(); f->nx = rl();
    long npar = rl();
    for (long j = 0; j < npar; ++j) {
      fmi3ValueReference vr = (fmi3ValueReference)rl(); double v = rd();
      if (f->set(f->c, &vr, 1, &v, 1) > fmi3Warning) fail("SetFloat64 (parameter)");
    }
    if (enter(f->c, fmi3False, 0.0, 0.0, fmi3False, 0.0) > fmi3Warning || leave(f->c) > fmi3Warning) fail("initialisation");
    if (cont(f->c) > fmi3Warning) fail("EnterContinuousTimeMode");
  }
  nX = rl();
  W = calloc(7 * (nX ? nX : 1), sizeof(double));
  long nbuf = rl();
  buf = calloc(nbuf ? nbuf : 1, sizeof(double));
  nP = rl();
  p_f = malloc(nP * sizeof(long)); p_n = malloc(nP * sizeof(long)); p_off = malloc(nP * sizeof(long)); p_vr = malloc(nP * sizeof(long*));
  for (long j = 0; j < nP; ++j) {
    p_f[j] = rl(); p_n[j] = rl(); p_off[j] = rl(); p_vr[j] = malloc(p_n[j] * sizeof(long));
    for (long i = 0; i < p_n[j]; ++i) p_vr[j][i] = rl();
  }
  nG = rl(); g_a = malloc(nG * sizeof(long)); g_b = malloc(nG * sizeof(long));
  for (long g = 0; g < nG; ++g) { g_a[g] = rl(); g_b[g] = rl(); }
  nR = rl(); r_src = malloc((nR + 1) * sizeof(long)); r_dst = malloc((nR + 1) * sizeof(long));
  r_gain = malloc((nR + 1) * sizeof(double)); r_off = malloc((nR + 1) * sizeof(double));
  for (long j = 0; j < nR; ++j) { r_src[j] = rl(); r_dst[j] = rl(); r_gain[j] = rd(); r_off[j] = rd(); }
  nRG = rl(); rg_a = malloc(nRG * sizeof(long)); rg_b = malloc(nRG * sizeof(long));
  for (long g = 0; g < nRG; ++g) { rg_a[g] = rl(); rg_b[g] = rl(); }
  nL = rl(); lv = malloc((3 * nL + 1) * sizeof(long));
  for (long j = 0; j < 3 * nL; ++j) lv[j] = rl();
  nME = rl(); me = malloc((nME + 1) * sizeof(long));
  for (long j = 0; j < nME; ++j) me[j] = rl();
  k_stop = rl(); num = rl(); den = rl(); nper = rl();
  for (long j = 0; j < nper; ++j) per[j] = rl();
  t0 = rd(); h_max = rd();
  /* initial states (the FMUs' own after initialisation), then the replayed held inputs of every instant */
  for (long i = 0; i < nX; ++i) W[i] = rd();
  n_in = rl(); in_slot = malloc((n_in + 1) * sizeof(long));
  for (long j = 0; j < n_in; ++j) in_slot[j] = rl();
  long n_rows = rl();
  inputs = malloc((n_rows * n_in + 1) * sizeof(double));
  for (long j = 0; j < n_rows * n_in; ++j) inputs[j] = rd();
  fclose(fp);

  struct timespec a, b, ca, cb;
  clock_gettime(CLOCK_MONOTONIC, &a);
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ca);
  long k = 0, inst = 0;
  io(1, 1);
  for (;;) {
    double t = t0 + (double)(k * den) / (double)num;
    if (nME) eval(t, 1);
    io(0, 0);
    route(0);
    if (k < k_stop) {
      long r = inst < n_rows ? inst : n_rows - 1;
      for (long j = 0; j < n_in; ++j) buf[in_slot[j]] = inputs[r * n_in + j];
      route(1);
      io(1, 1);
    }
    ++inst;
    if (k >= k_stop) break;
    long k_next = k_stop;
    for (long j = 0; j < nper; ++j) { long kn = (k / per[j] + 1) * per[j]; if (kn < k_next) k_next = kn; }
    double t_next = t0 + (double)(k_next * den) / (double)num;
    if (nME && nX) {
      double L = t_next - t;
      long n = (long)ceil(L / h_max - 1e-9);
      if (n < 1) n = 1;
      for (long i = 0; i < nX; ++i) W[nX + i] = W[i];
      for (long j = 0; j < n; ++j) {
        double ta = t + L * j / n, t1 = t + L * (j + 1) / n, h = t1 - ta, th = ta + 0.5 * h;
        deriv(ta, j != 0); stage(0, 0.5 * h);
        deriv(th, 1); stage(1, 0.5 * h);
        deriv(th, 1); stage(2, h);
        deriv(t1, 1);
        for (long i = 0; i < nX; ++i) {
          W[i] = W[nX + i] + h / 6.0 * (W[3 * nX + i] + 2.0 * W[4 * nX + i] + 2.0 * W[5 * nX + i] + W[2 * nX + i]);
          W[nX + i] = W[i];
        }
      }
    }
    k = k_next;
  }
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cb);
  clock_gettime(CLOCK_MONOTONIC, &b);
  double wall = (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec);
  double cpu = (cb.tv_sec - ca.tv_sec) + 1e-9 * (cb.tv_nsec - ca.tv_nsec);
  printf("%.9f %ld %.17g %.9f\n", wall, inst, buf[p_off[0]], cpu);
  return 0;
}
