/* The interface between a test model (<name>/model.c) and the FMI glue (common/fmi2.c, common/fmi3.c).

   A model file defines, before including this header:
     MODEL_TOKEN       instantiation token (FMI 3.0) / GUID (FMI 2.0), checked at instantiation
     N_STATES          number of continuous states (may be 0)
     N_INDICATORS      number of event indicators (may be 0)
     CS_STEP           fixed step [s] of the co-simulation integrator (common/cs.c)
     ModelData         a struct holding every variable of the model
   and, after it, the functions declared at the end of this file and the table VARS (N_VARS entries) of its
   variables. The glue (common/shared.c) is included after the model. */
#ifndef TEST_FMU_MODEL_H
#define TEST_FMU_MODEL_H

#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* C has no zero-length arrays: buffers for states and indicators get at least one element. */
#define NX_BUF (N_STATES > 0 ? N_STATES : 1)
#define NZ_BUF (N_INDICATORS > 0 ? N_INDICATORS : 1)

/* Time tolerance of state-event location in the co-simulation integrator [s]. */
#define EVENT_TOL 1e-12

typedef enum { T_F64, T_F32, T_I32, T_I64, T_BOOL } VarType;

/* One model variable: its value reference, its type and where it lives in ModelData. */
typedef struct {
    unsigned int vr;
    VarType type;
    size_t offset;
} VarInfo;

#define VAR(vr, type, field) { vr, type, offsetof(ModelData, field) }

typedef struct Instance {
    double time;
    bool cs;                     /* instantiated for co-simulation: events are handled inside doStep */
    bool early_return_allowed;   /* FMI 3.0 co-simulation: doStep may return before its end on terminate */
    bool next_event_defined;     /* a time event is scheduled at next_event */
    double next_event;
    bool terminate;              /* the model asks the importer to stop */
    bool states_changed;         /* the last event changed the continuous states */
    char *name;
    void *env;                   /* the importer's instance environment */
    void *logger;                /* the importer's log callback (FMI version specific type) */
    ModelData d;
} Instance;

/* Sets every variable to its start value. */
static void model_start(ModelData *d);
/* Computes outputs and derivative variables from states, inputs, parameters and time. */
static void model_outputs(Instance *c);
static void model_get_states(Instance *c, double x[]);
static void model_set_states(Instance *c, const double x[]);
static void model_derivatives(Instance *c, double dx[]);
static void model_indicators(Instance *c, double z[]);
/* At the end of initialisation: initial discrete values and the first time event. */
static void model_initialize(Instance *c);
/* One pass of event iteration at c->time; returns true when another pass is needed. */
static bool model_event(Instance *c);

#endif
