/* A model whose event iteration never settles: at the time event t_chatter every fmi3UpdateDiscreteStates
   flips the Boolean toggle and asks for another pass. An importer must stop with an error naming the instant;
   the Co-Simulation side gives up after MAX_EVENT_ITERATIONS passes and returns fmi3Error. Before t_chatter
   x = time (der(x) = 1). */
#include <stdbool.h>
#include <stdint.h>

#define MODEL_TOKEN "{e4b82f17-5a3c-4d06-9c1e-86d0f7a2b3c5}"
#define N_STATES 1
#define N_INDICATORS 0
#define CS_STEP 1e-3

typedef struct {
    double x, der_x, t_chatter;
    bool toggle;
} ModelData;

#include "model.h"

static const VarInfo VARS[] = { VAR(1, T_F64, x), VAR(2, T_F64, der_x), VAR(3, T_F64, t_chatter), VAR(4, T_BOOL, toggle) };
static const size_t N_VARS = sizeof VARS / sizeof VARS[0];

static void model_start(ModelData *d)
{
    d->x = 0;
    d->t_chatter = 0.5;
    d->toggle = false;
}

static void model_outputs(Instance *c) { c->d.der_x = 1; }
static void model_get_states(Instance *c, double x[]) { x[0] = c->d.x; }
static void model_set_states(Instance *c, const double x[]) { c->d.x = x[0]; }

static void model_derivatives(Instance *c, double dx[])
{
    model_outputs(c);
    dx[0] = c->d.der_x;
}

static void model_indicators(Instance *c, double z[]) {}

static void model_initialize(Instance *c)
{
    c->next_event_defined = true;
    c->next_event = c->d.t_chatter;
}

static bool model_event(Instance *c)
{
    if (c->time < c->d.t_chatter - 1e-9) return false;
    c->d.toggle = !c->d.toggle;
    return true;
}
