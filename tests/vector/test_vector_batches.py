"""Partial batches (EnvPool's ``async_reset``/``send``/``recv``): each env's own trajectory is the
one SyncVectorEnv gives for the same seed and actions, whatever order envs come back in, on the
Python and the native step path; bad ids and actions are refused with the pool still usable."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from step_paths import cartpole_fns
from vector_envs import CountEnv, FaultyEnv, GatedEnv, count_fns

from modelicagym.errors import ActionError, ArgumentError, ConfigError
from modelicagym.vector import EnvError, NoPendingCallError, PendingCallError, PoolVectorEnv

pytestmark = pytest.mark.timeout(120)


def action_of(env: int, t: int, space: Any) -> int:
    """The action env ``env`` gets at its ``t``-th step (of a ``Discrete`` space): fixed in advance,
    whatever the order envs come back in."""
    return int(space.start) + (env * 7 + t * 3 + t // 4) % int(space.n)


def final_observation(infos: dict, k: int) -> np.ndarray | None:
    """Row ``k``'s ``final_obs`` info (``SAME_STEP``), or ``None``."""
    return infos["final_obs"][k] if "_final_obs" in infos and infos["_final_obs"][k] else None


def partial_trajectories(pool: PoolVectorEnv, rounds: int, seed: int) -> dict[int, list[tuple]]:
    """Per env, what ``recv`` returned for it (with its final observation where it ended in
    ``SAME_STEP`` mode), while actions follow `action_of`."""
    space = pool.single_action_space
    pool.async_reset(seed=seed)
    seen: dict[int, list[tuple]] = {}
    for _ in range(rounds):
        observations, rewards, terminations, truncations, infos = pool.recv()
        ids = infos["env_id"]
        assert len(ids) == pool.batch_size
        for k, env in enumerate(ids.tolist()):
            seen.setdefault(env, []).append((observations[k].copy(), float(rewards[k]), bool(terminations[k]),
                                             bool(truncations[k]), final_observation(infos, k)))
        pool.send(np.array([action_of(env, len(seen[env]) - 1, space) for env in ids.tolist()]), ids)
    return seen


def sync_trajectories(
    fns: list[Callable[[], Any]], steps: int, seed: int, autoreset_mode: AutoresetMode = AutoresetMode.NEXT_STEP
) -> dict[int, list[tuple]]:
    """Per env, ``steps + 1`` results of SyncVectorEnv (the reset, then steps) with `action_of`."""
    sync = SyncVectorEnv(fns, autoreset_mode=autoreset_mode)
    space = sync.single_action_space
    observations, _ = sync.reset(seed=seed)
    records = {env: [(observations[env].copy(), 0.0, False, False, None)] for env in range(len(fns))}
    for t in range(steps):
        actions = np.array([action_of(env, t, space) for env in range(len(fns))])
        observations, rewards, terminations, truncations, infos = sync.step(actions)
        for env in range(len(fns)):
            records[env].append((observations[env].copy(), float(rewards[env]), bool(terminations[env]),
                                 bool(truncations[env]), final_observation(infos, env)))
    sync.close()
    return records


def assert_prefixes_agree(partial_runs: dict[int, list[tuple]], sync_runs: dict[int, list[tuple]]) -> None:
    for env, records in partial_runs.items():
        expected = sync_runs[env][: len(records)]
        assert len(expected) == len(records), f"env {env} stepped more than the reference"
        for t, (got, want) in enumerate(zip(records, expected)):
            np.testing.assert_array_equal(got[0], want[0], err_msg=f"env {env}, step {t}")
            assert got[1:4] == want[1:4], f"env {env}, step {t}: {got[1:4]} != {want[1:4]}"
            assert (got[4] is None) == (want[4] is None), f"env {env}, step {t}: final_obs {got[4]} != {want[4]}"
            if got[4] is not None:
                np.testing.assert_array_equal(got[4], want[4], err_msg=f"env {env}, step {t}: final_obs")


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_native_same_step_resets_report_their_final_observation(mode: AutoresetMode) -> None:
    """Cart-poles on the native step: an env reset in the step that ended it has its final
    observation in the batch that returns it, as in SyncVectorEnv."""
    native, python = cartpole_fns(6)
    with PoolVectorEnv(native, num_workers=2, batch_size=3, autoreset_mode=mode) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}
        runs = partial_trajectories(pool, 120, seed=5)
    expected = sync_trajectories(python, max(map(len, runs.values())), seed=5, autoreset_mode=mode)
    assert_prefixes_agree(runs, expected)
    assert sum(record[4] is not None for records in runs.values() for record in records) >= (
        3 if mode is AutoresetMode.SAME_STEP else 0)


