/*
 * model.c -- the CoolingConsumer test FMU (see config.h for its equations).
 */
#include <math.h>

#include "model.h"

static void set_start_values(ModelData *m) {
    m->valve = 0.0;
    m->p_supply = 3e5;
    m->p_return = 1.2e5;
    m->T_supply = 279.15;
    m->T_amb = 0.0;
    m->Q_gain = 2000.0;
    m->C_room = 5e5;
    m->UA = 3000.0;
    m->T_room_0 = 297.15;
    m->opening = 0.0;
    m->T_room = m->T_room_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->C_room > 0.0) || !(m->UA >= 0.0)) {
        fmu_log(comp, StatusError, LogStatusError, "invalid parameters: need C_room > 0, UA >= 0 (got C_room=%g UA=%g)",
                m->C_room, m->UA);
        return StatusError;
    }
    m->opening = 0.0;
    m->T_room = m->T_room_0;
    return StatusOK;
}

/* the coil: mass flow, cooling power and return temperature from the valve's opening */
static void coil(ModelData *m) {
    const double dp = m->p_supply - m->p_return;
    const double capacity = (m->m_flow = KV * m->opening * sqrt(dp > 0.0 ? dp : 0.0)) * CP_WATER;
    if (capacity > 1e-9) {
        m->Q_flow = (1.0 - exp(-m->UA / capacity)) * capacity * (m->T_room - m->T_supply);
        m->T_return = m->T_supply + m->Q_flow / capacity;
    } else {
        m->Q_flow = 0.0;
        m->T_return = m->T_room;
    }
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    ModelData *m = M(comp);
    const double command = m->valve < 0.0 ? 0.0 : (m->valve > 1.0 ? 1.0 : m->valve);
    coil(m);
    dx[0] = (command - m->opening) / TAU_VALVE;
    dx[1] = (m->Q_gain + G_WALLS * (m->T_amb - m->T_room) - m->Q_flow) / m->C_room;
}

static void calculate_values(ModelInstance *comp) {
    ModelData *m = M(comp);
    double dx[NX];
    get_derivatives(comp, dx);
    m->der_opening = dx[0];
    m->der_T_room = dx[1];
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->opening;
    x[1] = m->T_room;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->opening = x[0];
    m->T_room = x[1];
}

/* co-simulation's internal RK4 step: well inside the valve's 10 s */
static double cs_step_size(const ModelInstance *comp) {
    (void)comp;
    return 0.5;
}

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_T_ROOM, T_room, VarReadOnly),
    FLOAT64_VAR(VR_DER_T_ROOM, der_T_room, VarReadOnly),
    FLOAT64_VAR(VR_OPENING, opening, VarReadOnly),
    FLOAT64_VAR(VR_DER_OPENING, der_opening, VarReadOnly),
    FLOAT64_VAR(VR_VALVE, valve, VarInput),
    FLOAT64_VAR(VR_P_SUPPLY, p_supply, VarInput),
    FLOAT64_VAR(VR_P_RETURN, p_return, VarInput),
    FLOAT64_VAR(VR_T_SUPPLY, T_supply, VarInput),
    FLOAT64_VAR(VR_T_AMB, T_amb, VarInput),
    FLOAT64_VAR(VR_Q_GAIN, Q_gain, VarInput),
    FLOAT64_VAR(VR_T_RETURN, T_return, VarReadOnly),
    FLOAT64_VAR(VR_M_FLOW, m_flow, VarReadOnly),
    FLOAT64_VAR(VR_Q_FLOW, Q_flow, VarReadOnly),
    FLOAT64_VAR(VR_C_ROOM, C_room, VarFixed),
    FLOAT64_VAR(VR_UA, UA, VarFixed),
    FLOAT64_VAR(VR_T_ROOM_0, T_room_0, VarFixed),
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
