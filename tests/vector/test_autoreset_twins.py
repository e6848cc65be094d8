"""The pool's autoreset is written twice: in Python (`modelicagym.vector.slice.autoreset.Autoreset`) and
in C (``step_batch`` in ``native/csrc/slice.c``, ``end_steps`` in ``csrc/endings.c``). The same
envs, seeds and actions through a slice on the Python path and a slice on the native path give the
same observations, rewards, terminations, truncations and infos (``final_obs`` / ``final_info``
included), in every autoreset mode the pool supports, whichever way the native path resets."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import ExitStack
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from env_slices import env_slice
from gymnasium.vector import AutoresetMode
from python_endings import endings_fns
from step_paths import cartpole_fns, probe_env
from vector_rollouts import assert_same

from modelicagym.native.abi import Flags
from modelicagym.vector.dispatch.infos import add_final_infos, merge_infos
from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.buffers import SharedBuffers
from modelicagym.vector.wire.protocol import Kind

pytestmark = pytest.mark.timeout(180)


def infos_of(reply: Any, buffers: SharedBuffers) -> dict[str, Any]:
    """The vector infos the pool builds from a slice's reply and the native step's same-step resets."""
    assert reply is None or reply.kind is Kind.INFOS, reply
    infos = merge_infos(reply.data if reply else [], buffers.spec.num_envs)
    add_final_infos(infos, buffers.take_final_ready(), buffers.final_observations, buffers.spec.num_envs)
    return infos


def run(part: EnvSlice, buffers: SharedBuffers, actions: list[np.ndarray], seeds: list[int]) -> tuple[list, int]:
    """Everything the slice reports over ``actions`` (in ``DISABLED`` mode ended envs are reset with a
    reset mask, recorded too), and the flags its native steps raised."""
    flags_seen = 0
    buffers.reset_mask[:] = True
    records: list[Any] = [(buffers.observations.read_batch(copy_out=True), infos_of(part.reset(seeds, None), buffers))]
    for action in actions:
        buffers.actions.write_batch(action)
        reply = part.step()
        if part.native is not None:
            flags_seen |= int(np.bitwise_or.reduce(part.native.flags))
        records.append((buffers.observations.read_batch(copy_out=True), buffers.rewards.copy(),
                        buffers.terminations.copy(), buffers.truncations.copy(), infos_of(reply, buffers)))
        ended = buffers.terminations | buffers.truncations
        if part.autoreset_mode is AutoresetMode.DISABLED and ended.any():
            buffers.reset_mask[:] = ended
            reply = part.reset(None, None)
            records.append((buffers.observations.read_batch(copy_out=True), infos_of(reply, buffers)))
    return records, flags_seen


def probe_fns(family_fmu: Callable[[str, int], Path], fault: int) -> tuple[list, list]:
    """Probe envs whose env 1 fails (fault 2: doStep returns Error) or ends the model (fault 1)."""
    def fns(**path: Any) -> list:
        faulty = {"fault": fault, "fault_after": 3}
        return [partial(probe_env, family_fmu("probe", 2), parameters=faulty if i == 1 else {}, max_episode_steps=8,
                        **path) for i in range(3)]
    return fns(), fns(step_path="python")


#: how the native slice finishes its steps -> (env fns: native, python), a flag that must be seen
#: (the native path really went that way; None: no such flag)
VARIANTS: dict[str, Callable[..., tuple[tuple[list, list], int | None]]] = {
    "C resets": lambda _: (cartpole_fns(3), Flags.RESET_DONE),
    "Python resets": lambda _: (cartpole_fns(3, reset_rung="reset"), Flags.PYTHON_RESET),
    "endings in Python": lambda _: (endings_fns("arrays, class", 3), Flags.RESET_DONE),
    "model ends": lambda family_fmu: (probe_fns(family_fmu, 1), Flags.MODEL_ENDED),
    "FMU error": lambda family_fmu: (probe_fns(family_fmu, 2), Flags.FMU_ERROR),
}


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda mode: mode.value)
def test_python_and_native_slices_autoreset_alike(variant: str, mode: AutoresetMode,
                                                  family_fmu: Callable[[str, int], Path]) -> None:
    (native_fns, python_fns), flag = VARIANTS[variant](family_fmu)
    seeds = [3, 4, 5]
    with ExitStack() as stack:
        native, native_buffers = stack.enter_context(env_slice(native_fns, mode))
        python, python_buffers = stack.enter_context(env_slice(python_fns, mode))
        assert (native.step_path, python.step_path) == ("native", "python"), native.step_path_reason
        assert (native.endings is not None) == (variant == "endings in Python")
        space = native.envs[0].action_space
        space.seed(11)
        actions = [np.stack([space.sample() for _ in seeds]) for _ in range(60)]
        expected, _ = run(python, python_buffers, actions, seeds)
        actual, flags_seen = run(native, native_buffers, actions, seeds)
    assert_same(expected, actual)
    ends = sum(int((record[2] | record[3]).sum()) for record in expected if len(record) == 5)
    assert ends >= 3, "too few episodes ended: autoreset was hardly exercised"
    if mode is AutoresetMode.SAME_STEP:
        assert any("final_obs" in record[-1] for record in expected if len(record) == 5)
    resets_in_step = flag in (Flags.RESET_DONE, Flags.PYTHON_RESET) and mode is not AutoresetMode.DISABLED
    if resets_in_step or flag in (Flags.MODEL_ENDED, Flags.FMU_ERROR):
        assert flags_seen & flag, f"the native slice never raised {Flags.__name__} {flag}: not the path meant"
