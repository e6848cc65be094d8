"""The reset ladder on the test FMUs: every rung replays a fresh episode bit for bit (FMI 2 and 3,
co-simulation and model exchange); FMUs without snapshots start at ``"reset"``; a buggy
``fmiReset`` is caught and demoted with a warning; once-per-process FMUs are never instantiated
twice."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from episodes import observations
from fmpy import extract
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmu_family import BALL_OUTPUTS, FAULTS, probe_variables, rewrite

from modelicagym import FMUEnv
from modelicagym.fmu import FMUError, FMUInstance, UnsupportedFeatureError, open_fmu
from modelicagym.fmu.instance import RUNGS


def config(model: str, fmu: Path) -> dict:
    """Inputs, outputs and per-episode parameters for a model of the family."""
    if model == "ball":
        return dict(inputs=["a"], outputs=BALL_OUTPUTS, n_steps=40,
                    other={"e": 0.6, "h_0": 1.4, "t_switch": 0.7})
    inputs, outputs = probe_variables(fmu)
    return dict(inputs=inputs, outputs=outputs, n_steps=20, other={"position_0": 2.0, "gain": 0.5})


def flat(observation) -> np.ndarray:
    if isinstance(observation, dict):
        return np.concatenate([np.ravel(observation[k]).astype(float) for k in sorted(observation)])
    return np.ravel(observation).astype(float)


def episode(env: FMUEnv, actions, parameters=None) -> np.ndarray:
    """One episode, none of whose steps ends it, as one flat array of its observations and end time."""
    rows = observations(env, actions, options={"parameters": parameters} if parameters else None)
    assert len(rows) == len(actions) + 1, "the episode ended early"
    return np.concatenate([*map(flat, rows), [env.time]])


def fixed_actions(env: FMUEnv, n: int, seed: int) -> list:
    env.action_space.seed(seed)
    return [env.action_space.sample() for _ in range(n)]


def identical(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("rung", RUNGS)
@pytest.mark.parametrize("model", ["probe", "ball"])
def test_every_rung_replays_a_fresh_episode_bit_for_bit(family_fmu, model, fmi_version, fmu_mode, rung, caplog):
    fmu = family_fmu(model, fmi_version)
    c = config(model, fmu)
    make = lambda **kw: FMUEnv(fmu=fmu, inputs=c["inputs"], outputs=c["outputs"], mode=fmu_mode, **kw)  # noqa: E731
    fresh = make()
    actions = fixed_actions(fresh, c["n_steps"], seed=3)
    other_actions = fixed_actions(fresh, c["n_steps"], seed=4)
    expected = episode(fresh, actions)
    expected_other = episode(make(), other_actions, c["other"])
    fresh.close()

    env = make(reset_rung=rung)
    with caplog.at_level(logging.WARNING):
        runs = [episode(env, actions), episode(env, other_actions, c["other"]), episode(env, actions),
                episode(env, actions), episode(env, other_actions, c["other"])]
    assert env.fmu.reset_rung == rung
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []
    for k in (0, 2, 3):
        assert identical(runs[k], expected), f"episode {k}"
    for k in (1, 4):
        assert identical(runs[k], expected_other), f"episode {k}"
    assert not identical(expected, expected_other)
    env.close()


def test_without_snapshots_auto_picks_reset_and_snapshot_is_refused(family_fmu, fmi_version, caplog):
    path = family_fmu("probe_late", fmi_version)
    env = FMUEnv(fmu=path, inputs=["force", "gear"], outputs=["position", "steps", "clock"])
    assert env.fmu.reset_rung == "reset"
    actions = fixed_actions(env, 10, seed=5)
    with caplog.at_level(logging.WARNING):
        runs = [episode(env, actions) for _ in range(3)]
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []
    assert env.fmu.reset_rung == "reset"
    assert identical(runs[0], runs[1]) and identical(runs[0], runs[2])
    # the FMU really cannot snapshot: a runtime that tried would have been told so
    with pytest.raises(FMUError, match="getFMUstate is not supported"):
        env.fmu.binding.get_state()
    env.close()
    with pytest.raises(UnsupportedFeatureError, match="canGetAndSetFMUstate is false"):
        FMUEnv(fmu=path, inputs=["force"], outputs=["position"], reset_rung="snapshot")
    with pytest.raises(UnsupportedFeatureError, match="reset_rung='reset' or 'reinstantiate'"):
        FMUInstance(path, reset_rung="snapshot")


def test_the_buggy_reset_is_really_buggy(family_fmu, fmi_version, tmp_path):
    """Straight through fmpy: after fmiReset the step counter of probe*_buggy keeps its value."""
    for name, expected in (("probe_buggy", 3), ("probe", 0)):
        path = family_fmu(name, fmi_version)
        description = open_fmu(path)
        version = description.fmi_version
        cls = FMU2Slave if version == 2 else FMU3Slave
        fmu = cls(guid=description.guid, modelIdentifier="Probe", unzipDirectory=extract(path, tmp_path / name),
                  instanceName="raw")
        fmu.instantiate()
        steps_vr = [description.variable("steps").value_reference]
        get_steps = fmu.getInteger if version == 2 else fmu.getInt32
        for episode in range(2):
            if version == 2:
                fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            if episode == 1:
                break
            for k in range(3):
                fmu.doStep(currentCommunicationPoint=0.1 * k, communicationStepSize=0.1)
            assert get_steps(steps_vr) == [3]
            fmu.reset()
        assert get_steps(steps_vr) == [expected], name
        fmu.terminate()
        fmu.freeInstance()


def test_a_buggy_reset_is_demoted_with_a_warning_and_episodes_stay_right(family_fmu, fmi_version, caplog):
    path = family_fmu("probe_buggy", fmi_version)
    fresh = FMUEnv(fmu=path, inputs=["force", "gear"], outputs=["position", "steps"],
                   parameters={"enable": True, "mode": 2})
    actions = fixed_actions(fresh, 10, seed=6)
    expected = episode(fresh, actions)
    fresh.close()

    env = FMUEnv(fmu=path, inputs=["force", "gear"], outputs=["position", "steps"],
                 parameters={"enable": True, "mode": 2})
    assert env.fmu.reset_rung == "reset"
    with caplog.at_level(logging.WARNING):
        first = episode(env, actions)
        assert caplog.records == []
        second = episode(env, actions)
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1
    message = warnings[0].getMessage()
    assert "reset rung 'reset'" in message and "different initial outputs" in message
    assert "resets use 'reinstantiate' (a new instance, initialized) from now on. Results are not affected" in message
    assert env.fmu.reset_rung == "reinstantiate"
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        later = [episode(env, actions) for _ in range(2)]
    assert caplog.records == []
    for run in (first, second, *later):
        assert identical(run, expected)
    env.close()


def snapshot_that_fails(family_fmu, fmi_version: int, how: str, folder: Path) -> Path:
    """A probe whose snapshots ``how`` fail: "inexact" (restored with a small error) or "refused"
    (probe_late refuses getFMUstate, and this copy claims canGetAndSetFMUstate="true" anyway)."""
    if how == "inexact":
        return family_fmu("probe_inexact", fmi_version)
    attribute = "canGetAndSetFMUstate" if fmi_version == 2 else "canGetAndSetFMUState"
    return rewrite(family_fmu("probe_late", fmi_version), folder / "Probe.fmu",
                   edit_description=lambda t: t.replace(f'{attribute}="false"', f'{attribute}="true"'))


@pytest.mark.parametrize("how, phrases", [
    ("inexact", ["reset rung 'snapshot' gave different initial outputs"]),
    ("refused", ["reset rung 'snapshot' failed", "getFMUstate is not supported"]),
])
def test_a_failing_snapshot_is_demoted_to_reset(family_fmu, fmi_version, how, phrases, tmp_path, caplog):
    env = FMUEnv(fmu=snapshot_that_fails(family_fmu, fmi_version, how, tmp_path), inputs=["force"],
                 outputs=["position", "steps"])
    assert env.fmu.reset_rung == "snapshot"
    actions = fixed_actions(env, 10, seed=8)
    with caplog.at_level(logging.WARNING):
        runs = [episode(env, actions) for _ in range(4)]
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1, warnings
    assert all(phrase in warnings[0] for phrase in phrases), warnings[0]
    assert env.fmu.reset_rung == "reset"
    for run in runs[1:]:
        assert identical(run, runs[0])
    env.close()


def test_a_buggy_reset_can_be_skipped_by_config(family_fmu, fmi_version, caplog):
    env = FMUEnv(fmu=family_fmu("probe_buggy", fmi_version), inputs=["force"], outputs=["steps"], reset_rung="reinstantiate")
    with caplog.at_level(logging.WARNING):
        for _ in range(3):
            env.reset()
            for k in range(1, 4):
                observation, *_ = env.step(np.array([0.0]))
                assert observation == k
    assert caplog.records == []
    env.close()


def test_once_per_process_fmu_is_never_instantiated_twice(family_fmu, fmi_version):
    """With ``instances_per_process="one"`` the FMU's own binary serves every instance: the probe
    refuses a second live one, and the ladder frees before it instantiates again."""
    path = family_fmu("probe_once", fmi_version)
    assert open_fmu(path).once_per_process()

    def make(**kw: object) -> FMUEnv:
        return FMUEnv(fmu=path, inputs=["force"], outputs=["steps"], instances_per_process="one", **kw)

    env = make()
    env.reset()
    env.step(np.array([1.0]))
    with pytest.raises(FMUError) as raised:
        make()
    message = str(raised.value)
    assert "Instantiate failed" in message
    assert "can be instantiated only once per process, and 1 instance(s) are alive" in message
    observation, *_ = env.step(np.array([1.0]))  # the first env is unaffected
    assert observation == 2
    env.close()

    for rung in RUNGS:  # every rung, and recovery from an error, frees before instantiating
        env = make(reset_rung=rung, parameters={"fault": FAULTS["error"], "fault_after": 2})
        for _ in range(3):
            env.reset()
            env.step(np.array([0.0]))
            env.step(np.array([0.0]))
            *_, truncated, info = env.step(np.array([0.0]))
            assert truncated and "injected fault" in info["fmu_error"]
            observation, _ = env.reset(options={"parameters": {"fault": FAULTS["none"]}})
            for k in range(1, 4):
                observation, *_ = env.step(np.array([0.0]))
            assert observation == 3
        env.close()
    make().close()  # closed envs freed their instance


def test_several_instances_of_an_ordinary_fmu_live_side_by_side(family_fmu):
    envs = [FMUEnv(fmu=family_fmu("probe", 2), inputs=["force"], outputs=["position"]) for _ in range(3)]
    for k, env in enumerate(envs):
        env.reset()
        env.step(np.array([float(k)]))
    assert [float(env.fmu.outputs.views["position"]) for env in envs] == pytest.approx([0.0, 0.1, 0.2])
    for env in envs:
        env.close()


def test_a_buggy_reset_is_caught_when_parameters_change_every_episode(family_fmu):
    env = FMUEnv(fmu=family_fmu("probe_buggy", 2), inputs=["force"], outputs=["steps"],
                 parameters={"gain": lambda rng: rng.uniform(0.5, 2.0)})
    env.reset(seed=0)
    for _ in range(5):
        env.step(np.array([0.0]))
    observation, _ = env.reset()
    env.close()
    assert observation == 0
