/*
 * fmi1Functions.c -- the FMI 1.0 API as a thin adapter onto the framework core
 * (fmu_instance.h).
 *
 * In FMI 1.0 an FMU is either co-simulation or model exchange, and every
 * function name carries the model identifier (`CartPole_fmiDoStep`). The
 * builder (modelicagym.fmu.build) writes into build_config.h
 *   MODEL_IDENTIFIER           the modelIdentifier of the model description;
 *   FMI1_CO_SIMULATION or      which of the two APIs this binary exports.
 *   FMI1_MODEL_EXCHANGE
 * FMI 1.0 has no explicit modes: fmiInitializeSlave / fmiInitialize run the
 * core's initialization mode (and, for model exchange, the initial event
 * iteration), and fmiEventUpdate enters and leaves the core's event mode.
 * A model may define STATE_VALUE_REFERENCES in config.h (an initializer list of
 * NX value references) for fmiGetStateValueReferences; otherwise the states
 * are reported as fmiUndefinedValueReference.
 */
#include <string.h>

#include "fmi1Functions.h"
#include "fmu_instance.h"

#ifndef MODEL_IDENTIFIER
#error "MODEL_IDENTIFIER must be defined (build_config.h)"
#endif
#if defined(FMI1_CO_SIMULATION) == defined(FMI1_MODEL_EXCHANGE)
#error "define exactly one of FMI1_CO_SIMULATION and FMI1_MODEL_EXCHANGE (build_config.h)"
#endif

#define FMI1_PASTE(identifier, name) identifier##_##name
#define FMI1_EXPAND(identifier, name) FMI1_PASTE(identifier, name)
/* The exported name of FMI 1.0 function `name`: MODEL_IDENTIFIER_name. */
#define FMI1(name) FMI1_EXPAND(MODEL_IDENTIFIER, name)

#if defined(_WIN32)
#define FMI1_EXPORT __declspec(dllexport)
#elif defined(__GNUC__)
#define FMI1_EXPORT __attribute__((visibility("default")))
#else
#define FMI1_EXPORT
#endif

#define COMP ((ModelInstance *)c)

typedef char assert_fmi1Integer_is_int32[sizeof(fmi1Integer) == sizeof(int32_t) ? 1 : -1];
typedef char assert_fmi1Real_is_double[sizeof(fmi1Real) == sizeof(double) ? 1 : -1];

/* FMI 1.0 loggers take the component (there is no environment pointer) and format the
 * message printf-style: pass it as the format with '%' escaped. */
static void log_to_fmi1(ModelInstance *comp, Status status, const char *category,
                        const char *message) {
    fmi1CallbackLogger logger = (fmi1CallbackLogger)comp->log_callback;
    char escaped[2048];
    if (!logger) {
        return;
    }
    fmu_escape_percent(message, escaped, sizeof escaped);
    logger((fmi1Component)comp, comp->instance_name, (fmi1Status)status, category, escaped);
}

static ModelInstance *instantiate(fmi1String instanceName, InterfaceType type, fmi1String GUID,
                                  const fmi1CallbackFunctions *functions, fmi1Boolean loggingOn) {
    return fmu_instantiate(instanceName, type, GUID, loggingOn != fmi1False, log_to_fmi1, NULL,
                           (void (*)(void))functions->logger);
}

/* Enter and leave the core's initialization mode at tStart. */
static Status initialize(ModelInstance *comp, double start_time, bool set_start_time) {
    Status status = set_start_time ? fmu_setup_experiment(comp, start_time) : StatusOK;
    if (status <= StatusWarning) {
        status = fmu_enter_initialization_mode(comp);
    }
    if (status <= StatusWarning) {
        status = fmu_exit_initialization_mode(comp);
    }
    return status;
}

/* ------------------------------------------------------------ common */

FMI1_EXPORT const char *FMI1(fmiGetVersion)(void) { return "1.0"; }

FMI1_EXPORT fmi1Status FMI1(fmiSetDebugLogging)(fmi1Component c, fmi1Boolean loggingOn) {
    return (fmi1Status)fmu_set_debug_logging(COMP, loggingOn != fmi1False, 0, NULL);
}

FMI1_EXPORT fmi1Status FMI1(fmiGetReal)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                        fmi1Real value[]) {
    return (fmi1Status)fmu_get(COMP, VarFloat64, vr, nvr, value, nvr);
}

