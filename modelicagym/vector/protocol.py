"""What the parent and a worker say to each other.

The hot path needs no messages: the parent writes a command code into the worker's slot of the
shared ``command`` array and posts the worker's ``go`` signal; the worker answers by writing its
results into shared memory, setting its ``reply`` slot and posting ``done``. Only when the reply slot
says so does a pickled reply follow on the pipe (non-empty infos, an error, results of ``call``).
Rare commands (reset with seeds or options, call, set_attr, close) travel as a pickled
:class:`Message` on the pipe, announced by the ``MESSAGE`` command code.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

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


@dataclass(frozen=True)
class Message:
    """A pickled message on a worker's pipe; ``kind`` names it, ``data`` is its payload.

    Parent to worker: ``reset`` (seeds for the worker's envs, options), ``call`` (name, args,
    kwargs), ``set_attr`` (name, values for the worker's envs), ``close``, ``buffers``
    (:class:`~modelicagym.vector.buffers.BufferSpec`, followed by the memory's file descriptor).
    Worker to parent: ``ready`` (:class:`EnvDescription`), ``infos`` (list of ``(env_index, info)``),
    ``results`` (list, one per env), ``error`` (:class:`~modelicagym.vector.errors.RemoteError`),
    ``call_error`` (same, but the env is still usable), ``ok``.
    """

    kind: str
    data: Any = None


@dataclass(frozen=True)
class EnvDescription:
    """What a worker reports about its envs once it has created them."""

    observation_space: Space
    action_space: Space
    metadata: dict[str, Any]
    render_mode: str | None
    spec: EnvSpec | None


@dataclass(frozen=True)
class WorkerConfig:
    """Settings of a worker that do not change over the pool's life."""

    autoreset_mode: AutoresetMode
    #: seconds a waiting party spins (yielding the CPU) before it blocks
    spin_time: float
