/* FMI 3.0 API over the model core (model_core.h): instances, modes, variables, type conversions, status codes and
 * the Model Exchange functions. Co-Simulation, FMU state and directional derivatives are in fmi3_cs.c. Functions
 * this FMU does not provide (clocks, scheduled execution, other types) are present, as the standard requires,
 * and answer fmi3Error. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3_common.h"

void log3(void *env, int error, const char *message) {
    Fmu3 *f = (Fmu3 *)env;
    if (f->log) f->log(f->env, error ? fmi3Error : fmi3OK, error ? "logStatusError" : "logEvents", message);
}

fmi3Status refuse(fmi3Instance instance, const char *function) {
    Fmu3 *f = (Fmu3 *)instance;
    char text[200];
    snprintf(text, sizeof text, "%s is not provided by this FMU or not now (FMI 3.0, %s)", function,
             MODEL_IDENTIFIER);
    if (f) log3(f, 1, text);
    return fmi3Error;
}

fmi3Status status(int core_result) { return core_result == CORE_OK ? fmi3OK : fmi3Error; }

static int initialising(Fmu3 *f) { return f->mode == MODE_INSTANTIATED || f->mode == MODE_INITIALIZATION; }

/* ---- instance life cycle ---- */

Fmu3 *fmu3_new(fmi3String instantiationToken, fmi3InstanceEnvironment instanceEnvironment,
               fmi3LogMessageCallback logMessage, int co_simulation) {
    Fmu3 *f;
    if (instantiationToken && strcmp(instantiationToken, INSTANTIATION_TOKEN) != 0) {
        if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                                   "instantiationToken does not match the modelDescription of " MODEL_IDENTIFIER);
        return NULL;
    }
    f = (Fmu3 *)calloc(1, sizeof(Fmu3));
    if (!f) return NULL;
    f->log = logMessage;
    f->env = instanceEnvironment;
    f->mode = MODE_INSTANTIATED;
    f->co_simulation = co_simulation;
    f->model = model_new(log3, f);
    if (!f->model) {
        free(f);
        return NULL;
    }
    return f;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instanceName, (void)resourcePath, (void)visible, (void)loggingOn;
    return fmu3_new(instantiationToken, instanceEnvironment, logMessage, 0);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                               MODEL_IDENTIFIER " does not provide Scheduled Execution");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Fmu3 *f = (Fmu3 *)instance;
    if (!f) return;
    model_free(f->model);
    free(f);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    (void)instance, (void)loggingOn, (void)nCategories, (void)categories;
    return fmi3OK;
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    Fmu3 *f = (Fmu3 *)instance;
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    f->model->t = startTime;
    model_touch(f->model);
    f->mode = MODE_INITIALIZATION;
    return fmi3OK;
}

/* Model Exchange: on to Event Mode (the importer iterates the events). Co-Simulation: the FMU iterates the
 * events of the initial instant itself and is then in Step Mode. */
fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    Fmu3 *f = (Fmu3 *)instance;
    f->mode = f->co_simulation ? MODE_STEP : MODE_EVENT;
    if (model_initialize(f->model)) return fmi3Error;
    return f->co_simulation ? status(model_event_iteration(f->model, &f->terminated)) : fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    ((Fmu3 *)instance)->mode = MODE_EVENT;
    return status(model_count_event(((Fmu3 *)instance)->model));
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    Fmu3 *f = (Fmu3 *)instance;
    f->mode = MODE_CONTINUOUS;
    model_settle_indicators(f->model);
    return fmi3OK;
}

/* The end of the simulation: the passes where terminal() is true, after which the final values can be read. */
fmi3Status fmi3Terminate(fmi3Instance instance) {
    Fmu3 *f = (Fmu3 *)instance;
    int initialised = f->mode == MODE_EVENT || f->mode == MODE_CONTINUOUS || f->mode == MODE_STEP;
    f->mode = MODE_TERMINATED;
    if (initialised && model_terminal(f->model)) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    Fmu3 *f = (Fmu3 *)instance;
    model_reset(f->model);
    f->mode = MODE_INSTANTIATED;
    f->terminated = 0;
    return fmi3OK;
}

