"""A contiguous slice of a pool's envs, run against the shared buffers: the work of a step.

An :class:`EnvSlice` is what a worker process runs (:mod:`~modelicagym.vector.worker`), and what
the calling process runs itself when it steps a slice of the envs (``caller_steps``): the envs,
the autoreset of the pool's mode, and where the results go in shared memory. It knows nothing of
processes, pipes or signals; each command returns the reply message the parent gets (``None`` when
there is nothing to say).
"""

from __future__ import annotations

import dataclasses
import logging
from multiprocessing.reduction import ForkingPickler
from time import perf_counter_ns
from typing import Any

import gymnasium as gym
from gymnasium.vector import AutoresetMode

from modelicagym.vector.buffers import SharedBuffers
from modelicagym.vector.errors import RemoteError, SpaceMismatchError
from modelicagym.vector.protocol import Command, EnvDescription, Kind, Message

__all__ = ["EnvSlice", "close_envs", "describe_envs"]

logger = logging.getLogger(__name__)

_StepResult = tuple[Any, float, bool, bool, dict[str, Any]]


def describe_envs(envs: list[gym.Env], first_env: int) -> EnvDescription:
    """What the parent needs to know about the envs; raises if they disagree on their spaces."""
    first = envs[0]
    for offset, env in enumerate(envs[1:], start=1):
        if env.observation_space != first.observation_space or env.action_space != first.action_space:
            raise SpaceMismatchError(
                f"env {first_env + offset} has spaces ({env.observation_space}, {env.action_space}), "
                f"env {first_env} has ({first.observation_space}, {first.action_space}): "
                "all envs of a pool must have the same observation and action spaces"
            )
    description = EnvDescription(
        first.observation_space, first.action_space, dict(first.metadata), first.render_mode, first.spec
    )
    try:
        ForkingPickler.dumps(description.spec)
    except Exception:
        description = dataclasses.replace(description, spec=None)
    return description


def close_envs(envs: list[gym.Env]) -> None:
    """Close every env, logging (not raising) what fails."""
    for env in envs:
        try:
            env.close()
        except Exception:
            logger.exception("closing an env failed")


