"""The motor-driven pendulum: its model (FMI 2/3, co-simulation and model exchange agree), the
swing-up task's reward and episodes, the baseline controller, and the front doors."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import modelicagym
from modelicagym.errors import ModelicaGymError
from modelicagym.models.pendulum.env import EnergySwingUp, PendulumSwingUpEnv


def drive(env: gym.Env, controller, seed: int = 0, steps: int | None = None):
    """Observations and rewards of one episode under ``controller`` (or ``steps`` of it)."""
    observation, _ = env.reset(seed=seed)
    observations, rewards = [observation], []
    for _ in range(steps or 10**9):
        observation, reward, terminated, truncated, _ = env.step(controller(observation))
        observations.append(observation)
        rewards.append(reward)
        if terminated or truncated:
            break
    return np.array(observations), np.array(rewards)


def test_spaces_and_the_reset_state():
    env = modelicagym.make("pendulum", theta_0=np.pi, omega_0=0.0)
    assert env.action_space == gym.spaces.Box(-6.0, 6.0, (1,), dtype=np.float64)
    assert env.observation_space.shape == (3,)
    observation, info = env.reset(seed=0)
    np.testing.assert_allclose(observation, [-1.0, 0.0, 0.0], atol=1e-12)  # hanging still
    assert info == {}
    env.close()


def test_each_episode_starts_at_a_random_angle_drawn_from_the_seed():
    env = PendulumSwingUpEnv()
    first = [env.reset(seed=seed)[0] for seed in (1, 2, 1)]
    np.testing.assert_array_equal(first[0], first[2])
    assert not np.allclose(first[0], first[1])
    angles = [np.arctan2(*env.reset()[0][[1, 0]]) for _ in range(40)]
    assert min(angles) < -1.5 and max(angles) > 1.5  # uniform over the circle
    assert all(abs(env.reset()[0][2]) <= 1.0 for _ in range(10))
    env.close()


def test_reward_is_the_documented_quadratic_cost_and_episodes_are_truncated_at_200_steps():
    env = PendulumSwingUpEnv()
    observation, _ = env.reset(seed=3)
    rng = np.random.default_rng(0)
    for k in range(200):
        action = rng.uniform(-6.0, 6.0, 1)
        observation, reward, terminated, truncated, _ = env.step(action)
        cos_theta, sin_theta, omega = observation
        theta = np.arctan2(sin_theta, cos_theta)
        assert reward == pytest.approx(-(theta**2 + 0.1 * omega**2 + 0.001 * action[0] ** 2), rel=1e-12)
        assert not terminated
        assert truncated == (k == 199)
    env.close()


def test_the_motor_alone_cannot_lift_the_pendulum_but_the_baseline_swings_it_up_and_holds_it():
    env = PendulumSwingUpEnv(theta_0=np.pi, omega_0=0.0)
    pushed, _ = drive(env, lambda observation: np.array([6.0]))
    assert pushed[:, 0].max() < 0.0, "full voltage one way must not bring the pendulum above horizontal"
    swung, rewards = drive(env, EnergySwingUp())
    assert len(rewards) == 200
    assert np.all(swung[-40:, 0] > 0.99), "the last 2 s upright"
    zero_return = drive(env, lambda observation: np.zeros(1))[1].sum()
    assert rewards.sum() > 0.2 * zero_return  # far better than hanging
    env.close()


def test_the_baseline_controller_takes_a_batch_of_observations():
    controller = EnergySwingUp()
    batch = np.array([[-1.0, 0.0, 0.5], [-1.0, 0.0, -0.5], [1.0, 0.0, 0.0], [0.99, 0.141, 0.0]])
    actions = controller(batch)
    assert actions.shape == (4, 1)
    np.testing.assert_allclose(actions[:2, 0], [6.0, -6.0])  # pump in the direction of motion
    assert actions[2, 0] == 0.0 and actions[3, 0] < 0.0  # upright: hold; tilted: push back
    np.testing.assert_array_equal(controller(batch[0]), actions[0])


def test_fmi_versions_and_interface_types_agree():
    """FMI 2.0 and 3.0 co-simulation give the same numbers; model exchange with CVODE follows them."""
    controller = EnergySwingUp()
    reference, _ = drive(PendulumSwingUpEnv(theta_0=np.pi, omega_0=0.0), controller, steps=60)
    fmi3, _ = drive(PendulumSwingUpEnv(theta_0=np.pi, omega_0=0.0, fmi_version=3), controller, steps=60)
    np.testing.assert_array_equal(fmi3, reference)
    me, _ = drive(PendulumSwingUpEnv(theta_0=np.pi, omega_0=0.0, mode="me", tolerance=1e-8), controller, steps=60)
    np.testing.assert_allclose(me, reference, atol=1e-3)


def test_invalid_model_parameters_are_a_clear_error():
    env = PendulumSwingUpEnv(model_parameters={"inductance": -1.0})
    with pytest.raises(ModelicaGymError, match="inductance"):
        env.reset(seed=0)
    env.close()


@pytest.mark.processes
def test_registered_with_gymnasium_and_steps_in_the_pool():
    wrapped = gym.make("ModelicaGym/PendulumSwingUp-v0")
    assert wrapped.reset(seed=0)[0].shape == (3,)
    wrapped.close()
    pool = modelicagym.make_vec("pendulum", n=3, theta_0=np.pi, omega_0=0.0)
    controller = EnergySwingUp()
    observations, _ = pool.reset(seed=0)
    for _ in range(100):
        observations = pool.step(controller(observations))[0]
    single, _ = drive(PendulumSwingUpEnv(theta_0=np.pi, omega_0=0.0), controller, steps=100)
    np.testing.assert_allclose(observations, np.repeat(single[-1:], 3, axis=0), atol=1e-12)
    pool.close()
