/*
 * fmu_instance.c -- lifecycle, variable access, RK4 co-simulation, model
 * exchange and FMU states, independent of the FMI version (see fmu_instance.h).
 */
#include "fmu_instance.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_EVENT_ITERATIONS 100
#define LOG_MESSAGE_SIZE 1024
#define STATE_MAGIC 0x4d47464du /* "MGFM" */
#define STATE_FORMAT_VERSION 1u

/* Allowed interface states of the calls (bit masks of Mode). */
#define MODES_INITIALIZED (ModeInitialization | ModeEvent | ModeContinuousTime | ModeStep | ModeTerminated)

const char *const LOG_CATEGORY_NAMES[N_LOG_CATEGORIES] = {
    "logEvents", "logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal",
};

typedef struct {
    uint32_t magic;
    uint32_t version;
    uint64_t payload_size;
} StateHeader;

/* ---------------------------------------------------------------- logging */

static void vlog(ModelInstance *comp, Status status, LogCategory category, const char *format,
                 va_list args) {
    char message[LOG_MESSAGE_SIZE];
    if (!comp->log_sink || category >= N_LOG_CATEGORIES) {
        return;
    }
    if (status < StatusError && !comp->log_enabled[category]) {
        return;
    }
    vsnprintf(message, sizeof message, format, args);
    comp->log_sink(comp, status, LOG_CATEGORY_NAMES[category], message);
}

void fmu_log(ModelInstance *comp, Status status, LogCategory category, const char *format, ...) {
    va_list args;
    if (!comp) {
        return;
    }
    va_start(args, format);
    vlog(comp, status, category, format, args);
    va_end(args);
}

/* Log an error and return StatusError. */
static Status fail(ModelInstance *comp, const char *format, ...) FMU_PRINTF_FORMAT(2, 3);
static Status fail(ModelInstance *comp, const char *format, ...) {
    va_list args;
    va_start(args, format);
    vlog(comp, StatusError, LogStatusError, format, args);
    va_end(args);
    return StatusError;
}

Status fmu_unsupported(ModelInstance *comp, const char *function) {
    if (!comp) {
        return StatusError;
    }
    return fail(comp, "%s is not supported by this FMU", function);
}

static const char *mode_name(Mode mode) {
    switch (mode) {
    case ModeInstantiated: return "instantiated";
    case ModeInitialization: return "initialization mode";
    case ModeEvent: return "event mode";
    case ModeContinuousTime: return "continuous-time mode";
    case ModeStep: return "step mode";
    case ModeTerminated: return "terminated";
    case ModeError: return "error";
    }
    return "unknown";
}

static bool allowed(ModelInstance *comp, const char *function, unsigned modes) {
    if (comp->s.mode & modes) {
        return true;
    }
    fail(comp, "%s is not allowed in %s", function, mode_name(comp->s.mode));
    return false;
}

/* ------------------------------------------------------------- lifecycle */

static void reset_state(ModelInstance *comp) {
    memset(&comp->s, 0, sizeof comp->s);
    model_definition.set_start_values(M(comp));
    comp->s.mode = ModeInstantiated;
    comp->s.dirty = true;
}

static bool definition_is_complete(ModelInstance *comp) {
    const ModelDefinition *md = &model_definition;
    if (!md->set_start_values || (md->n_variables > 0 && !md->variables)) {
        fail(comp, "model_definition lacks set_start_values or its variable table");
        return false;
    }
    if (NX > 0 && (!md->get_continuous_states || !md->set_continuous_states || !md->get_derivatives)) {
        fail(comp, "model_definition has NX > 0 but lacks a continuous-state hook");
        return false;
    }
    if (NZ > 0 && !md->get_event_indicators) {
        fail(comp, "model_definition has NZ > 0 but lacks get_event_indicators");
        return false;
    }
    return true;
}

static char *copy_string(const char *s) {
    size_t n = strlen(s) + 1;
    char *copy = malloc(n);
    if (copy) {
        memcpy(copy, s, n);
    }
    return copy;
}

