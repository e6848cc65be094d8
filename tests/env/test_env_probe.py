"""`FMUEnv` on the Probe test FMU: spaces of every kind, the Gymnasium contract, what the model
computes, the episode ends an FMU can cause (terminated, error, crash), start time, logging, and
clear errors for every kind of bad input."""

from __future__ import annotations

import logging
import signal
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest
from episodes import observations
from fmu_family import FAULTS, MODES, probe_variables
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env

from modelicagym import FMUEnv
from modelicagym.fmu import FMUCallError, VariableError


@pytest.fixture
def make_env(family_fmu):
    """``make_env(name, fmi_version, **config)`` -> FMUEnv on a family member (by default every
    probe variable in and out); closed after the test."""
    made: list[FMUEnv] = []

    def make(name: str, fmi_version: int, **config) -> FMUEnv:
        fmu = family_fmu(name, fmi_version)
        inputs, outputs = probe_variables(fmu)
        config.setdefault("inputs", inputs)
        config.setdefault("outputs", outputs)
        env = FMUEnv(fmu=fmu, **config)
        made.append(env)
        return env

    yield make
    for env in made:
        env.close()


def full_action(fmi_version: int, gear=3, mode="cool", enable=True, boost=True, force=0.5, u=(0.5, -1.0, 0.25),
                trim=-7, tag=2**64 - 5):
    action = {"gear": gear, "mode": MODES[mode], "enable": int(enable), "boost": int(boost), "force": np.array(force)}
    if fmi_version == 3:
        action.update(u=np.array(u), trim=trim, tag=tag)
    return action


# -- spaces and the Gymnasium contract --------------------------------------------------------


@pytest.mark.parametrize(
    "inputs, expected",
    [
        (["gear"], spaces.Discrete(5)),
        (["mode"], spaces.Discrete(3, start=1)),
        (["enable", "boost"], spaces.MultiBinary(2)),
        (["gear", "mode"], spaces.MultiDiscrete([5, 3], start=[0, 1])),
        (["force"], spaces.Box(-10.0, 10.0, (1,), np.float64)),
        (None, None),  # every input: a Dict
    ],
    ids=["Discrete", "Discrete-enum", "MultiBinary", "MultiDiscrete", "Box", "Dict"],
)
def test_env_checker_passes_for_every_kind_of_action_space(make_env, fmi_version, inputs, expected):
    config = {"inputs": inputs} if inputs else {}
    env = make_env("probe", fmi_version, max_episode_steps=20, parameters={"enable": True}, **config)
    if expected is not None:
        assert env.action_space == expected
    else:
        assert isinstance(env.action_space, spaces.Dict)
        assert set(env.action_space.keys()) == set(probe_variables(env.description)[0])
    assert isinstance(env.observation_space, spaces.Dict)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded observation spaces
        check_env(env, skip_render_check=True)
    for _ in range(3):  # random actions of the space drive the FMU and observations stay inside
        env.reset(seed=1)
        for _ in range(5):
            observation, *_ = env.step(env.action_space.sample())
            assert env.observation_space.contains(observation)


def test_observations_follow_the_model_equations(make_env, fmi_version):
    env = make_env("probe", fmi_version)
    observation, info = env.reset()
    assert info == {}
    assert observation["steps"] == 0 and observation["clock"] == 0.0 and observation["mode_out"] == 1
    observation, reward, terminated, truncated, info = env.step(full_action(fmi_version))
    assert (reward, terminated, truncated, info) == (1.0, False, False, {})
    speed = 3 * -1 * 2  # gear * direction(cool) * boost
    assert observation["speed"] == speed
    assert observation["mode_out"] == MODES["cool"]
    assert observation["moving"] == 1
    assert observation["steps"] == 1
    assert observation["clock"] == pytest.approx(0.1, abs=1e-15)
    assert observation["position"] == pytest.approx((speed + 0.5) * 0.1, abs=1e-12)
    if fmi_version == 3:
        u = np.array([0.5, -1.0, 0.25])
        np.testing.assert_allclose(observation["y"], [3 * u, u + 0.1], rtol=0, atol=1e-15)
        np.testing.assert_array_equal(observation["positive"], [1, 0, 1])
        assert observation["ticks"] == 10**12 and observation["ticks"].dtype == np.int64
        assert observation["thrust"] == 0.5 and observation["thrust"].dtype == np.float32
        assert observation["level"] == 1000 - 70
        assert observation["tag_out"] == 2**64 - 5 and observation["tag_out"].dtype == np.uint64
    observation, *_ = env.step(full_action(fmi_version, enable=False, force=-2.0))
    assert observation["speed"] == 0 and observation["moving"] == 1 and observation["steps"] == 2
    if fmi_version == 3:
        assert observation["ticks"] == 2 * 10**12
    assert observation["position"] == pytest.approx((speed + 0.5) * 0.1 - 0.2, abs=1e-12)