FMI1_EXPORT fmi1Status FMI1(fmiGetInteger)(fmi1Component c, const fmi1ValueReference vr[],
                                           size_t nvr, fmi1Integer value[]) {
    return (fmi1Status)fmu_get(COMP, VarInt32, vr, nvr, value, nvr);
}

FMI1_EXPORT fmi1Status FMI1(fmiGetBoolean)(fmi1Component c, const fmi1ValueReference vr[],
                                           size_t nvr, fmi1Boolean value[]) {
    size_t i;
    for (i = 0; i < nvr; i++) {
        bool b = false;
        Status status = fmu_get(COMP, VarBoolean, &vr[i], 1, &b, 1);
        if (status > StatusWarning) {
            return (fmi1Status)status;
        }
        value[i] = b ? fmi1True : fmi1False;
    }
    return c ? fmi1OK : fmi1Error;
}

FMI1_EXPORT fmi1Status FMI1(fmiGetString)(fmi1Component c, const fmi1ValueReference vr[],
                                          size_t nvr, fmi1String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 && c ? fmi1OK : (fmi1Status)fmu_unsupported(COMP, "fmiGetString");
}

FMI1_EXPORT fmi1Status FMI1(fmiSetReal)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                        const fmi1Real value[]) {
    return (fmi1Status)fmu_set(COMP, VarFloat64, vr, nvr, value, nvr);
}

FMI1_EXPORT fmi1Status FMI1(fmiSetInteger)(fmi1Component c, const fmi1ValueReference vr[],
                                           size_t nvr, const fmi1Integer value[]) {
    return (fmi1Status)fmu_set(COMP, VarInt32, vr, nvr, value, nvr);
}

FMI1_EXPORT fmi1Status FMI1(fmiSetBoolean)(fmi1Component c, const fmi1ValueReference vr[],
                                           size_t nvr, const fmi1Boolean value[]) {
    size_t i;
    for (i = 0; i < nvr; i++) {
        const bool b = value[i] != fmi1False;
        Status status = fmu_set(COMP, VarBoolean, &vr[i], 1, &b, 1);
        if (status > StatusWarning) {
            return (fmi1Status)status;
        }
    }
    return c ? fmi1OK : fmi1Error;
}

FMI1_EXPORT fmi1Status FMI1(fmiSetString)(fmi1Component c, const fmi1ValueReference vr[],
                                          size_t nvr, const fmi1String value[]) {
    (void)vr;
    (void)value;
    return nvr == 0 && c ? fmi1OK : (fmi1Status)fmu_unsupported(COMP, "fmiSetString");
}

#ifdef FMI1_CO_SIMULATION
/* ------------------------------------------------------ co-simulation */

FMI1_EXPORT const char *FMI1(fmiGetTypesPlatform)(void) { return "standard32"; }

FMI1_EXPORT fmi1Component FMI1(fmiInstantiateSlave)(fmi1String instanceName, fmi1String fmuGUID,
                                                    fmi1String fmuLocation, fmi1String mimeType,
                                                    fmi1Real timeout, fmi1Boolean visible,
                                                    fmi1Boolean interactive,
                                                    fmi1CallbackFunctions functions,
                                                    fmi1Boolean loggingOn) {
    (void)fmuLocation;
    (void)mimeType;
    (void)timeout;
    (void)visible;
    (void)interactive;
    return instantiate(instanceName, CoSimulation, fmuGUID, &functions, loggingOn);
}

FMI1_EXPORT fmi1Status FMI1(fmiInitializeSlave)(fmi1Component c, fmi1Real tStart,
                                                fmi1Boolean StopTimeDefined, fmi1Real tStop) {
    (void)StopTimeDefined;
    (void)tStop;
    return c ? (fmi1Status)initialize(COMP, tStart, true) : fmi1Error;
}

FMI1_EXPORT fmi1Status FMI1(fmiTerminateSlave)(fmi1Component c) {
    return (fmi1Status)fmu_terminate(COMP);
}

FMI1_EXPORT fmi1Status FMI1(fmiResetSlave)(fmi1Component c) { return (fmi1Status)fmu_reset(COMP); }

FMI1_EXPORT void FMI1(fmiFreeSlaveInstance)(fmi1Component c) { fmu_free(COMP); }