ModelInstance *fmu_instantiate(const char *instance_name, InterfaceType type, const char *token,
                               bool logging_on, LogSink sink, void *log_env,
                               void (*log_callback)(void)) {
    ModelInstance *comp = calloc(1, sizeof *comp);
    int i;
    if (!comp) {
        return NULL;
    }
    comp->type = type;
    comp->log_sink = sink;
    comp->log_env = log_env;
    comp->log_callback = log_callback;
    comp->instance_name = copy_string(instance_name ? instance_name : "");
    for (i = 0; i < N_LOG_CATEGORIES; i++) {
        comp->log_enabled[i] = logging_on;
    }
    if (!comp->instance_name) {
        fmu_free(comp);
        return NULL;
    }
#ifdef FMU_INSTANTIATION_TOKEN
    if (!token || strcmp(token, FMU_INSTANTIATION_TOKEN) != 0) {
        fail(comp, "instantiation token \"%s\" does not match \"%s\"", token ? token : "(null)",
             FMU_INSTANTIATION_TOKEN);
        fmu_free(comp);
        return NULL;
    }
#else
    (void)token;
#endif
    if (!definition_is_complete(comp)) {
        fmu_free(comp);
        return NULL;
    }
    reset_state(comp);
    return comp;
}

void fmu_free(ModelInstance *comp) {
    if (!comp) {
        return;
    }
    free(comp->instance_name);
    free(comp);
}

Status fmu_set_debug_logging(ModelInstance *comp, bool logging_on, size_t n_categories,
                             const char *const categories[]) {
    size_t i;
    int c;
    if (!comp) {
        return StatusError;
    }
    if (n_categories == 0) {
        for (c = 0; c < N_LOG_CATEGORIES; c++) {
            comp->log_enabled[c] = logging_on;
        }
        return StatusOK;
    }
    for (i = 0; i < n_categories; i++) {
        for (c = 0; c < N_LOG_CATEGORIES; c++) {
            if (categories[i] && strcmp(categories[i], LOG_CATEGORY_NAMES[c]) == 0) {
                break;
            }
        }
        if (c == N_LOG_CATEGORIES) {
            return fail(comp, "unknown log category \"%s\"", categories[i] ? categories[i] : "(null)");
        }
        comp->log_enabled[c] = logging_on;
    }
    return StatusOK;
}

/* Bring calculated values up to date before they are read. */
static Status update_values(ModelInstance *comp) {
    if (!comp->s.dirty || comp->s.mode == ModeInstantiated) {
        return StatusOK;
    }
    if (comp->s.mode == ModeInitialization && model_definition.initialize) {
        Status status = model_definition.initialize(comp);
        if (status > StatusWarning) {
            return status;
        }
    }
    if (model_definition.calculate_values) {
        model_definition.calculate_values(comp);
    }
    comp->s.dirty = false;
    return StatusOK;
}

Status fmu_setup_experiment(ModelInstance *comp, double start_time) {
    if (!comp) {
        return StatusError;
    }
    if (!allowed(comp, "setupExperiment", ModeInstantiated)) {
        return StatusError;
    }
    comp->s.time = start_time;
    comp->s.last_successful_time = start_time;
    return StatusOK;
}

Status fmu_enter_initialization_mode(ModelInstance *comp) {
    if (!comp) {
        return StatusError;
    }
    if (!allowed(comp, "enterInitializationMode", ModeInstantiated)) {
        return StatusError;
    }
    comp->s.mode = ModeInitialization;
    comp->s.dirty = true;
    return StatusOK;
}

/* One event update: clear the flags, let the model update, log what happened. */
static Status event_update(ModelInstance *comp) {
    EventFlags *e = &comp->s.event;
    Status status = StatusOK;
    e->new_discrete_states_needed = false;
    e->terminate_simulation = false;
    e->nominals_changed = false;
    e->values_changed = false;
    e->next_event_time_defined = false;
    if (model_definition.event_update) {
        status = model_definition.event_update(comp);
    }
    comp->s.dirty = true;
    fmu_log(comp, StatusOK, LogEvents,
            "event update at t=%.17g: values changed %d, terminate %d, next event %s%.17g",
            comp->s.time, e->values_changed, e->terminate_simulation,
            e->next_event_time_defined ? "at t=" : "undefined, ",
            e->next_event_time_defined ? e->next_event_time : 0.0);
    return status;
}

