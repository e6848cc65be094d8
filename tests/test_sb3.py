"""`modelicagym.sb3.SB3VecEnv`: SB3's conventions exactly, over the pool in every autoreset mode and
over SyncVectorEnv; it returns what SB3's own DummyVecEnv returns over the same envs, step by step,
and SB3's wrappers and evaluation run on it."""

from __future__ import annotations

import tempfile
from functools import partial
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from extras import imported
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from vector_envs import count_fns

import modelicagym
from modelicagym.vector import PoolVectorEnv

imported("stable_baselines3")
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.evaluation import evaluate_policy  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize  # noqa: E402

from modelicagym.sb3 import SB3VecEnv, folderless_logger  # noqa: E402

pytestmark = [pytest.mark.timeout(300), pytest.mark.usefixtures("pool_services")]


def assert_equal(a: Any, b: Any, where: str) -> None:
    """Deep equality of SB3 results: arrays by value and dtype, numbers by value, dicts by keys."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), f"{where}: keys {sorted(a)} != {sorted(b)}"
        for key in a:
            assert_equal(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), f"{where}: {len(a)} != {len(b)}"
        for k, (x, y) in enumerate(zip(a, b)):
            assert_equal(x, y, f"{where}[{k}]")
    elif isinstance(a, np.ndarray) and a.ndim:
        assert a.dtype == np.asarray(b).dtype, f"{where}: dtype {a.dtype} != {np.asarray(b).dtype}"
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def lockstep(ours: SB3VecEnv, reference: DummyVecEnv, steps: int, seed: int) -> int:
    """Step both with the same random actions after ``seed(seed)``; assert every result equal.
    Returns how many episodes ended."""
    ours.seed(seed)
    reference.seed(seed)
    assert_equal(ours.reset(), reference.reset(), "reset")
    assert_equal(ours.reset_infos, reference.reset_infos, "reset_infos")
    ours.action_space.seed(seed)
    ended = 0
    for t in range(steps):
        actions = np.stack([ours.action_space.sample() for _ in range(ours.num_envs)])
        got, want = ours.step(actions), reference.step(actions)
        assert_equal(got, want, f"step {t}")
        assert_equal(ours.reset_infos, reference.reset_infos, f"step {t}: reset_infos")
        ended += int(want[2].sum())
    return ended


def cartpole_fns(n: int) -> list:
    return [partial(modelicagym.make, "cartpole", max_episode_steps=12 + 5 * i) for i in range(n)]


VECTORS = {
    "pool same-step": lambda fns: PoolVectorEnv(fns, num_workers=2, autoreset_mode=AutoresetMode.SAME_STEP),
    "pool next-step": lambda fns: PoolVectorEnv(fns, num_workers=2, autoreset_mode=AutoresetMode.NEXT_STEP),
    "pool disabled": lambda fns: PoolVectorEnv(fns, num_workers=2, autoreset_mode=AutoresetMode.DISABLED),
    "pool in the caller": lambda fns: PoolVectorEnv(fns, num_workers=0, autoreset_mode=AutoresetMode.SAME_STEP),
    "sync same-step": lambda fns: SyncVectorEnv(fns, autoreset_mode=AutoresetMode.SAME_STEP),
    "sync next-step": lambda fns: SyncVectorEnv(fns),
}


@pytest.mark.parametrize("vector", list(VECTORS))
@pytest.mark.parametrize("fns", [cartpole_fns, partial(count_fns, act="discrete")], ids=["cartpole", "count"])
def test_step_by_step_what_dummy_vec_env_returns(vector: str, fns: Any) -> None:
    """Observations, float32 rewards, dones, per-env infos (``terminal_observation``,
    ``TimeLimit.truncated``, nested infos), ``reset_infos``: all equal, including after the
    next ``seed()`` (env i gets seed + i)."""
    ours, reference = SB3VecEnv(VECTORS[vector](fns(4))), DummyVecEnv(fns(4))
    try:
        assert lockstep(ours, reference, 80, seed=3) >= 4
        assert lockstep(ours, reference, 20, seed=11) >= 1
    finally:
        ours.close()
        reference.close()


@pytest.mark.parametrize("vector", ["pool same-step", "sync next-step"])
def test_attributes_and_methods_of_selected_envs(vector: str) -> None:
    ours = SB3VecEnv(VECTORS[vector](count_fns(3)))
    try:
        ours.reset()
        assert ours.get_attr("max_len") == [4, 7, 10]
        assert ours.get_attr("max_len", indices=[2, 0]) == [10, 4]
        ours.set_attr("label", "picked", indices=1)
        assert ours.get_attr("label") == ["count", "picked", "count"]
        assert ours.env_method("double", 21, indices=[1]) == [42]
        assert ours.env_method("double", x=2) == [4, 4, 4]
        assert ours.env_is_wrapped(gym.Wrapper) == [False] * 3
        assert ours.has_attr("max_len") and not ours.has_attr("no_such_thing")
    finally:
        ours.close()


def test_sb3_wrappers_training_and_evaluation_run_on_the_pool(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """PPO learns for a few hundred steps through VecMonitor and VecNormalize on the pool; the
    monitor's episodes and evaluate_policy's returns are those of whole episodes. With
    `folderless_logger`, SB3 leaves no ``SB3-<date>`` folder in the temporary folder."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    envs = SB3VecEnv(modelicagym.make_vec("cartpole", n=4, max_episode_steps=50, autoreset_mode="SameStep"))
    try:
        monitored = VecNormalize(VecMonitor(envs), norm_reward=False)
        model = PPO("MlpPolicy", monitored, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
        model.set_logger(folderless_logger(model.verbose))
        model.learn(256)
        lengths = [episode["l"] for episode in model.ep_info_buffer]
        assert lengths and all(1 <= length <= 50 for length in lengths)
        monitored.training = False
        returns, episode_lengths = evaluate_policy(model, monitored, n_eval_episodes=4, return_episode_rewards=True)
        assert len(returns) == 4 and all(1 <= length <= 50 for length in episode_lengths)
    finally:
        envs.close()
    assert not list(tmp_path.glob("SB3-*")), "SB3's logger made a folder in the temporary folder"


def test_a_gymnasium_env_is_refused() -> None:
    with pytest.raises(ValueError, match="wraps a gymnasium.vector.VectorEnv"):
        SB3VecEnv(modelicagym.make("cartpole"))


@pytest.fixture
def one_torch_thread() -> Any:
    """Seeded runs repeat at a fixed torch thread count: one, as the examples and benchmark use."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


#: short runs (seconds): PPO updates after 2 x 64 env steps, SAC after 64 random ones, episodes of 16 steps
SHORT = {"ppo": ({"n_steps": 64, "batch_size": 64, "n_epochs": 2}, 384),
         "sac": ({"learning_starts": 64, "batch_size": 64}, 192)}


@pytest.mark.usefixtures("one_torch_thread")
@pytest.mark.parametrize("algorithm", list(SHORT))
def test_the_same_seed_gives_the_same_learning_curve_and_policy(algorithm: str) -> None:
    """Two runs of a preset with one seed on the pool: the same curve, the same evaluation returns,
    the same network weights, bit for bit; another seed gives another curve."""
    from dataclasses import replace

    import torch

    from modelicagym.sb3_train import preset, train

    settings, budget = SHORT[algorithm]
    spec = replace(preset("pendulum", algorithm).with_settings(**settings), goal=0.0)  # never reached: runs it all

    def run(seed: int) -> Any:
        return train(spec, seed, envs=2, budget=budget, max_episode_steps=16, eval_episodes=2)

    first, again, other = run(0), run(0), run(1)
    assert len(first.curve) == first.steps // 32 and first.steps == again.steps >= budget  # 2 episodes of 16
    assert first.curve == again.curve
    assert first.eval_returns == again.eval_returns
    weights, weights_again = first.model.policy.state_dict(), again.model.policy.state_dict()
    assert all(torch.equal(weights[key], weights_again[key]) for key in weights)
    assert other.curve != first.curve


def test_a_missing_preset_is_named_with_those_there_are() -> None:
    from modelicagym.errors import ArgumentError
    from modelicagym.sb3_train import preset

    with pytest.raises(ArgumentError, match=r"no sac preset for env 'cartpole'; presets: .*pendulum \(sac\)"):
        preset("cartpole", "sac")
