/* The model core: see model_core.h. The CasADi functions all take (x, u, p, t, m); a continuous model has an
 * empty m, no indicators, an update that changes nothing and next_time = inf. Those that solve the nonlinear
 * loops (ode, out, observe, loops, the derivatives) also take g, where the loops' Newton iterations start: the
 * last solution (as every Modelica tool does, so that a loop with several solutions stays on its branch).
 * Below the FMI-independent services, the Co-Simulation ones: event iteration, the embedded solver, directional
 * derivatives, the state. */
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

/* Where the loops' iterations at the current time start: the last solution at or before it; the first kept when
 * all are after it. Reading forgets nothing: an evaluation at an earlier time that solves nothing (an event
 * indicator at an output point the integrator has passed) must not drop the solutions of its accepted steps. */
static const double *start_point(const Model *s) {
    int k = s->g_count - 1;
    while (k > 0 && s->g_time[k] > s->t) k--;
    return s->g[k];
}

/* The loops' solutions g_new at the current time, where finite (a loop that did not converge is NaN). Those kept
 * for later times are forgotten (they belong to an integrator's rejected step, or to one an output point lies
 * before), and the new one is the start of the next solves. */
static void keep_solution(Model *s, const double *g_new) {
    int k, top;
    while (s->g_count > 1 && s->g_time[s->g_count - 1] > s->t) s->g_count--;
    top = s->g_count - 1;
    if (s->g_time[top] != s->t) {
        if (s->g_count == G_CHAIN) {
            memmove(s->g, s->g + 1, (G_CHAIN - 1) * sizeof s->g[0]);
            memmove(s->g_time, s->g_time + 1, (G_CHAIN - 1) * sizeof(double));
        } else top = s->g_count++;
        memcpy(s->g[top], s->g[top - 1], N_G * sizeof(double));
        s->g_time[top] = s->t;
    }
    for (k = 0; k < N_G; k++)
        if (isfinite(g_new[k])) s->g[top][k] = g_new[k];
}

/* Evaluate f(x, u, p, t, m[, extra]) into up to three results; nonzero when the generated code failed. */
static int call_with(Model *s, casadi_fn f, const double *m, const double *extra, double *r0, double *r1,
                     double *r2) {
    s->arg[0] = s->x;
    s->arg[1] = s->u;
    s->arg[2] = s->p;
    s->arg[3] = &s->t;
    s->arg[4] = m;
    s->arg[5] = extra;  /* read only by the functions with a sixth argument */
    s->res[0] = r0;
    s->res[1] = r1;
    s->res[2] = r2;
    if (f(s->arg, s->res, (casadi_int *)s->iw, s->w, 0)) {
        logf_(s, 1, "evaluation of the model equations failed at t = %.17g%s", s->t, "");
        return CORE_ERROR;
    }
    return CORE_OK;
}

/* f(x, u, p, t, m[, g]): g the loops' starting point (start_point), read by the functions that take it. */
static int call(Model *s, casadi_fn f, const double *m, double *r0, double *r1, double *r2) {
    return call_with(s, f, m, start_point(s), r0, r1, r2);
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
    memcpy(s->g[0], G_START, N_G * sizeof(double));
    s->g_time[0] = -INFINITY;
    s->g_count = 1;
    memset(s->x_set, 0, sizeof s->x_set);
    memset(s->z_side, 0, sizeof s->z_side);
    s->last_event = -INFINITY;
    s->events_in_a_row = 0;
    s->cs_step = CS_STEP;
    s->cs_method = CS_METHOD;
    model_touch(s);
}

/* Something the results depend on changed: recompute them when next asked. */
void model_touch(Model *s) { s->fresh_xdot = s->fresh_y = s->fresh_z = s->fresh_v = s->fresh_q = s->fresh_g = 0; }

/* A result of n values that is not a number where a nonlinear loop's Newton iterations did not converge (the
 * lowering makes it NaN there): an error naming the first such loop. A NaN of another cause is left as it is. */
