/* What the FMI 3.0 API files (fmi3_me.c: instances, variables, Model Exchange; fmi3_cs.c: Co-Simulation, FMU
 * state, directional derivatives) share: the instance and its modes, logging and status helpers. */
#ifndef COSIM_FMI3_COMMON_H
#define COSIM_FMI3_COMMON_H

#include "fmi3Functions.h"
#include "model_core.h"

enum { MODE_INSTANTIATED, MODE_INITIALIZATION, MODE_EVENT, MODE_CONTINUOUS, MODE_STEP, MODE_TERMINATED };

typedef struct {
    Model *model;
    int mode;
    int co_simulation;   /* instantiated by fmi3InstantiateCoSimulation */
    int terminated;      /* Co-Simulation: the model called terminate() (doStep reports it and goes no further) */
    fmi3LogMessageCallback log;
    fmi3InstanceEnvironment env;
} Fmu3;

/* The core's logger (core_logger) for an Fmu3. */
void log3(void *env, int error, const char *message);
/* Log that the function cannot be used (not provided, wrong arguments or mode) and return fmi3Error. */
fmi3Status refuse(fmi3Instance instance, const char *function);
fmi3Status status(int core_result);
/* A new instance (NULL when the token is not this FMU's or memory is short). */
Fmu3 *fmu3_new(fmi3String instantiationToken, fmi3InstanceEnvironment instanceEnvironment,
               fmi3LogMessageCallback logMessage, int co_simulation);

#endif
