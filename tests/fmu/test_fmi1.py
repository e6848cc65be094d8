"""FMI 1.0 FMUs through the runtime and the env: the cart-pole built for FMI 1.0 (co-simulation
and model exchange are separate FMUs there) against the FMI 2.0 one, the reset ladder without
FMU states, the Python step path, the pool, events on the bouncing ball, and a stand-alone
third-party-style FMI 1.0 slave compiled with fmpy's CMake project."""

from __future__ import annotations

import logging
import math
import shutil
import warnings
import zipfile

import gymnasium as gym
import numpy as np
import pytest
from episodes import observations
from fmu_family import BALL_DIR, BALL_OUTPUTS, FMUS_DIR
from gymnasium.utils.env_checker import check_env
from vector_rollouts import assert_same, rollout

import modelicagym
from modelicagym.errors import ArgumentError
from modelicagym.fmu import FMUCallError, FMUInstance, UnsupportedFeatureError, open_fmu
from modelicagym.fmu.build import build_source_fmu, compile_sources
from modelicagym.models.cartpole import OUTPUTS
from modelicagym.models.cartpole.env import CartPoleEnv

PUSHES = np.random.default_rng(11).integers(0, 2, size=80)


def free_env(**options) -> CartPoleEnv:
    """A Cart-Pole env whose episodes never end on bounds, to compare long trajectories."""
    return CartPoleEnv(x_threshold=1e9, theta_threshold=1e9, **options)


def trajectory(env: gym.Env, pushes=PUSHES, **reset) -> np.ndarray:
    return np.array(observations(env, [int(p) for p in pushes], seed=0, **reset))


# -- the FMUs --------------------------------------------------------------------------------------


def test_fmi1_cartpole_is_one_interface_type_per_fmu(cartpole_fmu, fmu_mode):
    description = open_fmu(cartpole_fmu(1, fmu_mode))  # validates against fmpy's FMI 1.0 schema
    assert description.fmi_version == 1
    assert description.modes == (fmu_mode,)
    assert not description.can_snapshot(fmu_mode)
    assert description.can_reset(fmu_mode) == (fmu_mode == "cs")
    other = "me" if fmu_mode == "cs" else "cs"
    with pytest.raises(UnsupportedFeatureError, match="does not support"):
        FMUInstance(description, mode=other)
    assert description.variables["m_cart"].settable_before_initialization
    assert description.variables["f"].is_input and description.variables["x"].is_output


def test_unknown_fmi_versions_and_modes_are_refused_with_the_allowed_values():
    with pytest.raises(ArgumentError, match="fmi_version must be one of 1, 2, 3, not 4"):
        modelicagym.make("cartpole", fmi_version=4)
    with pytest.raises(ArgumentError, match="mode must be one of 'cs', 'me'"):
        CartPoleEnv(fmi_version=1, mode="co-simulation")


# -- the cart-pole against FMI 2.0 ---------------------------------------------------------------


def test_co_simulation_matches_fmi2_exactly():
    with free_env(fmi_version=1, mode="cs") as fmi1, free_env(fmi_version=2, mode="cs") as fmi2:
        a, b = trajectory(fmi1), trajectory(fmi2)
    assert a.shape == b.shape == (len(PUSHES) + 1, len(OUTPUTS))
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_model_exchange_matches_fmi2_within_solver_tolerance():
    with free_env(fmi_version=1, mode="me") as fmi1, free_env(fmi_version=2, mode="me") as fmi2:
        a, b = trajectory(fmi1), trajectory(fmi2)
    assert a.shape == b.shape
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6)
    assert np.abs(np.diff(a[:, 0])).max() > 1e-3  # the cart moves: the comparison means something


