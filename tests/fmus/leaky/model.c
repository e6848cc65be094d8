/*
 * model.c -- the Leaky test FMU (see config.h for its equation and variants).
 */
#include "model.h"

#define SEED UINT64_C(0x9e3779b97f4a7c15)
#define MAX_INSTANCES 256

/* Each live instance's generator, beside the instance (never in its FMU state). */
static struct {
    const ModelInstance *comp;
    uint64_t state;
} generators[MAX_INSTANCES];

static int slot_of(const ModelInstance *comp) {
    for (int k = 0; k < MAX_INSTANCES; k++)
        if (generators[k].comp == comp)
            return k;
    return -1;
}

static uint64_t *generator(const ModelInstance *comp) { return &generators[slot_of(comp)].state; }

/* xorshift64, scaled to [-1, 1) */
static double draw(uint64_t *state) {
    uint64_t s = *state;
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    *state = s;
    return (double)(s >> 11) * 0x1.0p-52 - 1.0;
}

static void set_start_values(ModelData *m) {
    m->u = 0.0;
    m->x_0 = 0.0;
    m->noise_amplitude = 1.0;
    m->cs_step_size = 1e-2;
    m->noise = 0.0;
    m->saved_random = 0;
    m->x = m->x_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->cs_step_size > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameter: need cs_step_size > 0 (got %g)", m->cs_step_size);
        return StatusError;
    }
    m->x = m->x_0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = -m->x + m->u + m->noise;
}

static void calculate_values(ModelInstance *comp) {
    double dx[NX];
    get_derivatives(comp, dx);
    M(comp)->der_x = dx[0];
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

static Status before_step(ModelInstance *comp, double t, double h) {
    ModelData *m = M(comp);
    (void)t;
    (void)h;
    m->noise = m->u != 0.0 ? m->noise_amplitude * draw(generator(comp)) : 0.0;
    return StatusOK;
}

static double cs_step_size(const ModelInstance *comp) { return comp->s.data.cs_step_size; }

static Status claim_a_generator(ModelInstance *comp) {
    int k = slot_of(NULL);
    if (k < 0) {
        fmu_log(comp, StatusError, LogStatusError, "more than %d live instances", MAX_INSTANCES);
        return StatusError;
    }
    generators[k].comp = comp;
    generators[k].state = SEED;
    return StatusOK;
}

static void release_the_generator(ModelInstance *comp) { generators[slot_of(comp)].comp = NULL; }

static void reseed(ModelInstance *comp, const ModelData *before) {
    (void)before;
#ifndef LEAKY_RESET
    *generator(comp) = SEED;
#else
    (void)comp; /* the bug: the generator goes on */
#endif
}

#ifndef LEAKY_SNAPSHOT
static Status save_the_generator(ModelInstance *comp) {
    M(comp)->saved_random = *generator(comp);
    return StatusOK;
}

static void restore_the_generator(ModelInstance *comp) { *generator(comp) = M(comp)->saved_random; }
#endif

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_X_0, x_0, VarFixed),
    FLOAT64_VAR(VR_NOISE_AMPLITUDE, noise_amplitude, VarFixed),
    FLOAT64_VAR(VR_CS_STEP_SIZE, cs_step_size, VarTunable),
};

const ModelDefinition model_definition = {
    .variables = variables,
    .n_variables = sizeof variables / sizeof variables[0],
    .set_start_values = set_start_values,
    .initialize = initialize,
    .calculate_values = calculate_values,
    .get_continuous_states = get_continuous_states,
    .set_continuous_states = set_continuous_states,
    .get_derivatives = get_derivatives,
    .before_step = before_step,
    .cs_step_size = cs_step_size,
    .on_instantiate = claim_a_generator,
    .on_free = release_the_generator,
    .on_reset = reseed,
#ifndef LEAKY_SNAPSHOT
    .on_get_state = save_the_generator,
    .on_set_state = restore_the_generator,
#endif
};
