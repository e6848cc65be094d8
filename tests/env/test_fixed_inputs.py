"""``fixed_inputs``: the inputs an agent does not drive, held at a value (or one drawn per episode),
on the cooling consumer (``tests/fmus/consumer``), a test FMU in the shape of a third-party export:
six inputs, one a command, five the conditions it runs in."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from modelicagym import FMUEnv
from modelicagym.errors import ConfigError, ConfigTypeError
from modelicagym.vector import PoolVectorEnv

OUTPUTS = ["T_room", "T_return", "m_flow", "Q_flow"]
CONDITIONS = {"p_supply": 3e5, "p_return": 1.2e5, "T_supply": 279.15, "T_amb": 303.15, "Q_gain": 2000.0}


def consumer(path, **options) -> FMUEnv:
    """The consumer acting on its valve, the other inputs held at `CONDITIONS`."""
    config = {"fmu": path, "inputs": ["valve"], "outputs": OUTPUTS, "action_bounds": {"valve": (0.0, 1.0)},
              "fixed_inputs": CONDITIONS, "time_step": 60.0, "max_episode_steps": 30}
    return FMUEnv({**config, **options})


def room_after(env: FMUEnv, valve: float, steps: int = 30, **reset) -> float:
    env.reset(**reset)
    for _ in range(steps):
        observation, *_ = env.step(np.array([valve]))
    return float(observation[0])


def test_held_inputs_drive_the_model_and_hold_at_every_reset(family_fmu, fmi_version, fmu_mode):
    path = family_fmu("consumer", fmi_version)
    env = consumer(path, mode=fmu_mode)
    closed = [room_after(env, 0.0) for _ in range(3)]  # the later resets restore a snapshot: the values stay
    assert closed[0] == closed[1] == closed[2]
    # valve closed: the room tends to T_amb + Q_gain / G = 303.15 + 10 K from 297.15 K, with C / G = 2500 s
    assert closed[0] == pytest.approx(313.15 - 16.0 * np.exp(-1800.0 / 2500.0), abs=0.05)
    assert room_after(env, 1.0) < 290.0  # full flow of 6 degC water cools it
    assert env.episode_parameters["T_amb"] == 303.15
    env.close()
    hotter = consumer(path, mode=fmu_mode, fixed_inputs={**CONDITIONS, "T_amb": 313.15})
    assert room_after(hotter, 0.0) > closed[0] + 4.0
    hotter.close()


def test_held_inputs_give_the_same_steps_on_both_step_paths(family_fmu):
    path = family_fmu("consumer", 2)
    runs = []
    for step_path in ("auto", "python"):
        env = consumer(path, step_path=step_path)
        env.reset(seed=0)
        runs.append([env.step(np.array([a]))[0].tolist() for a in (0.2, 1.0, 0.5, 0.0)])
        env.close()
    assert runs[0] == runs[1]


def test_a_held_input_may_be_drawn_every_episode(family_fmu):
    env = consumer(family_fmu("consumer", 2), fixed_inputs={**CONDITIONS, "T_amb": lambda rng: rng.uniform(283.15, 313.15)})
    assert not env.reset_is_deterministic
    drawn, rooms = [], []
    for seed in (1, 2, 1):
        rooms.append(room_after(env, 0.0, seed=seed))
        drawn.append(env.episode_parameters["T_amb"])
    assert drawn[0] == drawn[2] != drawn[1] and all(283.15 <= t <= 313.15 for t in drawn)
    assert rooms[0] == rooms[2] != rooms[1]
    env.close()


@pytest.mark.parametrize("options, message", [
    ({"fixed_inputs": {**CONDITIONS, "T_ambient": 300.0}},
     r"fixed_inputs names 'T_ambient', which is not an input of this FMU. Did you mean 'T_amb'\?"),
    ({"fixed_inputs": {**CONDITIONS, "valve": 0.5}},
     (r"^'valve' is in both 'inputs' \(driven by the action\) and 'fixed_inputs' \(held at a value\): keep it in "
      r"one of them$")),
    ({"fixed_inputs": {**CONDITIONS, "UA": 100.0}},
     r"fixed_inputs names 'UA', which is not an input \(causality 'parameter'\): put it in 'parameters'"),
    ({"fixed_inputs": {**CONDITIONS, "m_flow": 1.0}},
     r"fixed_inputs names 'm_flow', which is not an input \(causality 'output'\): only inputs are held"),
    ({"parameters": {"T_amb": 290.0}}, r"'T_amb' is in both 'parameters'"),
    ({"action_bounds": {"valve": None}},
     (r"^action_bounds of 'valve' is still None, the placeholder `modelicagym info` writes where nothing in the FMU "
      r"says an input's range: give each a \(low, high\) pair")),
])
def test_mistakes_are_one_line_that_names_them(family_fmu, options, message):
    with pytest.raises(ConfigError, match=message) as raised:
        consumer(family_fmu("consumer", 2), **options).close()
    assert "\n" not in str(raised.value)


def test_a_held_value_of_the_wrong_type_is_refused_at_construction(family_fmu):
    with pytest.raises(ConfigTypeError, match=r"fixed input 'T_amb' \(Real\) needs a float value, got 'warm'"):
        consumer(family_fmu("consumer", 2), fixed_inputs={**CONDITIONS, "T_amb": "warm"})
    with pytest.raises(ConfigTypeError, match=r"fixed_inputs must be \{input: value\}"):
        consumer(family_fmu("consumer", 2), fixed_inputs=[("T_amb", 300.0)])


@pytest.fixture
def consumer_fmu(family_fmu) -> str:
    """The consumer FMU, built (and its binary tried) before ``no_leaks`` takes its snapshot."""
    return family_fmu("consumer", 2)


@pytest.mark.processes
def test_a_pool_holds_the_inputs_as_a_single_env_does(consumer_fmu, no_leaks):
    path = consumer_fmu
    options = {"fixed_inputs": {**CONDITIONS, "T_amb": lambda rng: rng.uniform(283.15, 313.15)}}
    actions = np.array([[0.0], [1.0]])
    expected = []
    for seed, action in zip((5, 6), actions):
        env = consumer(path, **options)
        env.reset(seed=seed)
        expected.append([env.step(action)[0].tolist() for _ in range(3)])
        env.close()
    pool = PoolVectorEnv([functools.partial(consumer, path, **options)] * 2, num_workers=2)
    try:
        pool.reset(seed=[5, 6])
        got = [pool.step(actions)[0].tolist() for _ in range(3)]
    finally:
        pool.close()
    assert [[step[k] for step in got] for k in range(2)] == expected