def test_parameters_per_episode(fmu_mode):
    """Per-episode parameters (options, and a sampler in the config) give FMI 2.0's trajectories."""
    def heavy_or_light(rng):
        return float(rng.choice([2.0, 20.0]))

    with free_env(fmi_version=1, mode=fmu_mode, m_cart=heavy_or_light) as fmi1, \
            free_env(fmi_version=2, mode=fmu_mode, m_cart=heavy_or_light) as fmi2:
        for seed in range(3):
            a = np.array(observations(fmi1, [int(p) for p in PUSHES[:30]], seed=seed))
            b = np.array(observations(fmi2, [int(p) for p in PUSHES[:30]], seed=seed))
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 if fmu_mode == "cs" else 1e-6)
        options = {"parameters": {"m_pole": 3.0, "theta_0": 1.5}}
        a = trajectory(fmi1, PUSHES[:30], options=options)
        b = trajectory(fmi2, PUSHES[:30], options=options)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 if fmu_mode == "cs" else 1e-6)
        assert a[0][2] == pytest.approx(1.5)


def test_reset_gives_identical_episodes_on_the_rungs_fmi1_has(fmu_mode):
    with free_env(fmi_version=1, mode=fmu_mode) as env:
        first = trajectory(env)
        second = trajectory(env)
        other = trajectory(env, options={"parameters": {"m_cart": 4.0}})
        third = trajectory(env)
        rung = env.fmu.reset_rung
    np.testing.assert_array_equal(first, second)
    np.testing.assert_array_equal(first, third)
    assert not np.array_equal(first, other)
    assert rung == ("reset" if fmu_mode == "cs" else "reinstantiate")


def test_the_snapshot_rung_is_refused_and_me_has_no_reset(cartpole_fmu, fmu_mode):
    with pytest.raises(UnsupportedFeatureError, match="FMI 1.0 has no FMU state"):
        FMUInstance(cartpole_fmu(1, fmu_mode), mode=fmu_mode, reset_rung="snapshot")
    if fmu_mode == "me":
        with pytest.raises(UnsupportedFeatureError, match="no reset function"):
            FMUInstance(cartpole_fmu(1, "me"), mode="me", reset_rung="reset")
    with free_env(fmi_version=1, mode=fmu_mode, reset_rung="reinstantiate") as forced, \
            free_env(fmi_version=1, mode=fmu_mode) as auto:
        np.testing.assert_array_equal(trajectory(forced), trajectory(auto))
        np.testing.assert_array_equal(trajectory(forced), trajectory(auto))


def test_the_env_steps_natively_in_both_modes(fmu_mode):
    with CartPoleEnv(fmi_version=1, mode=fmu_mode) as env:
        assert env.step_path == "native", env.step_path_reason
        env.reset(seed=0)
        _, reward, terminated, truncated, _ = env.step(1)
        assert (reward, terminated, truncated) == (1.0, False, False)


def test_fmu_errors_carry_the_fmus_message(fmu_mode, caplog):
    with CartPoleEnv(fmi_version=1, mode=fmu_mode) as env, caplog.at_level(logging.ERROR):
        with pytest.raises(FMUCallError, match="invalid parameters: need m_cart > 0"):
            env.reset(options={"parameters": {"m_cart": -1.0}})
        env.reset(seed=0)  # the broken instance is replaced
        assert env.step(0)[0].shape == (4,)
    assert any("invalid parameters" in r.getMessage() for r in caplog.records)


@pytest.mark.processes
def test_the_pool_runs_fmi1_and_matches_sync_vector_env(no_leaks):
    with modelicagym.make_vec("cartpole", n=2, fmi_version=1) as pool:
        assert [path for path, _ in pool.step_paths] == ["native", "native"]
        expected_envs = gym.vector.SyncVectorEnv([lambda: CartPoleEnv(fmi_version=1, step_path="python")] * 2)
        try:
            assert_same(rollout(pool, 60), rollout(expected_envs, 60))
        finally:
            expected_envs.close()


# -- events: the bouncing ball in FMI 1.0 model exchange ---------------------------------------


