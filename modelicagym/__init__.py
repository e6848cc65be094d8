"""modelicagym: Modelica models exported as FMUs, as Gymnasium environments, stepped in parallel.

``FMUEnv`` wraps any FMU from a few lines of config; ``make("cartpole")`` and
``make_vec("cartpole", n=8)`` are the front doors; ``modelicagym.vector`` holds the
multi-process pool and ``modelicagym.fmu`` the FMI runtime underneath. Every error raised is a
``ModelicaGymError`` (its families are in ``modelicagym.errors``).
"""

from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING

from modelicagym import errors
from modelicagym.env.config import FMUEnvConfig
from modelicagym.env.fmu_env import FMUEnv
from modelicagym.errors import ModelicaGymError
from modelicagym.registry import make, make_vec, register_environments

if TYPE_CHECKING:  # imported when first used (`__getattr__`): numpy's CSV and plotting stay out of `import modelicagym`
    from modelicagym.simulation import simulate

register_environments()

try:
    #: the installed distribution's version; pyproject.toml's ``version`` is its one source
    __version__ = version("modelicagym")
except PackageNotFoundError:  # imported from a source tree that was never installed
    __version__ = "0+unknown"
__all__ = ["FMUEnv", "FMUEnvConfig", "ModelicaGymError", "errors", "make", "make_vec", "register_environments",
           "simulate"]


def __getattr__(name: str) -> object:
    """``simulate`` (`modelicagym.simulation.simulate`), imported when first used."""
    if name == "simulate":
        from modelicagym.simulation import simulate

        return simulate
    raise AttributeError(f"module 'modelicagym' has no attribute {name!r}")
