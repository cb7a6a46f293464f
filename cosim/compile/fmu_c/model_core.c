/* The model core: see model_core.h. The CasADi functions all take (x, u, p, t, m); a continuous model has an
 * empty m, no indicators, an update that changes nothing and next_time = inf. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"
#include "model_core.h"

typedef int (*casadi_fn)(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem);

static void logf_(Model *s, int error, const char *format, double t, const char *text) {
    char buffer[1024];
    if (!s->log) return;
    snprintf(buffer, sizeof buffer, format, t, text);
    s->log(s->log_env, error, buffer);
}

/* Evaluate f(x, u, p, t, m) into up to three results; nonzero when the generated code failed. */
static int call(Model *s, casadi_fn f, const double *m, double *r0, double *r1, double *r2) {
    s->arg[0] = s->x;
    s->arg[1] = s->u;
    s->arg[2] = s->p;
    s->arg[3] = &s->t;
    s->arg[4] = m;
    s->res[0] = r0;
    s->res[1] = r1;
    s->res[2] = r2;
    if (f(s->arg, s->res, (casadi_int *)s->iw, s->w, 0)) {
        logf_(s, 1, "evaluation of the model equations failed at t = %.17g%s", s->t, "");
        return CORE_ERROR;
    }
    return CORE_OK;
}

Model *model_new(core_logger log, void *log_env) {
    Model *s = (Model *)calloc(1, sizeof(Model));
    if (!s) return NULL;
    s->log = log;
    s->log_env = log_env;
    model_reset(s);
    return s;
}

void model_free(Model *s) { free(s); }

/* Back to start values, as after instantiation. */
void model_reset(Model *s) {
    s->t = 0.0;
    memcpy(s->x, X_START, N_X * sizeof(double));
    memcpy(s->u, U_START, N_U * sizeof(double));
    memcpy(s->p, P_START, N_P * sizeof(double));
    memcpy(s->m, M_START, N_M * sizeof(double));
    memset(s->x_set, 0, sizeof s->x_set);
    memset(s->z_side, 0, sizeof s->z_side);
    model_touch(s);
}

/* Something the results depend on changed: recompute them when next asked. */
void model_touch(Model *s) { s->fresh_xdot = s->fresh_y = s->fresh_z = 0; }

const double *model_derivatives(Model *s) {
    if (!s->fresh_xdot) {
        if (call(s, cosim_ode, s->m, s->xdot, NULL, NULL)) return NULL;
        s->fresh_xdot = 1;
    }
    return s->xdot;
}

static const double *outputs(Model *s) {
    if (!s->fresh_y) {
        if (call(s, cosim_out, s->m, s->y, NULL, NULL)) return NULL;
        s->fresh_y = 1;
    }
    return s->y;
}

/* An indicator exactly 0 is reported on the side it was on when continuous time began (as +-DBL_MIN): a
 * solver that locates a root exactly at 0 (CVode can) has then not yet crossed, and goes on to where the
 * indicator is strictly on the other side, where update() sees the relation flipped. Without this, a root at
 * exactly 0 is an event where no relation changed, and the crossing that follows is not seen at all. */
const double *model_indicators(Model *s) {
    int k;
    if (!s->fresh_z) {
        if (call(s, cosim_indicators, s->m, s->z, NULL, NULL)) return NULL;
        for (k = 0; k < N_Z; k++)
            if (s->z[k] == 0.0) s->z[k] = s->z_side[k] * DBL_MIN;
        s->fresh_z = 1;
    }
    return s->z;
}

/* Continuous time begins: remember the side of each indicator (see model_indicators). */
void model_settle_indicators(Model *s) {
    const double *z = model_indicators(s);
    int k;
    if (!z) return;
    for (k = 0; k < N_Z; k++) s->z_side[k] = z[k] > 0.0 ? 1.0 : z[k] < 0.0 ? -1.0 : 0.0;
}

static int discrete_type(int k) {
    return D_KIND[k] == 2 ? TYPE_BOOLEAN : D_KIND[k] == 0 ? TYPE_FLOAT64 : TYPE_INT64;
}

static const char *TYPE_NAMES[] = {"Float64", "Int64", "Boolean"};

/* The FMI type of value reference vr, or -1 when there is no such variable. */
static int type_of(unsigned int vr) {
    if (vr >= N_VR) return -1;
    if (vr >= VR_D && vr < VR_D + N_D) return discrete_type((int)(vr - VR_D));
    return TYPE_FLOAT64;
}

static int check_type(Model *s, unsigned int vr, int type) {
    char text[128];
    int actual = type_of(vr);
    if (actual == type) return CORE_OK;
    if (actual < 0) snprintf(text, sizeof text, "no variable has value reference %u", vr);
    else snprintf(text, sizeof text, "value reference %u is a %s variable, not %s", vr, TYPE_NAMES[actual],
                  TYPE_NAMES[type]);
    logf_(s, 1, "t = %.17g: %s", s->t, text);
    return CORE_ERROR;
}

