/* Step events: x rises with der(x) = 1 and, once x >= 1 at the end of an integrator step, fmi3CompletedIntegratorStep
   asks for event mode, where x := x - 1 and the counter steps up. However late the event, x + resets = time. */
#include <stdbool.h>
#include <stdint.h>

#define MODEL_TOKEN "{71a0e3b6-d852-4c9f-b3e1-0f6d2a95c847}"
#define N_STATES 1
#define N_INDICATORS 0
#define CS_STEP 1e-3
#define HAS_STEP_EVENT

typedef struct {
    double x, der_x;
    int32_t resets;
} ModelData;

#include "model.h"

static const VarInfo VARS[] = { VAR(1, T_F64, x), VAR(2, T_F64, der_x), VAR(3, T_I32, resets) };
static const size_t N_VARS = sizeof VARS / sizeof VARS[0];

static void model_start(ModelData *d)
{
    d->x = 0;
    d->resets = 0;
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
static void model_initialize(Instance *c) {}
static bool model_step_event(Instance *c) { return c->d.x >= 1; }

static bool model_event(Instance *c)
{
    while (c->d.x >= 1) {
        c->d.x -= 1;
        c->d.resets += 1;
        c->states_changed = true;
    }
    return false;
}
