"""Reference solution of the cart-pole physics, independent of the C model.

The C model uses a hand-simplified closed form. Here the equations of motion are assembled
the generic way, body by body: for generalized coordinates q = (x, theta), each rigid body i
(cart, pole cylinder, end mass) with mass m_i, rotational inertia I_i about its centre of
mass and centre-of-mass Jacobian J_i(q) contributes

    M(q)    += m_i J_i^T J_i + I_i w^T w           (w = d(angle)/dq)
    h(q, v) += m_i J_i^T (dJ_i/dt v)               (velocity-product terms)
    Q(q)    += J_i^T (0, -m_i g)                   (gravity)

and M(q) q_ddot = Q + (f, 0) - h is solved with numpy. Integration: scipy DOP853 with
rtol = atol = 1e-12, restarted at every control interval (force held constant).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.integrate import solve_ivp

GRAVITY = 9.81
END_MASS_INERTIA = 0.001  # MSL Body default I_33


@dataclass(frozen=True)
class CartPoleParameters:
    m_cart: float = 10.0
    m_pole: float = 1.0
    length: float = 2.0
    diameter: float = 0.05
    density: float = 900.0


@dataclass(frozen=True)
class _Body:
    mass: float
    inertia: float   # about its own centre of mass, around z
    distance: float  # of its centre of mass from the hinge, along the pole (0 for the cart)
    on_pole: bool    # rotates with theta


def _bodies(p: CartPoleParameters) -> list[_Body]:
    cylinder_length = p.length / 2
    radius = p.diameter / 2
    cylinder_mass = p.density * math.pi * radius**2 * cylinder_length
    cylinder_inertia = cylinder_mass * (3 * radius**2 + cylinder_length**2) / 12
    return [
        _Body(p.m_cart, 0.0, 0.0, on_pole=False),
        _Body(cylinder_mass, cylinder_inertia, cylinder_length / 2, on_pole=True),
        _Body(p.m_pole, END_MASS_INERTIA, cylinder_length, on_pole=True),
    ]


def accelerations(state: np.ndarray, force: float, p: CartPoleParameters) -> np.ndarray:
    """(x_ddot, theta_ddot) for state (x, x_dot, theta, theta_dot) under a horizontal force."""
    theta, theta_dot = state[2], state[3]
    mass_matrix = np.zeros((2, 2))
    rhs = np.array([force, 0.0])
    for body in _bodies(p):
        if body.on_pole:
            c = body.distance
            jac = np.array([[1.0, -c * math.sin(theta)], [0.0, c * math.cos(theta)]])
            jac_dot_v = np.array([-c * math.cos(theta), -c * math.sin(theta)]) * theta_dot**2
            w = np.array([0.0, 1.0])
        else:
            jac = np.array([[1.0, 0.0], [0.0, 0.0]])
            jac_dot_v = np.zeros(2)
            w = np.zeros(2)
        mass_matrix += body.mass * jac.T @ jac + body.inertia * np.outer(w, w)
        rhs += jac.T @ np.array([0.0, -body.mass * GRAVITY]) - body.mass * jac.T @ jac_dot_v
    return np.linalg.solve(mass_matrix, rhs)


def simulate(forces: Sequence[float], dt: float, initial_state: Sequence[float],
             p: CartPoleParameters = CartPoleParameters()) -> np.ndarray:
    """States at t = 0, dt, ..., len(forces) * dt with force k held on [k dt, (k+1) dt)."""
    states = [np.asarray(initial_state, dtype=float)]
    for k, force in enumerate(forces):
        def rhs(_t: float, y: np.ndarray, force: float = force) -> np.ndarray:
            acc = accelerations(y, force, p)
            return np.array([y[1], acc[0], y[3], acc[1]])

        sol = solve_ivp(rhs, (k * dt, (k + 1) * dt), states[-1], method="DOP853",
                        rtol=1e-12, atol=1e-12)
        if not sol.success:
            raise RuntimeError(sol.message)
        states.append(sol.y[:, -1])
    return np.array(states)