def test_ball_events_match_fmi2_model_exchange(family_fmu):
    def bounces(path):
        with FMUInstance(path, mode="me", outputs=BALL_OUTPUTS) as fmu:
            episodes = []
            for _ in range(2):
                fmu.reset({"t_switch": 1.5})
                rows = []
                for _ in range(40):
                    fmu.step(0.05)
                    rows.append([float(fmu.outputs.views[name]) for name in BALL_OUTPUTS])
                episodes.append(np.array(rows))
            return episodes

    fmi1 = bounces(build_source_fmu(BALL_DIR, 1, "me"))
    fmi2 = bounces(family_fmu("ball", 2))
    index = {name: k for k, name in enumerate(BALL_OUTPUTS)}
    for a, b in zip(fmi1, fmi2):
        assert a[-1, index["bounces"]] == b[-1, index["bounces"]] == 3
        assert a[-1, index["t_switched"]] == pytest.approx(1.5)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(fmi1[0], fmi1[1])  # re-instantiated: the same episode again


# -- a third-party-style FMI 1.0 slave, compiled by fmpy's CMake project -------------------------


@pytest.fixture(scope="module")
def dahlquist_fmu(tmp_path_factory):
    source = FMUS_DIR / "dahlquist1"
    unzipdir = tmp_path_factory.mktemp("dahlquist") / "fmu"
    (unzipdir / "sources").mkdir(parents=True)
    shutil.copy(source / "modelDescription.xml", unzipdir)
    shutil.copy(source / "dahlquist.c", unzipdir / "sources")
    binary = compile_sources(unzipdir)
    assert binary.name.startswith("Dahlquist.")
    path = unzipdir.parent / "Dahlquist.fmu"
    with zipfile.ZipFile(path, "w") as archive:
        for file in sorted(p for p in unzipdir.rglob("*") if p.is_file()):
            archive.write(file, file.relative_to(unzipdir).as_posix())
    return path


@pytest.mark.processes
def test_a_third_party_fmi1_slave_loads_and_runs(dahlquist_fmu):
    k, u, dt = 2.0, 0.5, 0.1
    with FMUInstance(dahlquist_fmu, inputs=["u"], outputs=["x", "steps", "positive"]) as fmu:
        assert fmu.description.fmi_version == 1 and fmu.reset_rung == "reset"
        for _ in range(2):  # the second episode goes through fmiResetSlave
            fmu.reset({"k": k, "x0": 1.0})
            fmu.inputs.views["u"][...] = u
            for n in range(1, 11):
                fmu.step(dt)
                x = u / k + (1.0 - u / k) * math.exp(-k * n * dt)
                assert float(fmu.outputs.views["x"]) == pytest.approx(x, rel=1e-12)
                assert int(fmu.outputs.views["steps"]) == n
                assert bool(fmu.outputs.views["positive"])
        assert "reset" in fmu._verified
        with pytest.raises(FMUCallError, match="k must be > 0"):
            fmu.reset({"k": -1.0})


@pytest.mark.processes
def test_a_third_party_fmi1_slave_as_an_env(dahlquist_fmu):
    env = modelicagym.FMUEnv(fmu=dahlquist_fmu, inputs=["u"], outputs=["x"], parameters={"k": 1.0},
                             time_step=0.5, max_episode_steps=4, termination={"x": (-10.0, 10.0)})
    with env:
        assert env.step_path == "native", env.step_path_reason
        obs, _ = env.reset(seed=0)
        assert obs == pytest.approx([1.0])
        for n in range(1, 5):
            obs, reward, terminated, truncated, _ = env.step(np.array([1.0]))
        assert obs == pytest.approx([1.0])  # x = u/k = 1 is the equilibrium
        assert truncated and not terminated


def test_passes_gymnasium_env_checker(fmu_mode):
    env = CartPoleEnv(fmi_version=1, mode=fmu_mode)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded observation space warnings
        check_env(env, skip_render_check=False)
    env.close()
