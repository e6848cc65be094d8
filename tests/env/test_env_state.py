"""An env's state as a value: saved mid-episode, loaded in another process, the env goes on bit for
bit as the one it came from; refused by another FMU; one line for an FMU that cannot serialize."""

from __future__ import annotations

import pickle
from functools import partial
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
import pytest
from fmu_family import STAIRCASE_OUTPUTS
from state_runs import run, run_in_another_process

import modelicagym
from modelicagym import FMUEnv
from modelicagym.env.saved_state import StartStates
from modelicagym.errors import ArgumentError, ConfigError
from modelicagym.fmu import StateMismatchError, UnsupportedFeatureError

#: steps the run takes after the state is saved; episodes of 10 steps, so resets come in between
STEPS_AFTER = 30


def staircase_env(path: Path, mode: str, step_path: str = "auto") -> FMUEnv:
    return FMUEnv(fmu=path, mode=mode, inputs=["u"], outputs=list(STAIRCASE_OUTPUTS[:3]), time_step=0.07,
                  max_episode_steps=10, step_path=step_path)


CASES = ([f"cartpole-fmi{v}-{m}" for v in (2, 3) for m in ("cs", "me")] + ["cartpole-fmi2-me-python"]
         + [f"staircase-fmi{v}-{m}" for v in (2, 3) for m in ("cs", "me")] + ["staircase-fmi3-me-python"])


def factory_for(case: str, family_fmu: Callable[[str, int], Path]) -> Callable[[], Any]:
    """A picklable env fn for ``case``: model-fmi<version>-<mode>[-python]."""
    model, version, mode, *python = case.split("-")
    step_path = "python" if python else "auto"
    fmi_version = int(version[3:]) if version.startswith("fmi") else 2
    if model == "cartpole":
        return partial(modelicagym.make, "cartpole", fmi_version=fmi_version, mode=mode, step_path=step_path,
                       max_episode_steps=10)
    return partial(staircase_env, family_fmu("staircase", fmi_version), mode, step_path)


@pytest.mark.processes
@pytest.mark.parametrize("case", CASES)
def test_a_state_goes_on_bit_for_bit_in_another_process(
    case: str, tmp_path: Path, family_fmu: Callable[[str, int], Path]
) -> None:
    factory = factory_for(case, family_fmu)
    env = factory()
    env.action_space.seed(5)
    env.reset(seed=3)
    for _ in range(7):
        env.step(env.action_space.sample())
    state = env.unwrapped.get_state()
    actions = [env.action_space.sample() for _ in range(STEPS_AFTER)]
    here = run(env, actions)
    there = run_in_another_process(tmp_path, factory, state, actions)
    assert there == here
    assert state.elapsed_steps == 7 and state.time == pytest.approx(7 * env.unwrapped.time_step)


def test_reset_from_a_state_starts_an_episode_there(cartpole_fmu: Callable[..., Path]) -> None:
    env = modelicagym.make("cartpole", max_episode_steps=10)
    env.reset(seed=0)
    for action in (1, 0, 1, 1):
        observation, *_ = env.step(action)
    state = env.unwrapped.get_state()
    other = modelicagym.make("cartpole", max_episode_steps=10)
    started, info = other.reset(options={"state": state})
    assert np.array_equal(started, observation) and info == {}
    assert other.unwrapped.time == env.unwrapped.time and other.unwrapped.elapsed_steps == 0
    for _ in range(10):  # a whole episode from there: max_episode_steps counts from the state
        truncated = other.step(0)[3]
    assert truncated or other.unwrapped.elapsed_steps < 10
    with pytest.raises(ArgumentError, match="exclude each other"):
        other.reset(options={"state": state, "parameters": {"m_cart": 3.0}})


