/*
 * fmi2Functions.c -- the FMI 2.0 API (co-simulation and model exchange in one
 * binary) as a thin adapter onto the framework core (fmu_instance.h).
 */
#include <string.h>

#include "fmi2Functions.h"
#include "fmu_instance.h"

#define COMP ((ModelInstance *)c)

typedef char assert_fmi2Integer_is_int32[sizeof(fmi2Integer) == sizeof(int32_t) ? 1 : -1];
typedef char assert_fmi2Real_is_double[sizeof(fmi2Real) == sizeof(double) ? 1 : -1];

/* FMI 2.0 loggers format the message printf-style: pass it as the format with '%' escaped. */
static void log_to_fmi2(ModelInstance *comp, Status status, const char *category,
                        const char *message) {
    fmi2CallbackLogger logger = (fmi2CallbackLogger)comp->log_callback;
    char escaped[2048];
    if (!logger) {
        return;
    }
    fmu_escape_percent(message, escaped, sizeof escaped);
    logger(comp->log_env, comp->instance_name, (fmi2Status)status, category, escaped);
}

/* ------------------------------------------------------------ common */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    return (fmi2Status)fmu_set_debug_logging(COMP, loggingOn != fmi2False, nCategories, categories);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    (void)fmuResourceLocation;
    (void)visible;
    return fmu_instantiate(instanceName, fmuType == fmi2CoSimulation ? CoSimulation : ModelExchange,
                           fmuGUID, loggingOn != fmi2False, log_to_fmi2,
                           functions ? functions->componentEnvironment : NULL,
                           functions ? (void (*)(void))functions->logger : NULL);
}

void fmi2FreeInstance(fmi2Component c) { fmu_free(COMP); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    return (fmi2Status)fmu_setup_experiment(COMP, startTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return (fmi2Status)fmu_enter_initialization_mode(COMP);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return (fmi2Status)fmu_exit_initialization_mode(COMP);
}

fmi2Status fmi2Terminate(fmi2Component c) { return (fmi2Status)fmu_terminate(COMP); }

fmi2Status fmi2Reset(fmi2Component c) { return (fmi2Status)fmu_reset(COMP); }

/* ------------------------------------------------------ get and set */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    return (fmi2Status)fmu_get(COMP, VarFloat64, vr, nvr, value, nvr);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    return (fmi2Status)fmu_get(COMP, VarInt32, vr, nvr, value, nvr);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    size_t i;
    for (i = 0; i < nvr; i++) {
        bool b = false;
        Status status = fmu_get(COMP, VarBoolean, &vr[i], 1, &b, 1);
        if (status > StatusWarning) {
            return (fmi2Status)status;
        }
        value[i] = b ? fmi2True : fmi2False;
    }
    return c ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 && c ? fmi2OK : (fmi2Status)fmu_unsupported(COMP, "fmi2GetString");
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    return (fmi2Status)fmu_set(COMP, VarFloat64, vr, nvr, value, nvr);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    return (fmi2Status)fmu_set(COMP, VarInt32, vr, nvr, value, nvr);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    size_t i;
    for (i = 0; i < nvr; i++) {
        const bool b = value[i] != fmi2False;
        Status status = fmu_set(COMP, VarBoolean, &vr[i], 1, &b, 1);
        if (status > StatusWarning) {
            return (fmi2Status)status;
        }
    }
    return c ? fmi2OK : fmi2Error;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 && c ? fmi2OK : (fmi2Status)fmu_unsupported(COMP, "fmi2SetString");
}

/* ---------------------------------------------------------- FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    return (fmi2Status)fmu_get_state(COMP, FMUstate);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    return (fmi2Status)fmu_set_state(COMP, FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    return (fmi2Status)fmu_free_state(COMP, FMUstate);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate;
    if (!c || !size) {
        return fmi2Error;
    }
    *size = fmu_serialized_state_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    return (fmi2Status)fmu_serialize_state(COMP, FMUstate, (unsigned char *)serializedState, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    return (fmi2Status)fmu_deserialize_state(COMP, (const unsigned char *)serializedState, size,
                                             FMUstate);
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return (fmi2Status)fmu_unsupported(COMP, "fmi2GetDirectionalDerivative");
}

/* ----------------------------------------------------- model exchange */

fmi2Status fmi2EnterEventMode(fmi2Component c) { return (fmi2Status)fmu_enter_event_mode(COMP); }

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    EventFlags flags;
    Status status;
    if (!eventInfo) {
        return (fmi2Status)fmu_unsupported(COMP, "fmi2NewDiscreteStates without eventInfo");
    }
    memset(&flags, 0, sizeof flags);
    status = fmu_update_discrete_states(COMP, &flags);
    eventInfo->newDiscreteStatesNeeded = flags.new_discrete_states_needed;
    eventInfo->terminateSimulation = flags.terminate_simulation;
    eventInfo->nominalsOfContinuousStatesChanged = flags.nominals_changed;
    eventInfo->valuesOfContinuousStatesChanged = flags.values_changed;
    eventInfo->nextEventTimeDefined = flags.next_event_time_defined;
    eventInfo->nextEventTime = flags.next_event_time;
    return (fmi2Status)status;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    return (fmi2Status)fmu_enter_continuous_time_mode(COMP);
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    bool enter = false, terminate = false;
    Status status = fmu_completed_integrator_step(COMP, &enter, &terminate);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (enterEventMode) {
        *enterEventMode = enter;
    }
    if (terminateSimulation) {
        *terminateSimulation = terminate;
    }
    return (fmi2Status)status;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    return (fmi2Status)fmu_set_time(COMP, time);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    return (fmi2Status)fmu_set_continuous_states(COMP, x, nx);
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    return (fmi2Status)fmu_get_derivatives(COMP, derivatives, nx);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    return (fmi2Status)fmu_get_event_indicators(COMP, eventIndicators, ni);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    return (fmi2Status)fmu_get_continuous_states(COMP, x, nx);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    return (fmi2Status)fmu_get_nominals(COMP, x_nominal, nx);
}

/* ------------------------------------------------------ co-simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return (fmi2Status)fmu_unsupported(COMP, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return (fmi2Status)fmu_unsupported(COMP, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    bool terminated;
    double last_successful_time;
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)fmu_do_step(COMP, currentCommunicationPoint, communicationStepSize,
                                   &terminated, &last_successful_time);
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return (fmi2Status)fmu_unsupported(COMP, "fmi2CancelStep");
}

/* Status queries: only lastSuccessfulTime and terminated are available. */
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s;
    (void)value;
    return c ? fmi2Discard : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (!c || !value) {
        return fmi2Error;
    }
    if (s != fmi2LastSuccessfulTime) {
        return fmi2Discard;
    }
    *value = COMP->s.last_successful_time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    (void)value;
    return c ? fmi2Discard : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (!c || !value) {
        return fmi2Error;
    }
    if (s != fmi2Terminated) {
        return fmi2Discard;
    }
    *value = COMP->s.terminated ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    return c ? fmi2Discard : fmi2Error;
}
