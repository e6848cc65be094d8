"""Episode bookkeeping over a vector env with NEXT_STEP autoreset.

After env ``i`` returns ``terminated`` or ``truncated``, its next ``step`` ignores the action,
resets the env and returns the first observation of the new episode with reward 0: that
transition belongs to no episode. :class:`EpisodeTracker` says which transitions of a batch
belong to an episode someone still wants, and which episodes just ended, with their lengths and
returns. `train` and the batch-rollout example share it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["EpisodeTracker"]

_NO_LENGTHS, _NO_RETURNS = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float64)


class EpisodeTracker:
    """Per env of a batch: the running episode's length and return, and whether its next step is
    an autoreset.

    Example::

        tracker = EpisodeTracker(envs.num_envs)
        observations, _ = envs.reset(seed=0)
        for _ in range(100):
            observations, rewards, terminated, truncated, _ = envs.step(envs.action_space.sample())
            live = tracker.live()
            ended, lengths, returns = tracker.update(live, rewards, terminated, truncated)
    """

    def __init__(self, n: int) -> None:
        #: steps and summed reward of each env's running episode so far
        self.length = np.zeros(n, dtype=np.int64)
        self.episode_return = np.zeros(n, dtype=np.float64)
        self._resetting = np.zeros(n, dtype=bool)

    def live(self, wanted: np.ndarray | bool = True) -> np.ndarray:
        """The envs whose last transition belongs to an episode (not an autoreset) that is ``wanted``."""
        return ~self._resetting & wanted

    def update(
        self, live: np.ndarray, rewards: np.ndarray, terminated: np.ndarray, truncated: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Count the ``live`` transitions of a step; returns the envs whose episode just ended,
        with those episodes' lengths and returns (their counters start again at zero)."""
        self.length += live
        self.episode_return += np.where(live, rewards, 0.0)
        self._resetting = ends = terminated | truncated
        ended = np.flatnonzero(live & ends)
        if not ended.size:  # most steps: nothing to take out
            return ended, _NO_LENGTHS, _NO_RETURNS
        lengths, returns = self.length[ended], self.episode_return[ended]
        self.length[ended] = 0
        self.episode_return[ended] = 0.0
        return ended, lengths, returns