def test_flat_discrete_spaces_move_values_of_different_fmi_types(make_env, fmi_version):
    """gear (Integer) and mode (Enumeration) share one MultiDiscrete action, speed (Integer) and
    mode_out (Enumeration) one MultiDiscrete observation, though the FMI moves them with different
    calls in FMI 3.0 and different declared types in FMI 2.0."""
    env = make_env("probe", fmi_version, inputs=["gear", "mode"], outputs=["speed", "mode_out"],
                   parameters={"enable": True})
    assert isinstance(env.observation_space, spaces.MultiDiscrete)
    observation, _ = env.reset()
    np.testing.assert_array_equal(observation, [0, 1])
    assert env.observation_space.contains(observation)
    observation, *_ = env.step(np.array([4, MODES["heat"]]))
    np.testing.assert_array_equal(observation, [4, MODES["heat"]])
    observation, *_ = env.step(np.array([2, MODES["cool"]]))
    np.testing.assert_array_equal(observation, [-2, MODES["cool"]])
    assert env.observation_space.contains(observation)


def test_fmi3_value_types_round_trip_through_step(make_env, fmu_mode):
    """Int8 and UInt64 inputs, Float32, UInt16 and UInt64 outputs, exactly: 2**64 - 5 does not survive
    a float64 on the way, and the model rounds gain * force to Float32."""
    env = make_env("probe", 3, inputs=["force", "trim", "tag"], outputs=["thrust", "level", "tag_out"], mode=fmu_mode)
    assert env.action_space["trim"] == spaces.Discrete(201, start=-100)
    assert env.action_space["tag"] == spaces.Box(0, 2**64 - 1, (), np.uint64)
    assert env.observation_space["thrust"] == spaces.Box(-np.inf, np.inf, (), np.float32)
    assert env.observation_space["level"] == spaces.Box(0, 2**16 - 1, (), np.int64)
    assert env.observation_space["tag_out"] == spaces.Box(0, 2**64 - 1, (), np.uint64)
    observation, _ = env.reset()
    assert (observation["thrust"], observation["level"], observation["tag_out"]) == (0.0, 1000, 0)
    for force, trim, tag in [(0.1, -100, 2**64 - 5), (-3.3, 100, 2**63), (10.0, 0, 0), (-0.7, 55, 2**64 - 1)]:
        observation, *_ = env.step({"force": np.array(force), "trim": trim, "tag": tag})
        assert env.observation_space.contains(observation)
        assert observation["thrust"].dtype == np.float32 and observation["thrust"] == np.float32(force)
        assert observation["level"] == 1000 + 10 * trim
        assert observation["tag_out"].dtype == np.uint64 and int(observation["tag_out"]) == tag
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded observation spaces
        check_env(env, skip_render_check=True)


@pytest.mark.parametrize(
    "inputs, outputs, action, expected",
    [
        (["tag"], ["tag_out"], 2**64 - 5, np.uint64(2**64 - 5)),
        (["trim"], ["level"], -100, np.int64(0)),
        (["force"], ["thrust"], np.array([0.1]), np.array([0.1], dtype=np.float32)),
    ],
    ids=["UInt64", "Int8-UInt16", "Float32"],
)
def test_fmi3_value_types_in_flat_spaces(make_env, inputs, outputs, action, expected):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. gymnasium's warning for float64 bounds of a float32 Box
        env = make_env("probe", 3, inputs=inputs, outputs=outputs)
    assert env.observation_space.dtype == expected.dtype and env.observation_space.shape == expected.shape
    env.reset()
    observation, *_ = env.step(action)
    assert observation.dtype == expected.dtype and observation == expected
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded observation spaces
        check_env(env, skip_render_check=True)


