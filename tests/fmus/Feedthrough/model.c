/* Every FMI 3.0 type the master connects, with direct feedthrough from inputs to outputs:
   y_f64 = 2 u_f64, y_f32 = 2 u_f32 (Float32 arithmetic), y_i32 = u_i32 + 1, y_i64 = 3 u_i64, y_b = not u_b;
   the state x integrates u_f64 (der(x) = u_f64), so x has no direct feedthrough. */
#include <stdbool.h>
#include <stdint.h>

#define MODEL_TOKEN "{c3d5e8a1-6f24-4b9e-a0c7-2e8f1d4b6a90}"
#define N_STATES 1
#define N_INDICATORS 0
#define CS_STEP 1e-3

typedef struct {
    double u_f64, y_f64, x, der_x;
    float u_f32, y_f32;
    int32_t u_i32, y_i32;
    int64_t u_i64, y_i64;
    bool u_b, y_b;
} ModelData;

#include "model.h"

static const VarInfo VARS[] = {
    VAR(1, T_F64, u_f64), VAR(2, T_F32, u_f32), VAR(3, T_I32, u_i32), VAR(4, T_I64, u_i64), VAR(5, T_BOOL, u_b),
    VAR(6, T_F64, y_f64), VAR(7, T_F32, y_f32), VAR(8, T_I32, y_i32), VAR(9, T_I64, y_i64), VAR(10, T_BOOL, y_b),
    VAR(11, T_F64, x), VAR(12, T_F64, der_x),
};
static const size_t N_VARS = sizeof VARS / sizeof VARS[0];

static void model_start(ModelData *d)
{
    memset(d, 0, sizeof *d);
}

static void model_outputs(Instance *c)
{
    ModelData *d = &c->d;
    d->y_f64 = 2 * d->u_f64;
    d->y_f32 = 2.0f * d->u_f32;
    d->y_i32 = d->u_i32 + 1;
    d->y_i64 = 3 * d->u_i64;
    d->y_b = !d->u_b;
    d->der_x = d->u_f64;
}

static void model_get_states(Instance *c, double x[]) { x[0] = c->d.x; }
static void model_set_states(Instance *c, const double x[]) { c->d.x = x[0]; }

static void model_derivatives(Instance *c, double dx[])
{
    model_outputs(c);
    dx[0] = c->d.der_x;
}

static void model_indicators(Instance *c, double z[]) {}
static void model_initialize(Instance *c) {}
static bool model_event(Instance *c) { return false; }
