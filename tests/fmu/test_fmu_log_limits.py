"""A misbehaving FMU does not drown its user: its log messages are rate-limited per instance (the
first ones of each interval, then a count), and an FMU caught in an error loop (it logs errors and
returns OK, tests/fmus/noisy) ends the episode, truncated with the reason in ``info``, on either
step path. Ordinary warnings end nothing."""

from __future__ import annotations

import logging
import time

import numpy as np
import pytest
from gymnasium import spaces

from modelicagym import FMUEnv
from modelicagym.fmu.logs import LOG_LIMITS

STEP_PATHS = ("auto", "python")


def noisy_env(path, step_path: str = "auto", **config) -> FMUEnv:
    box = spaces.Box(-1000.0, 1000.0, (1,), np.float64)  # wider than the model can take, as an unbounded input's
    return FMUEnv(fmu=path, inputs=["u"], outputs=["x"], action_space=box, logging_on=True, step_path=step_path,
                  **config)


def fmu_records(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    """What the FMU logged (its messages and the summaries), not what the runtime said about it."""
    return [r for r in caplog.records if r.name.startswith("modelicagym.fmu.Noisy")]


def summaries(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in fmu_records(caplog) if "more messages from" in r.getMessage()]


@pytest.mark.parametrize("step_path", STEP_PATHS)
def test_a_flood_of_warnings_is_cut_to_the_first_and_a_count(family_fmu, fmi_version, step_path, caplog):
    env = noisy_env(family_fmu("noisy", fmi_version), step_path)
    assert env.step_path == ("python" if step_path == "python" else "native")
    with caplog.at_level(logging.DEBUG, logger="modelicagym"):
        env.reset()  # initialization logs one event message
        for _ in range(200):  # 2 warnings a step
            *_, terminated, truncated, _ = env.step(np.array([1.0]))
            assert not (terminated or truncated)
        assert len(fmu_records(caplog)) == LOG_LIMITS.per_interval
        env.close()  # says what it held back
    assert summaries(caplog) == [f"... {1 + 400 - LOG_LIMITS.per_interval} more messages from Noisy in the last 1 s"]
    assert len(fmu_records(caplog)) == LOG_LIMITS.per_interval + 1


def test_each_interval_lets_the_first_messages_through_and_counts_the_rest(family_fmu, monkeypatch, caplog):
    monkeypatch.setattr(LOG_LIMITS, "per_interval", 3)
    monkeypatch.setattr(LOG_LIMITS, "interval", 0.05)
    env = noisy_env(family_fmu("noisy", 2))
    with caplog.at_level(logging.DEBUG, logger="modelicagym"):
        env.reset()  # one event message
        for _ in range(5):
            env.step(np.array([1.0]))  # 10 warnings: 2 logged, 8 held back
        time.sleep(0.06)
        env.step(np.array([1.0]))  # a new interval: the count first, then 2 warnings
    messages = [r.getMessage() for r in fmu_records(caplog)]
    assert len(messages) == 3 + 1 + 2
    assert messages[3] == "... 8 more messages from Noisy in the last 1 s"
    assert "reduced the step" in messages[4] and "reduced the step" in messages[5]
    env.close()


@pytest.mark.parametrize("step_path", STEP_PATHS)
def test_an_error_loop_truncates_the_episode_and_says_why(family_fmu, fmi_version, step_path, caplog):
    env = noisy_env(family_fmu("noisy", fmi_version), step_path, max_episode_steps=100)
    with caplog.at_level(logging.DEBUG, logger="modelicagym"):
        env.reset(seed=0)
        for _ in range(3):
            *_, truncated, info = env.step(np.array([1.0]))
            assert not truncated and info == {}
        observation, _, terminated, truncated, info = env.step(np.array([400.0]))  # 500 errors, status OK
        assert truncated and not terminated
        assert "logged 500 error messages in one step (more than 100)" in info["fmu_error"]
        assert "error loop" in info["fmu_error"] and "below its minimum" in info["fmu_error"]
        observation, _ = env.reset()
        *_, truncated, info = env.step(np.array([1.0]))  # the next episode runs
        assert not truncated and info == {}
        env.close()
    assert len(fmu_records(caplog)) <= LOG_LIMITS.per_interval + 1


@pytest.mark.parametrize("step_path", STEP_PATHS)
@pytest.mark.parametrize("errors, ends", [(LOG_LIMITS.errors_per_step, False), (LOG_LIMITS.errors_per_step + 1, True)])
def test_more_errors_in_one_step_than_the_limit_end_the_episode(family_fmu, step_path, errors, ends):
    env = noisy_env(family_fmu("noisy", 2), step_path, parameters={"errors_per_step": errors})
    env.reset()
    for _ in range(3):  # errors do not add up over steps
        *_, truncated, info = env.step(np.array([400.0]))
        assert truncated == ends and ("fmu_error" in info) == ends
    env.close()


@pytest.mark.parametrize("step_path", STEP_PATHS)
def test_warnings_are_not_errors(family_fmu, step_path):
    """150 warnings a step, more than the errors a step may log, end nothing."""
    env = noisy_env(family_fmu("noisy", 2), step_path, parameters={"warnings_per_step": 150})
    env.reset()
    for _ in range(5):
        *_, truncated, info = env.step(np.array([1.0]))
        assert not truncated and info == {}
    assert env.fmu.clock.log_errors == 0
    env.close()


def test_messages_below_the_loggers_level_take_no_place(family_fmu, monkeypatch, caplog):
    monkeypatch.setattr(LOG_LIMITS, "per_interval", 3)
    env = noisy_env(family_fmu("noisy", 2))
    with caplog.at_level(logging.WARNING, logger="modelicagym"):
        env.reset()  # its event message is DEBUG: not logged, not counted
        env.step(np.array([1.0]))
        env.step(np.array([1.0]))  # 4 warnings: 3 logged, 1 held back
        env.close()
    messages = [r.getMessage() for r in fmu_records(caplog)]
    assert len(messages) == 4 and all("reduced the step" in m for m in messages[:3])
    assert messages[3] == "... 1 more message from Noisy in the last 1 s"


def test_episodes_that_all_end_in_an_error_loop_do_not_flood_the_log_either(family_fmu, caplog):
    """Random values of an unbounded input can trap every episode at its first step: the env's own
    warnings about truncated episodes are limited as the FMU's messages are."""
    env = noisy_env(family_fmu("noisy", 2))
    with caplog.at_level(logging.WARNING, logger="modelicagym"):
        for _ in range(60):
            env.reset()
            *_, truncated, info = env.step(np.array([400.0]))
            assert truncated and "error loop" in info["fmu_error"]
        env.close()
    truncations = [r.getMessage() for r in caplog.records if r.name == "modelicagym.env.fmu_env"]
    assert len(truncations) == LOG_LIMITS.per_interval + 1
    assert truncations[-1].startswith(f"... {60 - LOG_LIMITS.per_interval} more messages from Noisy")
    assert len(fmu_records(caplog)) == LOG_LIMITS.per_interval + 1
