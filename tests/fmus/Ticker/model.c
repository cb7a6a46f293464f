/* Time events only: the Integer counter steps up by one at t = period, 2 period, ... (announced through
   nextEventTime) and the state x integrates it: der(x) = counter.

   Closed form: counter = floor(t / period), x = period k (k - 1) / 2 + k (t - k period) with k = counter. */
#include <stdbool.h>
#include <stdint.h>

#define MODEL_TOKEN "{2f6a9d0e-3c1b-4e8a-9b7d-71c4e2a0b5d3}"
#define N_STATES 1
#define N_INDICATORS 0
#define CS_STEP 1e-3

typedef struct {
    double x, der_x, period;
    int32_t counter;
} ModelData;

#include "model.h"

enum { VR_X = 1, VR_DER_X, VR_PERIOD, VR_COUNTER };

static const VarInfo VARS[] = {
    VAR(VR_X, T_F64, x), VAR(VR_DER_X, T_F64, der_x), VAR(VR_PERIOD, T_F64, period), VAR(VR_COUNTER, T_I32, counter),
};
static const size_t N_VARS = sizeof VARS / sizeof VARS[0];

static void model_start(ModelData *d)
{
    d->x = 0;
    d->period = 0.25;
    d->counter = 0;
}

static void model_outputs(Instance *c) { c->d.der_x = c->d.counter; }
static void model_get_states(Instance *c, double x[]) { x[0] = c->d.x; }
static void model_set_states(Instance *c, const double x[]) { c->d.x = x[0]; }

static void model_derivatives(Instance *c, double dx[])
{
    model_outputs(c);
    dx[0] = c->d.der_x;
}

static void model_indicators(Instance *c, double z[]) {}

/* The counter is a function of time (floor of t / period, with a margin for the rounding of the event
   instant), so an update outside a time event changes nothing. */
static bool model_event(Instance *c)
{
    c->d.counter = (int32_t)floor(c->time / c->d.period + 1e-9);
    c->next_event_defined = true;
    c->next_event = (c->d.counter + 1) * c->d.period;
    return false;
}

static void model_initialize(Instance *c) { model_event(c); }
