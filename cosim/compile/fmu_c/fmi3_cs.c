/* FMI 3.0 Co-Simulation over the model core's embedded solver (model_do_step), and what masters use to roll
 * back and to linearise, for both interfaces: FMU state (get, set, serialise: the core's state array plus the
 * instance's mode) and directional derivatives (exact, model_directional). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3_common.h"

/* ---- Co-Simulation ---- */

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    (void)instanceName, (void)resourcePath, (void)visible, (void)loggingOn, (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables, (void)nRequiredIntermediateVariables, (void)intermediateUpdate;
    if (eventModeUsed) {  /* hasEventMode is false: events are handled inside fmi3DoStep */
        if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                                   MODEL_IDENTIFIER " handles its events inside fmi3DoStep (no Event Mode)");
        return NULL;
    }
    return fmu3_new(instantiationToken, instanceEnvironment, logMessage, 1);
}

/* The master's communication point may differ from the FMU's time by rounding (t0 + k h against a sum). */
#define TIME_SLACK 1e-9

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    Fmu3 *f = (Fmu3 *)instance;
    Model *s = f->model;
    double t_end = currentCommunicationPoint + communicationStepSize;
    char text[200];
    int terminated = 0, result;
    (void)noSetFMUStatePriorToCurrentPoint;
    *eventHandlingNeeded = fmi3False;
    *earlyReturn = fmi3False;
    *terminateSimulation = f->terminated ? fmi3True : fmi3False;
    *lastSuccessfulTime = s->t;
    if (f->mode != MODE_STEP) return refuse(instance, "fmi3DoStep outside Step Mode");
    if (f->terminated) return fmi3OK;
    if (fabs(currentCommunicationPoint - s->t) > TIME_SLACK * fmax(1.0, fabs(s->t)) || !(communicationStepSize >= 0)) {
        snprintf(text, sizeof text, "fmi3DoStep from %.17g by %.17g: expected to start at the FMU's time %.17g "
                 "with a step >= 0", currentCommunicationPoint, communicationStepSize, s->t);
        log3(f, 1, text);
        return fmi3Error;
    }
    s->t = currentCommunicationPoint;
    model_touch(s);
    result = model_do_step(s, t_end, &terminated);
    *lastSuccessfulTime = s->t;
    if (result) return fmi3Error;
    if (terminated) {
        f->terminated = 1;
        *terminateSimulation = fmi3True;
        *earlyReturn = s->t < t_end ? fmi3True : fmi3False;
        *lastSuccessfulTime = s->t;
    }
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return refuse(instance, "fmi3EnterStepMode (no Event Mode)"); }

/* ---- FMU state: the core's state array, then the mode and the terminated flag, all doubles ---- */

#define STATE_DOUBLES (model_state_size() + 2)

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    Fmu3 *f = (Fmu3 *)instance;
    double *buf = (double *)*FMUState;
    size_t n = model_state_size();
    if (!buf && !(buf = (double *)malloc(STATE_DOUBLES * sizeof(double))))
        return refuse(instance, "fmi3GetFMUState (out of memory)");
    model_state_save(f->model, buf);
    buf[n] = f->mode;
    buf[n + 1] = f->terminated;
    *FMUState = buf;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    Fmu3 *f = (Fmu3 *)instance;
    const double *buf = (const double *)FMUState;
    size_t n = model_state_size();
    if (!buf) return refuse(instance, "fmi3SetFMUState with a NULL state");
    if (model_state_load(f->model, buf)) return fmi3Error;
    f->mode = (int)buf[n];
    f->terminated = (int)buf[n + 1];
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    (void)instance;
    free(*FMUState);
    *FMUState = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    (void)instance, (void)FMUState;
    *size = STATE_DOUBLES * sizeof(double);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    if (size != STATE_DOUBLES * sizeof(double)) return refuse(instance, "fmi3SerializeFMUState with a wrong size");
    memcpy(serializedState, FMUState, size);
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    double *buf;
    if (size != STATE_DOUBLES * sizeof(double))
        return refuse(instance, "fmi3DeserializeFMUState with a wrong size (a state of another FMU?)");
    if (!(buf = (double *)malloc(size))) return refuse(instance, "fmi3DeserializeFMUState (out of memory)");
    memcpy(buf, serializedState, size);
    *FMUState = buf;
    return fmi3OK;
}

/* ---- directional derivatives ---- */

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                        size_t nSensitivity) {
    if (nSeed != nKnowns || nSensitivity != nUnknowns)
        return refuse(instance, "fmi3GetDirectionalDerivative with arrays (nSeed != nKnowns or nSensitivity != "
                                "nUnknowns)");
    return status(model_directional(((Fmu3 *)instance)->model, unknowns, nUnknowns, knowns, nKnowns, seed,
                                    sensitivity));
}