FMI1_EXPORT fmi1Status FMI1(fmiSetRealInputDerivatives)(fmi1Component c,
                                                        const fmi1ValueReference vr[], size_t nvr,
                                                        const fmi1Integer order[],
                                                        const fmi1Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return (fmi1Status)fmu_unsupported(COMP, "fmiSetRealInputDerivatives");
}

FMI1_EXPORT fmi1Status FMI1(fmiGetRealOutputDerivatives)(fmi1Component c,
                                                         const fmi1ValueReference vr[], size_t nvr,
                                                         const fmi1Integer order[],
                                                         fmi1Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return (fmi1Status)fmu_unsupported(COMP, "fmiGetRealOutputDerivatives");
}

FMI1_EXPORT fmi1Status FMI1(fmiCancelStep)(fmi1Component c) {
    return (fmi1Status)fmu_unsupported(COMP, "fmiCancelStep");
}

FMI1_EXPORT fmi1Status FMI1(fmiDoStep)(fmi1Component c, fmi1Real currentCommunicationPoint,
                                       fmi1Real communicationStepSize, fmi1Boolean newStep) {
    bool terminated;
    double last_successful_time;
    (void)newStep;
    return (fmi1Status)fmu_do_step(COMP, currentCommunicationPoint, communicationStepSize,
                                   &terminated, &last_successful_time);
}

/* Status queries: FMI 1.0 has no "terminated" status; only lastSuccessfulTime is available. */
FMI1_EXPORT fmi1Status FMI1(fmiGetStatus)(fmi1Component c, const fmi1StatusKind s,
                                          fmi1Status *value) {
    (void)s;
    (void)value;
    return c ? fmi1Discard : fmi1Error;
}

FMI1_EXPORT fmi1Status FMI1(fmiGetRealStatus)(fmi1Component c, const fmi1StatusKind s,
                                              fmi1Real *value) {
    if (!c || !value) {
        return fmi1Error;
    }
    if (s != fmi1LastSuccessfulTime) {
        return fmi1Discard;
    }
    *value = COMP->s.last_successful_time;
    return fmi1OK;
}

FMI1_EXPORT fmi1Status FMI1(fmiGetIntegerStatus)(fmi1Component c, const fmi1StatusKind s,
                                                 fmi1Integer *value) {
    (void)s;
    (void)value;
    return c ? fmi1Discard : fmi1Error;
}

FMI1_EXPORT fmi1Status FMI1(fmiGetBooleanStatus)(fmi1Component c, const fmi1StatusKind s,
                                                 fmi1Boolean *value) {
    (void)s;
    (void)value;
    return c ? fmi1Discard : fmi1Error;
}

FMI1_EXPORT fmi1Status FMI1(fmiGetStringStatus)(fmi1Component c, const fmi1StatusKind s,
                                                fmi1String *value) {
    (void)s;
    (void)value;
    return c ? fmi1Discard : fmi1Error;
}

#else
/* ----------------------------------------------------- model exchange */

static void to_event_info(const EventFlags *flags, fmi1EventInfo *eventInfo) {
    eventInfo->iterationConverged = flags->new_discrete_states_needed ? fmi1False : fmi1True;
    eventInfo->stateValueReferencesChanged = fmi1False;
    eventInfo->stateValuesChanged = flags->values_changed ? fmi1True : fmi1False;
    eventInfo->terminateSimulation = flags->terminate_simulation ? fmi1True : fmi1False;
    eventInfo->upcomingTimeEvent = flags->next_event_time_defined ? fmi1True : fmi1False;
    eventInfo->nextEventTime = flags->next_event_time_defined ? flags->next_event_time : 0.0;
}

FMI1_EXPORT const char *FMI1(fmiGetModelTypesPlatform)(void) { return "standard32"; }

FMI1_EXPORT fmi1Component FMI1(fmiInstantiateModel)(fmi1String instanceName, fmi1String GUID,
                                                    fmi1CallbackFunctions functions,
                                                    fmi1Boolean loggingOn) {
    return instantiate(instanceName, ModelExchange, GUID, &functions, loggingOn);
}

FMI1_EXPORT void FMI1(fmiFreeModelInstance)(fmi1Component c) { fmu_free(COMP); }

/* Before fmiInitialize, fmiSetTime sets the start time. */
FMI1_EXPORT fmi1Status FMI1(fmiSetTime)(fmi1Component c, fmi1Real time) {
    if (c && COMP->s.mode == ModeInstantiated) {
        return (fmi1Status)fmu_setup_experiment(COMP, time);
    }
    return (fmi1Status)fmu_set_time(COMP, time);
}