static void store_event_indicators(ModelInstance *comp) {
    if (NZ > 0) {
        model_definition.get_event_indicators(comp, comp->s.z_prev);
    }
}

/* Co-simulation: iterate event updates until the model is settled. */
static Status cs_event_iteration(ModelInstance *comp) {
    int i;
    for (i = 0; i < MAX_EVENT_ITERATIONS; i++) {
        Status status = event_update(comp);
        if (status > StatusWarning || comp->s.event.terminate_simulation ||
            !comp->s.event.new_discrete_states_needed) {
            store_event_indicators(comp);
            return status;
        }
    }
    return fail(comp, "event iteration did not converge after %d updates", MAX_EVENT_ITERATIONS);
}

Status fmu_exit_initialization_mode(ModelInstance *comp) {
    Status status = StatusOK;
    if (!comp) {
        return StatusError;
    }
    if (!allowed(comp, "exitInitializationMode", ModeInitialization)) {
        return StatusError;
    }
    if (model_definition.initialize) {
        status = model_definition.initialize(comp);
        if (status > StatusWarning) {
            return status;
        }
    }
    if (model_definition.calculate_values) {
        model_definition.calculate_values(comp);
    }
    comp->s.dirty = false;
    if (comp->type == ModelExchange) {
        comp->s.mode = ModeEvent;
        return status;
    }
    comp->s.mode = ModeStep;
    comp->s.last_successful_time = comp->s.time;
    status = cs_event_iteration(comp);
    if (comp->s.event.terminate_simulation) {
        comp->s.terminated = true;
    }
    return status;
}

Status fmu_terminate(ModelInstance *comp) {
    if (!comp) {
        return StatusError;
    }
    if (!allowed(comp, "terminate", MODES_INITIALIZED)) {
        return StatusError;
    }
    comp->s.mode = ModeTerminated;
    return StatusOK;
}

Status fmu_reset(ModelInstance *comp) {
    if (!comp) {
        return StatusError;
    }
    reset_state(comp);
    return StatusOK;
}

/* ------------------------------------------------------- variable access */

static size_t type_size(VarType type) {
    switch (type) {
    case VarFloat64: return sizeof(double);
    case VarInt32: return sizeof(int32_t);
    case VarInt64: return sizeof(int64_t);
    case VarBoolean: return sizeof(bool);
    case VarEnumeration: return sizeof(int32_t);
    }
    return 0;
}

static const char *type_name(VarType type) {
    switch (type) {
    case VarFloat64: return "Float64";
    case VarInt32: return "Int32";
    case VarInt64: return "Int64";
    case VarBoolean: return "Boolean";
    case VarEnumeration: return "Enumeration";
    }
    return "unknown";
}

/* The variable `vr` if it can be accessed as `type`, else NULL. */
static const VariableInfo *find_variable(ValueReference vr, VarType type) {
    size_t i;
    for (i = 0; i < model_definition.n_variables; i++) {
        const VariableInfo *v = &model_definition.variables[i];
        if (v->vr == vr) {
            bool as_enum = v->type == VarEnumeration && (type == VarInt32 || type == VarInt64);
            return v->type == type || as_enum ? v : NULL;
        }
    }
    return NULL;
}

/* Copy a variable's values out of ModelData into an array of `type` (Int64 access to
 * enumerations widens their int32_t storage). */
static void read_variable(ModelInstance *comp, const VariableInfo *v, VarType type, void *dst) {
    const char *field = (const char *)M(comp) + v->offset;
    size_t i;
    if (type == VarInt64 && v->type == VarEnumeration) {
        for (i = 0; i < v->count; i++) {
            ((int64_t *)dst)[i] = ((const int32_t *)(const void *)field)[i];
        }
    } else {
        memcpy(dst, field, v->count * type_size(type));
    }
}

/* Copy values of `type` into a variable's ModelData field; false (and nothing written)
 * when an Int64 value does not fit an enumeration's int32_t storage. */
