"""The FMUEnv layer: one FMU as a Gymnasium environment.

``fmu_env`` holds `FMUEnv` and its step contract; ``config`` the few lines of config that make one
(`FMUEnvConfig`) and ``config_checks`` their checks; ``spaces`` the spaces derived from model
variables and the observation; ``native_step`` the env's bridge to our C step (one call a step);
``saved_state`` an env's state as a value (`EnvState`) and start states drawn from a list (`StartStates`);
``tracking`` a tracking task's setpoints and observation entries (`uniform` draws, a `Schedule`).
"""

from modelicagym.env.config import FMUEnvConfig
from modelicagym.env.fmu_env import FMUEnv
from modelicagym.env.saved_state import EnvState, StartStates
from modelicagym.env.tracking import Schedule, uniform

__all__ = ["EnvState", "FMUEnv", "FMUEnvConfig", "Schedule", "StartStates", "uniform"]
