"""The Cart-Pole environment through our runtime: the Gymnasium contract, the four FMU variants
(FMI 2/3 x co-simulation/model exchange), the reset ladder, seeding and the front doors."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from episodes import observations
from gymnasium.utils.env_checker import check_env

import modelicagym
from modelicagym.fmu import FMUInstance
from modelicagym.fmu.instance import RUNGS
from modelicagym.models.cartpole import OUTPUTS
from modelicagym.models.cartpole.env import CartPoleEnv

PUSHES = np.random.default_rng(7).integers(0, 2, size=100)


def rollout(env: gym.Env, pushes, seed: int | None = 0, options=None) -> np.ndarray:
    """Observations of one episode driven by ``pushes`` (0 left, 1 right; as forces of 15 N for an
    env whose actions are forces), stopping early if the episode ends."""
    if isinstance(env.action_space, gym.spaces.Box):
        actions = [np.array([30.0 * push - 15.0]) for push in pushes]
    else:
        actions = [int(push) for push in pushes]
    return np.array(observations(env, actions, seed=seed, options=options))


def free_env(**options) -> CartPoleEnv:
    """A Cart-Pole env whose episodes never end on bounds, to compare long trajectories."""
    return CartPoleEnv(x_threshold=1e9, theta_threshold=1e9, **options)


def test_passes_gymnasium_env_checker(fmi_version):
    env = CartPoleEnv(fmi_version=fmi_version)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded observation space warnings
        check_env(env, skip_render_check=False)
    env.close()


def test_model_exchange_agrees_with_co_simulation(fmi_version):
    cs, me = free_env(fmi_version=fmi_version, mode="cs"), free_env(fmi_version=fmi_version, mode="me")
    a, b = rollout(cs, PUSHES), rollout(me, PUSHES)
    assert a.shape == b.shape == (101, 4)
    assert cs.time == pytest.approx(5.0)
    np.testing.assert_allclose(b, a, atol=1e-5, rtol=0)
    assert np.ptp(a[:, 2]) > 0.5, "the pole should have moved a lot in 5 s"


@pytest.mark.parametrize("step_path", ["auto", "python"])
def test_model_exchange_with_rk4_at_the_fmus_internal_step_gives_co_simulations_numbers(fmi_version, step_path):
    """The classical Runge-Kutta scheme of model exchange is the FMU's own co-simulation solver:
    at its internal step (5 ms) the two trajectories agree to rounding over 5 s."""
    cs = free_env(fmi_version=fmi_version, mode="cs")
    me = free_env(fmi_version=fmi_version, mode="me", solver="rk4", solver_step=5e-3, step_path=step_path)
    a, b = rollout(cs, PUSHES), rollout(me, PUSHES)
    assert me.step_path == ("native" if step_path == "auto" else "python")
    assert a.shape == b.shape == (101, 4)
    np.testing.assert_allclose(b, a, atol=1e-12, rtol=0)
    assert np.ptp(a[:, 2]) > 0.5


def test_fmi2_and_fmi3_give_the_same_trajectory():
    a = rollout(free_env(fmi_version=2), PUSHES)
    b = rollout(free_env(fmi_version=3), PUSHES)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("rung", RUNGS)
def test_every_reset_rung_replays_a_fresh_episode(fmi_version, fmu_mode, rung):
    fresh = rollout(free_env(fmi_version=fmi_version, mode=fmu_mode), PUSHES[:40])
    env = free_env(fmi_version=fmi_version, mode=fmu_mode, reset_rung=rung)
    rollout(env, PUSHES[:40][::-1])
    for _ in range(2):
        np.testing.assert_array_equal(rollout(env, PUSHES[:40]), fresh)
    assert env.fmu.reset_rung == rung


def test_auto_rung_is_snapshot_and_parameters_change_per_episode():
    env = free_env()
    assert env.fmu.reset_rung == "snapshot"
    base = rollout(env, PUSHES[:20])
    light = rollout(env, PUSHES[:20], options={"parameters": {"m_cart": 1.0}})
    assert not np.allclose(base, light)
    np.testing.assert_array_equal(rollout(env, PUSHES[:20]), base)  # back to the config's value
    np.testing.assert_array_equal(rollout(free_env(m_cart=1.0), PUSHES[:20]), light)


def test_seeded_domain_randomisation_is_reproducible(cartpole_fmu):
    def make() -> modelicagym.FMUEnv:
        """The cart-pole with a cart mass drawn from the env's generator every episode."""
        return modelicagym.FMUEnv(
            fmu=cartpole_fmu(2),
            inputs=["f"],
            outputs=list(OUTPUTS),
            parameters={"m_cart": lambda rng: rng.uniform(5.0, 15.0)},
            time_step=0.05,
        )

    a, b = make(), make()
    np.testing.assert_array_equal(rollout(a, PUSHES[:20], seed=3), rollout(b, PUSHES[:20], seed=3))
    assert a.episode_parameters["m_cart"] == b.episode_parameters["m_cart"]
    first = a.episode_parameters["m_cart"]
    rollout(a, PUSHES[:20], seed=4)
    assert a.episode_parameters["m_cart"] != first


