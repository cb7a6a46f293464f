/* The model core of an FMU exported by cosim: one instance of a lowered model (states, inputs, parameters,
 * event memory), lazy evaluation of the CasADi-generated functions, and one pass of event iteration.
 * It knows nothing of FMI: the API layers (FMI 3.0 and 2.0, Model Exchange and Co-Simulation) sit on top.
 * It also carries what a Co-Simulation layer needs: an embedded solver that advances to a communication point
 * with the events handled inside (model_do_step), exact directional derivatives (model_directional) and the
 * instance's state as a flat array of doubles (model_state_*).
 * All values are doubles inside; Integer and Boolean variables are whole numbers (see model_get/model_set). */
#ifndef COSIM_MODEL_CORE_H
#define COSIM_MODEL_CORE_H

#include <stddef.h>

#include "model_data.h"

/* Solutions of the nonlinear loops kept along an integration between accepted points (model_accept). */
#define G_CHAIN 16

/* Result codes of the core (the API layers map them to their status enums). */
#define CORE_OK 0
#define CORE_ERROR 1

/* Types a value reference can be read or written as. */
#define TYPE_FLOAT64 0
#define TYPE_INT64 1
#define TYPE_BOOLEAN 2

/* Embedded solvers of model_do_step (Model.cs_method). */
#define CS_RK4 0             /* classical fourth-order Runge-Kutta, fixed step */
#define CS_IMPLICIT_EULER 1  /* implicit Euler, Newton with the exact Jacobian of ode w.r.t. x (stiff plants) */

/* Events inside model_do_step: a state event is located to a bracket of EVENT_TOL seconds; event iteration
 * stops with an error after MAX_EVENT_PASSES passes at one instant, and model_do_step (or an importer's event
 * mode: model_count_event) after MAX_EVENTS_IN_A_ROW events each within CHATTER_WINDOW of the last
 * (chattering). The same rules as the master's (plant.py). */
#define EVENT_TOL 1e-10
#define CHATTER_WINDOW (100 * EVENT_TOL)
#define MAX_EVENT_PASSES 100
#define MAX_EVENTS_IN_A_ROW 100
/* The mixed system of an event pass (model_core.c, solve_mixed): candidates iterated at most
 * MAX_MIXED_ITERATIONS times, then the combinations of at most MAX_MIXED_SEARCH rows that changed tried. */
#define MAX_MIXED_ITERATIONS 20
#define MAX_MIXED_SEARCH 10

/* Logger the API layer provides: error is 0 for information, 1 for an error. */
typedef void (*core_logger)(void *env, int error, const char *message);

typedef struct {
    double t;
    double x[N_X + 1], u[N_U + 1], p[N_P + 1], m[N_M + 1];
    double xdot[N_X + 1], y[N_Y + 1], z[N_Z + 1];
    double v[N_OBS + 1], q[N_Q + 1];  /* the local variables (observe) and the calculated parameters */
    /* The nonlinear loops' solutions along the current integration: at g_time[k] (increasing), g[k]; a solve at
     * t starts from the last at or before t (model_accept keeps only the last). */
    double g[G_CHAIN][N_G + 1], g_time[G_CHAIN];
    int g_count;
    int x_set[N_X + 1];          /* state set by the importer before initialisation (x0 does not override) */
    double z_side[N_Z + 1];      /* sign of each indicator when continuous time last began (0: not known) */
    double last_event;           /* time of the last event (model_count_event), -inf before the first */
    int events_in_a_row;         /* events since the last that was over CHATTER_WINDOW after its predecessor */
    int fresh_xdot, fresh_y, fresh_z, fresh_v, fresh_q, fresh_g;  /* results valid for the current t, x, u, p, m */
    double cs_step;              /* internal step of model_do_step, s (value reference VR_CS: _cs_step) */
    int cs_method;               /* CS_RK4 or CS_IMPLICIT_EULER (value reference VR_CS + 1: _cs_method) */
    double mixed_tried[MAX_MIXED_ITERATIONS][N_M + 1];  /* candidates of an event pass's mixed system */
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

/* The nonlinear loops' Newton iterations start from their last solution at or before the current time: an
 * integrator's trial point beyond a branch's end moves a loop to its other branch for later points only, so that
 * a step it rejects and retries shorter sees the branch as it was. model_accept: the current point is accepted
 * (an integrator step completed, continuous time begins), the solutions before it are forgotten. */
int model_accept(Model *s);
int model_initialize(Model *s);
int model_event_pass(Model *s, EventFlags *flags);
int model_terminal(Model *s);
double model_next_time(Model *s);

/* Event iteration at the current instant: passes until m settles, then the indicators' sides are remembered.
 * *terminated is set when terminate() fired. A Co-Simulation layer calls it once after model_initialize. */
int model_event_iteration(Model *s, int *terminated);

/* Advance from s->t to t_end with the embedded solver (s->cs_method, internal step at most s->cs_step, equal
 * steps between events): state events located within the step, time events stepped onto exactly, event
 * iteration at each; a hybrid model also iterates its events at the start (inputs may have changed).
 * s->t == t_end on return unless *terminated (then s->t is the instant terminate() fired). */
int model_do_step(Model *s, double t_end, int *terminated);
int model_count_event(Model *s);

/* sensitivity = d(unknown)/d(known) seed at the current point, exact (CasADi forward mode). known: value
 * references of states and inputs; unknown: state derivatives, outputs, states. */
int model_directional(Model *s, const unsigned *unknown, size_t n_unknown, const unsigned *known,
                      size_t n_known, const double *seed, double *sensitivity);

/* The instance's state as model_state_size() doubles: the sizes (to check a buffer belongs to this model),
 * t, x, u, p, m, the loops' solutions (g_count, g_time, g), x_set, z_side, cs_step, cs_method. Serialisation
 * is the buffer's bytes. model_state_load fails (and changes nothing) when the sizes differ. */
size_t model_state_size(void);
void model_state_save(const Model *s, double *buf);
int model_state_load(Model *s, const double *buf);

#endif