def test_tunable_parameter_mid_episode_and_fixed_one_refused(make_env):
    env = make_env("probe", 2, inputs=["force"], outputs=["position"])
    env.reset()
    env.fmu.set_values({"gain": 3.0})
    observation, *_ = env.step(np.array([1.0]))
    assert observation[0] == pytest.approx(0.3, abs=1e-12)
    with pytest.raises(FMUCallError, match="cannot be set in step mode"):
        env.fmu.set_values({"position_0": 1.0})
    env.reset()  # back to the configured values: gain = 1
    observation, *_ = env.step(np.array([1.0]))
    assert observation[0] == pytest.approx(0.1, abs=1e-12)


# -- episode ends caused by the FMU -----------------------------------------------------------


def test_discard_with_terminated_ends_the_episode(make_env, fmi_version):
    env = make_env("probe", fmi_version, parameters={"fault": FAULTS["terminate"], "fault_after": 3})
    for episode in range(2):
        env.reset()
        for k in range(3):
            observation, reward, terminated, truncated, info = env.step(full_action(fmi_version))
            assert (terminated, truncated, info) == (False, False, {})
        observation, reward, terminated, truncated, info = env.step(full_action(fmi_version))
        assert terminated and not truncated, f"episode {episode}"
        assert info == {"fmu_terminated": True}
        assert reward == env.negative_reward
        assert observation["steps"] == 3
        assert not env.fmu.broken


def test_error_truncates_with_the_fmu_message_and_reset_recovers(make_env, fmi_version, monkeypatch, caplog):
    env = make_env("probe", fmi_version, parameters={"fault": FAULTS["error"], "fault_after": 3})
    actions = [full_action(fmi_version, gear=k % 5) for k in range(10)]
    observation, _ = env.reset()
    first = [observation]
    for action in actions[:3]:
        observation, reward, terminated, truncated, info = env.step(action)
        assert (terminated, truncated, info) == (False, False, {})
        first.append(observation)
    with caplog.at_level(logging.WARNING):
        observation, reward, terminated, truncated, info = env.step(actions[3])
    assert truncated and not terminated and reward == 0.0
    assert "injected fault: doStep at t=0.3 fails after 3 steps" in info["fmu_error"]
    assert "returned Error" in info["fmu_error"]
    assert env.fmu.broken
    assert observation["steps"] == 3  # the last good outputs
    assert any("injected fault" in r.getMessage() and r.levelno == logging.ERROR for r in caplog.records)

    instantiations = []
    instantiate = env.fmu.binding.instantiate
    monkeypatch.setattr(env.fmu.binding, "instantiate", lambda *a: (instantiations.append(a), instantiate(*a)))
    replay = observations(env, actions)  # same parameters: a new instance, the same 3 good steps, the same error
    assert len(instantiations) == 1
    assert len(replay) == 5
    for a, b in zip(first, replay):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name])
    normal = observations(env, actions, options={"parameters": {"fault": FAULTS["none"]}})
    assert len(instantiations) == 2  # the error broke the instance again
    assert len(normal) == 11 and normal[-1]["steps"] == 10 and not env.fmu.broken
    for a, b in zip(first, normal):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name])


