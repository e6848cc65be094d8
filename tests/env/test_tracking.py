"""Tracking tasks from the config alone (``setpoints``, ``observe``, ``action_out_of_bounds``), on the
inertia (``modelicagym/samples/inertia``: a shaft whose speed ``w`` lags the torque ``tau`` by J/d = 10 s, a
load torque ``tau_load`` held, the angle ``phi`` integrating ``w``) and the room heater
(``tests/fmus/own_heater``): in `FMUEnv` on both step paths, with saved states, and in the pool; and
the task of ``modelicagym sample drive`` in a pool."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import modelicagym
from modelicagym import FMUEnv
from modelicagym.env.tracking import Schedule, uniform
from modelicagym.errors import ActionError, ConfigError

DT = 0.5


def shaft(path, **options) -> FMUEnv:
    """The inertia driven by ``tau`` in [-1, 1], its speed ``w`` to follow a setpoint drawn per episode
    under a load drawn per episode."""
    config = {"fmu": path, "inputs": ["tau"], "outputs": ["w", "phi"], "action_bounds": {"tau": (-1.0, 1.0)},
              "fixed_inputs": {"tau_load": uniform(-0.2, 0.0)}, "setpoints": {"w": uniform(100.0, 300.0)},
              "observe": ["setpoint", "error_integral", "previous_action", "tau_load"], "time_step": DT,
              "max_episode_steps": 20}
    return FMUEnv({**config, **options})


@pytest.fixture
def inertia(family_fmu) -> str:
    return str(family_fmu("inertia", 3))


def test_the_observation_holds_the_entries_after_the_outputs_with_their_bounds(inertia):
    env = shaft(inertia)
    assert env.observation_names == ["w", "phi", "setpoint:w", "error_integral:w", "previous_action", "tau_load"]
    assert env.observation_space.low.tolist() == [-np.inf, -np.inf, 100.0, -np.inf, -1.0, -0.2]
    assert env.observation_space.high.tolist() == [np.inf, np.inf, 300.0, np.inf, 1.0, 0.0]
    observation, _ = env.reset(seed=3)
    setpoint, load = env.episode_setpoints["w"], env.episode_parameters["tau_load"]
    assert observation.tolist() == [0.0, 0.0, setpoint, 0.0, 0.0, load]
    assert env.setpoints == {"w": setpoint} and 100.0 <= setpoint <= 300.0 and -0.2 <= load <= 0.0
    for observation in (env.step(np.array([a]))[0] for a in (0.5, -0.25, 1.0)):
        assert env.observation_space.contains(observation)
    assert observation[4] == 1.0 and observation[2] == setpoint
    env.reset(seed=4)
    assert env.episode_setpoints["w"] != setpoint  # drawn again, with the env's generator
    env.close()


def test_the_error_integral_sums_each_step_error_and_restarts_every_episode(inertia):
    env = shaft(inertia)
    for seed in (1, 2):
        observation, _ = env.reset(seed=seed)
        setpoint, integral = observation[2], 0.0
        for action in (1.0, 0.5, 0.2, 0.2):
            observation, *_ = env.step(np.array([action]))
            integral += (observation[0] - setpoint) * DT
            assert observation[3] == pytest.approx(integral, rel=1e-12)
        assert integral < -100.0
    env.close()


def test_entries_keep_the_native_step_path_and_match_the_python_one(inertia):
    runs = []
    for step_path in ("auto", "python"):
        env = shaft(inertia, step_path=step_path)
        env.reset(seed=7)
        runs.append([env.step(np.array([a]))[0].tolist() for a in (0.9, -0.3, 0.4, 0.0)])
        assert env.step_path == ("native" if step_path == "auto" else "python")
        env.close()
    assert runs[0] == runs[1]
    env = shaft(inertia)
    assert "the FMU steps in C" in env.step_path_reason and "error_integral:w" in env.step_path_reason
    env.close()


def test_setpoint_and_held_input_alone_let_c_write_the_inputs(inertia):
    env = shaft(inertia, setpoints={"w": 200.0}, observe=["setpoint", "error", "tau_load"])
    assert env.step_path == "native" and "the inputs" not in env.step_path_reason
    assert env.observation_space.low[2] == env.observation_space.high[2] == 200.0
    env.reset(seed=0)
    observation = env.step(np.array([0.5]))[0]
    assert observation[3] == observation[0] - 200.0
    env.close()


def test_a_schedule_steps_and_ramps_on_simulation_time(inertia, tmp_path):
    schedule = [(0.0, 100.0), (1.0, 100.0), (1.0, 200.0), (2.0, 200.0), (3.0, 300.0)]
    table = tmp_path / "ref.csv"
    table.write_text("time,value\n" + "\n".join(f"{t},{v}" for t, v in schedule) + "\n")
    for setpoint in (schedule, str(table)):
        env = shaft(inertia, setpoints={"w": setpoint}, observe=["setpoint"])
        assert (env.observation_space.low[2], env.observation_space.high[2]) == (100.0, 300.0)
        env.reset(seed=0)
        seen = [env.step(np.array([0.0]))[0][2] for _ in range(8)]  # t = 0.5, 1.0, ..., 4.0
        assert seen == [100.0, 200.0, 200.0, 200.0, 250.0, 300.0, 300.0, 300.0]
        env.close()
    assert Schedule(schedule).at(-1.0) == 100.0 and Schedule(schedule).at(2.5) == 250.0


def test_a_reward_reads_the_setpoint(inertia):
    env = shaft(inertia, observe=[], reward=lambda env, observation, action, terminated:
                -abs(observation[0] - env.setpoints["w"]))
    env.reset(seed=2)
    observation, reward, *_ = env.step(np.array([1.0]))
    assert observation.shape == (2,) and reward == -abs(observation[0] - env.episode_setpoints["w"])
    env.close()


def test_a_saved_state_carries_the_setpoint_the_previous_action_and_the_integral(inertia):
    for step_path in ("auto", "python"):
        env = shaft(inertia, step_path=step_path)
        env.reset(seed=5)
        for action in (0.8, 0.6):
            env.step(np.array([action]))
        state = pickle.loads(pickle.dumps(env.get_state()))
        after = [env.step(np.array([a]))[0].tolist() for a in (0.1, 0.3)]
        other = shaft(inertia, step_path=step_path)
        other.reset(seed=99)  # another setpoint, load and history
        other.set_state(state)
        assert [other.step(np.array([a]))[0].tolist() for a in (0.1, 0.3)] == after
        # a start from the state is a new episode: its setpoint and load, nothing kept of its steps
        observation, _ = other.reset(options={"state": state})
        assert observation[2] == after[0][2] and observation[3] == 0.0 and observation[4] == 0.0
        assert observation[5] == env.episode_parameters["tau_load"]
        env.close()
        other.close()


def test_clip_clips_a_box_action_and_error_refuses_it(inertia):
    env = shaft(inertia, action_out_of_bounds="clip")
    assert env.clips_actions
    env.reset(seed=0)
    observation = env.step(np.array([7.0]))[0]
    assert observation[4] == 1.0  # the previous action is the one applied
    with pytest.raises(ActionError, match="NaN"):
        env.step(np.array([np.nan]))
    env.close()
    env = shaft(inertia)
    env.reset(seed=0)
    with pytest.raises(ActionError, match="outside the bounds"):
        env.step(np.array([7.0]))
    env.close()


@pytest.mark.parametrize("options, message", [
    ({"observe": ["setpoint", "previous_actions"]},
     r"observe names 'previous_actions', which is neither .* Did you mean 'previous_action'\?"),
    ({"setpoints": {"ww": 100.0}}, r"setpoints names 'ww', which is not in 'outputs'. Did you mean 'w'\?"),
    ({"setpoints": {}, "observe": ["error_integral"]}, r"observe asks for 'error_integral', and 'setpoints' is empty"),
    ({"observe": ["setpoint:phi"]}, r"observe asks for 'setpoint:phi', and 'phi' has no setpoint"),
    ({"setpoints": {"w": [(1.0, 2.0), (0.0, 1.0)]}}, r"setpoint of 'w''s times must not decrease"),
    ({"action_out_of_bounds": "wrap"}, r"action_out_of_bounds must be one of \('error', 'clip'\)"),
])
def test_mistakes_are_one_line_that_names_them(inertia, options, message):
    with pytest.raises(ConfigError, match=message) as raised:
        shaft(inertia, **options).close()
    assert "\n" not in str(raised.value)


def test_a_temperature_setpoint_on_the_heater(family_fmu):
    config = {"fmu": str(family_fmu("own_heater", 2)), "inputs": ["u"], "outputs": ["T", "P"], "time_step": 60.0,
              "action_bounds": {"u": (0.0, 1.0)}, "setpoints": {"T": lambda rng: rng.uniform(18.0, 24.0)},
              "observe": ["setpoint", "error_integral"], "max_episode_steps": 10}
    env = FMUEnv(config)
    assert env.observation_space.low[2] == -np.inf  # a lambda's range is unknown
    observation, _ = env.reset(seed=0)
    assert 18.0 <= observation[2] <= 24.0 and env.step_path == "native"
    env.close()


@pytest.mark.processes
def test_a_pool_steps_the_task_as_single_envs_do(inertia, no_leaks):
    config = {"fmu": inertia, "inputs": ["tau"], "outputs": ["w", "phi"], "action_bounds": {"tau": (-1.0, 1.0)},
              "fixed_inputs": {"tau_load": lambda rng: rng.uniform(-0.2, 0.0)},
              "setpoints": {"w": lambda rng: rng.uniform(100.0, 300.0)}, "time_step": DT, "max_episode_steps": 3,
              "observe": ["setpoint", "error_integral", "previous_action", "tau_load"],
              "action_out_of_bounds": "clip"}
    actions = np.array([[0.5], [3.0]])  # the second is clipped to 1
    expected = []
    for seed, action in zip((5, 6), actions):
        env = FMUEnv(config)
        env.reset(seed=seed)
        expected.append([env.step(action)[0].tolist() for _ in range(3)])
        env.close()
    pool = modelicagym.make_vec(config, n=2, num_workers=1, autoreset_mode="SameStep")
    try:
        assert pool.call("step_path") == ("native", "native")
        pool.reset(seed=[5, 6])
        got = [pool.step(actions)[0] for _ in range(2)]
        saved = pool.get_states()  # the setpoint, the previous action and the integral go with it
        assert [s.task["previous_action"].tolist() for s in saved.states] == [[0.5], [1.0]]
        third, _, _, truncated, infos = pool.step(actions)  # the episodes end: autoreset, nothing kept of them
        assert truncated.all() and third[:, 3].tolist() == [0.0, 0.0] and third[:, 4].tolist() == [0.0, 0.0]
        assert [infos["final_obs"][k].tolist() for k in range(2)] == [runs[2] for runs in expected]
        pool.set_states(saved)
        assert pool.step(actions)[0].tolist() == third.tolist()
    finally:
        pool.close()
    assert [[step[k].tolist() for step in got] for k in range(2)] == [runs[:2] for runs in expected]


def test_a_task_file_s_table_is_beside_it_and_a_json_config_draws_uniformly(inertia, tmp_path):
    import json

    from modelicagym.task import load_config_file, load_task

    folder = tmp_path / "task"
    folder.mkdir()
    (folder / "ref.csv").write_text("0,100\n2,300\n")
    (folder / "task.py").write_text(f"config = {{'fmu': {inertia!r}, 'inputs': ['tau'], 'outputs': ['w'], "
                                    "'time_step': 0.5, 'setpoints': {'w': 'ref.csv'}, 'observe': ['setpoint']}\n")
    env = FMUEnv(load_task(folder / "task.py"))
    env.reset(seed=0)
    assert [env.step(np.array([0.0]))[0][1] for _ in range(5)] == [150.0, 200.0, 250.0, 300.0, 300.0]
    env.close()
    (folder / "task.json").write_text(json.dumps({
        "fmu": inertia, "inputs": ["tau"], "outputs": ["w"], "time_step": 0.5, "observe": ["setpoint", "tau_load"],
        "setpoints": {"w": {"uniform": [100, 300]}}, "fixed_inputs": {"tau_load": {"uniform": [-0.2, 0.0]}}}))
    env = FMUEnv(load_config_file(folder / "task.json"))
    assert env.observation_space.low[1:].tolist() == [100.0, -0.2] and env.observation_space.high[1:].tolist() == [
        300.0, 0.0]
    observation, _ = env.reset(seed=1)
    assert observation[1:].tolist() == [env.episode_setpoints["w"], env.episode_parameters["tau_load"]]
    env.close()


@pytest.mark.processes
def test_the_drive_sample_s_task_draws_per_env_and_per_episode_in_a_pool_and_its_pi_tracks(tmp_path, no_leaks):
    """`modelicagym sample drive`'s task, from an empty folder: each env of a pool draws its own
    setpoint and load, again at every autoreset, as a single env with the same seed does; the task's
    PI brings each env's motor to its setpoint."""
    from modelicagym.samples import write_sample
    from modelicagym.task import read_task_file

    write_sample("drive", tmp_path)
    tasks = [read_task_file(tmp_path / "drive_task.py") for _ in range(2)]  # a PI of its own for each env
    config, steps = tasks[0].config, tasks[0].config["max_episode_steps"]
    expected = []
    for seed, task in zip((5, 6), tasks):
        env = FMUEnv(config)
        observation, _ = env.reset(seed=seed)
        task.baseline.reset()
        run = [observation.tolist()]
        for _ in range(steps):
            observation = env.step(task.baseline.act(observation))[0]
            run.append(observation.tolist())
        expected.append(run)
        env.close()
    pool = modelicagym.make_vec(config, n=2, num_workers=1, autoreset_mode="SameStep")
    try:
        assert pool.call("step_path") == ("native", "native")
        observations, _ = pool.reset(seed=[5, 6])
        assert observations.tolist() == [run[0] for run in expected]
        for task in tasks:
            task.baseline.reset()
        for step in range(1, steps + 1):
            actions = np.array([task.baseline.act(o) for task, o in zip(tasks, observations)])
            observations, _, _, truncated, infos = pool.step(actions)
            if step < steps:
                assert observations.tolist() == [run[step] for run in expected]
        assert truncated.all() and [infos["final_obs"][k].tolist() for k in range(2)] == [run[-1] for run in expected]
        # the next episodes: new draws, from rest
        assert observations[:, 0].tolist() == [0.0, 0.0] and observations[:, 4].tolist() == [0.0, 0.0]
        for k in range(2):
            assert observations[k, [2, 5]].tolist() != [expected[k][0][2], expected[k][0][5]]
            assert 50.0 <= observations[k, 2] <= 200.0 and -1.0 <= observations[k, 5] <= 0.0
    finally:
        pool.close()
    assert expected[0][0][2:] != expected[1][0][2:]  # each env its own draws
    assert all(abs(run[-1][0] - run[-1][2]) < 0.5 for run in expected)  # the PI reached each setpoint
