"""A pool's envs' states: a checkpoint (`pool.get_states`) that a new pool resumes bit for bit, and
resets that start each env from its own state (``options["options_per_env"]``)."""

from __future__ import annotations

import pickle
from functools import partial

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import modelicagym
from modelicagym.env.saved_state import StartStates
from modelicagym.errors import ArgumentError, ArgumentTypeError
from modelicagym.fmu import StateMismatchError
from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.saved_states import VectorState

N = 4
STEPS, CHECKPOINT = 40, 17


def pool(**options: object) -> modelicagym.vector.PoolVectorEnv:
    """Cart-poles whose episodes end at different steps, over two workers and the calling process."""
    return modelicagym.make_vec("cartpole", n=N, num_workers=2, caller_steps=True,
                                options_per_env=[{"max_episode_steps": 5 + 3 * i} for i in range(N)], **options)


def steps(envs: object, actions: np.ndarray) -> list[tuple]:
    """Each batch's observations, rewards, terminations and truncations, as bytes."""
    out = []
    for batch in actions:
        observations, rewards, terminations, truncations, _ = envs.step(batch)
        out.append((observations.tobytes(), rewards.tobytes(), terminations.tobytes(), truncations.tobytes()))
    return out


@pytest.mark.parametrize("mode, autoreset", [("cs", AutoresetMode.NEXT_STEP), ("me", AutoresetMode.NEXT_STEP),
                                             ("cs", AutoresetMode.SAME_STEP)])
def test_a_resumed_pool_goes_on_bit_for_bit_as_the_uninterrupted_one(
    mode: str, autoreset: AutoresetMode, no_leaks: None
) -> None:
    actions = np.random.default_rng(2).integers(2, size=(STEPS, N))
    with pool(mode=mode, autoreset_mode=autoreset) as envs:
        envs.reset(seed=9)
        steps(envs, actions[:CHECKPOINT])
        checkpoint = pickle.loads(pickle.dumps(envs.get_states()))  # saved beside a model, then loaded
        uninterrupted = steps(envs, actions[CHECKPOINT:])
    assert isinstance(checkpoint, VectorState) and len(checkpoint) == N
    assert any(checkpoint.needs_reset) or autoreset is AutoresetMode.SAME_STEP
    with pool(mode=mode, autoreset_mode=autoreset) as envs:
        envs.reset(seed=123)  # another start: the checkpoint overrides it
        envs.set_states(checkpoint)
        assert steps(envs, actions[CHECKPOINT:]) == uninterrupted


def test_a_reset_starts_each_env_from_its_own_state(no_leaks: None) -> None:
    env = modelicagym.make("cartpole")
    env.reset(seed=0)
    states = []
    for k in range(N):
        observation, *_ = env.step(k % 2)
        states.append((env.unwrapped.get_state(), observation))
    with pool() as envs:
        observations, _ = envs.reset(options={"options_per_env": [{"state": s} for s, _ in states]})
        assert all(np.array_equal(observations[i], states[i][1]) for i in range(N))
        assert envs.get_attr("time") == tuple(s.time for s, _ in states)
        options = StartStates([s for s, _ in states]).options_per_env(N, np.random.default_rng(0))
        envs.reset(options={"options_per_env": options})
        assert envs.get_attr("time") == tuple(o["state"].time for o in options)
        with pytest.raises(ArgumentError, match="one per env"):
            envs.reset(options={"options_per_env": [{}] * (N - 1)})
        with pytest.raises(ArgumentError, match="2 states for 4 envs"):
            envs.set_states([states[0][0]] * 2)
        envs.reset()  # still usable


def slow_env(path: object, **config: object) -> modelicagym.FMUEnv:
    return modelicagym.FMUEnv(fmu=path, inputs=["u"], outputs=["y"], time_step=0.1, max_episode_steps=6,
                              parameters={"init_seconds": 0.02, **config.pop("parameters", {})}, **config)


