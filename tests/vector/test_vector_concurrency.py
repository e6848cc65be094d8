"""``max_concurrency``, as ``gymnasium.vector.AsyncVectorEnv`` takes it: at most that many envs in
``reset`` or ``step`` at once, the same results as ``AsyncVectorEnv`` with the same limit, and the
same checks of the value."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np
import pytest
from gymnasium.vector import AsyncVectorEnv
from vector_envs import ConcurrencyProbe, CountEnv
from vector_rollouts import assert_same, rollout

from modelicagym.vector import PoolVectorEnv


def probes(counter: Path, n: int) -> list:
    counter.write_text("0 0")
    return [partial(ConcurrencyProbe, str(counter), max_len=6)] * n


@pytest.mark.parametrize("layout", [{"num_workers": 4}, {"num_workers": 3, "caller_steps": True}],
                         ids=["workers", "caller-steps"])
@pytest.mark.parametrize("limit", [1, 2])
def test_at_most_max_concurrency_envs_reset_or_step_at_once(tmp_path: Path, layout: dict, limit: int) -> None:
    counter = tmp_path / "inside"
    with PoolVectorEnv(probes(counter, 4), max_concurrency=limit, **layout) as pool:
        pool.reset(seed=0)
        for _ in range(4):
            pool.step(np.zeros(4, dtype=np.int64))
        pool.step_async(np.zeros(4, dtype=np.int64))
        pool.step_wait()
        pool.reset(seed=1, options={"reset_mask": np.array([True, False, True, True])})
    assert 1 <= ConcurrencyProbe.most_inside(str(counter)) <= limit


def test_without_max_concurrency_the_probe_sees_envs_step_together(tmp_path: Path) -> None:
    """The probe above can fail: with no limit, the four workers' envs are inside ``step`` together."""
    counter = tmp_path / "inside"
    with PoolVectorEnv(probes(counter, 4), num_workers=4) as pool:
        pool.reset(seed=0)
        for _ in range(4):
            pool.step(np.zeros(4, dtype=np.int64))
    assert ConcurrencyProbe.most_inside(str(counter)) > 2


def test_partial_batches_respect_max_concurrency(tmp_path: Path) -> None:
    counter = tmp_path / "inside"
    with PoolVectorEnv(probes(counter, 4), num_workers=4, batch_size=2, max_concurrency=2) as pool:
        pool.async_reset(seed=0)
        for _ in range(6):
            *_, infos = pool.recv()
            pool.send(np.zeros(2, dtype=np.int64), infos["env_id"])
    assert ConcurrencyProbe.most_inside(str(counter)) <= 2


@pytest.mark.parametrize("limit", [1, 3])
def test_results_are_async_vector_envs_with_the_same_limit(limit: int) -> None:
    fns = [partial(CountEnv, max_len=5)] * 4
    reference = AsyncVectorEnv(fns, max_concurrency=limit)
    expected = rollout(reference, 25)
    reference.close()
    with PoolVectorEnv(fns, num_workers=2, max_concurrency=limit) as pool:
        assert pool.max_concurrency == limit
        assert_same(expected, rollout(pool, 25))


@pytest.mark.parametrize("value", [0, -1, 1.5, "2"])
def test_a_bad_max_concurrency_is_refused_as_async_vector_env_refuses_it(value: object) -> None:
    with pytest.raises(ValueError) as expected:
        AsyncVectorEnv([CountEnv], max_concurrency=value)
    with pytest.raises(ValueError) as got:
        PoolVectorEnv([CountEnv], max_concurrency=value)
    assert str(got.value) == str(expected.value)
