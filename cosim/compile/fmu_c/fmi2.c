/* FMI 2.0 API over the model core (model_core.h): Model Exchange and Co-Simulation in one binary (the kind is
 * chosen by fmi2Instantiate), with directional derivatives and FMU state get/set/serialise.
 * Co-Simulation steps with the core's embedded solver (model_do_step: events are handled inside the step).
 * Integer and Boolean variables are the core's Int64 and Boolean discretes (an FMI 2 Integer is 32 bits). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model_core.h"

enum { MODE_INSTANTIATED, MODE_INITIALIZATION, MODE_EVENT, MODE_CONTINUOUS, MODE_TERMINATED };

typedef struct {
    Model *model;
    fmi2Type kind;
    int mode;
    int terminated;              /* Co-Simulation: the model called terminate() during a step */
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    char name[256];
} Fmu2;

static void log_fmu(void *env, int error, const char *message) {
    Fmu2 *f = (Fmu2 *)env;
    if (f->logger)
        f->logger(f->env, f->name, error ? fmi2Error : fmi2OK, error ? "logStatusError" : "logEvents", "%s",
                  message);
}

static fmi2Status refuse(fmi2Component c, const char *what) {
    Fmu2 *f = (Fmu2 *)c;
    char text[200];
    snprintf(text, sizeof text, "%s (FMI 2.0 %s of %s)", what,
             f && f->kind == fmi2CoSimulation ? "Co-Simulation" : "Model Exchange", MODEL_IDENTIFIER);
    if (f) log_fmu(f, 1, text);
    return fmi2Error;
}

static fmi2Status status(int core_result) { return core_result == CORE_OK ? fmi2OK : fmi2Error; }

static int initialising(Fmu2 *f) { return f->mode == MODE_INSTANTIATED || f->mode == MODE_INITIALIZATION; }

/* ---- instance life cycle ---- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    Fmu2 *f;
    fmi2CallbackLogger logger = functions ? functions->logger : NULL;
    fmi2ComponentEnvironment env = functions ? functions->componentEnvironment : NULL;
    (void)fmuResourceLocation, (void)visible, (void)loggingOn;
    if (fmuGUID && strcmp(fmuGUID, INSTANTIATION_TOKEN) != 0) {
        if (logger) logger(env, instanceName, fmi2Error, "logStatusError", "%s",
                           "the GUID does not match the modelDescription of " MODEL_IDENTIFIER);
        return NULL;
    }
    f = (Fmu2 *)calloc(1, sizeof(Fmu2));
    if (!f) return NULL;
    f->kind = fmuType;
    f->logger = logger;
    f->env = env;
    f->mode = MODE_INSTANTIATED;
    snprintf(f->name, sizeof f->name, "%s", instanceName ? instanceName : MODEL_IDENTIFIER);
    f->model = model_new(log_fmu, f);
    if (!f->model) {
        free(f);
        return NULL;
    }
    return f;
}

void fmi2FreeInstance(fmi2Component c) {
    Fmu2 *f = (Fmu2 *)c;
    if (!f) return;
    model_free(f->model);
    free(f);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)c, (void)loggingOn, (void)nCategories, (void)categories;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Fmu2 *f = (Fmu2 *)c;
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    f->model->t = startTime;
    model_touch(f->model);
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ((Fmu2 *)c)->mode = MODE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Fmu2 *f = (Fmu2 *)c;
    if (model_initialize(f->model)) return fmi2Error;
    if (f->kind == fmi2ModelExchange) {
        f->mode = MODE_EVENT;
        return fmi2OK;
    }
    f->mode = MODE_CONTINUOUS;
    return status(model_event_iteration(f->model, &f->terminated));
}

/* The end of the simulation: the passes where terminal() is true, after which the final values can be read. */
fmi2Status fmi2Terminate(fmi2Component c) {
    Fmu2 *f = (Fmu2 *)c;
    int initialised = f->mode == MODE_EVENT || f->mode == MODE_CONTINUOUS;
    f->mode = MODE_TERMINATED;
    if (initialised && model_terminal(f->model)) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Fmu2 *f = (Fmu2 *)c;
    model_reset(f->model);
    f->mode = MODE_INSTANTIATED;
    f->terminated = 0;
    return fmi2OK;
}