static bool write_variable(ModelInstance *comp, const VariableInfo *v, VarType type,
                           const void *src) {
    char *field = (char *)M(comp) + v->offset;
    size_t i;
    if (type == VarInt64 && v->type == VarEnumeration) {
        const int64_t *values = src;
        for (i = 0; i < v->count; i++) {
            if (values[i] < INT32_MIN || values[i] > INT32_MAX) {
                return false;
            }
        }
        for (i = 0; i < v->count; i++) {
            ((int32_t *)(void *)field)[i] = (int32_t)values[i];
        }
    } else {
        memcpy(field, src, v->count * type_size(type));
    }
    return true;
}

static bool settable(const ModelInstance *comp, VarKind kind) {
    unsigned modes = 0;
    switch (kind) {
    case VarReadOnly: modes = 0; break;
    case VarFixed: modes = ModeInstantiated | ModeInitialization; break;
    case VarTunable: modes = ModeInstantiated | ModeInitialization | ModeEvent | ModeStep; break;
    case VarInput:
        modes = ModeInstantiated | ModeInitialization | ModeEvent | ModeContinuousTime | ModeStep;
        break;
    }
    return (comp->s.mode & modes) != 0;
}

Status fmu_get(ModelInstance *comp, VarType type, const ValueReference vr[], size_t nvr,
               void *values, size_t n_values) {
    const size_t size = type_size(type);
    size_t i, index = 0;
    Status status;
    if (!comp) {
        return StatusError;
    }
    if (nvr > 0 && (!vr || !values)) {
        return fail(comp, "get%s: NULL value reference or value array", type_name(type));
    }
    status = update_values(comp);
    if (status > StatusWarning) {
        return status;
    }
    for (i = 0; i < nvr; i++) {
        const VariableInfo *v;
        if (type == VarFloat64 && vr[i] == VR_TIME) {
            if (index + 1 > n_values) {
                return fail(comp, "getFloat64: more values than the %zu given", n_values);
            }
            ((double *)values)[index++] = comp->s.time;
            continue;
        }
        v = find_variable(vr[i], type);
        if (!v) {
            return fail(comp, "get%s: unknown value reference %u", type_name(type), vr[i]);
        }
        if (index + v->count > n_values) {
            return fail(comp, "get%s: more values than the %zu given", type_name(type), n_values);
        }
        read_variable(comp, v, type, (char *)values + index * size);
        index += v->count;
    }
    if (index != n_values) {
        return fail(comp, "get%s: %zu values given for %zu", type_name(type), n_values, index);
    }
    return StatusOK;
}

Status fmu_set(ModelInstance *comp, VarType type, const ValueReference vr[], size_t nvr,
               const void *values, size_t n_values) {
    const size_t size = type_size(type);
    size_t i, index = 0;
    if (!comp) {
        return StatusError;
    }
    if (nvr > 0 && (!vr || !values)) {
        return fail(comp, "set%s: NULL value reference or value array", type_name(type));
    }
    for (i = 0; i < nvr; i++) {
        const VariableInfo *v = find_variable(vr[i], type);
        if (!v) {
            return fail(comp, "set%s: unknown value reference %u", type_name(type), vr[i]);
        }
        if (!settable(comp, v->kind)) {
            return fail(comp, "set%s: variable %u cannot be set in %s", type_name(type), vr[i],
                        mode_name(comp->s.mode));
        }
        if (index + v->count > n_values) {
            return fail(comp, "set%s: more values than the %zu given", type_name(type), n_values);
        }
        if (!write_variable(comp, v, type, (const char *)values + index * size)) {
            return fail(comp, "set%s: a value for variable %u is out of range", type_name(type),
                        vr[i]);
        }
        index += v->count;
    }
    if (index != n_values) {
        return fail(comp, "set%s: %zu values given for %zu", type_name(type), n_values, index);
    }
    comp->s.dirty = true;
    return StatusOK;
}

/* ----------------------------------------------------- co-simulation RK4 */

/* Evaluate dx/dt at time t for the states x (written into ModelData). */
static void derivatives_at(ModelInstance *comp, double t, const double x[], double dx[]) {
    comp->s.time = t;
    model_definition.set_continuous_states(M(comp), x);
    model_definition.get_derivatives(comp, dx);
}

