"""The FMUEnv layer: one FMU as a Gymnasium environment.

``fmu_env`` holds `FMUEnv` and its step contract; ``config`` the few lines of config that make one
(`FMUEnvConfig`) and ``config_checks`` their checks; ``spaces`` the spaces derived from model
variables and the observation; ``native_step`` the env's bridge to our C step (one call a step).
"""

from modelicagym.env.config import FMUEnvConfig
from modelicagym.env.fmu_env import FMUEnv

__all__ = ["FMUEnv", "FMUEnvConfig"]