class EnvSlice:
    """The envs ``first_env, first_env + 1, ...`` of a pool, stepped into shared memory.

    Args:
        envs: the envs, created in this process.
        first_env: the pool index of ``envs[0]``.
        slot: this slice's row in the per-slice shared arrays (``current_env``, ``timing``).
        autoreset_mode: the pool's autoreset mode.
    """

    def __init__(self, envs: list[gym.Env], first_env: int, slot: int, autoreset_mode: AutoresetMode) -> None:
        self.envs = envs
        self.first = first_env
        self.slot = slot
        #: as a worker handle's: the slot, and the pool indices of the envs
        self.index = slot
        self.env_indices = range(first_env, first_env + len(envs))
        self.buffers: SharedBuffers | None = None
        self._next_step = autoreset_mode is AutoresetMode.NEXT_STEP
        self._same_step = autoreset_mode is AutoresetMode.SAME_STEP
        self.needs_reset = [False] * len(envs)
        self._fmu_envs = [env.unwrapped if hasattr(env.unwrapped, "fmu_time_ns") else None for env in envs]
        self.handlers = {
            Kind.RESET: lambda data: self.reset(*data),
            Kind.CALL: self.call,
            Kind.SET_ATTR: self.set_attr,
        }

    def describe_envs(self) -> str:
        """``"4-7"`` or ``"4"``: the env indices of this slice, for messages."""
        first, last = self.env_indices[0], self.env_indices[-1]
        return str(first) if first == last else f"{first}-{last}"

    def run(self, code: int, message: Message | None) -> Message | None:
        """Run one command of the protocol (a ``Command`` code, and the message of ``MESSAGE``)."""
        if code == Command.STEP:
            return self.step()
        if code == Command.RESET:
            return self.reset(None, None)
        if code == Command.RESET_EMPTY_OPTIONS:
            return self.reset(None, {})
        return self.handlers[message.kind](message.data)

    def attach(self, buffers: SharedBuffers, needs_reset: bool) -> None:
        """Work on ``buffers`` from now on; ``needs_reset``: the envs were never reset."""
        self.buffers = buffers
        self.needs_reset = [needs_reset] * len(self.envs)

    def step(self) -> Message | None:
        """Step every env with its action from shared memory, with the pool's autoreset."""
        buffers = self.buffers
        actions, observations = buffers.actions, buffers.observations
        rewards, terminations, truncations = buffers.rewards, buffers.terminations, buffers.truncations
        current_env = buffers.current_env
        timed = bool(buffers.timing_enabled[0])
        env_ns = fmu_ns = 0
        infos = []
        for offset, env in enumerate(self.envs):
            index = self.first + offset
            current_env[self.slot] = index
            action = actions.read(index)
            if timed:
                fmu_env = self._fmu_envs[offset]
                fmu_start = 0 if fmu_env is None else fmu_env.fmu_time_ns
                start = perf_counter_ns()
            try:
                observation, reward, terminated, truncated, info = self._step_env(offset, env, action)
            except Exception as exc:
                return Message(Kind.ERROR, RemoteError.capture(exc, index))
            if timed:
                env_ns += perf_counter_ns() - start
                if fmu_env is not None:
                    fmu_ns += fmu_env.fmu_time_ns - fmu_start
            observations.write(index, observation)
            rewards[index] = reward
            terminations[index] = terminated
            truncations[index] = truncated
            if info:
                infos.append((index, info))
        if timed:
            buffers.timing[self.slot] = (env_ns, fmu_ns)
        return Message(Kind.INFOS, infos) if infos else None

    def _step_env(self, offset: int, env: gym.Env, action: Any) -> _StepResult:
        """One env's part of a vector step, with the autoreset of the pool's mode."""
        if self._next_step:
            if self.needs_reset[offset]:
                observation, info = env.reset()
                result = (observation, 0.0, False, False, info)
            else:
                result = env.step(action)
            self.needs_reset[offset] = bool(result[2] or result[3])
            return result
        observation, reward, terminated, truncated, info = env.step(action)
        if self._same_step and (terminated or truncated):
            reset_observation, reset_info = env.reset()
            info = {"final_obs": observation, "final_info": info, **reset_info}
            observation = reset_observation
        return observation, reward, terminated, truncated, info

    def reset(self, seeds: list[int | None] | None, options: dict[str, Any] | None) -> Message | None:
        """Reset the envs selected by the shared reset mask."""
        buffers = self.buffers
        mask, observations = buffers.reset_mask, buffers.observations
        infos = []
        for offset, env in enumerate(self.envs):
            index = self.first + offset
            if not mask[index]:
                continue
            buffers.current_env[self.slot] = index
            try:
                observation, info = env.reset(seed=None if seeds is None else seeds[offset], options=options)
            except Exception as exc:
                return Message(Kind.ERROR, RemoteError.capture(exc, index))
            observations.write(index, observation)
            self.needs_reset[offset] = False
            if info:
                infos.append((index, info))
        return Message(Kind.INFOS, infos) if infos else None

    def call(self, data: tuple[str, tuple[Any, ...], dict[str, Any]]) -> Message:
        name, args, kwargs = data
        results = []
        for offset, env in enumerate(self.envs):
            self.buffers.current_env[self.slot] = self.first + offset
            try:
                attr = env.get_wrapper_attr(name)
                results.append(attr(*args, **kwargs) if callable(attr) else attr)
            except Exception as exc:
                return Message(Kind.CALL_ERROR, RemoteError.capture(exc, self.first + offset))
        return Message(Kind.RESULTS, results)

    def set_attr(self, data: tuple[str, list[Any]]) -> Message | None:
        name, values = data
        for offset, (env, value) in enumerate(zip(self.envs, values, strict=True)):
            self.buffers.current_env[self.slot] = self.first + offset
            try:
                env.set_wrapper_attr(name, value)
            except Exception as exc:
                return Message(Kind.CALL_ERROR, RemoteError.capture(exc, self.first + offset))
        return None
