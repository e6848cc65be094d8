/*
 * model.c -- the Quitter test FMU (see config.h).
 */
#include "model.h"

#include <signal.h>
#include <stdlib.h>

static void set_start_values(ModelData *m) {
    m->x = 0.0;
    m->u = 0.0;
    m->quit = QUIT_NEVER;
    m->quit_after = 0;
    m->steps = 0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (m->quit < QUIT_NEVER || m->quit > QUIT_SEGFAULT || m->quit_after < 0) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need quit in 0..3 and quit_after >= 0 (got quit=%d quit_after=%d)",
                (int)m->quit, (int)m->quit_after);
        return StatusError;
    }
    m->x = 0.0;
    m->steps = 0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) { dx[0] = M(comp)->u; }

static void calculate_values(ModelInstance *comp) { M(comp)->der_x = M(comp)->u; }

static void get_continuous_states(const ModelData *m, double x[]) { x[0] = m->x; }

static void set_continuous_states(ModelData *m, const double x[]) { m->x = x[0]; }

/* The doStep after `quit_after` completed ones ends the process. */
static Status before_step(ModelInstance *comp, double t, double h) {
    ModelData *m = M(comp);
    (void)t;
    (void)h;
    if (m->quit != QUIT_NEVER && m->steps >= m->quit_after) {
        switch (m->quit) {
        case QUIT_EXIT:
            exit(0); /* an exporter's "fatal error" path: a silent, successful exit */
        case QUIT_ABORT:
            abort();
        case QUIT_SEGFAULT: {
            volatile int *null_pointer = NULL;
            *null_pointer = 42;
            raise(SIGSEGV); /* in case the write above did not fault */
            return StatusFatal;
        }
        default:
            break;
        }
    }
    m->steps++;
    comp->s.dirty = true;
    return StatusOK;
}

static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 0.01;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_U, u, VarInput),
    INT32_VAR(VR_QUIT, quit, VarFixed),
    INT32_VAR(VR_QUIT_AFTER, quit_after, VarFixed),
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
};