/* One classical Runge-Kutta step from t to t_next; leaves time at t_next. */
static void rk4_substep(ModelInstance *comp, double t, double t_next) {
    const double dt = t_next - t;
    double x0[NX_ALLOC], xt[NX_ALLOC], k1[NX_ALLOC], k2[NX_ALLOC], k3[NX_ALLOC], k4[NX_ALLOC];
    int i;
    if (NX > 0) {
        model_definition.get_continuous_states(M(comp), x0);
        comp->s.time = t;
        model_definition.get_derivatives(comp, k1);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + 0.5 * dt * k1[i];
        }
        derivatives_at(comp, t + 0.5 * dt, xt, k2);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + 0.5 * dt * k2[i];
        }
        derivatives_at(comp, t + 0.5 * dt, xt, k3);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + dt * k3[i];
        }
        derivatives_at(comp, t_next, xt, k4);
        for (i = 0; i < NX; i++) {
            xt[i] = x0[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        model_definition.set_continuous_states(M(comp), xt);
    }
    comp->s.time = t_next;
    comp->s.dirty = true;
}

/* Did an event indicator change sign since the last substep end? Updates z_prev. */
static bool state_event_occurred(ModelInstance *comp) {
    double z[NZ_ALLOC];
    bool crossed = false;
    int i;
    if (NZ == 0) {
        return false;
    }
    model_definition.get_event_indicators(comp, z);
    for (i = 0; i < NZ; i++) {
        if ((z[i] > 0.0) != (comp->s.z_prev[i] > 0.0)) {
            crossed = true;
        }
        comp->s.z_prev[i] = z[i];
    }
    return crossed;
}

static bool time_event_due(const ModelInstance *comp, double t, double eps) {
    return comp->s.event.next_event_time_defined && comp->s.event.next_event_time <= t + eps;
}

/* Integrate from t_start to t_end on a substep grid anchored at t_start (re-anchored at events). */
static Status integrate(ModelInstance *comp, double t_start, double t_end, double hs) {
    const double eps = 1e-6 * hs; /* shorter final substeps merge into the previous one */
    double t = t_start, anchor = t_start;
    long k = 0;
    comp->s.time = t_start;
    for (;;) {
        if (state_event_occurred(comp) || time_event_due(comp, t, eps)) {
            Status status = cs_event_iteration(comp);
            if (status > StatusWarning) {
                return status;
            }
            if (comp->s.event.terminate_simulation) {
                comp->s.terminated = true;
                comp->s.last_successful_time = t;
                return StatusDiscard;
            }
            if (time_event_due(comp, t, eps)) {
                return fail(comp, "next_event_time %.17g does not lie after t=%.17g",
                            comp->s.event.next_event_time, t);
            }
            anchor = t;
            k = 0;
        }
        if (t >= t_end) {
            break;
        }
        {
            double t_next = anchor + (double)(k + 1) * hs;
            if (t_next > t_end - eps) {
                t_next = t_end;
            }
            if (comp->s.event.next_event_time_defined && comp->s.event.next_event_time < t_next) {
                t_next = comp->s.event.next_event_time;
            }
            rk4_substep(comp, t, t_next);
            t = t_next;
            k++;
        }
    }
    comp->s.time = t_end;
    comp->s.last_successful_time = t_end;
    return StatusOK;
}

