"""Numbers from sweep results: mean episode lengths, smoothed learning curves, "did it learn?".

Conventions (the paper's): an episode's length is its number of steps; a setting's mean is taken
over all its episodes and then over repeats; "last 20" is the mean of each repeat's last 20
episodes, averaged over repeats. A setting *learns* when its last-20 mean is at least
``LEARNING_RATIO`` times its first-20 mean: the paper calls settings whose episode length stays
flat (about 9-10 steps) "failing to learn".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modelicagym.experiments.results import SweepResult

__all__ = ["LEARNING_RATIO", "WINDOW", "SettingSummary", "moving_average", "summarize"]

#: Episodes in the "first/last N episodes" means and in the moving average of the plots.
WINDOW = 20
#: Last-20 over first-20 mean episode length from which a setting counts as learning.
LEARNING_RATIO = 1.5


@dataclass(frozen=True)
class SettingSummary:
    """Episode-length statistics of one setting of a sweep (means over repeats, with std)."""

    label: str
    mean: float
    mean_std: float
    first: float
    last: float
    last_std: float
    env_steps: int

    @property
    def learns(self) -> bool:
        """Whether the last episodes are clearly longer than the first ones."""
        return self.last >= LEARNING_RATIO * self.first


def moving_average(values: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """Mean of each run of ``window`` consecutive values along the last axis ("valid" mode)."""
    values = np.asarray(values, dtype=np.float64)
    window = min(window, values.shape[-1])
    sums = np.cumsum(np.concatenate([np.zeros(values.shape[:-1] + (1,)), values], axis=-1), axis=-1)
    return (sums[..., window:] - sums[..., :-window]) / window


def summarize(result: SweepResult, window: int = WINDOW) -> dict[str, SettingSummary]:
    """Per setting label, the statistics of its episode lengths."""
    lengths = result.lengths.astype(np.float64)
    window = min(window, lengths.shape[-1])
    per_repeat = lengths.mean(axis=2)
    first = lengths[:, :, :window].mean(axis=2)
    last = lengths[:, :, -window:].mean(axis=2)
    steps = result.steps_per_setting()
    return {
        setting.label: SettingSummary(
            label=setting.label,
            mean=float(per_repeat[s].mean()),
            mean_std=float(per_repeat[s].std()),
            first=float(first[s].mean()),
            last=float(last[s].mean()),
            last_std=float(last[s].std()),
            env_steps=int(steps[s]),
        )
        for s, setting in enumerate(result.config.settings)
    }
