"""The master algorithm (modelicagym/system/master.py, and in C: csrc/step.c, env/native_system.py):
a system's trajectories equal a co-simulation loop written by hand over FMPy
(tests/system_cases.py), for Gauss-Seidel and Jacobi, with a unit conversion on the feedback, on
both step paths; the native path equals the Python path bit for bit (model exchange and
co-simulation components mixed, substeps, tables); a time table driving an input, shifted per
episode; saved states covering every component; a component's failure truncates the episode."""

from __future__ import annotations

import numpy as np
import pytest
from system_cases import OUTPUTS, RPM, TIME_STEP, hand_loop, system_config

from modelicagym import FMUEnv
from modelicagym.system import SystemState

ACTIONS = np.sin(np.arange(60) * 0.2) * 1.2  # beyond +-1 now and then: the motor's command is not clipped by the env


@pytest.fixture
def system_fmus(family_fmu):
    return family_fmu("motor", 2), family_fmu("inertia", 3)


def run(env: FMUEnv, actions: np.ndarray, **reset_options) -> np.ndarray:
    rows = [env.reset(seed=0, **reset_options)[0]]
    rows += [env.step(np.array([a]))[0] for a in actions]
    return np.array(rows)


def unbounded(config: dict) -> dict:
    return {**config, "action_bounds": {"motor.u": (-2.0, 2.0)}}


@pytest.mark.parametrize("step_path", ["auto", "python"])
@pytest.mark.parametrize("master", ["gauss-seidel", "jacobi"])
def test_the_system_steps_as_a_hand_written_fmpy_loop(system_fmus, master, step_path):
    motor, inertia = system_fmus
    env = FMUEnv(unbounded(system_config(motor, inertia, master=master, step_path=step_path)))
    assert env.step_path == ("native" if step_path == "auto" else "python")
    actual = run(env, ACTIONS)
    env.close()
    expected = hand_loop(motor, inertia, ACTIONS, master)
    np.testing.assert_allclose(actual, expected, rtol=1e-12, atol=1e-12)
    assert np.abs(actual[:, 0]).max() > 1.0  # the shaft turned, so the feedback through rpm mattered


def test_gauss_seidel_and_jacobi_differ(system_fmus):
    motor, inertia = system_fmus
    results = []
    for master in ("gauss-seidel", "jacobi"):
        with FMUEnv(unbounded(system_config(motor, inertia, master=master))) as env:
            results.append(run(env, ACTIONS[:10]))
    assert not np.array_equal(*results)


def test_parameters_reach_their_components(system_fmus):
    motor, inertia = system_fmus
    parameters = {"motor.k": 0.9, "plant.J": 0.03}
    with FMUEnv(unbounded(system_config(motor, inertia, parameters=parameters))) as env:
        actual = run(env, ACTIONS[:20])
    np.testing.assert_allclose(actual, hand_loop(motor, inertia, ACTIONS[:20], "gauss-seidel", parameters),
                               rtol=1e-12, atol=1e-12)


def test_an_action_may_drive_a_tunable_parameter(system_fmus):
    motor, inertia = system_fmus
    config = system_config(motor, inertia, inputs=["motor.k"], fixed_inputs={"motor.u": 1.0},
                           action_bounds={"motor.k": (0.0, 1.0)})
    with FMUEnv(config) as env:
        env.reset(seed=0)
        strong = env.step(np.array([1.0]))[0]
        env.reset(seed=0)
        weak = env.step(np.array([0.1]))[0]
    assert strong[3] > weak[3] > 0  # the motor's torque


def test_model_exchange_and_co_simulation_mixed(system_fmus):
    motor, inertia = system_fmus
    cs = system_config(motor, inertia)
    me = {**cs, "fmus": {"motor": str(motor), "plant": {"fmu": str(inertia), "mode": "me"}}}
    with FMUEnv(unbounded(me)) as env:
        assert env.fmu.components["plant"].mode == "me"
        mixed = run(env, ACTIONS[:30])
    with FMUEnv(unbounded(cs)) as env:
        both_cs = run(env, ACTIONS[:30])
    np.testing.assert_allclose(mixed, both_cs, rtol=1e-5, atol=1e-6)  # CVode against RK4: alike, not equal


def test_substeps_are_communication_steps_within_an_env_step(system_fmus):
    motor, inertia = system_fmus
    with FMUEnv(system_config(motor, inertia, substeps=4)) as env:
        env.reset(seed=0)
        env.step(np.array([1.0]))
        assert env.time == pytest.approx(TIME_STEP)
        assert env.fmu.components["motor"].steps == 4


