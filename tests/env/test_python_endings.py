"""A reward or termination written in Python keeps a single env on the native step path: C steps
the FMU, Python ends the step, with the Python path's results to the last bit; the array forms
(`compute_rewards`, `are_terminal`, ``batch_reward``, ``batch_termination``) serve one env too."""

from __future__ import annotations

import numpy as np
import pytest
from python_endings import KINDS, batch_reward, config_cartpole, reward
from step_paths import assert_same_steps

import modelicagym
from modelicagym.errors import ConfigError
from modelicagym.models.cartpole.env import CartPoleEnv
from modelicagym.models.pendulum.env import PendulumSwingUpEnv


@pytest.mark.parametrize("kind", KINDS)
def test_every_way_of_writing_them_steps_natively_as_the_python_path(kind: str) -> None:
    native, python = KINDS[kind](max_episode_steps=15), KINDS[kind](max_episode_steps=15, step_path="python")
    assert native.step_path == "native" and "in Python after it" in native.step_path_reason
    actions = np.random.default_rng(3).integers(2, size=300).tolist()
    assert assert_same_steps(native, python, actions) > 10
    terminated_by_python = "bounds in C" not in kind
    assert (native.native_step.state.n_bounds == 0) == terminated_by_python


def test_the_pendulum_steps_natively_with_its_reward_on_arrays() -> None:
    native = PendulumSwingUpEnv(max_episode_steps=20)
    python = PendulumSwingUpEnv(max_episode_steps=20, step_path="python")
    assert native.step_path == "native", native.step_path_reason
    actions = list(np.random.default_rng(4).uniform(-6, 6, size=(45, 1)))
    assert assert_same_steps(native, python, actions) == 2


def test_the_per_env_and_the_array_forms_give_the_same_rewards() -> None:
    per_env, arrays = config_cartpole(reward=reward), config_cartpole(batch_reward=batch_reward)
    actions = np.random.default_rng(5).integers(2, size=60).tolist()
    per_env.reset(seed=1)
    arrays.reset(seed=1)
    assert [per_env.step(a)[1] for a in actions[:8]] == [arrays.step(a)[1] for a in actions[:8]]


def test_a_hook_given_twice_or_not_callable_is_refused_in_one_line() -> None:
    with pytest.raises(ConfigError, match="both 'reward' and 'batch_reward'"):
        config_cartpole(reward=reward, batch_reward=batch_reward)
    with pytest.raises(TypeError, match="batch_termination must be a callable"):
        config_cartpole(batch_termination=0.5)


def test_an_array_form_that_is_not_a_classmethod_is_refused_in_one_line() -> None:
    class Forgot(CartPoleEnv):
        def compute_rewards(self, envs: object, observations: object, actions: object, terminated: object) -> None:
            return None

    with pytest.raises(TypeError, match=r"Forgot.compute_rewards must be a classmethod"):
        Forgot()


def test_an_array_hook_of_the_wrong_shape_names_itself() -> None:
    env = modelicagym.make("cartpole", batch_reward=lambda envs, o, a, t: np.zeros(3))
    env.reset(seed=0)
    with pytest.raises(ConfigError, match=r"returned an array of shape \(3,\) for 1 envs"):
        env.step(0)
