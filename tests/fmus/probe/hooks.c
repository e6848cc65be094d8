/*
 * hooks.c -- test-only wrappers around framework calls made by the FMI
 * adapters (config.h renames them to probe_* in the adapters' translation
 * units only), to reproduce behaviours of FMUs in the wild:
 *
 *   ONCE_PER_PROCESS  probe_instantiate refuses (logs an error, returns NULL)
 *                     while another instance of this library is alive;
 *   NO_SNAPSHOTS      probe_get_state refuses with a logged error;
 *   BUGGY_RESET       probe_reset forgets to reset the step counter;
 *   INEXACT_SNAPSHOTS probe_set_state restores the position with an error.
 *
 * Without these definitions every wrapper just forwards to the framework.
 */
#include "fmu_instance.h"

ModelInstance *probe_instantiate(const char *instance_name, InterfaceType type, const char *token,
                                 bool logging_on, LogSink sink, void *log_env,
                                 void (*log_callback)(void));
void probe_free(ModelInstance *comp);
Status probe_reset(ModelInstance *comp);
Status probe_get_state(ModelInstance *comp, void **state);
Status probe_set_state(ModelInstance *comp, const void *state);

static int live_instances = 0;

ModelInstance *probe_instantiate(const char *instance_name, InterfaceType type, const char *token,
                                 bool logging_on, LogSink sink, void *log_env,
                                 void (*log_callback)(void)) {
    ModelInstance *comp =
        fmu_instantiate(instance_name, type, token, logging_on, sink, log_env, log_callback);
    if (!comp) {
        return NULL;
    }
#ifdef ONCE_PER_PROCESS
    if (live_instances > 0) {
        fmu_log(comp, StatusError, LogStatusError,
                "this FMU can be instantiated only once per process, and %d instance(s) are alive",
                live_instances);
        fmu_free(comp);
        return NULL;
    }
#endif
    live_instances++;
    return comp;
}

void probe_free(ModelInstance *comp) {
    if (comp) {
        live_instances--;
    }
    fmu_free(comp);
}

Status probe_reset(ModelInstance *comp) {
#ifdef BUGGY_RESET
    Status status;
    int32_t steps;
    if (!comp) {
        return StatusError;
    }
    steps = M(comp)->steps;
    status = fmu_reset(comp);
    M(comp)->steps = steps; /* the bug: the counter survives the reset */
    return status;
#else
    return fmu_reset(comp);
#endif
}

Status probe_get_state(ModelInstance *comp, void **state) {
#ifdef NO_SNAPSHOTS
    (void)state;
    return fmu_unsupported(comp, "getFMUstate");
#else
    return fmu_get_state(comp, state);
#endif
}

Status probe_set_state(ModelInstance *comp, const void *state) {
    Status status = fmu_set_state(comp, state);
#ifdef INEXACT_SNAPSHOTS
    if (status <= StatusWarning) {
        M(comp)->position += 1e-9; /* the bug: a state that is not restored exactly */
        comp->s.dirty = true;
    }
#endif
    return status;
}
