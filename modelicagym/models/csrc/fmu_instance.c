/*
 * fmu_instance.c -- logging, lifecycle, variable access and FMU states, independent
 * of the FMI version (see fmu_instance.h). The solver side is in fmu_solver.c.
 */
#include "fmu_internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LOG_MESSAGE_SIZE 1024
#define STATE_MAGIC 0x4d47464du /* "MGFM" */
#define STATE_FORMAT_VERSION 1u

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
Status fmu_fail(ModelInstance *comp, const char *format, ...) {
    va_list args;
    va_start(args, format);
    vlog(comp, StatusError, LogStatusError, format, args);
    va_end(args);
    return StatusError;
}

void fmu_escape_percent(const char *message, char *out, size_t size) {
    size_t i, n = 0;
    if (size == 0) {
        return;
    }
    for (i = 0; message[i] && n + 2 < size; i++) {
        if (message[i] == '%') {
            out[n++] = '%';
        }
        out[n++] = message[i];
    }
    out[n] = '\0';
}

Status fmu_unsupported(ModelInstance *comp, const char *function) {
    if (!comp) {
        return StatusError;
    }
    return fmu_fail(comp, "%s is not supported by this FMU", function);
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
    case ModeConfiguration: return "configuration mode";
    }
    return "unknown";
}

bool fmu_allowed(ModelInstance *comp, const char *function, unsigned modes) {
    if (comp->s.mode & modes) {
        return true;
    }
    fmu_fail(comp, "%s is not allowed in %s", function, mode_name(comp->s.mode));
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
        fmu_fail(comp, "model_definition lacks set_start_values or its variable table");
        return false;
    }
    if (NX > 0 && (!md->get_continuous_states || !md->set_continuous_states || !md->get_derivatives)) {
        fmu_fail(comp, "model_definition has NX > 0 but lacks a continuous-state hook");
        return false;
    }
    if (NZ > 0 && !md->get_event_indicators) {
        fmu_fail(comp, "model_definition has NZ > 0 but lacks get_event_indicators");
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

/* Free an instance's memory (no hook: also for instances never handed out). */
static void release(ModelInstance *comp) {
    free(comp->instance_name);
    free(comp);
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
        release(comp);
        return NULL;
    }
#ifdef FMU_INSTANTIATION_TOKEN
    if (!token || strcmp(token, FMU_INSTANTIATION_TOKEN) != 0) {
        fmu_fail(comp, "instantiation token \"%s\" does not match \"%s\"", token ? token : "(null)",
             FMU_INSTANTIATION_TOKEN);
        release(comp);
        return NULL;
    }
#else
    (void)token;
#endif
    if (!definition_is_complete(comp)) {
        release(comp);
        return NULL;
    }
    reset_state(comp);
    if (model_definition.on_instantiate && model_definition.on_instantiate(comp) > StatusWarning) {
        release(comp);
        return NULL;
    }
    return comp;
}

void fmu_free(ModelInstance *comp) {
    if (!comp) {
        return;
    }
    if (model_definition.on_free) {
        model_definition.on_free(comp);
    }
    release(comp);
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
            return fmu_fail(comp, "unknown log category \"%s\"", categories[i] ? categories[i] : "(null)");
        }
        comp->log_enabled[c] = logging_on;
    }
    return StatusOK;
}

