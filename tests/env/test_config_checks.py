"""Every config value is checked at construction, and a mistake names its key."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import modelicagym
from modelicagym import FMUEnv
from modelicagym.errors import ConfigError, ConfigTypeError


@pytest.mark.parametrize(
    "options, error, match",
    [
        ({"time_step": float("inf")}, ConfigError, "time_step must be finite"),
        ({"time_step": float("nan")}, ConfigError, "time_step must be finite"),
        ({"time_step": "0.05"}, ConfigTypeError, "time_step must be a number, got '0.05' \\(str\\)"),
        ({"time_step": 0.0}, ConfigError, "time_step must be positive"),
        ({"max_episode_steps": 2.5}, ConfigTypeError, "max_episode_steps must be an integer"),
        ({"max_episode_steps": 0}, ConfigError, "max_episode_steps must be at least 1"),
        ({"positive_reward": float("inf")}, ConfigError, "positive_reward must be finite"),
        ({"fmu_options_tolerance": None}, ConfigTypeError, "unknown FMUEnv config key"),
        ({"tolerance": -1e-6}, ConfigError, "tolerance must be positive"),
        ({"solver_step": "small"}, ConfigTypeError, "solver_step must be a number"),
    ],
)
def test_numbers_are_checked_with_their_key(options: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        modelicagym.make("cartpole", **options)


@pytest.mark.parametrize(
    "bounds, match",
    [((-1.0, 0.0, 1.0), "must be a \\(low, high\\) pair"), ((1.0, -1.0), "has low > high"),
     ((float("nan"), 1.0), "contains NaN"), (("a", 1.0), "must be numbers"), (2.0, "must be a \\(low, high\\) pair")],
)
def test_termination_bounds_are_pairs_of_ordered_numbers(family_fmu: Callable[[str, int], Path], bounds: Any, match: str) -> None:
    with pytest.raises(ConfigError, match=rf"termination bound on 'position' {match}"):
        FMUEnv(fmu=family_fmu("probe", 2), inputs=["force"], outputs=["position"], termination={"position": bounds})


def test_infinite_bounds_are_fine(family_fmu: Callable[[str, int], Path]) -> None:
    env = FMUEnv(fmu=family_fmu("probe", 2), inputs=["force"], outputs=["position"], termination={"position": (float("-inf"), 3.0)})
    assert env.reset(seed=0)[0] is not None


@pytest.mark.parametrize(
    "parameters, error, match",
    [
        ({"m_cart": "heavy"}, ConfigTypeError, "parameter 'm_cart' \\(Real\\) needs a float value, got 'heavy'"),
        ({"m_cart": [10.0, 11.0]}, ConfigError, "parameter 'm_cart' \\(Real\\) is a scalar, got \\[10.0, 11.0\\]"),
        ({"m_cart": float("nan")}, ConfigError, "parameter 'm_cart' .* must be finite"),
        ({"m_cart": True}, ConfigTypeError, "parameter 'm_cart' .* needs a float value, got True"),
    ],
)
def test_a_parameter_that_does_not_fit_is_named_at_construction(parameters: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        FMUEnv(fmu=modelicagym.models.cartpole.cartpole_fmu(2), outputs=["x"], parameters=parameters)


def test_parameters_of_other_kinds(family_fmu: Callable[[str, int], Path]) -> None:
    def env(**parameters: Any) -> FMUEnv:
        return FMUEnv(fmu=family_fmu("probe", 2), inputs=["force"], outputs=["position"], parameters=parameters)

    env(gear=2, enable=True, gain=0.5).reset(seed=0)
    env(gain=lambda rng: rng.uniform(0, 1)).reset(seed=0)  # callables are drawn at reset
    for value in (1.5, 2.0, "2"):
        with pytest.raises(ConfigTypeError, match=f"parameter 'gear' \\(Integer\\) needs an integer value, got {value!r}"):
            env(gear=value)