static int loops_failed(Model *s, const double *result, int n) {
    double converged[N_LOOPS + 1];
    int i, k;
    for (i = 0; i < n && isfinite(result[i]); i++) {}
    if (!N_LOOPS || i == n || call(s, cosim_loops, s->m, converged, NULL, NULL)) return 0;
    for (k = 0; k < N_LOOPS; k++)
        if (converged[k] == 0.0) {
            logf_(s, 1, "t = %.17g: Newton's method did not converge on the %s here; no value is returned for "
                  "it (the loop may have no solution at these states, inputs and parameters)", s->t, LOOP_NAMES[k]);
            return 1;
        }
    return 0;
}

/* The result of a model function at the current t, x, u, p, m: computed once, then kept until model_touch.
 * cosim_ode, cosim_out and cosim_observe also give the loops' solutions there (keep_solution). */
static const double *cached(Model *s, casadi_fn f, double *result, int n, int *fresh) {
    double g_new[N_G + 1];
    int solves = f != cosim_calculated;
    if (!*fresh) {
        if (call(s, f, s->m, result, solves ? g_new : NULL, NULL) || loops_failed(s, result, n)) return NULL;
        if (solves && N_G) keep_solution(s, g_new);
        s->fresh_g |= solves;
        *fresh = 1;
    }
    return result;
}

const double *model_derivatives(Model *s) { return cached(s, cosim_ode, s->xdot, N_X, &s->fresh_xdot); }

static const double *outputs(Model *s) { return cached(s, cosim_out, s->y, N_Y, &s->fresh_y); }

/* The local variables: computed only when one is read (nothing in stepping reads them). */
static const double *observed(Model *s) { return cached(s, cosim_observe, s->v, N_OBS, &s->fresh_v); }

static const double *calculated(Model *s) { return cached(s, cosim_calculated, s->q, 0, &s->fresh_q); }