/* Bring calculated values up to date before they are read. */
Status fmu_update_values(ModelInstance *comp) {
    if (!comp->s.dirty || (comp->s.mode & (ModeInstantiated | ModeConfiguration))) {
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
    if (!fmu_allowed(comp, "setupExperiment", ModeInstantiated)) {
        return StatusError;
    }
    comp->s.time = start_time;
    comp->s.last_successful_time = start_time;
    return StatusOK;
}

Status fmu_enter_configuration_mode(ModelInstance *comp) {
    if (!comp) {
        return StatusError;
    }
    if (!fmu_allowed(comp, "enterConfigurationMode", ModeInstantiated)) {
        return StatusError;
    }
    comp->s.mode = ModeConfiguration;
    return StatusOK;
}

Status fmu_exit_configuration_mode(ModelInstance *comp) {
    if (!comp) {
        return StatusError;
    }
    if (!fmu_allowed(comp, "exitConfigurationMode", ModeConfiguration)) {
        return StatusError;
    }
    comp->s.mode = ModeInstantiated;
    return StatusOK;
}

Status fmu_enter_initialization_mode(ModelInstance *comp) {
    if (!comp) {
        return StatusError;
    }
    if (!fmu_allowed(comp, "enterInitializationMode", ModeInstantiated)) {
        return StatusError;
    }
    comp->s.mode = ModeInitialization;
    comp->s.dirty = true;
    return StatusOK;
}

Status fmu_exit_initialization_mode(ModelInstance *comp) {
    Status status = StatusOK;
    if (!comp) {
        return StatusError;
    }
    if (!fmu_allowed(comp, "exitInitializationMode", ModeInitialization)) {
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
    status = fmu_cs_event_iteration(comp);
    if (comp->s.event.terminate_simulation) {
        comp->s.terminated = true;
    }
    return status;
}

Status fmu_terminate(ModelInstance *comp) {
    if (!comp) {
        return StatusError;
    }
    if (!fmu_allowed(comp, "terminate", MODES_INITIALIZED)) {
        return StatusError;
    }
    comp->s.mode = ModeTerminated;
    return StatusOK;
}

Status fmu_reset(ModelInstance *comp) {
    ModelData before;
    if (!comp) {
        return StatusError;
    }
    before = comp->s.data;
    reset_state(comp);
    if (model_definition.on_reset) {
        model_definition.on_reset(comp, &before);
    }
    return StatusOK;
}

/* ------------------------------------------------------- variable access */

/* Size and FMI name of each VarType. */
static const struct {
    size_t size;
    const char *name;
} VAR_TYPES[] = {
    [VarFloat64] = {sizeof(double), "Float64"},   [VarFloat32] = {sizeof(float), "Float32"},
    [VarInt8] = {sizeof(int8_t), "Int8"},         [VarUInt8] = {sizeof(uint8_t), "UInt8"},
    [VarInt16] = {sizeof(int16_t), "Int16"},      [VarUInt16] = {sizeof(uint16_t), "UInt16"},
    [VarInt32] = {sizeof(int32_t), "Int32"},      [VarUInt32] = {sizeof(uint32_t), "UInt32"},
    [VarInt64] = {sizeof(int64_t), "Int64"},      [VarUInt64] = {sizeof(uint64_t), "UInt64"},
    [VarBoolean] = {sizeof(bool), "Boolean"},     [VarEnumeration] = {sizeof(int32_t), "Enumeration"},
};

static size_t type_size(VarType type) { return VAR_TYPES[type].size; }

static const char *type_name(VarType type) { return VAR_TYPES[type].name; }

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
    case VarStructural: modes = ModeConfiguration; break;
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
        return fmu_fail(comp, "get%s: NULL value reference or value array", type_name(type));
    }
    status = fmu_update_values(comp);
    if (status > StatusWarning) {
        return status;
    }
    for (i = 0; i < nvr; i++) {
        const VariableInfo *v;
        if (type == VarFloat64 && vr[i] == VR_TIME) {
            if (index + 1 > n_values) {
                return fmu_fail(comp, "getFloat64: more values than the %zu given", n_values);
            }
            ((double *)values)[index++] = comp->s.time;
            continue;
        }
        v = find_variable(vr[i], type);
        if (!v) {
            return fmu_fail(comp, "get%s: unknown value reference %u", type_name(type), vr[i]);
        }
        if (index + v->count > n_values) {
            return fmu_fail(comp, "get%s: more values than the %zu given", type_name(type), n_values);
        }
        read_variable(comp, v, type, (char *)values + index * size);
        index += v->count;
    }
    if (index != n_values) {
        return fmu_fail(comp, "get%s: %zu values given for %zu", type_name(type), n_values, index);
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
        return fmu_fail(comp, "set%s: NULL value reference or value array", type_name(type));
    }
    for (i = 0; i < nvr; i++) {
        const VariableInfo *v = find_variable(vr[i], type);
        if (!v) {
            return fmu_fail(comp, "set%s: unknown value reference %u", type_name(type), vr[i]);
        }
        if (!settable(comp, v->kind)) {
            return fmu_fail(comp, "set%s: variable %u cannot be set in %s", type_name(type), vr[i],
                        mode_name(comp->s.mode));
        }
        if (index + v->count > n_values) {
            return fmu_fail(comp, "set%s: more values than the %zu given", type_name(type), n_values);
        }
        if (!write_variable(comp, v, type, (const char *)values + index * size)) {
            return fmu_fail(comp, "set%s: a value for variable %u is out of range", type_name(type),
                        vr[i]);
        }
        index += v->count;
    }
    if (index != n_values) {
        return fmu_fail(comp, "set%s: %zu values given for %zu", type_name(type), n_values, index);
    }
    comp->s.dirty = true;
    return StatusOK;
}

/* ------------------------------------------------------------ FMU states */

Status fmu_get_state(ModelInstance *comp, void **state) {
    if (!comp || !state) {
        return comp ? fmu_fail(comp, "getFMUState: NULL state pointer") : StatusError;
    }
    if (model_definition.on_get_state) {
        Status status = model_definition.on_get_state(comp);
        if (status > StatusWarning) {
            return status;
        }
    }
    if (!*state) {
        *state = malloc(sizeof(InstanceState));
        if (!*state) {
            return fmu_fail(comp, "getFMUState: out of memory");
        }
    }
    memcpy(*state, &comp->s, sizeof(InstanceState));
    return StatusOK;
}

Status fmu_set_state(ModelInstance *comp, const void *state) {
    if (!comp || !state) {
        return comp ? fmu_fail(comp, "setFMUState: NULL state") : StatusError;
    }
    memcpy(&comp->s, state, sizeof(InstanceState));
    if (model_definition.on_set_state) {
        model_definition.on_set_state(comp);
        comp->s.dirty = true;
    }
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
        return fmu_fail(comp, "serializeFMUState: NULL state or buffer, or buffer smaller than %zu",
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
        return fmu_fail(comp, "deserializeFMUState: expected %zu bytes, got %zu",
                    fmu_serialized_state_size(), size);
    }
    memcpy(&header, buffer, sizeof header);
    if (header.magic != STATE_MAGIC || header.version != STATE_FORMAT_VERSION ||
        header.payload_size != sizeof(InstanceState)) {
        return fmu_fail(comp, "deserializeFMUState: the data is not a state of this FMU");
    }
    if (!*state) {
        *state = malloc(sizeof(InstanceState));
        if (!*state) {
            return fmu_fail(comp, "deserializeFMUState: out of memory");
        }
    }
    memcpy(*state, buffer + sizeof header, sizeof(InstanceState));
    return StatusOK;
}