@pytest.mark.processes
def test_segfault_kills_only_the_child_process(family_fmu, fmi_version):
    probe = family_fmu("probe", fmi_version)
    script = textwrap.dedent(
        f"""
        import numpy as np
        from modelicagym import FMUEnv
        env = FMUEnv(fmu={str(probe)!r}, inputs=["force"], outputs=["steps"],
                     parameters={{"fault": {FAULTS["crash"]}, "fault_after": 2}})
        env.reset()
        for k in range(5):
            observation, *_ = env.step(np.array([0.0]))
            print("step", k, int(observation["steps"] if isinstance(observation, dict) else observation), flush=True)
        print("survived", flush=True)
        """
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == -signal.SIGSEGV, result.stderr
    assert result.stdout.split("\n")[:2] == ["step 0 1", "step 1 2"]
    assert "survived" not in result.stdout
    # the parent is fine and can run the same FMU
    env = FMUEnv(fmu=probe, inputs=["force"], outputs=["steps"])
    env.reset()
    for k in range(5):
        observation, *_ = env.step(np.array([0.0]))
    assert observation == 5
    env.close()


# -- time -------------------------------------------------------------------------------------


def test_nonzero_start_time_without_drift(make_env, fmi_version, fmu_mode):
    env = make_env("probe_late", fmi_version, inputs=["force"], outputs=["clock", "position"], mode=fmu_mode)
    dt = env.time_step
    assert dt == 0.1
    for episode in range(2):
        observation, _ = env.reset()
        assert env.time == 10.0 and observation[0] == 10.0
        for k in range(1, 10_001 if episode == 0 else 11):
            observation, *_ = env.step(np.array([1.0]))
            assert env.time == 10.0 + k * dt
        assert observation[0] == pytest.approx(env.time, rel=1e-13)  # the FMU's own time
        assert observation[1] == pytest.approx((k * dt), rel=1e-9)


def test_start_time_from_the_config_overrides_the_model(make_env):
    env = make_env("probe", 2, inputs=["force"], outputs=["clock"], start_time=-3.0, time_step=0.25)
    observation, _ = env.reset()
    assert env.time == -3.0 and observation[0] == -3.0
    for k in range(1, 9):
        observation, *_ = env.step(np.array([0.0]))
        assert env.time == -3.0 + k * 0.25 and observation[0] == pytest.approx(env.time, abs=1e-15)


# -- logging ----------------------------------------------------------------------------------


def test_fmu_messages_go_to_logging_not_stdout(make_env, fmi_version, caplog, capfd):
    env = make_env("probe", fmi_version, inputs=["force"], outputs=["steps"], logging_on=True,
                   parameters={"fault": FAULTS["terminate"], "fault_after": 1})
    with caplog.at_level(logging.DEBUG, logger="modelicagym.fmu"):
        env.reset()
        env.step(np.array([0.0]))
        *_, info = env.step(np.array([0.0]))
        assert info == {"fmu_terminated": True}
        env.reset(options={"parameters": {"fault": FAULTS["error"], "fault_after": 0}})
        *_, info = env.step(np.array([0.0]))
        assert "injected fault: doStep at t=0 fails" in info["fmu_error"]
    records = [(r.levelno, r.getMessage()) for r in caplog.records if r.name == "modelicagym.fmu.Probe"]
    assert (logging.DEBUG, "Probe [logEvents] injected fault: the model ends the simulation at t=0.1") in records
    assert (logging.ERROR, "Probe [logStatusError] injected fault: doStep at t=0 fails after 0 steps") in records
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_debug_messages_only_when_logging_is_on(make_env, caplog):
    env = make_env("probe", 2, inputs=["force"], outputs=["steps"],
                   parameters={"fault": FAULTS["terminate"], "fault_after": 0})
    with caplog.at_level(logging.DEBUG, logger="modelicagym.fmu"):
        env.reset()
        *_, info = env.step(np.array([0.0]))
    assert info == {"fmu_terminated": True}
    assert [r for r in caplog.records if r.name == "modelicagym.fmu.Probe"] == []


# -- bad input --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "config, error, patterns",
    [
        ({"inputs": ["gaer"]}, VariableError, ["no input named 'gaer'", "Did you mean 'gear'"]),
        ({"outputs": ["postion"]}, VariableError, ["'postion'", "Did you mean 'position'"]),
        ({"parameters": {"fault_afer": 1}}, VariableError, ["'fault_afer'", "Did you mean 'fault_after'"]),
        ({"inputs": ["position"]}, VariableError, ["'position' cannot be an action", "causality 'output'", "gear"]),
        ({"parameters": {"limit": 1.0}}, VariableError, ["'limit' cannot be set", "calculatedParameter"]),
        ({"parameters": {"steps": 1}}, VariableError, ["'steps' cannot be set"]),
        ({"termination": {"postion": (-1, 1)}}, VariableError, ["Did you mean 'position'"]),
        ({"termination": {"clock": (-1, 1)}}, ValueError, ["'clock', which is not in 'outputs'"]),
        ({"time_stepp": 0.1}, TypeError, ["unknown FMUEnv config key 'time_stepp'", "Did you mean 'time_step'"]),
        ({"time_step": -1.0}, ValueError, ["time_step must be positive"]),
        ({"mode": "xx"}, ValueError, ["mode must be one of"]),
        ({"reset_rung": "sometimes"}, ValueError, ["reset_rung must be"]),
    ],
    ids=lambda x: None,
)
def test_configuration_errors_are_clear(make_env, config, error, patterns):
    config = {"inputs": ["force"], "outputs": ["position"], **config}
    with pytest.raises(error) as raised:
        make_env("probe", 2, **config)
    for pattern in patterns:
        assert pattern in str(raised.value)


