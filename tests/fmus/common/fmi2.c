/* FMI 2.0 Model Exchange and Co-Simulation glue around a test model (included after <name>/model.c). */
#include "fmi2Functions.h"
#include "shared.c"

static void log_error(Instance *c, const char *fn, const char *what)
{
    if (c->logger) ((fmi2CallbackLogger)c->logger)(c->env, c->name, fmi2Error, "logStatusError", "%s: %s", fn, what);
}

static fmi2Status unsupported(fmi2Component comp, const char *fn)
{
    log_error((Instance *)comp, fn, "not supported by this test FMU");
    return fmi2Error;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    Instance *c = calloc(1, sizeof(Instance));
    c->name = strdup(instanceName ? instanceName : "");
    c->env = functions ? functions->componentEnvironment : NULL;
    c->logger = functions ? (void *)functions->logger : NULL;
    c->cs = fmuType == fmi2CoSimulation;
    if (!fmuGUID || strcmp(fmuGUID, MODEL_TOKEN) != 0) {
        log_error(c, "fmi2Instantiate", "wrong GUID");
        free(c->name);
        free(c);
        return NULL;
    }
    model_start(&c->d);
    return c;
}

void fmi2FreeInstance(fmi2Component comp)
{
    Instance *c = comp;
    if (!c) return;
    free(c->name);
    free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    ((Instance *)comp)->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) { return fmi2OK; }

fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    Instance *c = comp;
    model_initialize(c);
    if (c->cs && !settle_events(c)) {
        log_error(c, "fmi2ExitInitializationMode", "event iteration does not settle");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp) { return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component comp)
{
    Instance *c = comp;
    c->time = 0;
    c->next_event_defined = c->terminate = c->states_changed = false;
    model_start(&c->d);
    return fmi2OK;
}

/* Copies variables of one type out of (get) or into (set) the model, converting to the FMI C type. */
static fmi2Status transfer(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, VarType type,
                           void *values, bool set, const char *fn)
{
    Instance *c = comp;
    if (!set) model_outputs(c);
    for (size_t k = 0; k < nvr; k++) {
        const VarInfo *v = find_var(vr[k], type);
        if (!v) {
            char what[96];
            snprintf(what, sizeof what, "no variable of this type with value reference %u", vr[k]);
            log_error(c, fn, what);
            return fmi2Error;
        }
        void *p = var_ptr(c, v);
        switch (type) {
        case T_F64: if (set) *(double *)p = ((const fmi2Real *)values)[k]; else ((fmi2Real *)values)[k] = *(double *)p; break;
        case T_I32: if (set) *(int32_t *)p = ((const fmi2Integer *)values)[k]; else ((fmi2Integer *)values)[k] = *(int32_t *)p; break;
        case T_BOOL: if (set) *(bool *)p = ((const fmi2Boolean *)values)[k]; else ((fmi2Boolean *)values)[k] = *(bool *)p; break;
        default: return fmi2Error;   /* FMI 2.0 has no Float32 or Int64 */
        }
    }
    return fmi2OK;
}

#define GETSET(Name, CType, type)                                                                               \
    fmi2Status fmi2Get##Name(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, CType value[])       \
    {                                                                                                            \
        return transfer(comp, vr, nvr, type, value, false, "fmi2Get" #Name);                                     \
    }                                                                                                            \
    fmi2Status fmi2Set##Name(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const CType value[]) \
    {                                                                                                            \
        return transfer(comp, vr, nvr, type, (void *)value, true, "fmi2Set" #Name);                              \
    }

GETSET(Real, fmi2Real, T_F64)
GETSET(Integer, fmi2Integer, T_I32)
GETSET(Boolean, fmi2Boolean, T_BOOL)

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    return unsupported(comp, "fmi2GetString");
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    return unsupported(comp, "fmi2SetString");
}

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate) { return unsupported(comp, "fmi2GetFMUstate"); }
fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate) { return unsupported(comp, "fmi2SetFMUstate"); }
fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate) { return unsupported(comp, "fmi2FreeFMUstate"); }

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t *size)
{
    return unsupported(comp, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    return unsupported(comp, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    return unsupported(comp, "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    return unsupported(comp, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2EnterEventMode(fmi2Component comp) { return fmi2OK; }

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo *info)
{
    Instance *c = comp;
    c->states_changed = false;
    info->newDiscreteStatesNeeded = model_event(c);
    info->terminateSimulation = c->terminate;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = c->states_changed;
    info->nextEventTimeDefined = c->next_event_defined;
    info->nextEventTime = c->next_event_defined ? c->next_event : 0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component comp) { return fmi2OK; }

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    *enterEventMode = STEP_EVENT((Instance *)comp);
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time)
{
    ((Instance *)comp)->time = time;
    return fmi2OK;
}

static fmi2Status check_size(Instance *c, size_t n, size_t expected, const char *fn)
{
    if (n == expected) return fmi2OK;
    log_error(c, fn, "wrong array size");
    return fmi2Error;
}

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx)
{
    if (check_size(comp, nx, N_STATES, "fmi2SetContinuousStates")) return fmi2Error;
    model_set_states(comp, x);
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx)
{
    if (check_size(comp, nx, N_STATES, "fmi2GetDerivatives")) return fmi2Error;
    model_derivatives(comp, derivatives);
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real eventIndicators[], size_t ni)
{
    if (check_size(comp, ni, N_INDICATORS, "fmi2GetEventIndicators")) return fmi2Error;
    model_indicators(comp, eventIndicators);
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component comp, fmi2Real x[], size_t nx)
{
    if (check_size(comp, nx, N_STATES, "fmi2GetContinuousStates")) return fmi2Error;
    model_get_states(comp, x);
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[], size_t nx)
{
    for (size_t i = 0; i < nx; i++) x_nominal[i] = 1.0;
    return fmi2OK;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    return unsupported(comp, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    return unsupported(comp, "fmi2GetRealOutputDerivatives");
}

/* A step that ends early because the model asks to terminate returns fmi2Discard; fmi2GetBooleanStatus
   (fmi2Terminated) and fmi2GetRealStatus (fmi2LastSuccessfulTime) then tell why and when. */
fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    Instance *c = comp;
    if (fabs(c->time - currentCommunicationPoint) > 1e-9) {
        log_error(c, "fmi2DoStep", "currentCommunicationPoint is not the instance's time");
        return fmi2Error;
    }
    if (!cs_advance(c, currentCommunicationPoint + communicationStepSize)) {
        log_error(c, "fmi2DoStep", "event iteration does not settle");
        return fmi2Error;
    }
    return c->terminate ? fmi2Discard : fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component comp) { return unsupported(comp, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value)
{
    return unsupported(comp, "fmi2GetStatus");
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value)
{
    if (s != fmi2LastSuccessfulTime) return unsupported(comp, "fmi2GetRealStatus");
    *value = ((Instance *)comp)->time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value)
{
    return unsupported(comp, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean *value)
{
    if (s != fmi2Terminated) return unsupported(comp, "fmi2GetBooleanStatus");
    *value = ((Instance *)comp)->terminate;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value)
{
    return unsupported(comp, "fmi2GetStringStatus");
}