int model_get(Model *s, unsigned int vr, int type, double *value) {
    const double *r;
    if (check_type(s, vr, type)) return CORE_ERROR;
    if (vr == 0) *value = s->t;
    else if (vr < VR_U) *value = s->p[vr - VR_P];
    else if (vr < VR_X) *value = s->u[vr - VR_U];
    else if (vr < VR_DX) *value = s->x[vr - VR_X];
    else if (vr < VR_Y) {
        if (!(r = model_derivatives(s))) return CORE_ERROR;
        *value = r[vr - VR_DX];
    } else if (vr < VR_D) {
        if (!(r = outputs(s))) return CORE_ERROR;
        *value = r[Y_INDEX[vr - VR_Y]];
    } else if (vr < VR_Z) *value = s->m[vr - VR_D];
    else {
        if (!(r = model_indicators(s))) return CORE_ERROR;
        *value = r[vr - VR_Z];
    }
    return CORE_OK;
}

/* Parameters and inputs can be set at any time, states only before initialisation ends. */
int model_set(Model *s, unsigned int vr, int type, double value, int initialising) {
    if (check_type(s, vr, type)) return CORE_ERROR;
    if (vr >= VR_P && vr < VR_U) s->p[vr - VR_P] = value;
    else if (vr >= VR_U && vr < VR_X) s->u[vr - VR_U] = value;
    else if (vr >= VR_X && vr < VR_DX && initialising) {
        s->x[vr - VR_X] = value;
        s->x_set[vr - VR_X] = 1;
    } else {
        char text[160];
        snprintf(text, sizeof text, "value reference %u cannot be set now (only parameters, inputs, and states "
                 "before initialisation)", vr);
        logf_(s, 1, "t = %.17g: %s", s->t, text);
        return CORE_ERROR;
    }
    model_touch(s);
    return CORE_OK;
}

/* End of initialisation: states the importer did not set start from x0(p); the event memory from initial(). */
int model_initialize(Model *s) {
    double x0[N_X + 1];
    int i;
    s->arg[0] = s->p;
    s->res[0] = x0;
    if (cosim_x0(s->arg, s->res, (casadi_int *)s->iw, s->w, 0)) {
        logf_(s, 1, "t = %.17g: evaluation of the initial states failed%s", s->t, "");
        return CORE_ERROR;
    }
    for (i = 0; i < N_X; i++)
        if (!s->x_set[i]) s->x[i] = x0[i];
    if (call(s, cosim_initial, NULL, s->m, NULL, NULL)) return CORE_ERROR;
    model_touch(s);
    return CORE_OK;
}

/* One pass of event iteration with `pass` (cosim_update, or cosim_terminal at the end): pass(x, u, p, t, m_pre)
 * with m_pre the current memory. */
static int event_pass_with(Model *s, casadi_fn pass, EventFlags *flags) {
    double x_new[N_X + 1], m_new[N_M + 1], status = 0.0;
    int i, k;
    memset(flags, 0, sizeof *flags);
    if (call(s, pass, s->m, x_new, m_new, &status)) return CORE_ERROR;
    for (i = 0; i < N_X; i++)
        if (x_new[i] != s->x[i]) flags->states_changed = 1;
    for (i = 0; i < N_M; i++)
        if (m_new[i] != s->m[i]) flags->discrete_changed = 1;
    memcpy(s->x, x_new, N_X * sizeof(double));
    memcpy(s->m, m_new, N_M * sizeof(double));
    model_touch(s);
    if (status == 1.0) {
        flags->terminate = 1;
        logf_(s, 0, "t = %.17g: the model called terminate(): %s", s->t, N_MSG ? MESSAGES[N_MSG - 1] : "");
    } else if (status >= 2.0) {
        k = (int)status - 2;
        logf_(s, 1, "t = %.17g: assertion failed: %s", s->t, k < N_MSG ? MESSAGES[k] : "(unknown assertion)");
        return CORE_ERROR;
    }
    return CORE_OK;
}

int model_event_pass(Model *s, EventFlags *flags) { return event_pass_with(s, cosim_update, flags); }

/* The end of the simulation: passes with terminal() true until the memory settles (when-clauses on terminal()
 * fire once: their held condition is set by the first pass). */
int model_terminal(Model *s) {
    EventFlags flags;
    int pass;
    for (pass = 0; pass < MAX_TERMINAL_PASSES; pass++) {
        if (event_pass_with(s, cosim_terminal, &flags)) return CORE_ERROR;
        if (!flags.discrete_changed && !flags.states_changed) return CORE_OK;
    }
    logf_(s, 1, "t = %.17g: the terminal() passes did not settle%s", s->t, "");
    return CORE_ERROR;
}

/* The next time event strictly after the current time, or INFINITY. */
double model_next_time(Model *s) {
    double next = INFINITY;
    s->arg[0] = &s->t;
    s->arg[1] = s->p;
    s->arg[2] = s->m;
    s->res[0] = &next;
    if (cosim_next_time(s->arg, s->res, (casadi_int *)s->iw, s->w, 0)) return INFINITY;
    return next;
}
