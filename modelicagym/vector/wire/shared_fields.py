"""The pool's shared memory, declared once: each field's name, dtype, shape and the C field it fills.

`SharedBuffers` (`modelicagym.vector.wire.buffers`) allocates one array per entry of `SHARED_FIELDS`,
in this order, as its attribute of the same name; `NativeBatch` (`modelicagym.vector.slice.native_slice`)
fills each ``mg_batch`` field (``native/csrc/slice.h``) named in ``c_fields`` from that array,
and checks when it is built that every field of ``mg_batch`` is filled exactly once: from a field
here, or from the slice itself (``native_slice.SLICE_FIELDS``). A field added to the C struct and
forgotten here is a `NativeABIError` naming it, not C reading a null pointer.

Shared wire: both sides (the calling process and the workers) lay out the memory from this table.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from enum import Enum

import numpy as np

from modelicagym.native.abi import MgBarrier

__all__ = ["CACHE_LINE", "SHARED_FIELDS", "Rows", "SharedField", "Values"]

#: bytes of a cache line: every field starts on one of its own
CACHE_LINE = 64


class Rows(Enum):
    """What a field's first axis counts, and so which row a slice's ``mg_batch`` points at."""

    #: one row per env of the pool; a slice's C field points at the row of its first env
    ENV = "env"
    #: one row per slot (a worker, or the calling process's slice); a slice's C field points at its slot's row
    SLOT = "slot"
    #: one row for the whole pool
    ONE = "one"

    def count(self, num_envs: int, num_slots: int) -> int:
        """How many rows a pool of ``num_envs`` envs in ``num_slots`` slots has."""
        return {Rows.ENV: num_envs, Rows.SLOT: num_slots, Rows.ONE: 1}[self]

    def row(self, first_env: int, slot: int) -> int:
        """The row a slice (its first env, its slot) points its C field at."""
        return {Rows.ENV: first_env, Rows.SLOT: slot, Rows.ONE: 0}[self]


class Values(Enum):
    """A field that holds values of a space (any layout Gymnasium's shared-memory helpers know)."""

    OBSERVATION = "observation"
    ACTION = "action"


@dataclass(frozen=True)
class SharedField:
    """One field of the pool's shared memory.

    Attributes:
        name: its attribute of `SharedBuffers`.
        rows: what its first axis counts.
        dtype: its numpy dtype, or the space whose values it holds (a batch, not an array).
        width: its shape after the first axis.
        c_fields: the ``mg_batch`` fields filled from it (none: C never sees it through a slice).
        doc: what it holds, who writes it.
    """

    name: str
    rows: Rows
    dtype: type | Values
    width: tuple[int, ...] = ()
    c_fields: tuple[str, ...] = ()
    doc: str = ""

    def shape(self, num_envs: int, num_slots: int) -> tuple[int, ...]:
        """The array's shape in a pool of ``num_envs`` envs in ``num_slots`` slots."""
        return (self.rows.count(num_envs, num_slots), *self.width)


#: every field of the pool's shared memory, in layout order
SHARED_FIELDS: tuple[SharedField, ...] = (
    SharedField("observations", Rows.ENV, Values.OBSERVATION, (),
                ("observations", "obs_stride", "obs_parts", "n_obs_parts"),
                "each env's observation, written by the process that steps it"),
    SharedField("final_observations", Rows.ENV, Values.OBSERVATION, (), ("final_obs",),
                "SAME_STEP: the last observation of an env the native step reset, where final_ready marks it"),
    SharedField("final_ready", Rows.ENV, np.uint8, (), ("final_ready",),
                "SAME_STEP: 1 where the native step reset the env and its final_obs row says it all"),
    SharedField("actions", Rows.ENV, Values.ACTION, (),
                ("actions", "action_stride", "action_parts", "n_action_parts", "scratch"),
                "each env's action, written by the calling process (a float Box as float64)"),
    SharedField("action_dtype", Rows.ONE, np.uint8, (), (),
                "the dtype (its char) of the batch of actions last given, in which each env gets its "
                "action back as SyncVectorEnv hands it; 0: as stored"),
    SharedField("rewards", Rows.ENV, np.float64, (), ("rewards",)),
    SharedField("terminations", Rows.ENV, np.bool_, (), ("terminations",)),
    SharedField("truncations", Rows.ENV, np.bool_, (), ("truncations",)),
    SharedField("reset_mask", Rows.ENV, np.bool_, (), (), "which envs a RESET resets"),
    SharedField("step_mask", Rows.ENV, np.uint8, (), ("active",),
                "which envs a STEP steps (all, except for a partial batch)"),
    SharedField("in_caller", Rows.ENV, np.uint8, (), ("in_caller",),
                "1 where the calling process steps the env, 0 where its worker does (the placement)"),
    SharedField("needs_reset", Rows.ENV, np.uint8, (), ("needs_reset",),
                "written only by the process that steps the env: RESET_THEN_REPORT (it ended; its next "
                "step is its reset) or RESET_THEN_STEP (it moved at an episode boundary)"),
    SharedField("command", Rows.SLOT, np.int32, (), (), "each slot's command"),
    SharedField("reply", Rows.SLOT, np.int32, (), (), "each slot's reply"),
    SharedField("current_env", Rows.SLOT, np.int64, (), ("current_env",),
                "the env each slot is running, to name it if its process dies"),
    SharedField("timing", Rows.SLOT, np.int64, (2,), ("timing",),
                "each slot's env time and FMU time of the last step, in nanoseconds"),
    SharedField("timing_enabled", Rows.ONE, np.bool_, (), ("timing_enabled",)),
    SharedField("go_spin_ns", Rows.ONE, np.int64, (), (),
                "how long a worker waiting for its next command polls before it sleeps, in nanoseconds: "
                "written by the calling process when the workers that step change "
                "(`Dispatcher.stepping_changed`, `dispatch.go_poll_time`), read at every such wait"),
    SharedField("signals", Rows.SLOT, np.uint32, (2, CACHE_LINE // 4), (),
                "each slot's go and done signals (native/csrc/signal.h), a cache line each"),
    SharedField("barrier", Rows.ONE, np.uint8, (ctypes.sizeof(MgBarrier),), (),
                "the step's barrier (native/csrc/slice.h mg_barrier): the bell every worker's go sleeps on, "
                "the count of the step's workers yet to answer, and the signal the last one posts"),
)