@pytest.mark.parametrize("master", ["gauss-seidel", "jacobi"])
@pytest.mark.parametrize("variant", ["cs", "me", "substeps"])
def test_the_native_path_steps_a_system_as_the_python_path(system_fmus, tmp_path, master, variant):
    motor, inertia = system_fmus
    table = tmp_path / "load.csv"
    table.write_text("time,torque\n0,0\n0.1,-0.05\n0.3,0.04\n")
    plant = {"fmu": str(inertia), "mode": "me"} if variant == "me" else str(inertia)
    config = unbounded(system_config(motor, inertia, master=master, substeps=3 if variant == "substeps" else 1,
                                     fmus={"motor": str(motor), "plant": plant, "load": str(table)},
                                     connections=[*system_config(motor, inertia)["connections"],
                                                  ("load.torque", "plant.tau_load")],
                                     outputs=[*OUTPUTS, "load.torque"]))
    runs = {}
    for step_path in ("auto", "python"):
        with FMUEnv({**config, "step_path": step_path}) as env:
            runs[env.step_path] = [run(env, ACTIONS[:40], options={"parameters": {"load.time_offset": offset}})
                                   for offset in (0.0, 0.07)]
            runs[env.step_path].append((env.time, env.fmu.components["load"].time, env.fmu.components["plant"].time))
    np.testing.assert_array_equal(np.array(runs["native"][:2]), np.array(runs["python"][:2]))
    assert runs["native"][2] == runs["python"][2]


@pytest.mark.parametrize("master", ["gauss-seidel", "jacobi"])
def test_c_resets_a_system_as_python_does(system_fmus, tmp_path, master, monkeypatch):
    """Once every FMU's snapshot rung is verified, C resets the system (each FMU's snapshot, the
    tables' clocks, the connections settled): the episodes are those of Python's resets."""
    from modelicagym.system import SystemInstance

    motor, inertia = system_fmus
    table = tmp_path / "load.csv"
    table.write_text("time,torque\n0,-0.01\n0.2,0.03\n")
    config = unbounded(system_config(motor, inertia, master=master,
                                     fmus={"motor": str(motor), "plant": {"fmu": str(inertia), "mode": "me"},
                                           "load": str(table)},
                                     connections=[*system_config(motor, inertia)["connections"],
                                                  ("load.torque", "plant.tau_load")],
                                     parameters={"load.time_offset": 0.05, "plant.J": 0.02}))
    python_resets = []
    original = SystemInstance.reset
    monkeypatch.setattr(SystemInstance, "reset", lambda self, values=None: (python_resets.append(1),
                                                                            original(self, values))[1])
    runs = {}
    for step_path in ("auto", "python"):
        python_resets.clear()
        with FMUEnv({**config, "step_path": step_path}) as env:
            runs[step_path] = [run(env, ACTIONS[:12]) for _ in range(6)]
        runs[step_path + " resets"] = len(python_resets)
    np.testing.assert_array_equal(np.array(runs["auto"]), np.array(runs["python"]))
    assert runs["python resets"] == 6 and runs["auto resets"] < 6


@pytest.mark.parametrize("step_path", ["auto", "python"])
def test_a_failing_component_truncates_the_episode_naming_it(system_fmus, family_fmu, step_path):
    motor, inertia = system_fmus
    config = system_config(motor, inertia, step_path=step_path,
                           fmus={"motor": str(motor), "plant": str(inertia), "probe": str(family_fmu("probe", 2))},
                           connections=[*system_config(motor, inertia)["connections"], ("motor.tau", "probe.force")],
                           parameters={"probe.fault": 2, "probe.fault_after": 5})
    with FMUEnv(config) as env:
        env.reset(seed=0)
        infos = [env.step(np.array([0.5]))[1:] for _ in range(6)]
        assert [truncated for _, _, truncated, _ in infos] == [False] * 5 + [True]
        assert "probe" in infos[-1][3]["fmu_error"] and "fmiDoStep" in infos[-1][3]["fmu_error"]
        env.reset(seed=0)  # the failed component is instantiated again
        assert not env.step(np.array([0.5]))[3]


@pytest.mark.parametrize("step_path", ["auto", "python"])
@pytest.mark.parametrize("action", [np.array([1.5]), np.array([np.nan]), np.array([1.5], dtype=np.float32),
                                    np.array([2]), np.array([[0.5]])])
def test_an_action_outside_the_space_is_refused_and_steps_no_component(system_fmus, step_path, action):
    motor, inertia = system_fmus
    with FMUEnv(system_config(motor, inertia, step_path=step_path)) as env:
        env.reset(seed=0)
        env.step(np.array([0.5]))
        before = env.unwrapped.fmu.save_state()
        with pytest.raises(ValueError, match=r"^invalid action .*the action space is Box"):
            env.step(action)
        assert env.time == TIME_STEP and env.elapsed_steps == 1
        assert [c.time for c in env.fmu.components.values()] == [TIME_STEP, TIME_STEP]
        after = env.step(np.array([0.5]))[0]
        env.unwrapped.fmu.load_state(before)
        env.elapsed_steps = 1
        assert np.array_equal(env.step(np.array([0.5]))[0], after)  # the refused action changed no input