Status fmu_do_step(ModelInstance *comp, double t, double h, bool *terminated,
                   double *last_successful_time) {
    Status status = StatusOK;
    double hs;
    if (!comp) {
        return StatusError;
    }
    if (comp->type != CoSimulation) {
        return fail(comp, "doStep: the instance was instantiated for model exchange");
    }
    if (!allowed(comp, "doStep", ModeStep)) {
        return StatusError;
    }
    if (comp->s.terminated) {
        fmu_log(comp, StatusDiscard, LogStatusDiscard, "doStep: the simulation has terminated");
        status = StatusDiscard;
    } else if (!(h >= 0.0)) {
        return fail(comp, "doStep: communicationStepSize %.17g must be >= 0", h);
    } else if (fabs(t - comp->s.time) > 1e-9 * fmax(1.0, fabs(t))) {
        return fail(comp, "doStep: currentCommunicationPoint %.17g differs from the FMU time %.17g",
                    t, comp->s.time);
    } else {
        hs = model_definition.cs_step_size ? model_definition.cs_step_size(comp) : DEFAULT_CS_STEP_SIZE;
        if (!(hs > 0.0)) {
            return fail(comp, "doStep: internal step size %.17g must be > 0", hs);
        }
        comp->s.time = t;
        if (model_definition.before_step) {
            status = model_definition.before_step(comp, t, h);
            if (status >= StatusError) {
                comp->s.mode = ModeError;
                return status;
            }
            if (comp->s.event.terminate_simulation) {
                comp->s.terminated = true;
                status = StatusDiscard;
            }
        }
        if (status != StatusDiscard) {
            status = integrate(comp, t, t + h, hs);
            if (status >= StatusError) {
                comp->s.mode = ModeError;
            }
        } else {
            comp->s.last_successful_time = t;
        }
    }
    *terminated = comp->s.terminated;
    *last_successful_time = comp->s.last_successful_time;
    return status;
}

/* ------------------------------------------------------- model exchange */

static Status check_me(ModelInstance *comp, const char *function, unsigned modes) {
    if (comp->type != ModelExchange) {
        return fail(comp, "%s: the instance was instantiated for co-simulation", function);
    }
    return allowed(comp, function, modes) ? StatusOK : StatusError;
}

static Status check_size(ModelInstance *comp, const char *function, size_t n, size_t expected,
                         const void *array) {
    if (n != expected) {
        return fail(comp, "%s: %zu values given, the model has %zu", function, n, expected);
    }
    if (n > 0 && !array) {
        return fail(comp, "%s: NULL array", function);
    }
    return StatusOK;
}

Status fmu_set_time(ModelInstance *comp, double time) {
    if (!comp || check_me(comp, "setTime", ModeEvent | ModeContinuousTime) != StatusOK) {
        return StatusError;
    }
    comp->s.time = time;
    comp->s.dirty = true;
    return StatusOK;
}

Status fmu_set_continuous_states(ModelInstance *comp, const double x[], size_t nx) {
    if (!comp || check_me(comp, "setContinuousStates", ModeEvent | ModeContinuousTime) != StatusOK ||
        check_size(comp, "setContinuousStates", nx, NX, x) != StatusOK) {
        return StatusError;
    }
    if (NX > 0) {
        model_definition.set_continuous_states(M(comp), x);
    }
    comp->s.dirty = true;
    return StatusOK;
}

Status fmu_get_continuous_states(ModelInstance *comp, double x[], size_t nx) {
    Status status;
    if (!comp || !allowed(comp, "getContinuousStates", MODES_INITIALIZED | ModeError) ||
        check_size(comp, "getContinuousStates", nx, NX, x) != StatusOK) {
        return StatusError;
    }
    status = update_values(comp);
    if (NX > 0 && status <= StatusWarning) {
        model_definition.get_continuous_states(M(comp), x);
    }
    return status;
}

Status fmu_get_derivatives(ModelInstance *comp, double dx[], size_t nx) {
    Status status;
    if (!comp || !allowed(comp, "getDerivatives", MODES_INITIALIZED | ModeError) ||
        check_size(comp, "getDerivatives", nx, NX, dx) != StatusOK) {
        return StatusError;
    }
    status = update_values(comp);
    if (NX > 0 && status <= StatusWarning) {
        model_definition.get_derivatives(comp, dx);
    }
    return status;
}

Status fmu_get_event_indicators(ModelInstance *comp, double z[], size_t nz) {
    Status status;
    if (!comp || !allowed(comp, "getEventIndicators", MODES_INITIALIZED | ModeError) ||
        check_size(comp, "getEventIndicators", nz, NZ, z) != StatusOK) {
        return StatusError;
    }
    status = update_values(comp);
    if (NZ > 0 && status <= StatusWarning) {
        model_definition.get_event_indicators(comp, z);
    }
    return status;
}

Status fmu_get_nominals(ModelInstance *comp, double nominals[], size_t nx) {
    size_t i;
    if (!comp || check_size(comp, "getNominalsOfContinuousStates", nx, NX, nominals) != StatusOK) {
        return StatusError;
    }
    for (i = 0; i < nx; i++) {
        nominals[i] = 1.0;
    }
    return StatusOK;
}