/* ---- events ---- */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    Fmu3 *f = (Fmu3 *)instance;
    EventFlags flags;
    double next;
    int result = model_event_pass(f->model, &flags);
    next = model_next_time(f->model);
    *discreteStatesNeedUpdate = flags.discrete_changed;
    *terminateSimulation = flags.terminate;
    *nominalsOfContinuousStatesChanged = fmi3False;
    *valuesOfContinuousStatesChanged = flags.states_changed;
    *nextEventTimeDefined = isfinite(next) ? fmi3True : fmi3False;
    *nextEventTime = isfinite(next) ? next : 0.0;
    return status(result);
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi3False;
    *terminateSimulation = fmi3False;
    return status(model_accept(((Fmu3 *)instance)->model));
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    (void)instance;
    *nEventIndicators = N_Z;
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    const double *z;
    if (nEventIndicators == 0) return fmi3OK;
    if (nEventIndicators != N_Z) return refuse(instance, "fmi3GetEventIndicators with a wrong count");
    if (!(z = model_indicators(((Fmu3 *)instance)->model))) return fmi3Error;
    memcpy(eventIndicators, z, N_Z * sizeof(double));
    return fmi3OK;
}

/* ---- continuous states ---- */

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    Model *s = ((Fmu3 *)instance)->model;
    s->t = time;
    model_touch(s);
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    (void)instance;
    *nContinuousStates = N_X;
    return fmi3OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    Model *s = ((Fmu3 *)instance)->model;
    if (nContinuousStates != N_X) return refuse(instance, "fmi3SetContinuousStates with a wrong count");
    if (N_X) memcpy(s->x, continuousStates, N_X * sizeof(double));
    model_touch(s);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    Model *s = ((Fmu3 *)instance)->model;
    if (nContinuousStates != N_X) return refuse(instance, "fmi3GetContinuousStates with a wrong count");
    if (N_X) memcpy(continuousStates, s->x, N_X * sizeof(double));
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    const double *xdot;
    if (nContinuousStates != N_X) return refuse(instance, "fmi3GetContinuousStateDerivatives with a wrong count");
    if (!(xdot = model_derivatives(((Fmu3 *)instance)->model))) return fmi3Error;
    if (N_X) memcpy(derivatives, xdot, N_X * sizeof(double));
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    if (nContinuousStates != N_X) return refuse(instance, "fmi3GetNominalsOfContinuousStates with a wrong count");
    if (N_X) memcpy(nominals, X_NOMINAL, N_X * sizeof(double));
    return fmi3OK;
}

/* ---- variables: Float64, Int64 and Boolean exist; every other type has no variables ---- */

#define GETTER(NAME, CTYPE, TYPE, CONVERT)                                                                     \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[],                          \
                    size_t nValueReferences, CTYPE values[], size_t nValues) {                                  \
        Model *s = ((Fmu3 *)instance)->model;                                                                   \
        double v;                                                                                               \
        size_t i;                                                                                               \
        if (nValues != nValueReferences) return refuse(instance, #NAME " with arrays (nValues != nValueReferences)"); \
        for (i = 0; i < nValueReferences; i++) {                                                                \
            if (model_get(s, valueReferences[i], TYPE, &v)) return fmi3Error;                                  \
            values[i] = CONVERT;                                                                                \
        }                                                                                                       \
        return fmi3OK;                                                                                          \
    }

#define SETTER(NAME, CTYPE, TYPE)                                                                               \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[],                          \
                    size_t nValueReferences, const CTYPE values[], size_t nValues) {                            \
        Fmu3 *f = (Fmu3 *)instance;                                                                             \
        size_t i;                                                                                               \
        if (nValues != nValueReferences) return refuse(instance, #NAME " with arrays (nValues != nValueReferences)"); \
        for (i = 0; i < nValueReferences; i++)                                                                  \
            if (model_set(f->model, valueReferences[i], TYPE, (double)values[i], initialising(f))) return fmi3Error; \
        return fmi3OK;                                                                                          \
    }

GETTER(fmi3GetFloat64, fmi3Float64, TYPE_FLOAT64, v)
GETTER(fmi3GetInt64, fmi3Int64, TYPE_INT64, (fmi3Int64)v)
GETTER(fmi3GetBoolean, fmi3Boolean, TYPE_BOOLEAN, v != 0.0)
SETTER(fmi3SetFloat64, fmi3Float64, TYPE_FLOAT64)
SETTER(fmi3SetInt64, fmi3Int64, TYPE_INT64)
SETTER(fmi3SetBoolean, fmi3Boolean, TYPE_BOOLEAN)

#define NO_VARIABLES(NAME, CTYPE, CONST)                                                                        \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[],                          \
                    size_t nValueReferences, CONST CTYPE values[], size_t nValues) {                            \
        (void)valueReferences, (void)values, (void)nValues;                                                     \
        return nValueReferences ? refuse(instance, #NAME " (the FMU has no variable of this type)") : fmi3OK;   \
    }

NO_VARIABLES(fmi3GetFloat32, fmi3Float32, )
NO_VARIABLES(fmi3GetInt8, fmi3Int8, )
NO_VARIABLES(fmi3GetUInt8, fmi3UInt8, )
NO_VARIABLES(fmi3GetInt16, fmi3Int16, )
NO_VARIABLES(fmi3GetUInt16, fmi3UInt16, )
NO_VARIABLES(fmi3GetInt32, fmi3Int32, )
NO_VARIABLES(fmi3GetUInt32, fmi3UInt32, )
NO_VARIABLES(fmi3GetUInt64, fmi3UInt64, )
NO_VARIABLES(fmi3GetString, fmi3String, )
NO_VARIABLES(fmi3SetFloat32, fmi3Float32, const)
NO_VARIABLES(fmi3SetInt8, fmi3Int8, const)
NO_VARIABLES(fmi3SetUInt8, fmi3UInt8, const)
NO_VARIABLES(fmi3SetInt16, fmi3Int16, const)
NO_VARIABLES(fmi3SetUInt16, fmi3UInt16, const)
NO_VARIABLES(fmi3SetInt32, fmi3Int32, const)
NO_VARIABLES(fmi3SetUInt32, fmi3UInt32, const)
NO_VARIABLES(fmi3SetUInt64, fmi3UInt64, const)
NO_VARIABLES(fmi3SetString, fmi3String, const)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)valueReferences, (void)valueSizes, (void)values, (void)nValues;
    return nValueReferences ? refuse(instance, "fmi3GetBinary") : fmi3OK;
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueReferences, (void)valueSizes, (void)values, (void)nValues;
    return nValueReferences ? refuse(instance, "fmi3SetBinary") : fmi3OK;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    (void)valueReferences, (void)values;
    return nValueReferences ? refuse(instance, "fmi3GetClock") : fmi3OK;
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    (void)valueReferences, (void)values;
    return nValueReferences ? refuse(instance, "fmi3SetClock") : fmi3OK;
}

/* ---- not provided: variable dependencies, adjoint derivatives, clocks, configuration, output derivatives ---- */

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference, (void)nDependencies;
    return refuse(instance, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t nDependencies) {
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    return refuse(instance, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed;
    (void)sensitivity, (void)nSensitivity;
    return refuse(instance, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) { return refuse(instance, "fmi3EnterConfigurationMode"); }

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) { return refuse(instance, "fmi3ExitConfigurationMode"); }

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    return refuse(instance, "fmi3GetIntervalDecimal");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions, (void)qualifiers;
    return refuse(instance, "fmi3GetIntervalFraction");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return refuse(instance, "fmi3GetShiftDecimal");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return refuse(instance, "fmi3GetShiftFraction");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    return refuse(instance, "fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return refuse(instance, "fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    return refuse(instance, "fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    return refuse(instance, "fmi3SetShiftFraction");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) { return refuse(instance, "fmi3EvaluateDiscreteStates"); }

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    (void)valueReferences, (void)nValueReferences, (void)orders, (void)values, (void)nValues;
    return refuse(instance, "fmi3GetOutputDerivatives");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference, (void)activationTime;
    return refuse(instance, "fmi3ActivateModelPartition");
}