/* ---- variables: Real, Integer and Boolean; no String variables ---- */

#define GETTER(NAME, CTYPE, TYPE, CONVERT)                                                                     \
    fmi2Status NAME(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, CTYPE value[]) {              \
        Model *s = ((Fmu2 *)c)->model;                                                                         \
        double v;                                                                                              \
        size_t i;                                                                                              \
        for (i = 0; i < nvr; i++) {                                                                            \
            if (model_get(s, vr[i], TYPE, &v)) return fmi2Error;                                               \
            value[i] = CONVERT;                                                                                \
        }                                                                                                      \
        return fmi2OK;                                                                                         \
    }

#define SETTER(NAME, CTYPE, TYPE)                                                                              \
    fmi2Status NAME(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const CTYPE value[]) {        \
        Fmu2 *f = (Fmu2 *)c;                                                                                   \
        size_t i;                                                                                              \
        for (i = 0; i < nvr; i++)                                                                              \
            if (model_set(f->model, vr[i], TYPE, (double)value[i], initialising(f))) return fmi2Error;        \
        return fmi2OK;                                                                                         \
    }

GETTER(fmi2GetReal, fmi2Real, TYPE_FLOAT64, v)
GETTER(fmi2GetInteger, fmi2Integer, TYPE_INT64, (fmi2Integer)v)
GETTER(fmi2GetBoolean, fmi2Boolean, TYPE_BOOLEAN, v != 0.0 ? fmi2True : fmi2False)
SETTER(fmi2SetReal, fmi2Real, TYPE_FLOAT64)
SETTER(fmi2SetInteger, fmi2Integer, TYPE_INT64)
SETTER(fmi2SetBoolean, fmi2Boolean, TYPE_BOOLEAN)

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)vr, (void)value;
    return nvr ? refuse(c, "fmi2GetString: the FMU has no String variable") : fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)vr, (void)value;
    return nvr ? refuse(c, "fmi2SetString: the FMU has no String variable") : fmi2OK;
}

/* ---- FMU state: the core's flat array of doubles after the API layer's mode and terminated flag ---- */

static size_t state_doubles(void) { return model_state_size() + 2; }

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    Fmu2 *f = (Fmu2 *)c;
    double *buf = (double *)*FMUstate;
    if (!buf && !(buf = (double *)malloc(state_doubles() * sizeof(double))))
        return refuse(c, "fmi2GetFMUstate: out of memory");
    buf[0] = f->mode;
    buf[1] = f->terminated;
    model_state_save(f->model, buf + 2);
    *FMUstate = buf;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    Fmu2 *f = (Fmu2 *)c;
    const double *buf = (const double *)FMUstate;
    if (!buf) return refuse(c, "fmi2SetFMUstate: no state given");
    f->mode = (int)buf[0];
    f->terminated = (int)buf[1];
    return status(model_state_load(f->model, buf + 2));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)c;
    free(*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)c, (void)FMUstate;
    *size = state_doubles() * sizeof(double);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    if (size != state_doubles() * sizeof(double)) return refuse(c, "fmi2SerializeFMUstate: wrong buffer size");
    memcpy(serializedState, FMUstate, size);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    double *buf;
    if (size != state_doubles() * sizeof(double))
        return refuse(c, "fmi2DeSerializeFMUstate: the bytes are not a state of this FMU (wrong size)");
    if (!(buf = (double *)malloc(size))) return refuse(c, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(buf, serializedState, size);
    *FMUstate = buf;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    return status(model_directional(((Fmu2 *)c)->model, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                                    dvUnknown));
}