@pytest.mark.parametrize("batch_size", [1, 2, 5])
def test_each_env_follows_its_sync_vector_env_trajectory(batch_size: int) -> None:
    fns = count_fns(6, act="discrete")
    with PoolVectorEnv(fns, num_workers=2, batch_size=batch_size) as pool:
        runs = partial_trajectories(pool, 60, seed=11)
    assert set(runs) == set(range(6))
    assert_prefixes_agree(runs, sync_trajectories(fns, max(map(len, runs.values())), seed=11))


def test_cartpole_on_the_native_path_follows_sync_vector_env() -> None:
    native, python = cartpole_fns(5)
    with PoolVectorEnv(native, num_workers=2, batch_size=2) as pool:
        assert {path for path, _ in pool.step_paths} == {"native"}
        runs = partial_trajectories(pool, 80, seed=5)
    assert_prefixes_agree(runs, sync_trajectories(python, max(map(len, runs.values())), seed=5))


def test_a_slow_env_does_not_hold_back_the_fast_ones(tmp_path: Path) -> None:
    """Env 0 cannot finish a step until the gate opens: meanwhile the other worker's envs keep
    coming back; once it opens, env 0 comes back too."""
    gate = tmp_path / "gate"
    fns = [partial(GatedEnv, str(gate), max_len=1000)] + [partial(CountEnv, max_len=1000)] * 3
    with PoolVectorEnv(fns, num_workers=2, max_envs_per_worker=3, batch_size=1) as pool:
        pool.async_reset(seed=0)
        returned = []
        for _ in range(40):
            *_, infos = pool.recv()
            returned += infos["env_id"].tolist()
            pool.send(np.zeros(1, dtype=np.int64), infos["env_id"])
        assert returned.count(0) == 1 and len(returned) == 40
        gate.touch()
        while 0 not in returned[40:]:  # env 0 comes back once its step can finish (else the test times out)
            *_, infos = pool.recv()
            returned += infos["env_id"].tolist()
            pool.send(np.zeros(1, dtype=np.int64), infos["env_id"])


def test_bad_ids_and_actions_are_refused_and_the_pool_stays_usable() -> None:
    with PoolVectorEnv(count_fns(4), num_workers=2, batch_size=2) as pool:
        with pytest.raises(NoPendingCallError, match="before `async_reset`"):
            pool.send(np.zeros(1, dtype=np.int64), [0])
        pool.async_reset(seed=0)
        *_, infos = pool.recv()
        ids = infos["env_id"]
        others = sorted(set(range(4)) - set(ids.tolist()))
        with pytest.raises(ArgumentError, match="not yet returned by recv"):
            pool.send(np.zeros(1, dtype=np.int64), others[:1])
        with pytest.raises(ArgumentError, match="must lie in"):
            pool.send(np.zeros(1, dtype=np.int64), [7])
        with pytest.raises(ArgumentError, match="must not repeat"):
            pool.send(np.zeros(2, dtype=np.int64), [ids[0], ids[0]])
        with pytest.raises(ActionError, match=f"env {ids[1]}: .*out of range"):
            pool.send(np.array([0, 9]), ids)
        with pytest.raises(PendingCallError, match="not all returned by `recv`"):
            pool.step(np.zeros(4, dtype=np.int64))
        pool.send(np.zeros(2, dtype=np.int64), ids)
        *_, infos = pool.recv()
        *_, infos2 = pool.recv()
        assert sorted(infos["env_id"].tolist() + infos2["env_id"].tolist()) == [0, 1, 2, 3]
        with pytest.raises(ArgumentError, match="send\\(\\) more envs first"):
            pool.recv()
        pool.reset(seed=0)
        pool.step(np.zeros(4, dtype=np.int64))