def test_parameter_values_the_fmu_rejects_surface_its_message(make_env):
    env = make_env("probe", 2, inputs=["force"], outputs=["position"], parameters={"fault_after": -1})
    with pytest.raises(FMUCallError, match=r"invalid values: .*fault_after=-1"):
        env.reset()
    observation, _ = env.reset(options={"parameters": {"fault_after": 0}})  # recovers
    assert observation[0] == 0.0
    with pytest.raises(VariableError, match="Did you mean 'gain'"):
        env.reset(options={"parameters": {"gian": 2.0}})


@pytest.mark.parametrize(
    "inputs, action, problem",
    [
        (["force"], np.array([1.0, 2.0]), "expected shape (1,), got shape (2,)"),
        (["force"], np.array([np.nan]), "NaN"),
        (["force"], np.array([10.5]), "outside the bounds"),
        (["force"], np.array([-10.5], dtype=np.float32), "outside the bounds"),
        (["force"], np.array([11]), "outside the bounds"),
        (["force"], np.array([np.inf]), "NaN or infinity"),
        (["force"], "push", "expected numbers"),
        (["gear"], 5, "out of range [0, 4]"),
        (["gear"], 1.5, "expected integers"),
        (["gear"], np.array([1, 2]), "expected a single integer"),
        (["mode"], 0, "out of range [1, 3]"),
        (["gear", "mode"], np.array([4, 4]), "out of range"),
        (["gear", "mode"], np.array([1]), "expected shape (2,)"),
        (["enable", "boost"], np.array([1, 2]), "expected 0 or 1"),
        (["gear", "force"], {"gear": 1}, "expected a dict with keys ['force', 'gear']"),
        (["gear", "force"], {"gear": 1, "force": np.array(11.0)}, "'force': outside the bounds"),
    ],
    ids=lambda x: None,
)
def test_invalid_actions_name_the_action_and_the_space(make_env, inputs, action, problem):
    env = make_env("probe", 2, inputs=inputs, outputs=["position"])
    env.reset()
    with pytest.raises(ValueError) as raised:
        env.step(action)
    message = str(raised.value)
    assert problem in message
    assert message.startswith(f"invalid action {action!r}"[:40])
    assert str(env.action_space) in message
    assert env.time == 0.0  # nothing reached the FMU


@pytest.mark.parametrize("step_path", ["auto", "python"])
@pytest.mark.parametrize("value", [np.inf, -np.inf, np.nan])
def test_an_action_that_is_not_finite_is_refused_within_infinite_bounds(make_env, step_path, value):
    """An array action's values are checked in C on the native path (bounds, finite), as
    `check_action` checks them on the Python path: the same error, nothing stepped."""
    env = make_env("probe", 2, inputs=["force"], outputs=["position"], step_path=step_path,
                   action_space=spaces.Box(-np.inf, np.inf, (1,), np.float64))
    assert env.step_path == ("native" if step_path == "auto" else "python")
    env.reset()
    with pytest.raises(ValueError, match=r"^invalid action array\(\[-?(inf|nan)\]\): it contains NaN or infinity"):
        env.step(np.array([value]))
    assert env.time == 0.0 and env.elapsed_steps == 0
    env.step(np.array([1e300]))  # any finite value passes
    assert env.time > 0.0


def test_tunable_parameters_can_be_actions(make_env, fmi_version, fmu_mode):
    """FMI lets a master change a tunable parameter between steps: it may be driven by an action
    (``gain``: position' = speed + gain * force; ``limit`` = 10 * gain)."""
    env = make_env("probe", fmi_version, inputs=["force", "gain"], outputs=["position", "limit"],
                   parameters={"gear": 0, "enable": True}, time_step=1.0, mode=fmu_mode)
    assert env.reset(seed=0)[0].tolist() == [0.0, 10.0]
    assert env.step(np.array([1.0, 0.5]))[0].tolist() == [0.5, 5.0]
    assert env.step(np.array([1.0, 2.0]))[0].tolist() == [2.5, 20.0]
    assert env.reset()[0].tolist() == [0.0, 10.0], "a reset brings the parameter back to its start value"


def test_a_fixed_parameter_cannot_be_an_action(make_env, fmi_version):
    with pytest.raises(VariableError, match="'position_0' cannot be an action.*tunable parameters: gain"):
        make_env("probe", fmi_version, inputs=["position_0"], outputs=["position"])
