/* The model core of an FMU exported by cosim: one instance of a lowered model (states, inputs, parameters,
 * event memory), lazy evaluation of the CasADi-generated functions, and one pass of event iteration.
 * It knows nothing of FMI: the API layers (fmi3_me.c today; FMI 2.0 and Co-Simulation later) sit on top.
 * All values are doubles inside; Integer and Boolean variables are whole numbers (see model_get/model_set). */
#ifndef COSIM_MODEL_CORE_H
#define COSIM_MODEL_CORE_H

#include "model_data.h"

/* Result codes of the core (the API layers map them to their status enums). */
#define CORE_OK 0
#define CORE_ERROR 1

/* Most passes with terminal() true at the end of the simulation (model_terminal). */
#define MAX_TERMINAL_PASSES 100

/* Types a value reference can be read or written as. */
#define TYPE_FLOAT64 0
#define TYPE_INT64 1
#define TYPE_BOOLEAN 2

/* Logger the API layer provides: error is 0 for information, 1 for an error. */
typedef void (*core_logger)(void *env, int error, const char *message);

typedef struct {
    double t;
    double x[N_X + 1], u[N_U + 1], p[N_P + 1], m[N_M + 1];
    double xdot[N_X + 1], y[N_Y + 1], z[N_Z + 1];
    int x_set[N_X + 1];          /* state set by the importer before initialisation (x0 does not override) */
    double z_side[N_Z + 1];      /* sign of each indicator when continuous time last began (0: not known) */
    int fresh_xdot, fresh_y, fresh_z;  /* cached results valid for the current t, x, u, p, m */
    core_logger log;
    void *log_env;
    const double *arg[SZ_ARG + 1];
    double *res[SZ_RES + 1];
    long long int iw[SZ_IW + 1];
    double w[SZ_W + 1];
} Model;

/* Flags of one event pass (model_event_pass). */
typedef struct {
    int discrete_changed;    /* m changed: another pass is needed */
    int states_changed;      /* x changed (reinit) */
    int terminate;           /* terminate() fired */
} EventFlags;

Model *model_new(core_logger log, void *log_env);
void model_free(Model *s);
void model_reset(Model *s);
void model_touch(Model *s);
int model_get(Model *s, unsigned int vr, int type, double *value);
int model_set(Model *s, unsigned int vr, int type, double value, int initialising);
const double *model_derivatives(Model *s);
const double *model_indicators(Model *s);
void model_settle_indicators(Model *s);
int model_initialize(Model *s);
int model_event_pass(Model *s, EventFlags *flags);
int model_terminal(Model *s);
double model_next_time(Model *s);

#endif