FMI1_EXPORT fmi1Status FMI1(fmiSetContinuousStates)(fmi1Component c, const fmi1Real x[],
                                                    size_t nx) {
    return (fmi1Status)fmu_set_continuous_states(COMP, x, nx);
}

FMI1_EXPORT fmi1Status FMI1(fmiCompletedIntegratorStep)(fmi1Component c,
                                                        fmi1Boolean *callEventUpdate) {
    bool enter = false, terminate = false;
    Status status = fmu_completed_integrator_step(COMP, &enter, &terminate);
    if (callEventUpdate) {
        *callEventUpdate = enter ? fmi1True : fmi1False;
    }
    return (fmi1Status)status;
}

/* Initialization and the initial event iteration; leaves the core in continuous-time mode. */
FMI1_EXPORT fmi1Status FMI1(fmiInitialize)(fmi1Component c, fmi1Boolean toleranceControlled,
                                           fmi1Real relativeTolerance, fmi1EventInfo *eventInfo) {
    EventFlags flags;
    Status status;
    (void)toleranceControlled;
    (void)relativeTolerance;
    if (!c) {
        return fmi1Error;
    }
    if (!eventInfo) {
        return (fmi1Status)fmu_unsupported(COMP, "fmiInitialize without eventInfo");
    }
    memset(&flags, 0, sizeof flags);
    status = initialize(COMP, 0.0, false);
    if (status <= StatusWarning) {
        Status update = fmu_me_event_update(COMP, false, &flags);
        status = update > status ? update : status;
    }
    to_event_info(&flags, eventInfo);
    return (fmi1Status)status;
}

FMI1_EXPORT fmi1Status FMI1(fmiGetDerivatives)(fmi1Component c, fmi1Real derivatives[],
                                               size_t nx) {
    return (fmi1Status)fmu_get_derivatives(COMP, derivatives, nx);
}

FMI1_EXPORT fmi1Status FMI1(fmiGetEventIndicators)(fmi1Component c, fmi1Real eventIndicators[],
                                                   size_t ni) {
    return (fmi1Status)fmu_get_event_indicators(COMP, eventIndicators, ni);
}

FMI1_EXPORT fmi1Status FMI1(fmiEventUpdate)(fmi1Component c, fmi1Boolean intermediateResults,
                                            fmi1EventInfo *eventInfo) {
    EventFlags flags;
    Status status;
    if (!c) {
        return fmi1Error;
    }
    if (!eventInfo) {
        return (fmi1Status)fmu_unsupported(COMP, "fmiEventUpdate without eventInfo");
    }
    memset(&flags, 0, sizeof flags);
    status = fmu_me_event_update(COMP, intermediateResults != fmi1False, &flags);
    to_event_info(&flags, eventInfo);
    return (fmi1Status)status;
}

FMI1_EXPORT fmi1Status FMI1(fmiGetContinuousStates)(fmi1Component c, fmi1Real states[],
                                                    size_t nx) {
    return (fmi1Status)fmu_get_continuous_states(COMP, states, nx);
}

FMI1_EXPORT fmi1Status FMI1(fmiGetNominalContinuousStates)(fmi1Component c, fmi1Real x_nominal[],
                                                           size_t nx) {
    return (fmi1Status)fmu_get_nominals(COMP, x_nominal, nx);
}

FMI1_EXPORT fmi1Status FMI1(fmiGetStateValueReferences)(fmi1Component c, fmi1ValueReference vrx[],
                                                        size_t nx) {
#ifdef STATE_VALUE_REFERENCES
    static const ValueReference refs[NX_ALLOC] = STATE_VALUE_REFERENCES;
#endif
    size_t i;
    if (!c) {
        return fmi1Error;
    }
    if (nx != (size_t)NX || (nx > 0 && !vrx)) {
        return (fmi1Status)fmu_unsupported(COMP, "fmiGetStateValueReferences with a wrong size");
    }
    for (i = 0; i < nx; i++) {
#ifdef STATE_VALUE_REFERENCES
        vrx[i] = refs[i];
#else
        vrx[i] = fmi1UndefinedValueReference;
#endif
    }
    return fmi1OK;
}

FMI1_EXPORT fmi1Status FMI1(fmiTerminate)(fmi1Component c) { return (fmi1Status)fmu_terminate(COMP); }

#endif
