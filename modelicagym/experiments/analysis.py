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
    """Episode-length statistics of one setting of a sweep.

    The ``repeat_*`` tuples hold one value per repeat: the mean length of all its episodes, of its
    first and of its last ``WINDOW`` episodes. The properties average them over repeats.
    ``time_step`` is the setting's seconds per step, when its options give one; ``longest_possible``
    the longest episode any agent could achieve, when the search found it.
    """

    label: str
    repeat_means: tuple[float, ...]
    repeat_firsts: tuple[float, ...]
    repeat_lasts: tuple[float, ...]
    env_steps: int
    time_step: float | None = None
    longest_possible: int | None = None

    @property
    def mean(self) -> float:
        """Mean episode length over all episodes and repeats."""
        return float(np.mean(self.repeat_means))

    @property
    def mean_std(self) -> float:
        """Standard deviation over repeats of the per-repeat mean length."""
        return float(np.std(self.repeat_means))

    @property
    def first(self) -> float:
        """Mean length of the first ``WINDOW`` episodes, averaged over repeats."""
        return float(np.mean(self.repeat_firsts))

    @property
    def last(self) -> float:
        """Mean length of the last ``WINDOW`` episodes, averaged over repeats."""
        return float(np.mean(self.repeat_lasts))

    @property
    def last_std(self) -> float:
        """Standard deviation over repeats of the last-``WINDOW`` mean."""
        return float(np.std(self.repeat_lasts))

    @property
    def last_standard_error(self) -> float:
        """Standard error of the last-``WINDOW`` mean over repeats (0 with a single repeat)."""
        n = len(self.repeat_lasts)
        return float(np.std(self.repeat_lasts, ddof=1) / np.sqrt(n)) if n > 1 else 0.0

    @property
    def last_seconds(self) -> float | None:
        """The last-``WINDOW`` mean in simulated seconds (``None`` without a time step)."""
        return None if self.time_step is None else self.last * self.time_step

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
    summaries = {}
    for s, setting in enumerate(result.config.settings):
        time_step = result.config.options_for(setting).get("time_step")
        summaries[setting.label] = SettingSummary(
            label=setting.label,
            repeat_means=tuple(per_repeat[s].tolist()),
            repeat_firsts=tuple(first[s].tolist()),
            repeat_lasts=tuple(last[s].tolist()),
            env_steps=int(steps[s]),
            time_step=float(time_step) if isinstance(time_step, (int, float)) else None,
            longest_possible=result.bounds.get(setting.label),
        )
    return summaries
