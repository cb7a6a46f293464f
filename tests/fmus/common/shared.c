/* Code shared by the FMI 2.0 and FMI 3.0 glue: variable lookup and the co-simulation integrator. */

/* Event iterations at one instant after which the model is taken to chatter. */
#define MAX_EVENT_ITERATIONS 100

/* A model with step events defines HAS_STEP_EVENT and model_step_event (true: enter event mode now). */
#ifdef HAS_STEP_EVENT
#define STEP_EVENT(c) model_step_event(c)
#else
#define STEP_EVENT(c) false
#endif

static const VarInfo *find_var(unsigned int vr, VarType type)
{
    for (size_t k = 0; k < N_VARS; k++) {
        if (VARS[k].vr == vr && VARS[k].type == type) return &VARS[k];
    }
    return NULL;
}

static void *var_ptr(Instance *c, const VarInfo *v)
{
    return (char *)&c->d + v->offset;
}

/* One classical Runge-Kutta step of length dt from (t0, x0); leaves the instance at t0 + dt with the new states. */
static void rk4(Instance *c, const double x0[], double t0, double dt)
{
    double k1[NX_BUF], k2[NX_BUF], k3[NX_BUF], k4[NX_BUF], x[NX_BUF];
    const double h[3] = { dt / 2, dt / 2, dt };
    double *k[4] = { k1, k2, k3, k4 };
    c->time = t0;
    model_set_states(c, x0);
    model_derivatives(c, k1);
    for (int s = 0; s < 3; s++) {
        for (int i = 0; i < N_STATES; i++) x[i] = x0[i] + h[s] * k[s][i];
        c->time = t0 + h[s];
        model_set_states(c, x);
        model_derivatives(c, k[s + 1]);
    }
    for (int i = 0; i < N_STATES; i++) x[i] = x0[i] + dt / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    c->time = t0 + dt;
    model_set_states(c, x);
}

/* True when an indicator changed domain (z > 0 against z <= 0), the FMI definition of a state event. */
static bool crossed(const double z0[], const double z1[])
{
    for (int i = 0; i < N_INDICATORS; i++) {
        if ((z0[i] > 0) != (z1[i] > 0)) return true;
    }
    return false;
}

/* Event iteration at the current instant; false when it does not settle (chattering). */
static bool settle_events(Instance *c)
{
    for (int k = 0; k < MAX_EVENT_ITERATIONS; k++) {
        if (!model_event(c) || c->terminate) return true;
    }
    return false;
}

/* Advances a co-simulation instance to t_end with fixed RK4 steps of CS_STEP. A state event is located by
   bisection on the step length to EVENT_TOL (re-integrating from the step's start), a time event is taken
   at its instant, a step event after the step that asks for it; all are handled by event iteration. Stops early when the model asks to terminate.
   Returns false when event iteration does not settle. */
static bool cs_advance(Instance *c, double t_end)
{
    double x0[NX_BUF], z0[NZ_BUF], z1[NZ_BUF];
    while (c->time < t_end - EVENT_TOL && !c->terminate) {
        double t0 = c->time, dt = fmin(CS_STEP, t_end - t0);
        bool time_event = c->next_event_defined && c->next_event <= t0 + dt + EVENT_TOL;
        if (time_event) dt = c->next_event - t0;
        model_get_states(c, x0);
        model_indicators(c, z0);
        rk4(c, x0, t0, dt);
        model_indicators(c, z1);
        if (crossed(z0, z1)) {
            double lo = 0, hi = dt;
            while (hi - lo > EVENT_TOL) {
                double mid = (lo + hi) / 2;
                rk4(c, x0, t0, mid);
                model_indicators(c, z1);
                if (crossed(z0, z1)) hi = mid; else lo = mid;
            }
            rk4(c, x0, t0, hi);
        } else if (time_event) {
            c->time = c->next_event;
        } else if (!STEP_EVENT(c)) {
            continue;
        }
        if (!settle_events(c)) return false;
    }
    if (!c->terminate) c->time = t_end;
    return true;
}
