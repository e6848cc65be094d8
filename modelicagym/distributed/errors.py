"""Errors of the Ray layer; every one is a :class:`~modelicagym.errors.ClusterError`."""

from __future__ import annotations

from collections.abc import Sequence

from modelicagym.errors import ClusterError

__all__ = ["ActorDiedError", "ClusterError", "RayNotInstalledError", "SweepGroupError"]


class RayNotInstalledError(ClusterError, ImportError):
    """Ray is not installed; ``pip install 'modelicagym[ray]'`` installs it."""


class ActorDiedError(ClusterError):
    """A Ray actor hosting envs of a `~modelicagym.distributed.RayVectorEnv` died (its process or
    its node was lost). ``RayVectorEnv.restart_actors()`` starts it again; then ``reset()``.

    Attributes:
        actor_index: index of the actor in the vector env.
        env_indices: the envs it hosted.
    """

    def __init__(self, message: str, actor_index: int, env_indices: Sequence[int]) -> None:
        super().__init__(message)
        self.actor_index = actor_index
        self.env_indices = tuple(env_indices)


class SweepGroupError(ClusterError):
    """A group of (setting, repeat) runs of a sweep failed on the cluster, after Ray's retries.
    Nothing of that sweep was written.

    Attributes:
        sweep: the sweep's name.
        env_indices: the envs (``setting * repeats + repeat``) of the group.
    """

    def __init__(self, message: str, sweep: str, env_indices: Sequence[int]) -> None:
        super().__init__(message)
        self.sweep = sweep
        self.env_indices = tuple(env_indices)
