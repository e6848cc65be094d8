"""What the parent and a worker say to each other.

The hot path needs no messages: the parent writes a :class:`Command` code into the worker's slot of
the shared ``command`` array and posts the worker's ``go`` signal; the worker answers by writing its
results into shared memory, setting its ``reply`` slot and posting ``done``. Only when the reply slot
says so does a pickled reply follow on the pipe (non-empty infos, an error, results of ``call``).
Rare commands (reset with seeds or options, call, set_attr, close) travel as a pickled
:class:`Message` on the pipe, announced by the ``MESSAGE`` command code. So do the actions and
observations of a space with no shared-memory layout (a custom ``Space``): each step is then a
``STEP`` message with the actions, answered by an ``OBSERVATIONS`` message.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any, NamedTuple

from gymnasium import Space
from gymnasium.envs.registration import EnvSpec
from gymnasium.vector import AutoresetMode

#: How often (seconds) a blocked party wakes up to check that the other side is still alive.
LIVENESS_INTERVAL = 0.05


class Command:
    """Command codes written into the shared ``command`` slot of a worker.

    Plain ints, not an ``IntEnum``: comparing a numpy scalar with an ``IntEnum`` member costs
    about 8 µs, more than a whole step round trip.
    """

    STEP = 1
    #: reset the envs selected by the shared reset mask with ``seed=None, options=None``
    RESET = 2
    #: as RESET, but with ``options={}`` (what a ``reset_mask``-only call leaves for the envs)
    RESET_EMPTY_OPTIONS = 3
    #: a :class:`Message` is waiting on the pipe
    MESSAGE = 4


class Reply:
    """Values of the shared ``reply`` slot, set by the worker before it posts ``done`` (plain ints)."""

    NONE = 0
    #: a pickled :class:`Message` follows on the pipe
    MESSAGE = 1


class Kind(str, enum.Enum):
    """What a :class:`Message` is; its ``data`` is given for each kind."""

    # parent -> worker
    #: ``(seeds of the worker's envs, options)``; ``options["options_per_env"]``, if any, holds
    #: only the worker's envs' entries
    RESET = "reset"
    #: ``(name, args, kwargs)``
    CALL = "call"
    #: ``(name, values of the worker's envs)``
    SET_ATTR = "set_attr"
    #: ``(name, per env of the worker its arguments or None)``: call each env's method with its own
    #: arguments (``None``: that env is not called)
    CALL_EACH = "call_each"
    #: actions of the worker's envs, when the action space has no shared-memory layout: step
    STEP = "step"
    #: no data: close the envs and exit
    CLOSE = "close"
    #: ``(BufferSpec, needs_reset, seconds to poll for a command)``, followed on the pipe by the
    #: memory's file descriptor
    BUFFERS = "buffers"
    # worker -> parent
    #: :class:`EnvDescription`: the envs are created
    READY = "ready"
    #: no data: the shared memory is mapped
    OK = "ok"
    #: list of ``(env_index, info)`` for the non-empty infos of a step or reset
    INFOS = "infos"
    #: ``(first env index, observations, infos)`` of a step or reset, when the observation space
    #: has no shared-memory layout (``infos`` as for ``INFOS``)
    OBSERVATIONS = "observations"
    #: list of results of ``call``, one per env
    RESULTS = "results"
    #: :class:`~modelicagym.vector.errors.RemoteError`: an env (or the worker) failed; the pool
    #: cannot trust the worker's envs any more
    ERROR = "error"
    #: :class:`~modelicagym.vector.errors.RemoteError` of ``call``/``set_attr``: the env is still usable
    CALL_ERROR = "call_error"


@dataclass(frozen=True)
class Message:
    """A pickled message on a worker's pipe: its :class:`Kind` and the payload that kind carries."""

    kind: Kind
    data: Any = None


class StepPath(NamedTuple):
    """How a slice of envs steps: ``path`` is ``"native"`` or ``"python"``, ``reason`` says why."""

    path: str
    reason: str


@dataclass(frozen=True)
class EnvDescription:
    """What a worker reports about its envs once it has created them."""

    observation_space: Space
    action_space: Space
    metadata: dict[str, Any]
    render_mode: str | None
    spec: EnvSpec | None
    step_path: StepPath
    #: the observation space of every env of the slice (they may differ in ``observation_mode="different"``)
    observation_spaces: tuple[Space, ...] = ()
    #: every env of the slice says it is safe in the calling process (`env_contract.safe_in_caller`)
    safe_in_caller: bool = False
    #: why the envs cannot move between processes at an episode boundary, ``None`` if they can
    #: (`modelicagym.vector.slice.env_slice.movable_reason`)
    movable_reason: str | None = "not described"
    #: every env of the slice clips an action outside its Box's bounds (``action_out_of_bounds="clip"``):
    #: the parent clips the batch instead of refusing it
    clips_actions: bool = False


@dataclass(frozen=True)
class WorkerConfig:
    """Settings of a worker that do not change over the pool's life."""

    autoreset_mode: AutoresetMode
    #: seconds a waiting party spins before it blocks
    spin_time: float
    #: the signals live in shared memory (:class:`~modelicagym.vector.wire.sync.FutexSignal`), else
    #: they are semaphores handed to the worker process when it starts
    shared_signals: bool = False
    #: the pool's limits, named in timeout messages (seconds; ``None``: none)
    step_timeout: float | None = None
    startup_timeout: float | None = None
    #: ``"same"`` or ``"different"`` (`modelicagym.vector.checks`)
    observation_mode: str = "same"
    #: the pool's envs, created at once by its parties: each may take its part of the memory
    #: the machine has available (`modelicagym.vector.slice.creation`); 0: unchecked
    num_envs: int = 0
    #: the usable cores the pool plans for (`modelicagym.cores.usable_cores`)
    cores: int = 1
    #: the CPUs the pool's stepping processes keep to (``None``: this process's affinity mask)
    cpus: tuple[int, ...] | None = None


#: what a worker is doing before it serves commands (named in messages; ``startup_timeout`` applies)
CREATION, START_UP = "creation", "start-up"
STARTUP_STAGES = (CREATION, START_UP)


def same_step_info(final_observation: Any, final_info: dict[str, Any], reset_info: dict[str, Any]) -> dict[str, Any]:
    """The info an env reports for a ``SAME_STEP`` step that ended its episode and reset it: the
    ended step's observation and info as ``final_obs`` / ``final_info``, beside the reset's own
    info (`modelicagym.vector.slice.autoreset`; the parent builds it for envs the native step reset)."""
    return {"final_obs": final_observation, "final_info": final_info, **reset_info}