def test_a_state_keeps_the_episodes_random_parameters_and_generator() -> None:
    env = modelicagym.make("cartpole", m_cart=lambda rng: rng.uniform(5.0, 20.0))
    env.reset(seed=11)
    env.step(1)
    state = env.unwrapped.get_state()
    later = [env.reset()[0] for _ in range(3)]  # the generator draws the next episodes' parameters
    other = modelicagym.make("cartpole", m_cart=lambda rng: rng.uniform(5.0, 20.0))
    other.unwrapped.set_state(state)
    assert other.unwrapped.episode_parameters == state.episode_parameters
    assert all(np.array_equal(a, other.reset()[0]) for a in later)


def test_a_state_is_refused_by_another_fmu(cartpole_fmu: Callable[..., Path]) -> None:
    env = modelicagym.make("cartpole")
    env.reset(seed=0)
    env.step(1)
    state = env.unwrapped.get_state()
    for other in (modelicagym.make("pendulum"), modelicagym.make("cartpole", fmi_version=3)):
        other.reset(seed=0)
        before = other.unwrapped.get_state()
        with pytest.raises(StateMismatchError, match="saved from .* not from this FMU"):
            other.unwrapped.set_state(state)
        assert other.unwrapped.get_state().fmu.data == before.fmu.data  # nothing changed
    model_exchange = modelicagym.make("cartpole", mode="me")
    with pytest.raises(StateMismatchError, match="saved in mode 'cs', not 'me'"):
        model_exchange.unwrapped.set_state(state)


@pytest.mark.parametrize("name, fmi_version, why", [
    ("probe_late", 2, "canGetAndSetFMUstate is false"),
    ("probe_late", 3, "canGetAndSetFMUstate is false"),
])
def test_an_fmu_that_cannot_serialize_says_so_in_one_line(
    name: str, fmi_version: int, why: str, family_fmu: Callable[[str, int], Path]
) -> None:
    env = FMUEnv(fmu=family_fmu(name, fmi_version), inputs=["force"], outputs=["position"], time_step=0.1)
    env.reset(seed=0)
    with pytest.raises(UnsupportedFeatureError) as caught:
        env.get_state()
    message = str(caught.value)
    assert message.count("\n") == 0 and why in message and "cannot save its state" in message
    assert env.step(np.array([1.0]))[0].shape == (1,)  # the rest works as before
    env.reset()


def test_fmi1_cannot_serialize_in_one_line(cartpole_fmu: Callable[..., Path]) -> None:
    env = modelicagym.make("cartpole", fmi_version=1)
    env.reset(seed=0)
    with pytest.raises(UnsupportedFeatureError, match="FMI 1.0 has no FMU state"):
        env.unwrapped.get_state()
    env.step(1)


def test_a_fresh_env_that_loads_a_state_still_checks_its_reset_rung(family_fmu: Callable[[str, int], Path]) -> None:
    """The leaky FMU's snapshots miss its noise generator: the rung check must still drop them
    after a set_state took the place of the first episode."""
    path = family_fmu("leaky_snapshot", 2)
    make = partial(FMUEnv, fmu=path, inputs=["u"], outputs=["x"], time_step=0.1, max_episode_steps=20)
    source = make()
    source.reset(seed=0)
    for _ in range(5):
        source.step(np.array([0.5]))
    state = source.get_state()
    fresh, loaded = make(), make()
    loaded.set_state(state)
    loaded.step(np.array([0.3]))
    actions = [np.array([0.5 * np.sin(k)]) for k in range(20)]
    for env in (fresh, loaded):
        env.reset(seed=1)
    assert [fresh.step(a)[0].tobytes() for a in actions] == [loaded.step(a)[0].tobytes() for a in actions]
    assert [fresh.reset()[0].tobytes()] + [fresh.step(a)[0].tobytes() for a in actions] == \
        [loaded.reset()[0].tobytes()] + [loaded.step(a)[0].tobytes() for a in actions]


