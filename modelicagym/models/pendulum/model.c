/*
 * model.c -- a pendulum swung up by a geared DC motor through a compliant shaft,
 * with LuGre friction in the motor bearing, for the modelicagym FMU framework.
 *
 * A control task where the simulation costs something: the motor's electrical
 * time constant (L/R = 0.5 ms) and the bristle dynamics of LuGre friction are
 * fast next to the 50 ms control step, so the co-simulation solver takes
 * thousands of RK4 substeps per doStep (the default cs_step_size, 2e-5 s, is
 * the largest step that stays accurate at the motor's top speed; see
 * Pendulum.mo). The equations (Pendulum.mo has them as Modelica):
 *
 *   pendulum   J theta'' = m g l sin(theta) - b omega + tau_s,  J = m l^2,
 *              theta = 0 upright, +-pi hanging down;
 *   shaft      tau_s = k_s twist + d_s twist',  twist = theta_m / N - theta
 *              (the gearbox output leads the pendulum by the shaft's twist);
 *   motor      J_m omega_m' = k_m i - T_f - tau_s / N,  theta_m' = omega_m;
 *   armature   L i' = u - R i - k_m omega_m;
 *   friction   (LuGre) g(v) = T_c + (T_s - T_c) exp(-(v / v_s)^2),
 *              z' = v - sigma0 |v| z / g(v),
 *              T_f = sigma0 z + sigma1 z' + sigma2 v,  v = omega_m.
 *
 * The states are (theta, omega, twist, omega_m, i, z); the motor angle itself
 * never enters the dynamics, so the twist replaces it (no loss of precision as
 * the motor turns many revolutions).
 */
#include <math.h>

#include "model.h"

#define GRAVITY 9.81

static void set_start_values(ModelData *m) {
    m->u = 0.0;
    m->mass = 1.0;
    m->length = 0.5;
    m->damping = 0.01;
    m->gear_ratio = 15.0;
    m->k_motor = 0.03;
    m->resistance = 1.0;
    m->inductance = 5e-4;
    m->j_motor = 2e-5;
    m->k_shaft = 50.0;
    m->d_shaft = 0.02;
    m->t_coulomb = 5e-3;
    m->t_stiction = 8e-3;
    m->v_stribeck = 5.0;
    m->sigma0 = 2.0;
    m->sigma1 = 5e-3;
    m->sigma2 = 1e-5;
    m->theta_0 = 3.141592653589793;
    m->omega_0 = 0.0;
    m->cs_step_size = 2e-5;
    m->theta = m->theta_0;
    m->omega = m->omega_0;
    m->twist = 0.0;
    m->omega_m = 0.0;
    m->current = 0.0;
    m->z = 0.0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->mass > 0.0) || !(m->length > 0.0) || !(m->gear_ratio > 0.0) || !(m->inductance > 0.0) ||
        !(m->j_motor > 0.0) || !(m->t_coulomb > 0.0) || !(m->t_stiction >= m->t_coulomb) ||
        !(m->v_stribeck > 0.0) || !(m->resistance >= 0.0) || !(m->k_shaft >= 0.0) || !(m->d_shaft >= 0.0) ||
        !(m->sigma0 >= 0.0) || !(m->sigma1 >= 0.0) || !(m->sigma2 >= 0.0) || !(m->cs_step_size > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need mass, length, gear_ratio, inductance, j_motor, t_coulomb, v_stribeck, "
                "cs_step_size > 0, t_stiction >= t_coulomb and the rest >= 0 (got mass=%g length=%g gear_ratio=%g "
                "inductance=%g j_motor=%g t_coulomb=%g t_stiction=%g v_stribeck=%g cs_step_size=%g)",
                m->mass, m->length, m->gear_ratio, m->inductance, m->j_motor, m->t_coulomb, m->t_stiction,
                m->v_stribeck, m->cs_step_size);
        return StatusError;
    }
    m->theta = m->theta_0;
    m->omega = m->omega_0;
    m->twist = 0.0;
    m->omega_m = m->gear_ratio * m->omega_0; /* the motor turns with the pendulum, the shaft relaxed */
    m->current = 0.0;
    m->z = 0.0;
    return StatusOK;
}