def test_an_env_error_names_the_env_and_stops_the_pool() -> None:
    """Envs 0 and 1 (worker 0) raise at their second step. Only they are sent again: were the
    other worker's envs sent too, a loaded machine could keep worker 0 waiting for the CPU
    while they come back batch after batch, for any number of rounds."""
    fns = [partial(FaultyEnv, "raise", at_step=2)] * 2 + count_fns(2)
    pool = PoolVectorEnv(fns, num_workers=2, batch_size=2)
    pool.async_reset(seed=0)
    with pytest.raises(EnvError, match="env 0"):
        for _ in range(5):  # the 4 resets in 2 batches, then the steps of envs 0 and 1 (the 2nd raises)
            *_, infos = pool.recv()
            faulty = infos["env_id"][infos["env_id"] < 2]
            if faulty.size:
                pool.send(np.zeros(faulty.size, dtype=np.int64), faulty)
    assert pool.closed


def test_closing_with_envs_in_flight_is_clean() -> None:
    pool = PoolVectorEnv(count_fns(4), num_workers=2, batch_size=4)
    pool.async_reset(seed=0)
    *_, infos = pool.recv()
    pool.send(np.zeros(4, dtype=np.int64), infos["env_id"])
    pool.close()
    assert pool.closed


@pytest.mark.parametrize("options, match", [
    ({"batch_size": 0}, "batch_size must lie in"),
    ({"batch_size": 5}, "batch_size must lie in"),
    ({"batch_size": 2.0}, "batch_size must be an int"),
    ({"batch_size": 2, "caller_steps": True}, "partial batches need every env in a worker"),
])
def test_batch_size_is_checked(options: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        PoolVectorEnv(count_fns(4), **options)


@pytest.mark.parametrize("native", [False, True], ids=["python path", "native path"])
@pytest.mark.parametrize("layout", [{"num_workers": 2}, {"caller_steps": True}])
def test_step_envs_steps_only_those_envs(layout: dict, native: bool) -> None:
    """Each env advances only when it is among ``env_ids``, exactly as a vector env of its own."""
    fns = cartpole_fns(5)[0] if native else count_fns(5)
    singles = [SyncVectorEnv([fn]) for fn in fns]
    rng = np.random.default_rng(0)
    with PoolVectorEnv(fns, **layout) as pool:
        pool.reset(seed=3)
        for i, single in enumerate(singles):
            single.reset(seed=3 + i)
        space = pool.single_action_space
        for t in range(60):
            ids = np.flatnonzero(rng.random(5) < 0.6)
            actions = np.array([action_of(i, t, space) for i in ids.tolist()], dtype=np.int64)
            selection = ids if t % 2 else np.isin(np.arange(5), ids)  # indices, or a boolean mask
            observations, rewards, terminations, truncations, infos = pool.step_envs(actions, selection)
            assert infos["env_id"].tolist() == ids.tolist()
            for k, i in enumerate(ids.tolist()):
                expected = singles[i].step(actions[k : k + 1])
                np.testing.assert_array_equal(observations[k], expected[0][0], err_msg=f"env {i}, step {t}")
                assert (rewards[k], terminations[k], truncations[k]) == (expected[1][0], expected[2][0], expected[3][0])
        everyone = pool.step(np.zeros(5, dtype=np.int64))
        for i, single in enumerate(singles):
            np.testing.assert_array_equal(everyone[0][i], single.step(np.zeros(1, dtype=np.int64))[0][0])
    for single in singles:
        single.close()
