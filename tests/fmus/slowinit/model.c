/*
 * model.c -- the SlowInit test FMU (see config.h).
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#include <time.h>

#include "model.h"

static void set_start_values(ModelData *m) {
    m->u = 0.0;
    m->tau = 1.0;
    m->x_0 = 0.0;
    m->init_seconds = 0.2;
    m->x = m->x_0;
}

static double thread_cpu_seconds(void) {
    struct timespec now;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

/* Busy for init_seconds of this thread's CPU time: the work a slow initialization does. */
static void work(double seconds) {
    const double until = thread_cpu_seconds() + seconds;
    volatile double sink = 0.0;
    while (thread_cpu_seconds() < until) {
        for (int k = 0; k < 10000; k++) {
            sink += 1e-9 * k;
        }
    }
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->tau > 0.0) || !(m->init_seconds >= 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameters: need tau > 0 and init_seconds >= 0");
        return StatusError;
    }
    work(m->init_seconds);
    m->x = m->x_0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    dx[0] = (m->u - m->x) / m->tau;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_x = dx[0];
}

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_Y, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_TAU, tau, VarFixed),
    FLOAT64_VAR(VR_X_0, x_0, VarFixed),
    FLOAT64_VAR(VR_INIT_SECONDS, init_seconds, VarFixed),
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
};