/* ---- Model Exchange ---- */

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    ((Fmu2 *)c)->mode = MODE_EVENT;
    return status(model_count_event(((Fmu2 *)c)->model));
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    Fmu2 *f = (Fmu2 *)c;
    EventFlags flags;
    int result = model_event_pass(f->model, &flags);
    double next = model_next_time(f->model);
    info->newDiscreteStatesNeeded = flags.discrete_changed;
    info->terminateSimulation = flags.terminate;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = flags.states_changed;
    info->nextEventTimeDefined = isfinite(next) ? fmi2True : fmi2False;
    info->nextEventTime = isfinite(next) ? next : 0.0;
    return status(result);
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    Fmu2 *f = (Fmu2 *)c;
    f->mode = MODE_CONTINUOUS;
    model_settle_indicators(f->model);
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return status(model_accept(((Fmu2 *)c)->model));
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    Model *s = ((Fmu2 *)c)->model;
    s->t = time;
    model_touch(s);
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Model *s = ((Fmu2 *)c)->model;
    if (nx != N_X) return refuse(c, "fmi2SetContinuousStates with a wrong number of states");
    if (N_X) memcpy(s->x, x, N_X * sizeof(double));
    model_touch(s);
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Model *s = ((Fmu2 *)c)->model;
    if (nx != N_X) return refuse(c, "fmi2GetContinuousStates with a wrong number of states");
    if (N_X) memcpy(x, s->x, N_X * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    const double *xdot;
    if (nx != N_X) return refuse(c, "fmi2GetDerivatives with a wrong number of states");
    if (!(xdot = model_derivatives(((Fmu2 *)c)->model))) return fmi2Error;
    if (N_X) memcpy(derivatives, xdot, N_X * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    const double *z;
    if (ni == 0) return fmi2OK;
    if (ni != N_Z) return refuse(c, "fmi2GetEventIndicators with a wrong number of indicators");
    if (!(z = model_indicators(((Fmu2 *)c)->model))) return fmi2Error;
    memcpy(eventIndicators, z, N_Z * sizeof(double));
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    if (nx != N_X) return refuse(c, "fmi2GetNominalsOfContinuousStates with a wrong count");
    if (N_X) memcpy(x_nominal, X_NOMINAL, N_X * sizeof(double));
    return fmi2OK;
}

/* ---- Co-Simulation ---- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Fmu2 *f = (Fmu2 *)c;
    Model *s = f->model;
    char text[200];
    (void)noSetFMUStatePriorToCurrentPoint;
    if (f->kind != fmi2CoSimulation) return refuse(c, "fmi2DoStep on a Model Exchange instance");
    if (f->terminated) return refuse(c, "fmi2DoStep after the model called terminate()");
    if (fabs(currentCommunicationPoint - s->t) > 1e-9 * (1.0 + fabs(s->t))) {
        snprintf(text, sizeof text, "fmi2DoStep from t = %.17g while the FMU is at t = %.17g",
                 currentCommunicationPoint, s->t);
        return refuse(c, text);
    }
    if (model_do_step(s, currentCommunicationPoint + communicationStepSize, &f->terminated)) return fmi2Error;
    return f->terminated ? fmi2Discard : fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return refuse(c, "fmi2CancelStep: doStep is never asynchronous"); }

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)order, (void)value;
    return nvr ? refuse(c, "fmi2SetRealInputDerivatives: the FMU does not interpolate inputs") : fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)order, (void)value;
    return nvr ? refuse(c, "fmi2GetRealOutputDerivatives: maxOutputDerivativeOrder is 0") : fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    if (s != fmi2DoStepStatus) return refuse(c, "fmi2GetStatus: only fmi2DoStepStatus is known");
    *value = ((Fmu2 *)c)->terminated ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (s != fmi2LastSuccessfulTime) return refuse(c, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is known");
    *value = ((Fmu2 *)c)->model->t;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    return refuse(c, "fmi2GetIntegerStatus: no integer status is defined");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (s != fmi2Terminated) return refuse(c, "fmi2GetBooleanStatus: only fmi2Terminated is known");
    *value = ((Fmu2 *)c)->terminated ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    return refuse(c, "fmi2GetStringStatus: no string status is defined");
}
