/*
 * model.c -- the TwoMassDrive sample FMU (see config.h for its equations).
 */
#include "model.h"

static void set_start_values(ModelData *m) {
    m->phiA = 0.0;
    m->wA = 0.0;
    m->phiB = 0.0;
    m->wB = 0.0;
    m->M_A = 0.0;
    m->M_B = 0.0;
    m->J_A = 0.005;
    m->J_B = 0.01;
    m->c = 10.0;
    m->d = 0.05;
}

static Status initialize(ModelInstance *comp) {
    const ModelData *m = M(comp);
    if (!(m->J_A > 0.0) || !(m->J_B > 0.0) || !(m->c >= 0.0) || !(m->d >= 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need J_A > 0, J_B > 0, c >= 0, d >= 0 (got J_A=%g J_B=%g c=%g d=%g)",
                m->J_A, m->J_B, m->c, m->d);
        return StatusError;
    }
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    const double shaft = m->c * (m->phiA - m->phiB) + m->d * (m->wA - m->wB);
    dx[0] = m->wA;
    dx[1] = (m->M_A - shaft) / m->J_A;
    dx[2] = m->wB;
    dx[3] = (m->M_B + shaft) / m->J_B;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_phiA = dx[0];
    m->der_wA = dx[1];
    m->der_phiB = dx[2];
    m->der_wB = dx[3];
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->phiA;
    x[1] = m->wA;
    x[2] = m->phiB;
    x[3] = m->wB;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->phiA = x[0];
    m->wA = x[1];
    m->phiB = x[2];
    m->wB = x[3];
}

/* co-simulation's internal RK4 step: a fiftieth of the shaft's period of oscillation (about 0.11 s) */
static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 2e-3;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_PHI_A, phiA, VarReadOnly),
    FLOAT64_VAR(VR_W_A, wA, VarReadOnly),
    FLOAT64_VAR(VR_PHI_B, phiB, VarReadOnly),
    FLOAT64_VAR(VR_W_B, wB, VarReadOnly),
    FLOAT64_VAR(VR_DER_PHI_A, der_phiA, VarReadOnly),
    FLOAT64_VAR(VR_DER_W_A, der_wA, VarReadOnly),
    FLOAT64_VAR(VR_DER_PHI_B, der_phiB, VarReadOnly),
    FLOAT64_VAR(VR_DER_W_B, der_wB, VarReadOnly),
    FLOAT64_VAR(VR_M_A, M_A, VarInput),
    FLOAT64_VAR(VR_M_B, M_B, VarInput),
    FLOAT64_VAR(VR_J_A, J_A, VarFixed),
    FLOAT64_VAR(VR_J_B, J_B, VarFixed),
    FLOAT64_VAR(VR_C, c, VarFixed),
    FLOAT64_VAR(VR_D, d, VarFixed),
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
    .cs_step_size = cs_step_size,
};
