"""The Cart-Pole model (the ModelicaGym toolbox's ``CartPole.mo``) as a source FMU.

``cartpole_fmu(2)`` / ``cartpole_fmu(3)`` return the path of the built FMU (FMI 2.0 / 3.0,
co-simulation and model exchange in one binary), ``cartpole_fmu(1, "cs")`` /
``cartpole_fmu(1, "me")`` the FMI 1.0 one (which is either), building it on first use and caching
it (see :mod:`modelicagym.fmu.build`). The variable names below are those of every model
description; the value references are identical in all of them.
"""

from __future__ import annotations

from pathlib import Path

from modelicagym.fmu.build import build_source_fmu

__all__ = [
    "DEFAULT_PARAMETERS",
    "INPUT",
    "MODEL_DIR",
    "OUTPUTS",
    "PARAMETERS",
    "VALUE_REFERENCES",
    "cartpole_fmu",
]

MODEL_DIR = Path(__file__).resolve().parent

#: The single input: force on the cart [N].
INPUT = "f"
#: Outputs (= continuous states), in observation order.
OUTPUTS = ("x", "x_dot", "theta", "theta_dot")
#: Fixed parameters (set before initialization) and the tunable co-simulation step.
PARAMETERS = ("m_cart", "m_pole", "length", "diameter", "density",
              "theta_0", "theta_dot_0", "x_0", "x_dot_0", "cs_step_size")
#: Start values of the parameters, as in the model descriptions.
DEFAULT_PARAMETERS = {
    "m_cart": 10.0, "m_pole": 1.0, "length": 2.0, "diameter": 0.05, "density": 900.0,
    "theta_0": 1.4835298641951802, "theta_dot_0": 0.0, "x_0": 0.0, "x_dot_0": 0.0,
    "cs_step_size": 5e-3,
}
#: Value references (config.h); in FMI 3.0 value reference 0 is ``time``.
VALUE_REFERENCES = {
    "f": 1, "x": 2, "x_dot": 3, "theta": 4, "theta_dot": 5,
    "der(x)": 6, "der(x_dot)": 7, "der(theta)": 8, "der(theta_dot)": 9,
    "m_cart": 10, "m_pole": 11, "length": 12, "diameter": 13, "density": 14,
    "theta_0": 15, "theta_dot_0": 16, "x_0": 17, "x_dot_0": 18, "cs_step_size": 19,
}


def cartpole_fmu(fmi_version: int = 2, mode: str | None = None) -> Path:
    """Path of the Cart-Pole ``.fmu`` for FMI ``fmi_version`` (1, 2 or 3), built on first use.

    ``mode`` (``"cs"``, the default, or ``"me"``) matters for FMI 1.0 only, whose FMUs are either
    co-simulation or model exchange.
    """
    return build_source_fmu(MODEL_DIR, fmi_version, mode)
