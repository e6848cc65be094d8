"""The pool's autoreset, written once in Python: what one env's part of a vector step is in each
of Gymnasium's autoreset modes.

- ``NEXT_STEP``: an env whose step ended (terminated or truncated) is marked; its next step is its
  reset, reported as ``(observation, 0.0, False, False, reset info)`` and its action ignored.
- ``SAME_STEP``: an env whose step ended is reset at once; the step reports the reset observation,
  and the ended step's observation and info as ``final_obs`` / ``final_info``
  (`modelicagym.vector.wire.protocol.same_step_info`).
- ``DISABLED``: nothing; the user resets ended envs.

Besides the modes, an env that moved to this process at an episode boundary (``RESET_THEN_STEP``,
`modelicagym.vector.layout.placement`) is reset silently before its step.

**Its C twin** is ``step_batch`` in ``modelicagym/native/csrc/slice.c`` (and ``end_steps`` in
``csrc/endings.c`` for a slice whose steps end in Python): the native path runs the same rules
without Python, and leaves to `Autoreset` what it cannot do (a reset only Python can do,
``Flags.PYTHON_RESET``). A change here is a change there; the test
``tests/vector/test_autoreset_twins.py`` steps the same envs both ways in every mode and asserts
identical results.

Runs wherever a slice is stepped (a worker, or the calling process for its own slice).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

from modelicagym.native.abi import NO_RESET, RESET_THEN_STEP
from modelicagym.vector.env_contract import PoolEnv, StepResult
from modelicagym.vector.wire.protocol import same_step_info

__all__ = ["Autoreset"]


class Autoreset:
    """The autoreset of ``mode`` for the envs of one slice.

    Args:
        mode: the pool's autoreset mode.
        needs_reset: per env of the slice, its mark (a view of the shared ``needs_reset``):
            ``NO_RESET``; ``RESET_THEN_REPORT`` (``NEXT_STEP``: it ended, its next step is its
            reset); ``RESET_THEN_STEP`` (it moved here at an episode boundary).
    """

    def __init__(self, mode: AutoresetMode, needs_reset: np.ndarray) -> None:
        self.mode = mode
        self.needs_reset = needs_reset
        self.next_step = mode is AutoresetMode.NEXT_STEP
        self.same_step = mode is AutoresetMode.SAME_STEP

    def step(self, offset: int, env: PoolEnv, action: Any, mark: int) -> StepResult:
        """Env ``offset``'s part of a vector step, given its mark in ``needs_reset`` (read by the
        caller, once for a whole slice): its reset (``NEXT_STEP`` after an ended step), or its step
        with ``action`` and what follows it (:meth:`after_step`)."""
        if mark:
            if mark == RESET_THEN_STEP:  # it moved here at an episode boundary
                env.reset()
                self.needs_reset[offset] = NO_RESET
            elif self.next_step:
                observation, info = env.reset()
                self.needs_reset[offset] = NO_RESET
                return observation, 0.0, False, False, info
        return self.after_step(offset, env, env.step(action))

    def after_step(self, offset: int, env: PoolEnv, result: StepResult) -> StepResult:
        """What follows env ``offset``'s step that gave ``result``: ``NEXT_STEP`` marks an ended env,
        ``SAME_STEP`` resets it now (its ``final_obs`` the observation of ``result``)."""
        observation, reward, terminated, truncated, info = result
        ended = bool(terminated or truncated)
        if self.next_step:
            self.needs_reset[offset] = ended
        elif self.same_step and ended:
            reset_observation, reset_info = env.reset()
            info = same_step_info(observation, info, reset_info)
            observation = reset_observation
        return observation, reward, terminated, truncated, info