/* The LuGre bristle rate z' and friction torque T_f at the motor speed v. */
static void lugre(const ModelData *m, double *dz, double *friction) {
    const double v = m->omega_m;
    const double ratio = v / m->v_stribeck;
    const double g = m->t_coulomb + (m->t_stiction - m->t_coulomb) * exp(-ratio * ratio);
    *dz = v - m->sigma0 * fabs(v) * m->z / g;
    *friction = m->sigma0 * m->z + m->sigma1 * *dz + m->sigma2 * v;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    double dz, friction;
    lugre(m, &dz, &friction);
    const double d_twist = m->omega_m / m->gear_ratio - m->omega;
    const double shaft_torque = m->k_shaft * m->twist + m->d_shaft * d_twist;
    const double inertia = m->mass * m->length * m->length;
    dx[0] = m->omega;
    dx[1] = (m->mass * GRAVITY * m->length * sin(m->theta) - m->damping * m->omega + shaft_torque) / inertia;
    dx[2] = d_twist;
    dx[3] = (m->k_motor * m->current - friction - shaft_torque / m->gear_ratio) / m->j_motor;
    dx[4] = (m->u - m->resistance * m->current - m->k_motor * m->omega_m) / m->inductance;
    dx[5] = dz;
}

static void calculate_values(ModelInstance *comp) {
    double dx[NX], dz;
    ModelData *m = M(comp);
    get_derivatives(comp, dx);
    m->der_theta = dx[0];
    m->der_omega = dx[1];
    m->der_twist = dx[2];
    m->der_omega_m = dx[3];
    m->der_current = dx[4];
    m->der_z = dx[5];
    m->cos_theta = cos(m->theta);
    m->sin_theta = sin(m->theta);
    lugre(m, &dz, &m->friction_torque);
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->theta;
    x[1] = m->omega;
    x[2] = m->twist;
    x[3] = m->omega_m;
    x[4] = m->current;
    x[5] = m->z;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->theta = x[0];
    m->omega = x[1];
    m->twist = x[2];
    m->omega_m = x[3];
    m->current = x[4];
    m->z = x[5];
}

static double cs_step_size(const ModelInstance *comp) { return comp->s.data.cs_step_size; }

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_U, u, VarInput),
    FLOAT64_VAR(VR_THETA, theta, VarReadOnly),
    FLOAT64_VAR(VR_OMEGA, omega, VarReadOnly),
    FLOAT64_VAR(VR_TWIST, twist, VarReadOnly),
    FLOAT64_VAR(VR_OMEGA_M, omega_m, VarReadOnly),
    FLOAT64_VAR(VR_CURRENT, current, VarReadOnly),
    FLOAT64_VAR(VR_Z, z, VarReadOnly),
    FLOAT64_VAR(VR_COS_THETA, cos_theta, VarReadOnly),
    FLOAT64_VAR(VR_SIN_THETA, sin_theta, VarReadOnly),
    FLOAT64_VAR(VR_FRICTION_TORQUE, friction_torque, VarReadOnly),
    FLOAT64_VAR(VR_DER_THETA, der_theta, VarReadOnly),
    FLOAT64_VAR(VR_DER_OMEGA, der_omega, VarReadOnly),
    FLOAT64_VAR(VR_DER_TWIST, der_twist, VarReadOnly),
    FLOAT64_VAR(VR_DER_OMEGA_M, der_omega_m, VarReadOnly),
    FLOAT64_VAR(VR_DER_CURRENT, der_current, VarReadOnly),
    FLOAT64_VAR(VR_DER_Z, der_z, VarReadOnly),
    FLOAT64_VAR(VR_MASS, mass, VarFixed),
    FLOAT64_VAR(VR_LENGTH, length, VarFixed),
    FLOAT64_VAR(VR_DAMPING, damping, VarFixed),
    FLOAT64_VAR(VR_GEAR_RATIO, gear_ratio, VarFixed),
    FLOAT64_VAR(VR_K_MOTOR, k_motor, VarFixed),
    FLOAT64_VAR(VR_RESISTANCE, resistance, VarFixed),
    FLOAT64_VAR(VR_INDUCTANCE, inductance, VarFixed),
    FLOAT64_VAR(VR_J_MOTOR, j_motor, VarFixed),
    FLOAT64_VAR(VR_K_SHAFT, k_shaft, VarFixed),
    FLOAT64_VAR(VR_D_SHAFT, d_shaft, VarFixed),
    FLOAT64_VAR(VR_T_COULOMB, t_coulomb, VarFixed),
    FLOAT64_VAR(VR_T_STICTION, t_stiction, VarFixed),
    FLOAT64_VAR(VR_V_STRIBECK, v_stribeck, VarFixed),
    FLOAT64_VAR(VR_SIGMA0, sigma0, VarFixed),
    FLOAT64_VAR(VR_SIGMA1, sigma1, VarFixed),
    FLOAT64_VAR(VR_SIGMA2, sigma2, VarFixed),
    FLOAT64_VAR(VR_THETA_0, theta_0, VarFixed),
    FLOAT64_VAR(VR_OMEGA_0, omega_0, VarFixed),
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
    .cs_step_size = cs_step_size,
};