@pytest.mark.parametrize("fmi_version, mode", [(2, "cs"), (3, "me")])
def test_init_once_initializes_one_env_and_gives_every_env_its_own_trajectory(
    fmi_version: int, mode: str, family_fmu: object, no_leaks: None
) -> None:
    path = family_fmu("slowinit", fmi_version)
    fns = [partial(slow_env, path, mode=mode) for _ in range(N)]
    actions = np.random.default_rng(3).uniform(-1, 1, size=(20, N, 1))
    runs = {}
    for init in ("each", "once"):
        with PoolVectorEnv(fns, num_workers=2, init=init) as envs:
            first, _ = envs.reset(seed=4)
            runs[init] = [first.tobytes()] + steps(envs, actions)
            runs[init + " initializations"] = envs.get_attr("initializations")
    assert runs["once"] == runs["each"]
    assert runs["each initializations"] == (1,) * N and sum(runs["once initializations"]) == 1


def test_init_once_falls_back_where_an_env_has_parameters_of_its_own_or_no_state(
    family_fmu: object, no_leaks: None
) -> None:
    path = family_fmu("slowinit", 2)
    fns = [partial(slow_env, path, parameters={"x_0": 0.5 if i == 2 else 0.0}) for i in range(N)]
    with PoolVectorEnv(fns, num_workers=2, init="once") as envs:
        observations, _ = envs.reset(seed=0)
        assert envs.get_attr("initializations") == (1, 0, 1, 0) and observations[2, 0] == 0.5
    late = family_fmu("probe_late", 2)
    fns = [partial(modelicagym.FMUEnv, fmu=late, inputs=["force"], outputs=["position"], time_step=0.1)
           for _ in range(N)]
    with PoolVectorEnv(fns, num_workers=2, init="once") as envs:  # probe_late cannot serialize its state
        envs.reset(seed=0)
        assert envs.get_attr("initializations") == (1,) * N


@pytest.mark.parametrize("autoreset", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_a_pools_autoresets_start_from_the_configs_start_states(autoreset: AutoresetMode, no_leaks: None) -> None:
    env = modelicagym.make("cartpole")
    env.reset(seed=0)
    for _ in range(6):
        env.step(1)
    state = env.unwrapped.get_state()
    with modelicagym.make_vec("cartpole", n=N, num_workers=2, caller_steps=True, start_states=[state],
                              max_episode_steps=3, autoreset_mode=autoreset) as envs:
        assert envs.step_paths[0].path == "native"  # its resets go to Python; its steps stay in C
        envs.reset(seed=1)
        assert envs.get_attr("time") == (state.time,) * N
        for _ in range(3):  # episodes of 3 steps: the later resets would be C's snapshot restores
            for _ in range(3 if autoreset is AutoresetMode.SAME_STEP else 4):
                envs.step(np.zeros(N, dtype=np.int64))
            assert envs.get_attr("time") == (state.time,) * N and envs.get_attr("elapsed_steps") == (0,) * N


def test_set_states_changes_no_env_when_one_refuses_its_state(no_leaks: None) -> None:
    """Cart-poles over FMI 2.0 and 3.0 (two FMUs, same spaces), one in the calling process and
    one in a worker: a state the other FMU refuses leaves both envs exactly where they were."""
    def mixed() -> PoolVectorEnv:
        return modelicagym.make_vec("cartpole", n=2, num_workers=1, caller_steps=True,
                                    options_per_env=[{"fmi_version": 2}, {"fmi_version": 3}])

    actions = np.random.default_rng(4).integers(2, size=(12, 2))
    with mixed() as untouched:
        untouched.reset(seed=1)
        steps(untouched, actions[:4])
        expected = steps(untouched, actions[4:])
    with mixed() as envs:
        assert envs.layout.envs_in_caller == 1
        envs.reset(seed=1)
        stale = envs.get_states().states
        steps(envs, actions[:4])
        # swapped, both refuse; env 0's own (stale) state with env 1 refusing the FMI 2.0 one:
        # env 0 would load its state if the refusal were not checked everywhere first
        for given, refused_by in (([stale[1], stale[0]], 0), ([stale[0], stale[0]], 1)):
            with pytest.raises(StateMismatchError) as caught:
                envs.set_states(given)
            message = str(caught.value)
            assert message.startswith(f"env {refused_by} (") and "before any env changed" in message
            assert "\n" not in message
        with pytest.raises(ArgumentTypeError, match="got bytes .unpickle"):
            envs.set_states(pickle.dumps(envs.get_states()))
        assert steps(envs, actions[4:]) == expected
