"""The root of every error modelicagym raises, and the families below it.

Every exception the package raises is a :class:`ModelicaGymError` *and* the built-in type a caller
would catch without knowing modelicagym: a config mistake is a ``ValueError`` (a ``TypeError``
when the type is wrong), a missing file a ``FileNotFoundError``, a failed build a
``RuntimeError``. So ``except ModelicaGymError`` catches everything of ours, and existing
``except ValueError`` code keeps working.

::

    ModelicaGymError
    ├── ConfigError (ValueError)            a config value is wrong: key, range, choice
    │   └── ConfigTypeError (TypeError)     ... of the wrong type
    ├── ArgumentError (ValueError)          an argument of a call is wrong (shape, count, value)
    │   ├── ArgumentTypeError (TypeError)   ... of the wrong type
    │   └── ActionError                     an action outside the action space
    │       └── ActionTypeError (TypeError) a scalar where a batch of actions belongs
    ├── NotFoundError (FileNotFoundError)   a file or results directory that does not exist
    ├── DataError (ValueError)              a file whose content cannot be used
    ├── CacheError (OSError)                a damaged cache entry that cannot be made again
    ├── DiskFullError (OSError)             a file could not be written: its file system is full
    ├── BuildError (RuntimeError)           C sources could not be compiled
    │   └── NativeBuildError                our native library (modelicagym.native)
    ├── ExtraNotInstalledError (ImportError) a feature's optional extra is missing (e.g. `plots`)
    ├── LoopDivergedError (ArithmeticError) a system's loop read from the previous step grew without bound
    ├── FMUError                            the FMI runtime: modelicagym.fmu.errors
    │   (FMUNotFoundError, InvalidFMUError, VariableError, FMUCallError, FMUBuildError, LoadTrialError, ...)
    ├── PoolError (RuntimeError)            the pool: modelicagym.vector.errors
    │   (EnvError, WorkerDiedError, WorkerTimeoutError, ...; misuse errors are also
    │   Gymnasium's AlreadyPendingCallError, NoAsyncCallError, ClosedEnvironmentError)
    └── ClusterError (RuntimeError)         Ray: modelicagym.distributed.errors
        (RayNotInstalledError (ImportError), ActorDiedError, SweepGroupError)

The command line prints any of them as one line and exits with status 1 (``--debug`` shows the
traceback).
"""

from __future__ import annotations

__all__ = [
    "ActionError",
    "ActionTypeError",
    "ArgumentError",
    "ArgumentTypeError",
    "BuildError",
    "CacheError",
    "ClusterError",
    "ConfigError",
    "ConfigTypeError",
    "DataError",
    "DiskFullError",
    "ExtraNotInstalledError",
    "LoopDivergedError",
    "ModelicaGymError",
    "NativeBuildError",
    "NotFoundError",
]


class ModelicaGymError(Exception):
    """Root of every error modelicagym raises."""


class ConfigError(ModelicaGymError, ValueError):
    """A config value is wrong (an unknown key, a value out of range, an unknown choice)."""


class ConfigTypeError(ConfigError, TypeError):
    """A config value has the wrong type."""


class ArgumentError(ModelicaGymError, ValueError):
    """An argument of a call is wrong (its shape, its count, its value)."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of a call has the wrong type."""


class ActionError(ArgumentError):
    """An action is outside the env's action space (wrong shape, out of range, NaN)."""


class ActionTypeError(ActionError, TypeError):
    """Not a batch of actions at all (a scalar for a vector env), as Gymnasium's vector envs say."""


class NotFoundError(ModelicaGymError, FileNotFoundError):
    """A file or directory that was asked for does not exist."""


class DataError(ModelicaGymError, ValueError):
    """A file exists but its content cannot be used (incomplete results, a malformed table)."""


class CacheError(ModelicaGymError, OSError):
    """A cache entry is damaged and cannot be rebuilt or extracted again (a read-only cache)."""


class DiskFullError(ModelicaGymError, OSError):
    """A file could not be written because its file system is full (or the quota is used up).

    Made by `modelicagym.disk.disk_full`: ``errno`` is the original's (ENOSPC or EDQUOT),
    ``filename`` the file that was being written, and the message one line that names it and
    says what to do.
    """

    def __str__(self) -> str:
        return self.strerror or super().__str__()


class BuildError(ModelicaGymError, RuntimeError):
    """C sources could not be compiled (no compiler or CMake, or a compiler error)."""


class NativeBuildError(BuildError):
    """Our native library (``modelicagym/native/csrc``) could not be compiled."""


class ExtraNotInstalledError(ModelicaGymError, ImportError):
    """A feature needs an optional extra that is not installed; the message names the feature and
    the ``pip install 'modelicagym[<extra>]'`` that installs it."""


class LoopDivergedError(ModelicaGymError, ArithmeticError):
    """A loop of a system (connections of direct feedthrough, run with a one-step delay) grew without
    bound: a value it carries from the previous communication step is not finite or beyond
    ``modelicagym.system.loops.LOOP_BOUND``. The message names the loop, the connection and the time,
    and what to change (the loop's gain, the time step, where it is broken, the master)."""


class ClusterError(ModelicaGymError, RuntimeError):
    """Running on a Ray cluster failed: Ray missing, an actor or a task lost with its node."""
