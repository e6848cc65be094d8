"""A pool's slice of envs on freshly made shared buffers, in this process: for tests of `EnvSlice`."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import gymnasium as gym
from gymnasium.vector import AutoresetMode

from modelicagym.vector.slice.env_slice import EnvSlice
from modelicagym.vector.wire.buffers import BufferSpec, SharedBuffers


@contextmanager
def env_slice(fns: list[Callable[[], gym.Env]], mode: AutoresetMode) -> Iterator[tuple[EnvSlice, SharedBuffers]]:
    """The envs of ``fns`` as a worker's slice 0 on freshly made buffers."""
    envs = [fn() for fn in fns]
    spec = BufferSpec(envs[0].observation_space, envs[0].action_space, len(envs), 1)
    buffers, fd = SharedBuffers.create(spec)
    part = EnvSlice(envs, first_env=0, slot=0, autoreset_mode=mode)
    try:
        part.attach(buffers, needs_reset=True)
        yield part, buffers
    finally:
        part.detach()
        os.close(fd)
        for env in envs:
            env.close()