Status fmu_enter_event_mode(ModelInstance *comp) {
    if (!comp || check_me(comp, "enterEventMode", ModeEvent | ModeContinuousTime) != StatusOK) {
        return StatusError;
    }
    comp->s.mode = ModeEvent;
    return StatusOK;
}

Status fmu_update_discrete_states(ModelInstance *comp, EventFlags *flags) {
    Status status;
    if (!comp || check_me(comp, "updateDiscreteStates", ModeEvent) != StatusOK) {
        return StatusError;
    }
    status = event_update(comp);
    *flags = comp->s.event;
    return status;
}

Status fmu_enter_continuous_time_mode(ModelInstance *comp) {
    if (!comp || check_me(comp, "enterContinuousTimeMode", ModeEvent) != StatusOK) {
        return StatusError;
    }
    comp->s.mode = ModeContinuousTime;
    return StatusOK;
}

Status fmu_completed_integrator_step(ModelInstance *comp, bool *enter_event_mode,
                                     bool *terminate_simulation) {
    if (!comp || check_me(comp, "completedIntegratorStep", ModeContinuousTime) != StatusOK) {
        return StatusError;
    }
    *enter_event_mode = false;
    *terminate_simulation = false;
    return StatusOK;
}

/* ------------------------------------------------------------ FMU states */

Status fmu_get_state(ModelInstance *comp, void **state) {
    if (!comp || !state) {
        return comp ? fail(comp, "getFMUState: NULL state pointer") : StatusError;
    }
    if (!*state) {
        *state = malloc(sizeof(InstanceState));
        if (!*state) {
            return fail(comp, "getFMUState: out of memory");
        }
    }
    memcpy(*state, &comp->s, sizeof(InstanceState));
    return StatusOK;
}

Status fmu_set_state(ModelInstance *comp, const void *state) {
    if (!comp || !state) {
        return comp ? fail(comp, "setFMUState: NULL state") : StatusError;
    }
    memcpy(&comp->s, state, sizeof(InstanceState));
    return StatusOK;
}

Status fmu_free_state(ModelInstance *comp, void **state) {
    if (!comp) {
        return StatusError;
    }
    if (state) {
        free(*state);
        *state = NULL;
    }
    return StatusOK;
}

size_t fmu_serialized_state_size(void) {
    return sizeof(StateHeader) + sizeof(InstanceState);
}

Status fmu_serialize_state(ModelInstance *comp, const void *state, unsigned char *buffer,
                           size_t size) {
    StateHeader header;
    if (!comp) {
        return StatusError;
    }
    if (!state || !buffer || size < fmu_serialized_state_size()) {
        return fail(comp, "serializeFMUState: NULL state or buffer, or buffer smaller than %zu",
                    fmu_serialized_state_size());
    }
    header.magic = STATE_MAGIC;
    header.version = STATE_FORMAT_VERSION;
    header.payload_size = sizeof(InstanceState);
    memcpy(buffer, &header, sizeof header);
    memcpy(buffer + sizeof header, state, sizeof(InstanceState));
    return StatusOK;
}

Status fmu_deserialize_state(ModelInstance *comp, const unsigned char *buffer, size_t size,
                             void **state) {
    StateHeader header;
    if (!comp) {
        return StatusError;
    }
    if (!buffer || !state || size != fmu_serialized_state_size()) {
        return fail(comp, "deserializeFMUState: expected %zu bytes, got %zu",
                    fmu_serialized_state_size(), size);
    }
    memcpy(&header, buffer, sizeof header);
    if (header.magic != STATE_MAGIC || header.version != STATE_FORMAT_VERSION ||
        header.payload_size != sizeof(InstanceState)) {
        return fail(comp, "deserializeFMUState: the data is not a state of this FMU");
    }
    if (!*state) {
        *state = malloc(sizeof(InstanceState));
        if (!*state) {
            return fail(comp, "deserializeFMUState: out of memory");
        }
    }
    memcpy(*state, buffer + sizeof header, sizeof(InstanceState));
    return StatusOK;
}
