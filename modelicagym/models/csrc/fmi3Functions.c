/*
 * fmi3Functions.c -- the FMI 3.0 API (co-simulation and model exchange in one
 * binary) as a thin adapter onto the framework core (fmu_instance.h).
 * Supported variable types: Float32/64, (U)Int8/16/32/64 (Int64 also for
 * enumerations) and Boolean, scalars and arrays.
 */
#include "fmi3Functions.h"
#include "fmu_instance.h"

#define COMP ((ModelInstance *)instance)

static void log_to_fmi3(ModelInstance *comp, Status status, const char *category,
                        const char *message) {
    fmi3LogMessageCallback logger = (fmi3LogMessageCallback)comp->log_callback;
    if (logger) {
        logger(comp->log_env, (fmi3Status)status, category, message);
    }
}

static fmi3Instance instantiate(fmi3String instanceName, InterfaceType type,
                                fmi3String instantiationToken, fmi3Boolean loggingOn,
                                fmi3InstanceEnvironment instanceEnvironment,
                                fmi3LogMessageCallback logMessage) {
    return fmu_instantiate(instanceName, type, instantiationToken, loggingOn, log_to_fmi3,
                           instanceEnvironment, (void (*)(void))logMessage);
}

/* ------------------------------------------------------------ common */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    return (fmi3Status)fmu_set_debug_logging(COMP, loggingOn, nCategories, categories);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)resourcePath;
    (void)visible;
    return instantiate(instanceName, ModelExchange, instantiationToken, loggingOn,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible,
                                         fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
                                         fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    ModelInstance *comp = instantiate(instanceName, CoSimulation, instantiationToken, loggingOn,
                                      instanceEnvironment, logMessage);
    (void)resourcePath;
    (void)visible;
    (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (comp && eventModeUsed) {
        fmu_unsupported(comp, "co-simulation with event mode (eventModeUsed)");
        fmu_free(comp);
        return NULL;
    }
    return comp;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage) {
        logMessage(instanceEnvironment, fmi3Error, LOG_CATEGORY_NAMES[LogStatusError],
                   "scheduled execution is not supported by this FMU");
    }
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { fmu_free(COMP); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    Status status = fmu_setup_experiment(COMP, startTime);
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (status > StatusWarning) {
        return (fmi3Status)status;
    }
    return (fmi3Status)fmu_enter_initialization_mode(COMP);
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return (fmi3Status)fmu_enter_configuration_mode(COMP);
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return (fmi3Status)fmu_exit_configuration_mode(COMP);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return (fmi3Status)fmu_exit_initialization_mode(COMP);
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    return (fmi3Status)fmu_enter_event_mode(COMP);
}

fmi3Status fmi3Terminate(fmi3Instance instance) { return (fmi3Status)fmu_terminate(COMP); }

fmi3Status fmi3Reset(fmi3Instance instance) { return (fmi3Status)fmu_reset(COMP); }

/* ------------------------------------------------------ get and set */

/* fmi3Get<Type> and fmi3Set<Type> for a type stored as `ctype` in ModelData. */
#define GET_SET(Type, var_type, ctype)                                                         \
    typedef char assert_fmi3##Type##_is_##ctype[sizeof(fmi3##Type) == sizeof(ctype) ? 1 : -1]; \
    fmi3Status fmi3Get##Type(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             fmi3##Type values[], size_t nValues) {                            \
        return (fmi3Status)fmu_get(COMP, var_type, vr, nvr, values, nValues);                  \
    }                                                                                          \
    fmi3Status fmi3Set##Type(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             const fmi3##Type values[], size_t nValues) {                      \
        return (fmi3Status)fmu_set(COMP, var_type, vr, nvr, values, nValues);                  \
    }

GET_SET(Float64, VarFloat64, double)
GET_SET(Float32, VarFloat32, float)
GET_SET(Int8, VarInt8, int8_t)
GET_SET(UInt8, VarUInt8, uint8_t)
GET_SET(Int16, VarInt16, int16_t)
GET_SET(UInt16, VarUInt16, uint16_t)
GET_SET(Int32, VarInt32, int32_t)
GET_SET(UInt32, VarUInt32, uint32_t)
GET_SET(Int64, VarInt64, int64_t)
GET_SET(UInt64, VarUInt64, uint64_t)
GET_SET(Boolean, VarBoolean, bool)

