/*
 * model.c -- the Crashy test FMU (see config.h for its equations and variants).
 */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "model.h"

static void set_start_values(ModelData *m) {
    m->u = 0.0;
#ifdef TAU_REQUIRED
    m->tau = 0.0; /* not set: initialization refuses it */
#else
    m->tau = 1.0;
#endif
    m->x_0 = 0.0;
    m->x = m->x_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
#ifdef ABORT_IN_INITIALIZE
    fmu_log(comp, StatusError, LogStatusError, "initialization: the nonlinear solver did not converge");
    abort();
#endif
    if (!(m->tau > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameter: need tau > 0 (got tau=%g)", m->tau);
        return StatusError;
    }
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

/* ------------------------------------------------- build-time variants */

static Status misbehave_on_instantiate(ModelInstance *comp) {
#if defined(CRASH_IN_INSTANTIATE)
    volatile int *null_pointer = NULL;
#ifdef PRINT_TO_STDOUT
    (void)comp;
    printf("license file was not found\n");
#else
    fmu_log(comp, StatusError, LogStatusError, "license file was not found");
#endif
    *null_pointer = 42;   /* segmentation fault */
    raise(SIGSEGV);       /* in case the write above did not fault */
#elif defined(EXIT_IN_INSTANTIATE)
    fmu_log(comp, StatusError, LogStatusError, "no runtime licence: the FMU ends the program");
    exit(0);
#elif defined(HANG_IN_INSTANTIATE)
    fmu_log(comp, StatusError, LogStatusError, "waiting for the license server");
    for (;;)
        pause(); /* fmiInstantiate never returns (until the process is killed) */
#else
    (void)comp;
#endif
    return StatusOK;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_Y, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_TAU, tau, VarFixed),
    FLOAT64_VAR(VR_X_0, x_0, VarFixed),
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
    .on_instantiate = misbehave_on_instantiate,
};