@pytest.mark.parametrize("step_path", ["auto", "python"])
@pytest.mark.parametrize("master", ["gauss-seidel", "jacobi"])
def test_a_csv_table_drives_an_input_from_a_time_of_its_own_each_episode(system_fmus, tmp_path, master, step_path):
    motor, inertia = system_fmus
    table = tmp_path / "load.csv"
    times = np.arange(0.0, 10.0, 0.25)
    torque = -0.05 * np.cos(times)
    table.write_text("time,torque\n" + "".join(f"{float(t)!r},{float(y)!r}\n" for t, y in zip(times, torque)))
    config = system_config(motor, inertia, master=master, step_path=step_path,
                           fmus={"motor": str(motor), "plant": str(inertia), "load": str(table)},
                           connections=[*system_config(motor, inertia)["connections"], ("load.torque", "plant.tau_load")],
                           outputs=[*OUTPUTS, "load.torque"])
    with FMUEnv(unbounded(config)) as env:
        assert env.fmu.description.order[0] == "load"
        for offset in (0.0, 3.3):
            actual = run(env, ACTIONS[:25], options={"parameters": {"load.time_offset": offset}})
            times_seen = offset + TIME_STEP * np.arange(26)
            np.testing.assert_allclose(actual[:, -1], np.interp(times_seen, times, torque), rtol=0, atol=1e-15)
            expected = hand_loop(motor, inertia, ACTIONS[:25], master,
                                 load=lambda t, offset=offset: float(np.interp(t + offset, times, torque)))
            np.testing.assert_allclose(actual[:, :-1], expected, rtol=1e-12, atol=1e-12)


def test_saved_states_cover_every_component(system_fmus, tmp_path):
    motor, inertia = system_fmus
    table = tmp_path / "load.csv"
    table.write_text("time,torque\n0,0\n1,-0.1\n")
    config = system_config(motor, inertia, fmus={"motor": str(motor), "plant": str(inertia), "load": str(table)},
                           connections=[*system_config(motor, inertia)["connections"], ("load.torque", "plant.tau_load")])
    with FMUEnv(unbounded(config)) as env, FMUEnv(unbounded(config)) as other:
        run(env, ACTIONS[:15])
        state = env.get_state()
        assert isinstance(state.fmu, SystemState) and set(state.fmu.components) == {"motor", "plant", "load"}
        ahead = [env.step(np.array([a]))[0] for a in ACTIONS[15:30]]
        other.reset(seed=1)
        other.set_state(state)
        assert other.time == pytest.approx(15 * TIME_STEP)
        again = [other.step(np.array([a]))[0] for a in ACTIONS[15:30]]
    np.testing.assert_array_equal(np.array(ahead), np.array(again))


def test_the_feedback_is_converted_from_rad_per_s_to_rpm(system_fmus):
    motor, inertia = system_fmus
    config = system_config(motor, inertia, outputs=["plant.w", "motor.w"])
    with FMUEnv(config) as env:
        env.reset(seed=0)
        rows = np.array([env.step(np.array([1.0]))[0] for _ in range(5)])
    # Gauss-Seidel steps the motor first: it takes the speed the shaft had at the step's start
    assert rows[-1, 0] > 0
    np.testing.assert_allclose(rows[1:, 1], rows[:-1, 0] / RPM, rtol=1e-12)


def test_fmi_1_2_and_3_components_step_together(system_fmus):
    from fmu_family import BALL_DIR

    from modelicagym.fmu import UnsupportedFeatureError
    from modelicagym.fmu.build import build_source_fmu

    motor, inertia = system_fmus
    ball = build_source_fmu(BALL_DIR, 1, "me")  # FMI 1.0, model exchange: no dependencies declared
    config = system_config(motor, inertia, fmus={"motor": str(motor), "plant": {"fmu": str(inertia), "mode": "me"},
                                                 "ball": str(ball)},
                           connections=[*system_config(motor, inertia)["connections"], ("plant.w", "ball.a"),
                                        ("ball.v", "plant.tau_load")],
                           outputs=["plant.w", "ball.v", "ball.h"], parameters={"ball.h_0": 100.0})
    with FMUEnv(unbounded(config)) as env:
        assert [c.description.fmi_version for c in env.description.components.values()] == [2, 3, 1]
        first, second = run(env, ACTIONS[:20]), run(env, ACTIONS[:20])
        with pytest.raises(UnsupportedFeatureError, match="FMI 1.0 has no FMU state"):
            env.get_state()
    np.testing.assert_array_equal(first, second)  # every component's reset starts the same episode
    assert abs(first[-1, 1] + 9.81 * 20 * TIME_STEP) > 0.1  # not a free fall: the shaft's speed drives the ball
    # FMI 1.0 declares no dependencies: its outputs are taken to depend on every input, by the standard,
    # which closes a loop with the shaft's acceleration; it runs with a one-step delay, and says why it is one
    with FMUEnv({**config, "connections": [("plant.a", "ball.a"), ("ball.v", "plant.tau_load")]}) as env:
        assert env.metadata["loops"] == [
            ("loop plant.a -> ball.a, ball.v -> plant.tau_load: gauss-seidel reads ball.v -> plant.tau_load from the "
            "previous step (plant steps first in the loop); ball.v declares no dependencies, so FMI takes it to "
            "depend on every input, which closes this loop")]
