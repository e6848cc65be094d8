"""The motor-driven pendulum (``Pendulum.mo``) as a source FMU: a control task whose simulation
costs something.

A pendulum swung by a geared DC motor through a compliant shaft, with LuGre friction in the motor
bearing (the equations are in ``model.c``). The motor's electrical time constant and the friction's
bristle dynamics are fast next to a 50 ms control step, so the co-simulation solver takes 2,500 RK4
substeps per step at its default ``cs_step_size`` of 2e-5 s: ~0.4 ms of FMU work per step on one
core, where the cart-pole takes ~1 us. ``pendulum_fmu(2)`` / ``pendulum_fmu(3)`` return the built
FMU (co-simulation and model exchange in one binary), building it on first use and caching it
(see :mod:`modelicagym.fmu.build`).

Why 2e-5 s: the bristle dynamics stiffen with the motor speed. Against a reference at 2e-6 s,
an episode of pumping (motor up to 175 rad/s) stays within 1e-7 rad at steps up to 5e-5 s and
diverges at 6e-5 s; a pendulum spun over the top (206 rad/s) diverges at 5e-5 s. 2e-5 s keeps a
2.5x margin at the top speed the motor reaches.
"""

from __future__ import annotations

from pathlib import Path

from modelicagym.fmu.build import build_source_fmu

__all__ = ["DEFAULT_PARAMETERS", "INPUT", "MODEL_DIR", "OUTPUTS", "PARAMETERS", "pendulum_fmu"]

MODEL_DIR = Path(__file__).resolve().parent

#: The single input: the motor's armature voltage [V].
INPUT = "u"
#: The continuous states (outputs too); ``cos_theta`` and ``sin_theta`` are outputs as well.
OUTPUTS = ("theta", "omega", "twist", "omega_m", "current", "z")
#: Start values of the parameters, as in the model descriptions (SI units; angles in rad).
DEFAULT_PARAMETERS = {
    "mass": 1.0, "length": 0.5, "damping": 0.01, "gear_ratio": 15.0, "k_motor": 0.03,
    "resistance": 1.0, "inductance": 5e-4, "j_motor": 2e-5, "k_shaft": 50.0, "d_shaft": 0.02,
    "t_coulomb": 5e-3, "t_stiction": 8e-3, "v_stribeck": 5.0, "sigma0": 2.0, "sigma1": 5e-3,
    "sigma2": 1e-5, "theta_0": 3.141592653589793, "omega_0": 0.0, "cs_step_size": 2e-5,
}
#: The parameters, in value-reference order.
PARAMETERS = tuple(DEFAULT_PARAMETERS)


def pendulum_fmu(fmi_version: int = 2) -> Path:
    """Path of the pendulum ``.fmu`` for FMI ``fmi_version`` (2 or 3), built on first use."""
    return build_source_fmu(MODEL_DIR, fmi_version)