def test_start_states_in_the_config_start_every_reset_from_one_of_them() -> None:
    env = modelicagym.make("cartpole")
    env.reset(seed=0)
    states = []
    for k in range(3):
        env.step(k % 2)
        states.append(env.unwrapped.get_state())
    times = {s.time for s in states}
    picky = modelicagym.make("cartpole", start_states=states, max_episode_steps=4)
    assert picky.unwrapped.step_path == "native" and not picky.unwrapped.reset_is_deterministic
    seen = []
    picky.reset(seed=7)
    for _ in range(40):
        seen.append(picky.unwrapped.time)
        if any(picky.step(0)[2:4]):
            picky.reset()
    assert set(seen) >= times and min(seen) >= min(times)
    again = modelicagym.make("cartpole", start_states=StartStates(states), max_episode_steps=4)
    again.reset(seed=7)
    replay = []
    for _ in range(40):
        replay.append(again.unwrapped.time)
        if any(again.step(0)[2:4]):
            again.reset()
    assert replay == seen
    with pytest.raises(ConfigError, match="start_states is empty"):
        modelicagym.make("cartpole", start_states=[])


def test_steps_after_a_loaded_state_are_not_taken_for_a_fresh_episode(caplog: pytest.LogCaptureFixture) -> None:
    """A fresh env records its first episode for the reset check; steps from a loaded state are not
    that episode, so its exact snapshot rung stays, with no warning."""
    env = modelicagym.make("cartpole", max_episode_steps=10)
    env.reset(seed=0)
    for _ in range(5):
        env.step(1)
    loaded = modelicagym.make("cartpole", max_episode_steps=10)
    loaded.unwrapped.set_state(env.unwrapped.get_state())
    for _ in range(3):
        loaded.step(0)
    for _ in range(3):
        loaded.reset()
        loaded.step(1)
    assert loaded.unwrapped.fmu.reset_rung == "snapshot" and "reset rung" not in caplog.text


def test_a_state_is_refused_by_the_same_fmu_with_a_changed_binary(tmp_path: Path,
                                                                  cartpole_fmu: Callable[..., Path]) -> None:
    """Same GUID, same model description, one byte more in the binary: a rebuilt FMU may lay its
    state out differently, so its content hash differs and the state is refused."""
    import zipfile

    source = cartpole_fmu(2)
    changed = tmp_path / "CartPole-rebuilt.fmu"
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(changed, "w") as new:
        for item in old.infolist():
            data = old.read(item)
            new.writestr(item.filename, data + b"\0" if item.filename.endswith(".so") else data)
    copy = tmp_path / "CartPole-copy.fmu"
    copy.write_bytes(source.read_bytes())
    env = modelicagym.make("cartpole")
    env.reset(seed=0)
    env.step(1)
    state = env.unwrapped.get_state()
    same = FMUEnv(fmu=copy, inputs=["f"], outputs=["x"], time_step=0.05)
    same.set_state(state)  # the same bytes elsewhere: accepted
    assert same.time == state.time
    rebuilt = FMUEnv(fmu=changed, inputs=["f"], outputs=["x"], time_step=0.05)
    with pytest.raises(StateMismatchError, match="a state loads only into the FMU it was saved from, unchanged"):
        rebuilt.set_state(state)


def test_a_gymnasium_made_env_has_no_step_count_of_its_own_and_resumes_a_state() -> None:
    """A state holds the env's own step count (``max_episode_steps`` truncates on it), not a
    wrapper's: ``gymnasium.make`` adds no ``TimeLimit`` (unless given ``max_episode_steps``), only
    wrappers without a state to lose; a state loaded after a ``reset`` goes on as its source."""
    source = modelicagym.make("cartpole")
    source.reset(seed=2)
    for action in (1, 1, 0, 1, 0):
        source.step(action)
    state = source.get_state()
    actions = [1, 0, 0, 1, 1, 1, 0, 0]
    expected = [pickle.dumps(source.step(a)[:4]) for a in actions]
    env = gym.make("ModelicaGym/CartPole-v0")
    chain = [env]
    while isinstance(chain[-1], gym.Wrapper):
        chain.append(chain[-1].env)
    assert [type(w).__name__ for w in chain[:-1]] == ["OrderEnforcing", "PassiveEnvChecker"]
    env.reset()  # OrderEnforcing's own flag: a step needs a reset first
    env.unwrapped.set_state(state)
    assert [pickle.dumps(env.step(a)[:4]) for a in actions] == expected