int model_accept(Model *s) {
    if (!N_G) return CORE_OK;
    if (!s->fresh_g && !model_derivatives(s)) return CORE_ERROR;
    if (s->g_count > 1) {
        memcpy(s->g[0], s->g[s->g_count - 1], N_G * sizeof(double));
        s->g_time[0] = s->g_time[s->g_count - 1];
        s->g_count = 1;
    }
    return CORE_OK;
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

/* Continuous time begins: the point is accepted (model_accept), and the side of each indicator remembered (see
 * model_indicators). */
void model_settle_indicators(Model *s) {
    const double *z;
    int k;
    model_accept(s);  /* a loop that did not converge is reported by the next evaluation */
    if (!(z = model_indicators(s))) return;
    for (k = 0; k < N_Z; k++) s->z_side[k] = z[k] > 0.0 ? 1.0 : z[k] < 0.0 ? -1.0 : 0.0;
}

/* The FMI type of a kind code of model_data.h (D_KIND, K_KIND): 0 real, 1 integer, 2 boolean, 3 enumeration. */
static int kind_type(int kind) { return kind == 2 ? TYPE_BOOLEAN : kind == 0 ? TYPE_FLOAT64 : TYPE_INT64; }

static const char *TYPE_NAMES[] = {"Float64", "Int64", "Boolean"};

/* The FMI type of value reference vr, or -1 when there is no such variable. */
static int type_of(unsigned int vr) {
    if (vr >= N_VR) return -1;
    if (vr == VR_CS + 1) return TYPE_INT64;
    if (vr >= VR_D && vr < VR_D + N_D) return kind_type(D_KIND[vr - VR_D]);
    if (vr >= VR_K) return kind_type(K_KIND[vr - VR_K]);
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
    else if (vr < VR_CS) {
        if (!(r = model_indicators(s))) return CORE_ERROR;
        *value = r[vr - VR_Z];
    } else if (vr == VR_CS) *value = s->cs_step;
    else if (vr == VR_CS + 1) *value = s->cs_method;
    else if (vr < VR_Q) {
        if (!(r = observed(s))) return CORE_ERROR;
        *value = r[V_INDEX[vr - VR_V]];
    } else if (vr < VR_K) {
        if (!(r = calculated(s))) return CORE_ERROR;
        *value = r[vr - VR_Q];
    } else *value = K_VALUE[vr - VR_K];
    return CORE_OK;
}

/* The solver settings, before initialisation ends: a positive finite step, a known method. */
static int set_solver(Model *s, unsigned int vr, double value) {
    char text[160];
    if (vr == VR_CS && value > 0.0 && isfinite(value)) s->cs_step = value;
    else if (vr == VR_CS + 1 && (value == CS_RK4 || value == CS_IMPLICIT_EULER)) s->cs_method = (int)value;
    else {
        snprintf(text, sizeof text, "%s = %.17g is not allowed (expected %s)", vr == VR_CS ? "_cs_step" : "_cs_method",
                 value, vr == VR_CS ? "a positive step in s" : "0 (RK4) or 1 (implicit Euler)");
        logf_(s, 1, "t = %.17g: %s", s->t, text);
        return CORE_ERROR;
    }
    return CORE_OK;
}

/* Parameters and inputs can be set at any time; states and the solver settings only before initialisation
 * ends. */
int model_set(Model *s, unsigned int vr, int type, double value, int initialising) {
    if (check_type(s, vr, type)) return CORE_ERROR;
    if ((vr == VR_CS || vr == VR_CS + 1) && initialising) return set_solver(s, vr, value);
    if (vr >= VR_P && vr < VR_U) s->p[vr - VR_P] = value;
    else if (vr >= VR_U && vr < VR_X) s->u[vr - VR_U] = value;
    else if (vr >= VR_X && vr < VR_DX && initialising) {
        s->x[vr - VR_X] = value;
        s->x_set[vr - VR_X] = 1;
    } else {
        char text[160];
        snprintf(text, sizeof text, "value reference %u cannot be set now (only parameters and inputs; states and "
                 "solver settings before initialisation ends)", vr);
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

/* mixed(x, u, p, t, m_pre = s->m, c) into x_new, m_new, status and fresh; *solved when the relations and steps
 * take there the candidate values c gave them (fresh == m_new in the rows M_CAND). */
static int mixed_at(Model *s, const double *c, double *x_new, double *m_new, double *status, double *fresh,
                    int *solved) {
    int k;
    s->res[3] = fresh;  /* the fourth result; call_with() sets the others */
    if (call_with(s, cosim_mixed, s->m, c, x_new, m_new, status)) return CORE_ERROR;
    *solved = 1;
    for (k = 0; k < N_CAND; k++)
        if (fresh[M_CAND[k]] != m_new[M_CAND[k]]) *solved = 0;
    return CORE_OK;
}

/* The candidates of rows M_CAND that changed among the n tried (a cycle), each with its two values. Returns how
 * many, at most MAX_MIXED_SEARCH + 1. */
static int cycling_rows(double tried[][N_M + 1], int n, int *rows, double *low, double *high) {
    int k, j, count = 0;
    for (k = 0; k < N_CAND && count <= MAX_MIXED_SEARCH; k++)
        for (j = 1; j < n; j++)
            if (tried[j][M_CAND[k]] != tried[0][M_CAND[k]]) {
                rows[count] = M_CAND[k];
                low[count] = fmin(tried[0][M_CAND[k]], tried[j][M_CAND[k]]);
                high[count++] = fmax(tried[0][M_CAND[k]], tried[j][M_CAND[k]]);
                break;
            }
    return count;
}

static int bits(unsigned v) {
    int n = 0;
    for (; v; v >>= 1) n += (int)(v & 1u);
    return n;
}

/* The mixed system of one pass, when iterating the candidates cycled: each combination of the two values of
 * the rows that changed, fewest at the higher value first (a relation false before true: a friction element
 * stuck before it slides). Returns 1 with the pass's results when a combination is solved, 0 when none is. */
static int search_mixed(Model *s, double tried[][N_M + 1], int n, double *x_out, double *m_out, double *st_out) {
    int rows[MAX_MIXED_SEARCH + 1], count, ones, k, solved;
    double low[MAX_MIXED_SEARCH + 1], high[MAX_MIXED_SEARCH + 1], c[N_M + 1], fresh[N_M + 1];
    unsigned combo;
    count = cycling_rows(tried, n, rows, low, high);
    if (count > MAX_MIXED_SEARCH) return 0;
    memcpy(c, tried[n - 1], N_M * sizeof(double));
    for (ones = 0; ones <= count; ones++)
        for (combo = 0; combo < (1u << count); combo++) {
            if (bits(combo) != ones) continue;
            for (k = 0; k < count; k++) c[rows[k]] = (combo >> k) & 1u ? high[k] : low[k];
            if (mixed_at(s, c, x_out, m_out, st_out, fresh, &solved)) return -1;
            if (solved) return 1;
        }
    return 0;
}

/* The results of a solved pass become the pass's. */
static void take_pass(double *x_new, double *m_new, double *status, const double *x, const double *m, double st) {
    memcpy(x_new, x, N_X * sizeof(double));
    memcpy(m_new, m, N_M * sizeof(double));
    *status = st;
}

/* The mixed system of one pass (Modelica's event iteration at one instant, pre() held): the discrete variables
 * and the continuous unknowns that decide each other are solved together. From the relations' and steps' values
 * the pass gave (m_new), the candidates are iterated (each the values the last gave) until they reproduce
 * themselves; if they cycle, search_mixed tries the combinations of the rows that changed. x_new, m_new and
 * status become the solved pass's; when nothing solves it they stay the pass's as it was. */
static int solve_mixed(Model *s, double *x_new, double *m_new, double *status) {
    double (*tried)[N_M + 1] = s->mixed_tried, x_try[N_X + 1], m_try[N_M + 1], spare[N_M + 1], st = 0.0;
    int n, j, solved, repeated = 0, found;
    memcpy(tried[0], m_new, N_M * sizeof(double));
    for (n = 1; n <= MAX_MIXED_ITERATIONS && !repeated; n++) {
        if (mixed_at(s, tried[n - 1], x_try, m_try, &st, n < MAX_MIXED_ITERATIONS ? tried[n] : spare, &solved))
            return CORE_ERROR;
        if (solved) {
            take_pass(x_new, m_new, status, x_try, m_try, st);
            return CORE_OK;
        }
        for (j = 0; j < n && n < MAX_MIXED_ITERATIONS; j++)
            if (!memcmp(tried[j], tried[n], N_M * sizeof(double))) repeated = 1;
    }
    found = search_mixed(s, tried, n - 1 + repeated, x_try, m_try, &st);
    if (found < 0) return CORE_ERROR;
    if (found) take_pass(x_new, m_new, status, x_try, m_try, st);
    return CORE_OK;
}

/* One pass of event iteration with `pass` (cosim_update, or cosim_terminal at the end): pass(x, u, p, t, m_pre)
 * with m_pre the current memory; a pass of cosim_update that changes m is then solved as a mixed system. */
static int event_pass_with(Model *s, casadi_fn pass, EventFlags *flags) {
    double x_new[N_X + 1], m_new[N_M + 1], status = 0.0;
    int i, k;
    memset(flags, 0, sizeof *flags);
    if (call(s, pass, s->m, x_new, m_new, &status)) return CORE_ERROR;
    if (N_CAND && pass == cosim_update && memcmp(m_new, s->m, N_M * sizeof(double))
        && solve_mixed(s, x_new, m_new, &status))
        return CORE_ERROR;
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

/* ---- Co-Simulation services: event iteration, the embedded solver ---- */

/* Passes of `pass` until the memory settles (or terminate() fires); the indicators then settle too. */
static int iterate_events(Model *s, casadi_fn pass_fn, int *terminated) {
    EventFlags flags;
    int pass;
    *terminated = 0;
    for (pass = 0; pass < MAX_EVENT_PASSES; pass++) {
        if (event_pass_with(s, pass_fn, &flags)) return CORE_ERROR;
        if (flags.terminate) {
            *terminated = 1;
            return CORE_OK;
        }
        if (!flags.discrete_changed) {
            model_settle_indicators(s);
            return CORE_OK;
        }
    }
    logf_(s, 1, "t = %.17g: event iteration did not settle after %s passes", s->t, "MAX_EVENT_PASSES (100)");
    return CORE_ERROR;
}

int model_event_iteration(Model *s, int *terminated) { return iterate_events(s, cosim_update, terminated); }

/* The end of the simulation: the event iteration with terminal() true (a when-clause on terminal() fires once:
 * its held condition is set by the first pass). */
int model_terminal(Model *s) {
    int terminated;
    return iterate_events(s, cosim_terminal, &terminated);
}

/* s->xdot at (t, x): s is moved there. */
static const double *derivatives_at(Model *s, double t, const double *x) {
    s->t = t;
    if (x != s->x && N_X) memcpy(s->x, x, N_X * sizeof(double));
    model_touch(s);
    return model_derivatives(s);
}

/* One RK4 step of length h from (t0, x0), whose derivative is k1, to (t1, s->x). */
static int rk4(Model *s, double t0, const double *x0, const double *k1, double h, double t1) {
    double k2[N_X + 1], k3[N_X + 1], xs[N_X + 1], x1[N_X + 1];
    const double *f;
    int i;
    for (i = 0; i < N_X; i++) xs[i] = x0[i] + 0.5 * h * k1[i];
    if (!(f = derivatives_at(s, t0 + 0.5 * h, xs))) return CORE_ERROR;
    for (i = 0; i < N_X; i++) k2[i] = f[i], xs[i] = x0[i] + 0.5 * h * f[i];
    if (!(f = derivatives_at(s, t0 + 0.5 * h, xs))) return CORE_ERROR;
    for (i = 0; i < N_X; i++) k3[i] = f[i], xs[i] = x0[i] + h * f[i];
    if (!(f = derivatives_at(s, t1, xs))) return CORE_ERROR;
    for (i = 0; i < N_X; i++) x1[i] = x0[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + f[i]);
    s->t = t1;
    if (N_X) memcpy(s->x, x1, N_X * sizeof(double));
    model_touch(s);
    return CORE_OK;
}

/* Solve a x = b in place (a: n x n column-major, destroyed; b becomes x) by Gaussian elimination with partial
 * pivoting; nonzero when a is singular. */
static int solve_dense(int n, double *a, double *b) {
    int i, j, k, pivot;
    double factor, swap;
    for (k = 0; k < n; k++) {
        pivot = k;
        for (i = k + 1; i < n; i++)
            if (fabs(a[i + k * n]) > fabs(a[pivot + k * n])) pivot = i;
        if (a[pivot + k * n] == 0.0) return 1;
        if (pivot != k) {
            for (j = 0; j < n; j++) swap = a[k + j * n], a[k + j * n] = a[pivot + j * n], a[pivot + j * n] = swap;
            swap = b[k], b[k] = b[pivot], b[pivot] = swap;
        }
        for (i = k + 1; i < n; i++) {
            factor = a[i + k * n] / a[k + k * n];
            for (j = k; j < n; j++) a[i + j * n] -= factor * a[k + j * n];
            b[i] -= factor * b[k];
        }
    }
    for (k = n - 1; k >= 0; k--) {
        for (j = k + 1; j < n; j++) b[k] -= a[k + j * n] * b[j];
        b[k] /= a[k + k * n];
    }
    return 0;
}

#define NEWTON_ITERATIONS 20
#define NEWTON_RTOL 1e-10
#define NEWTON_ATOL 1e-12
#define NEWTON_FAILED 2
#define MAX_SPLITS 10

/* One implicit Euler step x1 = x0 + h f(t1, x1) from (t0, x0): Newton from the explicit Euler guess, with the
 * exact Jacobian I - h df/dx (cosim_jac_x) at every iteration; NEWTON_FAILED when it does not converge. */
static int implicit_euler(Model *s, const double *x0, const double *k1, double h, double t1) {
    double x[N_X + 1], r[N_X + 1], a[N_X * N_X + 1];
    const double *f;
    int i, iteration, converged = 0;
    for (i = 0; i < N_X; i++) x[i] = x0[i] + h * k1[i];
    for (iteration = 0; iteration < NEWTON_ITERATIONS && !converged; iteration++) {
        if (!(f = derivatives_at(s, t1, x))) return CORE_ERROR;
        for (i = 0; i < N_X; i++) r[i] = x[i] - x0[i] - h * f[i];
        if (call(s, cosim_jac_x, s->m, a, NULL, NULL)) return CORE_ERROR;
        for (i = 0; i < N_X * N_X; i++) a[i] *= -h;
        for (i = 0; i < N_X; i++) a[i + i * N_X] += 1.0;
        if (solve_dense(N_X, a, r)) return NEWTON_FAILED;
        converged = 1;
        for (i = 0; i < N_X; i++) {
            x[i] -= r[i];
            if (!(fabs(r[i]) <= NEWTON_ATOL + NEWTON_RTOL * fabs(x[i]))) converged = 0;
        }
    }
    if (!converged) return NEWTON_FAILED;
    s->t = t1;
    if (N_X) memcpy(s->x, x, N_X * sizeof(double));
    model_touch(s);
    return CORE_OK;
}

/* Implicit Euler from (t0, x0) to t1; where Newton fails (a kink of the model inside the step: contact,
 * friction), the step is done as two halves, down to 2^-MAX_SPLITS of it. */
static int implicit_step(Model *s, double t0, const double *x0, const double *k1, double h, double t1, int depth) {
    double xm[N_X + 1], km[N_X + 1];
    const double *f;
    int result = implicit_euler(s, x0, k1, h, t1);
    if (result != NEWTON_FAILED) return result;
    if (depth == MAX_SPLITS) {
        logf_(s, 1, "t = %.17g: implicit Euler: Newton did not converge even on 1/1024 of the step (%s)", t0,
              "a smaller _cs_step, or RK4, helps");
        return CORE_ERROR;
    }
    if ((result = implicit_step(s, t0, x0, k1, 0.5 * h, t0 + 0.5 * h, depth + 1))) return result;
    if (N_X) memcpy(xm, s->x, N_X * sizeof(double));
    if (!(f = model_derivatives(s))) return CORE_ERROR;
    if (N_X) memcpy(km, f, N_X * sizeof(double));
    return implicit_step(s, t0 + 0.5 * h, xm, km, 0.5 * h, t1, depth + 1);
}

static int step_from(Model *s, double t0, const double *x0, const double *k1, double h, double t1) {
    if (s->cs_method == CS_IMPLICIT_EULER) return implicit_step(s, t0, x0, k1, h, t1, 0);
    return rk4(s, t0, x0, k1, h, t1);
}

/* Whether an indicator changed sign between z0 and z1 (an exact 0 is on its former side: model_indicators). */
static int crossed(const double *z0, const double *z1) {
    int k;
    for (k = 0; k < N_Z; k++)
        if ((z0[k] > 0.0 && z1[k] < 0.0) || (z0[k] < 0.0 && z1[k] > 0.0)) return 1;
    return 0;
}

/* A step from (t0, x0) to t1 crossed an indicator: bisect the step length down to EVENT_TOL and end on the
 * far side of the first crossing, where update() sees the relation flipped. */
static int locate(Model *s, double t0, const double *x0, const double *k1, const double *z0, double h) {
    double a = 0.0, b = h, mid;
    const double *z;
    while (b - a > EVENT_TOL) {
        mid = a + 0.5 * (b - a);
        if (step_from(s, t0, x0, k1, mid, t0 + mid)) return CORE_ERROR;
        if (!(z = model_indicators(s))) return CORE_ERROR;
        if (crossed(z0, z)) b = mid;
        else a = mid;
    }
    return step_from(s, t0, x0, k1, b, t0 + b);
}

/* One internal step toward min(t_end, next time event), equal steps of at most cs_step; *event when it ended
 * at an event (state: located; time: stepped onto). */
static int internal_step(Model *s, double t_end, double next_event, int *event) {
    double x0[N_X + 1], k1[N_X + 1], z0[N_Z + 1], target, h, t0 = s->t;
    const double *f, *z;
    double n;
    int time_event = next_event <= t_end;
    target = time_event ? next_event : t_end;
    n = ceil((target - t0) / s->cs_step * (1.0 - 1e-12));
    h = n > 1.0 ? (target - t0) / n : target - t0;
    if (N_X) memcpy(x0, s->x, N_X * sizeof(double));
    if (!(f = model_derivatives(s))) return CORE_ERROR;
    if (N_X) memcpy(k1, f, N_X * sizeof(double));
    if (N_Z) {
        if (!(z = model_indicators(s))) return CORE_ERROR;
        memcpy(z0, z, N_Z * sizeof(double));
    }
    if (step_from(s, t0, x0, k1, h, n > 1.0 ? t0 + h : target)) return CORE_ERROR;
    *event = time_event && n <= 1.0;
    if (N_Z) {
        if (!(z = model_indicators(s))) return CORE_ERROR;
        if (crossed(z0, z)) {
            *event = 1;
            return locate(s, t0, x0, k1, z0, h);
        }
    }
    return CORE_OK;
}

/* An event at s->t: an error when it is the MAX_EVENTS_IN_A_ROW-th in a row each within CHATTER_WINDOW of the
 * last (chattering), in model_do_step and at an importer's event mode alike: an importer's solver would otherwise
 * go on from event to event without end (fmpy's CVode on the MSL's Rotational.Examples.Friction). */
int model_count_event(Model *s) {
    s->events_in_a_row = s->t - s->last_event < CHATTER_WINDOW ? s->events_in_a_row + 1 : 0;
    s->last_event = s->t;
    if (s->events_in_a_row < MAX_EVENTS_IN_A_ROW) return CORE_OK;
    logf_(s, 1, "t = %.17g: %s events in a row, each within 1e-8 s of the last (chattering)", s->t,
          "MAX_EVENTS_IN_A_ROW (100)");
    return CORE_ERROR;
}

int model_do_step(Model *s, double t_end, int *terminated) {
    double next_event;
    int event;
    *terminated = 0;
    /* the importer may have changed inputs or parameters since the last step: an event iteration at the start
     * sees the relations and edges they flipped (a converged one changes nothing) */
    if (N_M && (model_event_iteration(s, terminated) || *terminated)) return *terminated ? CORE_OK : CORE_ERROR;
    next_event = model_next_time(s);
    while (s->t < t_end) {
        if (next_event <= s->t) next_event = INFINITY;  /* next_time is strictly later; never step backward */
        if (internal_step(s, t_end, next_event, &event) || model_accept(s)) return CORE_ERROR;
        if (!event) continue;
        if (model_count_event(s)) return CORE_ERROR;
        if (model_event_iteration(s, terminated)) return CORE_ERROR;
        if (*terminated) return CORE_OK;
        next_event = model_next_time(s);
    }
    return CORE_OK;
}

/* ---- directional derivatives ---- */

static int seed_of(Model *s, unsigned vr, double value, double *dx, double *du) {
    char text[160];
    if (vr >= VR_X && vr < VR_DX) dx[vr - VR_X] += value;
    else if (vr >= VR_U && vr < VR_X) du[vr - VR_U] += value;
    else {
        snprintf(text, sizeof text, "directional derivatives are taken with respect to states and inputs; value "
                 "reference %u is neither", vr);
        logf_(s, 1, "t = %.17g: %s", s->t, text);
        return CORE_ERROR;
    }
    return CORE_OK;
}

/* Forward derivative of f (cosim_dode or cosim_dout: f(x, u, p, t, m, g, dx, du)) into r. */
static int forward(Model *s, casadi_fn f, const double *dx, const double *du, double *r) {
    s->arg[0] = s->x;
    s->arg[1] = s->u;
    s->arg[2] = s->p;
    s->arg[3] = &s->t;
    s->arg[4] = s->m;
    s->arg[5] = start_point(s);
    s->arg[6] = dx;
    s->arg[7] = du;
    s->res[0] = r;
    if (f(s->arg, s->res, (casadi_int *)s->iw, s->w, 0)) {
        logf_(s, 1, "t = %.17g: evaluation of the directional derivative failed%s", s->t, "");
        return CORE_ERROR;
    }
    return CORE_OK;
}

int model_directional(Model *s, const unsigned *unknown, size_t n_unknown, const unsigned *known,
                      size_t n_known, const double *seed, double *sensitivity) {
    double dx[N_X + 1] = {0}, du[N_U + 1] = {0}, dxdot[N_X + 1], dy[N_Y + 1];
    int have_dxdot = 0, have_dy = 0;
    size_t i;
    char text[160];
    unsigned vr;
    for (i = 0; i < n_known; i++)
        if (seed_of(s, known[i], seed[i], dx, du)) return CORE_ERROR;
    for (i = 0; i < n_unknown; i++) {
        vr = unknown[i];
        if (vr >= VR_DX && vr < VR_Y) {
            if (!have_dxdot && forward(s, cosim_dode, dx, du, dxdot)) return CORE_ERROR;
            have_dxdot = 1;
            sensitivity[i] = dxdot[vr - VR_DX];
        } else if (vr >= VR_Y && vr < VR_D) {
            if (!have_dy && forward(s, cosim_dout, dx, du, dy)) return CORE_ERROR;
            have_dy = 1;
            sensitivity[i] = dy[Y_INDEX[vr - VR_Y]];
        } else if (vr >= VR_X && vr < VR_DX) sensitivity[i] = dx[vr - VR_X];
        else {
            snprintf(text, sizeof text, "value reference %u has no directional derivative (unknowns are state "
                     "derivatives, outputs and states)", vr);
            logf_(s, 1, "t = %.17g: %s", s->t, text);
            return CORE_ERROR;
        }
    }
    return CORE_OK;
}

/* ---- the state as a flat array ---- */

#define N_SIZES 6

size_t model_state_size(void) { return N_SIZES + 1 + 2 * N_X + N_U + N_P + N_M + 1 + G_CHAIN * (N_G + 2) + N_Z + 2; }

static double *put(double *to, const double *from, int n) {
    if (n) memcpy(to, from, (size_t)n * sizeof(double));
    return to + n;
}

static const double *take(double *to, const double *from, int n) {
    if (n) memcpy(to, from, (size_t)n * sizeof(double));
    return from + n;
}

void model_state_save(const Model *s, double *buf) {
    const double sizes[N_SIZES] = {N_X, N_U, N_P, N_M, N_Z, N_G};
    int i;
    buf = put(buf, sizes, N_SIZES);
    *buf++ = s->t;
    buf = put(buf, s->x, N_X);
    buf = put(buf, s->u, N_U);
    buf = put(buf, s->p, N_P);
    buf = put(buf, s->m, N_M);
    *buf++ = s->g_count;
    buf = put(buf, s->g_time, G_CHAIN);
    buf = put(buf, s->g[0], G_CHAIN * (N_G + 1));
    for (i = 0; i < N_X; i++) *buf++ = s->x_set[i];
    buf = put(buf, s->z_side, N_Z);
    *buf++ = s->cs_step;
    *buf = s->cs_method;
}

int model_state_load(Model *s, const double *buf) {
    const double sizes[N_SIZES] = {N_X, N_U, N_P, N_M, N_Z, N_G};
    int i;
    if (memcmp(buf, sizes, sizeof sizes) != 0) {
        logf_(s, 1, "t = %.17g: the FMU state was saved by another model (its sizes differ)%s", s->t, "");
        return CORE_ERROR;
    }
    buf += N_SIZES;
    s->t = *buf++;
    buf = take(s->x, buf, N_X);
    buf = take(s->u, buf, N_U);
    buf = take(s->p, buf, N_P);
    buf = take(s->m, buf, N_M);
    s->g_count = (int)*buf++;
    if (s->g_count < 1 || s->g_count > G_CHAIN) s->g_count = 1;  /* not a state of this build */
    buf = take(s->g_time, buf, G_CHAIN);
    buf = take(s->g[0], buf, G_CHAIN * (N_G + 1));
    for (i = 0; i < N_X; i++) s->x_set[i] = *buf++ != 0.0;
    buf = take(s->z_side, buf, N_Z);
    s->cs_step = *buf++;
    s->cs_method = (int)*buf;
    model_touch(s);
    return CORE_OK;
}
