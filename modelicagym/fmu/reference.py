"""The first steps of a fresh instance: what every reset rung must reproduce before it serves.

A reset rung (docs/design.md, "Resets: the ladder") can be wrong in ways the initial outputs do
not show: a snapshot or an ``fmiReset`` that misses a solver's memory, a discrete state or a
counter changes the steps after it, not the outputs at time zero. So the first episode of a fresh
instance is recorded, step by step: the dt, the input values written and the outputs read
(bytes, so the comparison is bit for bit). Both step paths append to the same `MgRecorder`: the
Python path with :meth:`Reference.record`, the native one in ``csrc/step.c``. At its first use a
rung replays the recorded inputs and must give the recorded outputs (`FMUInstance`).

`STEPS` steps are recorded. An episode that ends sooner is continued, invisibly, at the next reset
(before that reset): the same instance steps on from where the episode ended, its inputs held at
their last values, until the reference has `STEPS` steps or the model ends or fails; the reset
rung then restores the start anyway. An episode of no step at all (a checker's resets) does not
make the reference: the next episode is fresh again (re-instantiated) and recorded in its turn, up
to `WAIT` times, because the user's inputs stir more of an FMU than its start values would.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from modelicagym.fmu.buffers import ValueBuffer
from modelicagym.native.abi import MgRecorder

__all__ = ["STEPS", "WAIT", "Reference"]

#: steps of a fresh episode a rung must reproduce at its first use
STEPS = 16
#: episodes of no step that may give way to a fresh one before the reference holds the start values
WAIT = 16


class Reference:
    """The first `STEPS` steps of a fresh episode with ``values`` applied (``key``: their frozen form).

    ``initial`` is the outputs right after initialization (bytes). Attach ``recorder`` to the
    instance's clock while the episode runs; ``count`` steps are recorded so far.
    """

    def __init__(self, values: dict[str, Any], key: tuple, inputs: ValueBuffer, outputs: ValueBuffer) -> None:
        self.values = values
        self.key = key
        self.initial = outputs.snapshot()
        input_bytes, output_bytes = len(inputs.snapshot()), len(self.initial)
        self.dts = np.zeros(STEPS, dtype=np.float64)
        self.inputs = np.zeros((STEPS, input_bytes), dtype=np.uint8)
        self.outputs = np.zeros((STEPS, output_bytes), dtype=np.uint8)
        self.recorder = recorder = MgRecorder()
        recorder.dts, recorder.inputs, recorder.outputs = (a.ctypes.data for a in (self.dts, self.inputs, self.outputs))
        recorder.input_bytes, recorder.output_bytes = input_bytes, output_bytes
        recorder.capacity = STEPS
        self.pointer = ctypes.pointer(recorder)

    @property
    def count(self) -> int:
        """Steps recorded so far."""
        return self.recorder.count

    @property
    def complete(self) -> bool:
        """Whether no more steps are to be recorded (`STEPS` of them, or `stop` was called)."""
        return self.recorder.count >= self.recorder.capacity

    def stop(self) -> None:
        """Record no more: what comes next (values set between steps) could not be replayed."""
        self.recorder.capacity = self.recorder.count

    def record(self, dt: float, inputs: ValueBuffer, outputs: ValueBuffer) -> None:
        """Append a step the Python path took (``csrc/step.c`` appends the native path's)."""
        recorder = self.recorder
        k = recorder.count
        if k < recorder.capacity:
            self.dts[k] = dt
            self.inputs[k] = np.frombuffer(inputs.snapshot(), dtype=np.uint8)
            self.outputs[k] = np.frombuffer(outputs.snapshot(), dtype=np.uint8)
            recorder.count = k + 1

    def step_inputs(self, k: int) -> bytes:
        """The input values step ``k`` wrote."""
        return self.inputs[k].tobytes()

    def equal_at(self, k: int, outputs: ValueBuffer) -> bool:
        """Whether ``outputs`` equal step ``k``'s bit for bit."""
        return outputs.snapshot() == self.outputs[k].tobytes()


def describe(outputs: ValueBuffer) -> str:
    """The values of ``outputs``, for a message."""
    return ", ".join(f"{name}={view.tolist()}" for name, view in outputs.views.items())
