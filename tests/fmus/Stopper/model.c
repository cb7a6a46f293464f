/* Asks the importer to stop: x = time (der(x) = 1) until the time event at t_stop, where the model sets
   terminateSimulation (Model Exchange: fmi*UpdateDiscreteStates; Co-Simulation: doStep ends at t_stop, FMI 3.0
   with terminateSimulation = true, FMI 2.0 with fmi2Discard and fmi2Terminated). */
#include <stdbool.h>
#include <stdint.h>

#define MODEL_TOKEN "{9e1d7c44-0b6f-4a2e-8d35-5f0c6a7b1e29}"
#define N_STATES 1
#define N_INDICATORS 0
#define CS_STEP 1e-3

typedef struct {
    double x, der_x, t_stop;
} ModelData;

#include "model.h"

enum { VR_X = 1, VR_DER_X, VR_T_STOP };

static const VarInfo VARS[] = {
    VAR(VR_X, T_F64, x), VAR(VR_DER_X, T_F64, der_x), VAR(VR_T_STOP, T_F64, t_stop),
};
static const size_t N_VARS = sizeof VARS / sizeof VARS[0];

static void model_start(ModelData *d)
{
    d->x = 0;
    d->t_stop = 0.6;
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
    c->next_event = c->d.t_stop;
}

static bool model_event(Instance *c)
{
    if (c->time >= c->d.t_stop - 1e-9) {
        c->terminate = true;
        c->next_event_defined = false;
    }
    return false;
}
