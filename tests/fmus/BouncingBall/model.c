/* A ball dropped from h onto a floor at h = 0: der(h) = v, der(v) = -g while flying. State event at h = 0
   with v < 0: v := -e v and the bounce counter goes up. When the rebound speed would fall below v_min the
   ball rests on the floor (flying = false, v = 0, h stays at the smallest positive double).

   Closed form from rest at h0: first impact t1 = sqrt(2 h0 / g) with speed w1 = g t1; after impact k the ball
   leaves with e^k w1 and lands again 2 e^k w1 / g later. */
#include <stdbool.h>
#include <stdint.h>

#define MODEL_TOKEN "{5b0c3f1e-9a57-4c1d-8f0e-b0c1ba11f3e1}"
#define N_STATES 2
#define N_INDICATORS 1
#define CS_STEP 1e-3

typedef struct {
    double h, der_h, v, der_v, g, e, v_min;
    int32_t bounces;
    bool flying;
} ModelData;

#include "model.h"

enum { VR_H = 1, VR_DER_H, VR_V, VR_DER_V, VR_G, VR_E, VR_V_MIN, VR_BOUNCES, VR_FLYING };

static const VarInfo VARS[] = {
    VAR(VR_H, T_F64, h), VAR(VR_DER_H, T_F64, der_h), VAR(VR_V, T_F64, v), VAR(VR_DER_V, T_F64, der_v),
    VAR(VR_G, T_F64, g), VAR(VR_E, T_F64, e), VAR(VR_V_MIN, T_F64, v_min),
    VAR(VR_BOUNCES, T_I32, bounces), VAR(VR_FLYING, T_BOOL, flying),
};
static const size_t N_VARS = sizeof VARS / sizeof VARS[0];

static void model_start(ModelData *d)
{
    d->h = 1;
    d->v = 0;
    d->g = 9.81;
    d->e = 0.7;
    d->v_min = 0.1;
    d->bounces = 0;
    d->flying = true;
}

static void model_outputs(Instance *c)
{
    c->d.der_h = c->d.flying ? c->d.v : 0;
    c->d.der_v = c->d.flying ? -c->d.g : 0;
}

static void model_get_states(Instance *c, double x[])
{
    x[0] = c->d.h;
    x[1] = c->d.v;
}

static void model_set_states(Instance *c, const double x[])
{
    c->d.h = x[0];
    c->d.v = x[1];
}

static void model_derivatives(Instance *c, double dx[])
{
    model_outputs(c);
    dx[0] = c->d.der_h;
    dx[1] = c->d.der_v;
}

/* The indicator is h itself. After an impact h is set to the smallest positive double, so that the
   indicator leaves the event on the positive side and the rebound is not taken for a new crossing. */
static void model_indicators(Instance *c, double z[])
{
    z[0] = c->d.h;
}

static void model_initialize(Instance *c)
{
    c->d.flying = true;
    c->next_event_defined = false;
}

static bool model_event(Instance *c)
{
    ModelData *d = &c->d;
    if (d->flying && d->h <= 0 && d->v < 0) {
        d->bounces += 1;
        d->h = DBL_MIN;
        d->v = -d->e * d->v;
        if (d->v < d->v_min) {
            d->v = 0;
            d->flying = false;
        }
        c->states_changed = true;
    }
    return false;
}
