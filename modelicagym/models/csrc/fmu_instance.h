/*
 * fmu_instance.h -- the FMI-version-independent core of the framework.
 *
 * The FMI 1.0, 2.0 and 3.0 adapters (fmi1Functions.c, fmi2Functions.c,
 * fmi3Functions.c) are thin
 * translations of the FMI API onto these functions: lifecycle and interface
 * state checks, typed get/set through the model's variable table, the RK4
 * co-simulation step, the model-exchange calls, and FMU state snapshots.
 * Every function accepts a NULL instance and returns StatusError for it.
 */
#ifndef MODELICAGYM_FMU_INSTANCE_H
#define MODELICAGYM_FMU_INSTANCE_H

#include "model.h"

/* Reserved value reference of the independent variable `time`. */
#define VR_TIME 0u

/* Lifecycle. `token` is checked against FMU_INSTANTIATION_TOKEN when defined;
 * the importer's logger is `log_callback` (cast back to its real type by `sink`). */
ModelInstance *fmu_instantiate(const char *instance_name, InterfaceType type, const char *token,
                               bool logging_on, LogSink sink, void *log_env,
                               void (*log_callback)(void));
void fmu_free(ModelInstance *comp);
Status fmu_set_debug_logging(ModelInstance *comp, bool logging_on, size_t n_categories,
                             const char *const categories[]);
Status fmu_setup_experiment(ModelInstance *comp, double start_time);
/* FMI 3.0 configuration mode: entered from and left to the instantiated state. */
Status fmu_enter_configuration_mode(ModelInstance *comp);
Status fmu_exit_configuration_mode(ModelInstance *comp);
Status fmu_enter_initialization_mode(ModelInstance *comp);
Status fmu_exit_initialization_mode(ModelInstance *comp);
Status fmu_terminate(ModelInstance *comp);
Status fmu_reset(ModelInstance *comp);

/* Typed access; values are the concatenated blocks of the value references
 * (a VR of an array variable maps to `count` contiguous values). `type` is the
 * type of `values`, any VarType but VarEnumeration: a variable is accessible
 * as its own type, and enumeration variables also as VarInt32 and VarInt64. */
Status fmu_get(ModelInstance *comp, VarType type, const ValueReference vr[], size_t nvr,
               void *values, size_t n_values);
Status fmu_set(ModelInstance *comp, VarType type, const ValueReference vr[], size_t nvr,
               const void *values, size_t n_values);

/* Co-simulation: integrate from t to t + h. On StatusDiscard, *terminated
 * tells whether the model ended the simulation; *last_successful_time is the
 * time reached. */
Status fmu_do_step(ModelInstance *comp, double t, double h, bool *terminated,
                   double *last_successful_time);

/* Model exchange. */
Status fmu_set_time(ModelInstance *comp, double time);
Status fmu_set_continuous_states(ModelInstance *comp, const double x[], size_t nx);
Status fmu_get_continuous_states(ModelInstance *comp, double x[], size_t nx);
Status fmu_get_derivatives(ModelInstance *comp, double dx[], size_t nx);
Status fmu_get_event_indicators(ModelInstance *comp, double z[], size_t nz);
Status fmu_get_nominals(ModelInstance *comp, double nominals[], size_t nx);
Status fmu_enter_event_mode(ModelInstance *comp);
Status fmu_update_discrete_states(ModelInstance *comp, EventFlags *flags);
Status fmu_enter_continuous_time_mode(ModelInstance *comp);
Status fmu_completed_integrator_step(ModelInstance *comp, bool *enter_event_mode,
                                     bool *terminate_simulation);

/* FMU states: heap copies of InstanceState, serialized with a small header. A non-NULL
 * *state given to fmu_get_state / fmu_deserialize_state is overwritten in place. */
Status fmu_get_state(ModelInstance *comp, void **state);
Status fmu_set_state(ModelInstance *comp, const void *state);
Status fmu_free_state(ModelInstance *comp, void **state);
size_t fmu_serialized_state_size(void);
Status fmu_serialize_state(ModelInstance *comp, const void *state, unsigned char *buffer,
                           size_t size);
Status fmu_deserialize_state(ModelInstance *comp, const unsigned char *buffer, size_t size,
                             void **state);

/* Copy `message` into `out` (`size` bytes) with every '%' doubled: FMI 1.0 and 2.0 loggers
 * treat the message as a printf format. */
void fmu_escape_percent(const char *message, char *out, size_t size);

/* Model exchange without explicit event mode (FMI 1.0): enter event mode if needed, run event
 * updates (until settled unless `intermediate`), return to continuous-time mode when settled. */
Status fmu_me_event_update(ModelInstance *comp, bool intermediate, EventFlags *flags);

/* Report a call the framework does not implement. */
Status fmu_unsupported(ModelInstance *comp, const char *function);

#endif /* MODELICAGYM_FMU_INSTANCE_H */
