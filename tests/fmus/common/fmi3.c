/* FMI 3.0 Model Exchange and Co-Simulation glue around a test model (included after <name>/model.c). */
#include "fmi3Functions.h"
#include "shared.c"

static void log_error(Instance *c, const char *fn, const char *what)
{
    char msg[256];
    snprintf(msg, sizeof msg, "%s: %s", fn, what);
    if (c->logger) ((fmi3LogMessageCallback)c->logger)(c->env, fmi3Error, "logStatusError", msg);
}

static fmi3Status unsupported(fmi3Instance instance, const char *fn)
{
    log_error((Instance *)instance, fn, "not supported by this test FMU");
    return fmi3Error;
}

static Instance *instantiate(fmi3String name, fmi3String token, fmi3InstanceEnvironment env,
                             fmi3LogMessageCallback logger, bool cs)
{
    Instance *c = calloc(1, sizeof(Instance));
    c->name = strdup(name ? name : "");
    c->env = env;
    c->logger = (void *)logger;
    c->cs = cs;
    if (!token || strcmp(token, MODEL_TOKEN) != 0) {
        log_error(c, "fmi3Instantiate", "wrong instantiationToken");
        free(c->name);
        free(c);
        return NULL;
    }
    model_start(&c->d);
    return c;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    return instantiate(instanceName, instantiationToken, instanceEnvironment, logMessage, false);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    Instance *c = instantiate(instanceName, instantiationToken, instanceEnvironment, logMessage, true);
    if (c) c->early_return_allowed = earlyReturnAllowed;
    return c;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    Instance *c = instance;
    if (!c) return;
    free(c->name);
    free(c);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    ((Instance *)instance)->time = startTime;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    Instance *c = instance;
    model_initialize(c);
    if (c->cs && !settle_events(c)) {
        log_error(c, "fmi3ExitInitializationMode", "event iteration does not settle");
        return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) { return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance instance) { return fmi3OK; }

fmi3Status fmi3Reset(fmi3Instance instance)
{
    Instance *c = instance;
    c->time = 0;
    c->next_event_defined = c->terminate = c->states_changed = false;
    model_start(&c->d);
    return fmi3OK;
}

/* Copies variables of one type out of (get) or into (set) the model, converting to the FMI C type. */
static fmi3Status transfer(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, VarType type,
                           void *values, bool set, const char *fn)
{
    Instance *c = instance;
    if (!set) model_outputs(c);
    for (size_t k = 0; k < nvr; k++) {
        if (type == T_F64 && vr[k] == 0 && !set) {   /* value reference 0 is the independent variable time */
            ((fmi3Float64 *)values)[k] = c->time;
            continue;
        }
        const VarInfo *v = find_var(vr[k], type);
        if (!v) {
            char what[96];
            snprintf(what, sizeof what, "no variable of this type with value reference %u", vr[k]);
            log_error(c, fn, what);
            return fmi3Error;
        }
        void *p = var_ptr(c, v);
        switch (type) {
        case T_F64: if (set) *(double *)p = ((const fmi3Float64 *)values)[k]; else ((fmi3Float64 *)values)[k] = *(double *)p; break;
        case T_F32: if (set) *(float *)p = ((const fmi3Float32 *)values)[k]; else ((fmi3Float32 *)values)[k] = *(float *)p; break;
        case T_I32: if (set) *(int32_t *)p = ((const fmi3Int32 *)values)[k]; else ((fmi3Int32 *)values)[k] = *(int32_t *)p; break;
        case T_I64: if (set) *(int64_t *)p = ((const fmi3Int64 *)values)[k]; else ((fmi3Int64 *)values)[k] = *(int64_t *)p; break;
        case T_BOOL: if (set) *(bool *)p = ((const fmi3Boolean *)values)[k]; else ((fmi3Boolean *)values)[k] = *(bool *)p; break;
        }
    }
    return fmi3OK;
}

#define GETSET(Name, CType, type)                                                                               \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, CType values[],    \
                             size_t nValues)                                                                     \
    {                                                                                                            \
        return transfer(instance, vr, nvr, type, values, false, "fmi3Get" #Name);                                \
    }                                                                                                            \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,                   \
                             const CType values[], size_t nValues)                                               \
    {                                                                                                            \
        return transfer(instance, vr, nvr, type, (void *)values, true, "fmi3Set" #Name);                         \
    }

GETSET(Float64, fmi3Float64, T_F64)
GETSET(Float32, fmi3Float32, T_F32)
GETSET(Int32, fmi3Int32, T_I32)
GETSET(Int64, fmi3Int64, T_I64)
GETSET(Boolean, fmi3Boolean, T_BOOL)

#define UNSUPPORTED_GETSET(Name, CType)                                                                         \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, CType values[],    \
                             size_t nValues)                                                                     \
    {                                                                                                            \
        return unsupported(instance, "fmi3Get" #Name);                                                           \
    }                                                                                                            \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,                   \
                             const CType values[], size_t nValues)                                               \
    {                                                                                                            \
        return unsupported(instance, "fmi3Set" #Name);                                                           \
    }

UNSUPPORTED_GETSET(Int8, fmi3Int8)
UNSUPPORTED_GETSET(UInt8, fmi3UInt8)
UNSUPPORTED_GETSET(Int16, fmi3Int16)
UNSUPPORTED_GETSET(UInt16, fmi3UInt16)
UNSUPPORTED_GETSET(UInt32, fmi3UInt32)
UNSUPPORTED_GETSET(UInt64, fmi3UInt64)
UNSUPPORTED_GETSET(String, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues)
{
    return unsupported(instance, "fmi3GetBinary");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    return unsupported(instance, "fmi3SetBinary");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[])
{
    return unsupported(instance, "fmi3GetClock");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[])
{
    return unsupported(instance, "fmi3SetClock");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    return unsupported(instance, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    return unsupported(instance, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    return unsupported(instance, "fmi3GetFMUState");
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    return unsupported(instance, "fmi3SetFMUState");
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    return unsupported(instance, "fmi3FreeFMUState");
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    return unsupported(instance, "fmi3SerializedFMUStateSize");
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size)
{
    return unsupported(instance, "fmi3SerializeFMUState");
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    return unsupported(instance, "fmi3DeserializeFMUState");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                        size_t nSensitivity)
{
    return unsupported(instance, "fmi3GetDirectionalDerivative");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    return unsupported(instance, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return unsupported(instance, "fmi3EnterConfigurationMode");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return unsupported(instance, "fmi3ExitConfigurationMode");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    return unsupported(instance, "fmi3GetIntervalDecimal");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                   fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    return unsupported(instance, "fmi3GetIntervalFraction");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               fmi3Float64 shifts[])
{
    return unsupported(instance, "fmi3GetShiftDecimal");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    return unsupported(instance, "fmi3GetShiftFraction");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 intervals[])
{
    return unsupported(instance, "fmi3SetIntervalDecimal");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    return unsupported(instance, "fmi3SetIntervalFraction");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[])
{
    return unsupported(instance, "fmi3SetShiftDecimal");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    return unsupported(instance, "fmi3SetShiftFraction");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) { return fmi3OK; }

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    Instance *c = instance;
    c->states_changed = false;
    *discreteStatesNeedUpdate = model_event(c);
    *terminateSimulation = c->terminate;
    *nominalsOfContinuousStatesChanged = false;
    *valuesOfContinuousStatesChanged = c->states_changed;
    *nextEventTimeDefined = c->next_event_defined;
    *nextEventTime = c->next_event_defined ? c->next_event : 0;
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) { return fmi3OK; }

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    *enterEventMode = STEP_EVENT((Instance *)instance);
    *terminateSimulation = false;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    ((Instance *)instance)->time = time;
    return fmi3OK;
}

static fmi3Status check_size(Instance *c, size_t n, size_t expected, const char *fn)
{
    if (n == expected) return fmi3OK;
    log_error(c, fn, "wrong array size");
    return fmi3Error;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    if (check_size(instance, nContinuousStates, N_STATES, "fmi3SetContinuousStates")) return fmi3Error;
    model_set_states(instance, continuousStates);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    if (check_size(instance, nContinuousStates, N_STATES, "fmi3GetContinuousStateDerivatives")) return fmi3Error;
    model_derivatives(instance, derivatives);
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    if (check_size(instance, nEventIndicators, N_INDICATORS, "fmi3GetEventIndicators")) return fmi3Error;
    model_indicators(instance, eventIndicators);
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    if (check_size(instance, nContinuousStates, N_STATES, "fmi3GetContinuousStates")) return fmi3Error;
    model_get_states(instance, continuousStates);
    return fmi3OK;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates)
{
    for (size_t i = 0; i < nContinuousStates; i++) nominals[i] = 1.0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    *nEventIndicators = N_INDICATORS;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    *nContinuousStates = N_STATES;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return fmi3OK; }

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues)
{
    return unsupported(instance, "fmi3GetOutputDerivatives");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    Instance *c = instance;
    double t_end = currentCommunicationPoint + communicationStepSize;
    if (fabs(c->time - currentCommunicationPoint) > 1e-9) {
        log_error(c, "fmi3DoStep", "currentCommunicationPoint is not the instance's time");
        return fmi3Error;
    }
    bool settled = cs_advance(c, t_end);
    *eventHandlingNeeded = false;
    *terminateSimulation = c->terminate;
    *earlyReturn = c->terminate && c->early_return_allowed && c->time < t_end;
    *lastSuccessfulTime = c->time;
    if (!settled) {
        log_error(c, "fmi3DoStep", "event iteration does not settle");
        return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    return unsupported(instance, "fmi3ActivateModelPartition");
}