/* ---------------------------------------------------------- FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return (fmi3Status)fmu_get_state(COMP, FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    return (fmi3Status)fmu_set_state(COMP, FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return (fmi3Status)fmu_free_state(COMP, FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    (void)FMUState;
    if (!instance || !size) {
        return fmi3Error;
    }
    *size = fmu_serialized_state_size();
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    return (fmi3Status)fmu_serialize_state(COMP, FMUState, serializedState, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    return (fmi3Status)fmu_deserialize_state(COMP, serializedState, size, FMUState);
}

/* ----------------------------------------------------- model exchange */

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime) {
    EventFlags flags = {false, false, false, false, false, 0.0};
    Status status = fmu_update_discrete_states(COMP, &flags);
    if (discreteStatesNeedUpdate) {
        *discreteStatesNeedUpdate = flags.new_discrete_states_needed;
    }
    if (terminateSimulation) {
        *terminateSimulation = flags.terminate_simulation;
    }
    if (nominalsOfContinuousStatesChanged) {
        *nominalsOfContinuousStatesChanged = flags.nominals_changed;
    }
    if (valuesOfContinuousStatesChanged) {
        *valuesOfContinuousStatesChanged = flags.values_changed;
    }
    if (nextEventTimeDefined) {
        *nextEventTimeDefined = flags.next_event_time_defined;
    }
    if (nextEventTime) {
        *nextEventTime = flags.next_event_time;
    }
    return (fmi3Status)status;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return (fmi3Status)fmu_enter_continuous_time_mode(COMP);
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation) {
    bool enter = false, terminate = false;
    Status status = fmu_completed_integrator_step(COMP, &enter, &terminate);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (enterEventMode) {
        *enterEventMode = enter;
    }
    if (terminateSimulation) {
        *terminateSimulation = terminate;
    }
    return (fmi3Status)status;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    return (fmi3Status)fmu_set_time(COMP, time);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    return (fmi3Status)fmu_set_continuous_states(COMP, continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    return (fmi3Status)fmu_get_derivatives(COMP, derivatives, nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators) {
    return (fmi3Status)fmu_get_event_indicators(COMP, eventIndicators, nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    return (fmi3Status)fmu_get_continuous_states(COMP, continuousStates, nContinuousStates);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    return (fmi3Status)fmu_get_nominals(COMP, nominals, nContinuousStates);
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    if (!instance || !nEventIndicators) {
        return fmi3Error;
    }
    *nEventIndicators = NZ;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    if (!instance || !nContinuousStates) {
        return fmi3Error;
    }
    *nContinuousStates = NX;
    return fmi3OK;
}

/* ------------------------------------------------------ co-simulation */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    bool terminated = false;
    double last_successful_time = currentCommunicationPoint;
    Status status = fmu_do_step(COMP, currentCommunicationPoint, communicationStepSize,
                                &terminated, &last_successful_time);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (eventHandlingNeeded) {
        *eventHandlingNeeded = fmi3False;
    }
    if (terminateSimulation) {
        *terminateSimulation = terminated;
    }
    if (earlyReturn) {
        *earlyReturn = fmi3False;
    }
    if (lastSuccessfulTime) {
        *lastSuccessfulTime = last_successful_time;
    }
    return (fmi3Status)status;
}

/* ------------------------------------------------------- unsupported
 * Each of these only reports that the feature is absent; their parameters are
 * intentionally unused. */

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif

#define UNSUPPORTED(name, parameters) \
    fmi3Status name parameters { return (fmi3Status)fmu_unsupported(COMP, #name); }

UNSUPPORTED(fmi3GetString, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                            size_t nValueReferences, fmi3String values[], size_t nValues))
UNSUPPORTED(fmi3SetString, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                            size_t nValueReferences, const fmi3String values[], size_t nValues))
UNSUPPORTED(fmi3GetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                            size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                            size_t nValues))
UNSUPPORTED(fmi3SetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                            size_t nValueReferences, const size_t valueSizes[],
                            const fmi3Binary values[], size_t nValues))
UNSUPPORTED(fmi3GetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                           size_t nValueReferences, fmi3Clock values[]))
UNSUPPORTED(fmi3SetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                           size_t nValueReferences, const fmi3Clock values[]))
UNSUPPORTED(fmi3GetNumberOfVariableDependencies,
            (fmi3Instance instance, fmi3ValueReference valueReference, size_t *nDependencies))
UNSUPPORTED(fmi3GetVariableDependencies,
            (fmi3Instance instance, fmi3ValueReference dependent,
             size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
             size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
             size_t nDependencies))
UNSUPPORTED(fmi3GetDirectionalDerivative,
            (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
             const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
             size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
UNSUPPORTED(fmi3GetAdjointDerivative,
            (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
             const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
             size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
UNSUPPORTED(fmi3GetIntervalDecimal,
            (fmi3Instance instance, const fmi3ValueReference valueReferences[],
             size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]))
UNSUPPORTED(fmi3GetIntervalFraction,
            (fmi3Instance instance, const fmi3ValueReference valueReferences[],
             size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
             fmi3IntervalQualifier qualifiers[]))
UNSUPPORTED(fmi3GetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 shifts[]))
UNSUPPORTED(fmi3GetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[]))
UNSUPPORTED(fmi3SetIntervalDecimal,
            (fmi3Instance instance, const fmi3ValueReference valueReferences[],
             size_t nValueReferences, const fmi3Float64 intervals[]))
UNSUPPORTED(fmi3SetIntervalFraction,
            (fmi3Instance instance, const fmi3ValueReference valueReferences[],
             size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]))
UNSUPPORTED(fmi3SetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 shifts[]))
UNSUPPORTED(fmi3SetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]))
UNSUPPORTED(fmi3EvaluateDiscreteStates, (fmi3Instance instance))
UNSUPPORTED(fmi3EnterStepMode, (fmi3Instance instance))
UNSUPPORTED(fmi3GetOutputDerivatives,
            (fmi3Instance instance, const fmi3ValueReference valueReferences[],
             size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
             size_t nValues))
UNSUPPORTED(fmi3ActivateModelPartition,
            (fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime))

#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif
