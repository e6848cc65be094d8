/*
 * model.c -- Cart-Pole (the ModelicaGym toolbox's CartPole.mo) for the
 * modelicagym FMU framework.
 *
 * Mechanics (CartPole.mo: MSL MultiBody Prismatic + Revolute + BodyCylinder + Body):
 *   cart of mass m_cart sliding along x without friction, pushed by f;
 *   at its centre a revolute joint about z holding the pole at angle theta from +x:
 *     - uniform solid cylinder, length Lc = length/2, diameter d, density rho:
 *         mass mc = rho * pi * (d/2)^2 * Lc, centre at Lc/2 along the pole,
 *         inertia about its centre (z axis) Ic = mc * (Lc^2/12 + d^2/16);
 *     - point mass m_pole at the cylinder's far end (distance Lc), with its own
 *       rotational inertia Ip = 0.001 kg m^2 (the MSL Body default);
 *   gravity g = 9.81 m/s^2 along -y.
 *
 * Lagrangian, with generalized coordinates (x, theta); a pole point at distance s
 * sits at (x + s cos theta, s sin theta):
 *   T = 1/2 Mt x_dot^2 - S sin(theta) x_dot theta_dot + 1/2 J theta_dot^2
 *   V = g S sin(theta)
 * where Mt = m_cart + mc + m_pole                     (total mass)
 *       S  = mc Lc/2 + m_pole Lc                      (first moment of the pole)
 *       J  = Ic + mc (Lc/2)^2 + Ip + m_pole Lc^2      (pole inertia about the joint)
 * Euler-Lagrange gives the mass-matrix form
 *   [ Mt            -S sin(theta) ] [ x_ddot     ]   [ f + S cos(theta) theta_dot^2 ]
 *   [ -S sin(theta)  J            ] [ theta_ddot ] = [ -g S cos(theta)              ]
 * solved by Cramer's rule; det = Mt J - S^2 sin^2(theta) >= m_cart J > 0 (by
 * Cauchy-Schwarz (mc + m_pole) J >= S^2), so any m_cart > 0 is well posed.
 */
#include <math.h>

#include "model.h"

#define GRAVITY 9.81
#define POLE_MASS_INERTIA 0.001
#define PI 3.14159265358979323846

static void set_start_values(ModelData *m) {
    m->f = 0.0;
    m->m_cart = 10.0;
    m->m_pole = 1.0;
    m->length = 2.0;
    m->diameter = 0.05;
    m->density = 900.0;
    m->theta_0 = 85.0 * PI / 180.0; /* 1.4835298641951802 */
    m->theta_dot_0 = 0.0;
    m->x_0 = 0.0;
    m->x_dot_0 = 0.0;
    m->cs_step_size = 5e-3; /* chosen by benchmarks/solver_accuracy.py: docs/cartpole-solver.md */
    m->x = m->x_0;
    m->x_dot = m->x_dot_0;
    m->theta = m->theta_0;
    m->theta_dot = m->theta_dot_0;
}

static Status initialize(ModelInstance *comp) {
    ModelData *m = M(comp);
    if (!(m->m_cart > 0.0) || !(m->m_pole >= 0.0) || !(m->length > 0.0) || !(m->diameter >= 0.0) ||
        !(m->density >= 0.0) || !(m->cs_step_size > 0.0)) {
        fmu_log(comp, StatusError, LogStatusError,
                "invalid parameters: need m_cart > 0, length > 0, cs_step_size > 0 and m_pole, "
                "diameter, density >= 0 (got m_cart=%g m_pole=%g length=%g diameter=%g density=%g "
                "cs_step_size=%g)",
                m->m_cart, m->m_pole, m->length, m->diameter, m->density, m->cs_step_size);
        return StatusError;
    }
    m->x = m->x_0;
    m->x_dot = m->x_dot_0;
    m->theta = m->theta_0;
    m->theta_dot = m->theta_dot_0;
    return StatusOK;
}

static void get_derivatives(ModelInstance *comp, double dx[]) {
    const ModelData *m = M(comp);
    const double lc = 0.5 * m->length;
    const double mc = m->density * PI * 0.25 * m->diameter * m->diameter * lc;
    const double total_mass = m->m_cart + mc + m->m_pole;
    const double s = mc * 0.5 * lc + m->m_pole * lc;
    const double j = mc * (lc * lc / 3.0 + m->diameter * m->diameter / 16.0) + POLE_MASS_INERTIA +
                     m->m_pole * lc * lc;
    const double sin_t = sin(m->theta), cos_t = cos(m->theta);
    const double a12 = -s * sin_t;
    const double b1 = m->f + s * cos_t * m->theta_dot * m->theta_dot;
    const double b2 = -GRAVITY * s * cos_t;
    const double det = total_mass * j - a12 * a12;
    dx[0] = m->x_dot;
    dx[1] = (j * b1 - a12 * b2) / det;
    dx[2] = m->theta_dot;
    dx[3] = (total_mass * b2 - a12 * b1) / det;
}

static void calculate_values(ModelInstance *comp) {
    double dx[NX];
    ModelData *m = M(comp);
    get_derivatives(comp, dx);
    m->der_x = dx[0];
    m->der_x_dot = dx[1];
    m->der_theta = dx[2];
    m->der_theta_dot = dx[3];
}

static void get_continuous_states(const ModelData *m, double x[]) {
    x[0] = m->x;
    x[1] = m->x_dot;
    x[2] = m->theta;
    x[3] = m->theta_dot;
}

static void set_continuous_states(ModelData *m, const double x[]) {
    m->x = x[0];
    m->x_dot = x[1];
    m->theta = x[2];
    m->theta_dot = x[3];
}

static double cs_step_size(const ModelInstance *comp) { return comp->s.data.cs_step_size; }

static const VariableInfo variables[] = {
    FLOAT64_VAR(VR_F, f, VarInput),
    FLOAT64_VAR(VR_X, x, VarReadOnly),
    FLOAT64_VAR(VR_X_DOT, x_dot, VarReadOnly),
    FLOAT64_VAR(VR_THETA, theta, VarReadOnly),
    FLOAT64_VAR(VR_THETA_DOT, theta_dot, VarReadOnly),
    FLOAT64_VAR(VR_DER_X, der_x, VarReadOnly),
    FLOAT64_VAR(VR_DER_X_DOT, der_x_dot, VarReadOnly),
    FLOAT64_VAR(VR_DER_THETA, der_theta, VarReadOnly),
    FLOAT64_VAR(VR_DER_THETA_DOT, der_theta_dot, VarReadOnly),
    FLOAT64_VAR(VR_M_CART, m_cart, VarFixed),
    FLOAT64_VAR(VR_M_POLE, m_pole, VarFixed),
    FLOAT64_VAR(VR_LENGTH, length, VarFixed),
    FLOAT64_VAR(VR_DIAMETER, diameter, VarFixed),
    FLOAT64_VAR(VR_DENSITY, density, VarFixed),
    FLOAT64_VAR(VR_THETA_0, theta_0, VarFixed),
    FLOAT64_VAR(VR_THETA_DOT_0, theta_dot_0, VarFixed),
    FLOAT64_VAR(VR_X_0, x_0, VarFixed),
    FLOAT64_VAR(VR_X_DOT_0, x_dot_0, VarFixed),
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
