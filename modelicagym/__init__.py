"""modelicagym: Modelica models exported as FMUs, as Gymnasium environments, stepped in parallel.

``FMUEnv`` wraps any FMU from a few lines of config; ``make("cartpole")`` and
``make_vec("cartpole", n=8)`` are the front doors; ``modelicagym.vector`` holds the
multi-process pool and ``modelicagym.fmu`` the FMI runtime underneath.
"""

from modelicagym.config import FMUEnvConfig
from modelicagym.env import FMUEnv
from modelicagym.registry import make, make_vec, register_environments

register_environments()

__version__ = "0.1.0"
__all__ = ["FMUEnv", "FMUEnvConfig", "make", "make_vec", "register_environments"]
