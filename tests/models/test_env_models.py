"""`FMUEnv` configured from scratch (no subclass) on the cart-pole and the bouncing ball: the
Gymnasium checker in every interface type and FMI version, termination bounds and truncation."""

from __future__ import annotations

import warnings

import numpy as np
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env

from modelicagym import FMUEnv
from modelicagym.models.cartpole import INPUT, OUTPUTS


def checked(env: FMUEnv) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded observation spaces
        check_env(env, skip_render_check=True)


def test_cartpole_as_a_plain_fmu_env(cartpole_fmu, fmi_version, fmu_mode):
    env = FMUEnv(fmu=cartpole_fmu(fmi_version), mode=fmu_mode, inputs=[INPUT], outputs=list(OUTPUTS),
                 termination={"x": (-2.4, 2.4)}, max_episode_steps=50)
    assert env.action_space == spaces.Box(-np.inf, np.inf, (1,), np.float64)
    assert env.observation_space.shape == (4,)
    checked(env)
    env.reset(seed=0)
    pushes = 0
    while True:  # push right until the cart leaves the track
        observation, reward, terminated, truncated, info = env.step(np.array([50.0]))
        pushes += 1
        if terminated or truncated:
            break
    assert terminated and not truncated and reward == env.negative_reward and info == {}
    assert observation[0] > 2.4 and pushes < 50
    env.reset()
    for k in range(50):
        *_, terminated, truncated, _ = env.step(np.array([0.0]))
    assert truncated and not terminated and env.elapsed_steps == 50
    env.close()


def test_bouncing_ball_as_a_plain_fmu_env(family_fmu, fmi_version, fmu_mode):
    env = FMUEnv(fmu=family_fmu("ball", fmi_version), mode=fmu_mode, inputs=["a"], outputs=["h", "v", "bounces"],
                 max_episode_steps=40)
    assert env.time_step == 0.05  # the model's default experiment
    assert env.action_space == spaces.Box(-5.0, 5.0, (1,), np.float64)
    assert isinstance(env.observation_space, spaces.Dict)
    checked(env)
    observation, _ = env.reset()
    assert observation["h"] == 1.0 and observation["bounces"] == 0
    for _ in range(40):
        observation, *_ = env.step(np.array([0.0]))
    assert observation["bounces"] == 3
    env.close()