def test_rewards_termination_and_truncation():
    env = CartPoleEnv(max_episode_steps=5)
    env.reset(seed=0)
    for k in range(5):
        _, reward, terminated, truncated, info = env.step(1)
        assert (reward, terminated) == (1.0, False)
    assert truncated and info == {}

    env = CartPoleEnv(negative_reward=-200.0)
    env.reset(seed=0)
    steps, terminated = 0, False
    while not terminated:
        observation, reward, terminated, truncated, _ = env.step(0)
        steps += 1
        assert not truncated and steps < 200
    assert reward == -200.0
    assert abs(observation[2] - np.pi / 2) > np.deg2rad(12) or abs(observation[0]) > 2.4


def test_time_is_start_plus_k_steps():
    env = free_env(time_step=0.01)
    env.reset(seed=0)
    for k in range(1, 1001):
        env.step(k % 2)
        assert env.time == 0.0 + k * 0.01


@pytest.mark.parametrize("action", [2, -1, 0.5, np.array([1]), np.nan, "left"])
def test_invalid_actions_raise_a_clear_error(action):
    env = CartPoleEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="invalid action .*Discrete\\(2\\)"):
        env.step(action)


def test_render_draws_the_pole_where_it_is():
    env = CartPoleEnv(render_mode="rgb_array", theta_0=np.pi / 2)
    env.reset(seed=0)
    image = env.render()
    assert image.shape == (400, 600, 3) and image.dtype == np.uint8
    drawn = (image[:, 300] != 255).any(axis=1)
    assert drawn[200:290].all(), "an upright pole is drawn above the cart"
    assert not drawn[:180].any(), "and nothing above its 1 m length"
    assert CartPoleEnv().render() is None


def test_front_doors():
    env = modelicagym.make("cartpole", force=11.0)
    assert isinstance(env, CartPoleEnv) and env.force == 11.0
    wrapped = gym.make("ModelicaGym/CartPole-v0", m_cart=5.0)
    assert isinstance(wrapped.unwrapped, CartPoleEnv)
    assert wrapped.unwrapped.config.parameters["m_cart"] == 5.0
    with pytest.raises(gym.error.UnregisteredEnv, match="Did you mean 'cartpole'"):
        modelicagym.make("cartpol")


def test_instance_rejects_unknown_or_unsettable_parameters(cartpole_fmu):
    instance = FMUInstance(cartpole_fmu(2), inputs=["f"], outputs=list(OUTPUTS))
    with pytest.raises(KeyError, match="Did you mean 'm_cart'"):
        instance.reset({"mcart": 1.0})
    with pytest.raises(KeyError, match="cannot be set"):
        instance.reset({"x": 1.0})
    instance.close()
    instance.close()


def test_the_continuous_cart_pole_is_the_same_task_with_a_force_action():
    """A force of +-15 N replays the discrete env's pushes; other forces in range are taken, a
    force beyond ``force`` is refused; registered by short name and Gymnasium id."""
    continuous, discrete = modelicagym.make("cartpole-continuous"), modelicagym.make("cartpole")
    assert continuous.action_space == gym.spaces.Box(-15.0, 15.0, (1,), dtype=np.float64)
    assert continuous.step_path == "native"
    np.testing.assert_array_equal(rollout(continuous, PUSHES), rollout(discrete, PUSHES))
    continuous.reset(seed=0)
    gentle, *_ = continuous.step(np.array([2.5]))
    assert 0 < gentle[1] < rollout(discrete, [1])[1][1]
    with pytest.raises(modelicagym.errors.ActionError):
        continuous.step(np.array([15.5]))
    wrapped = gym.make("ModelicaGym/CartPoleContinuous-v0", force=5.0)
    assert wrapped.action_space.high.tolist() == [5.0]
    check_env(wrapped.unwrapped)
