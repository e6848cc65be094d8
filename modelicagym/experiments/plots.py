"""Learning-curve figures like the paper's: one per sweep, one line per setting.

Each line is the moving average (window 20) of the episode length, averaged over repeats; the
band spans the smallest to the largest smoothed repeat. matplotlib is optional: without it the
plots are skipped with a warning.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from modelicagym.disk import atomic_write
from modelicagym.experiments.analysis import WINDOW, moving_average
from modelicagym.experiments.results import SweepResult

__all__ = ["plot_learning_curve", "plot_sweep"]

logger = logging.getLogger(__name__)


def plot_learning_curve(curve: list[tuple[float, float, float]], path: str | Path, title: str, *,
                        reference: tuple[str, float] | None = None, empty: str = "no episode ended") -> Path | None:
    """Draw a training run's ``(env steps, mean episode return, mean episode length)`` points
    (the deep-RL examples' curves) into a PNG at ``path``; ``None`` without matplotlib.

    ``reference`` (a label and a return, e.g. random actions') is drawn as a dashed line across the
    returns, so the curve says what it improves on; an empty ``curve`` still gives a picture, with
    ``empty`` written across it, so a run never leaves the reader to guess why there is none."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        logger.warning("matplotlib is not installed: skipping the plot %s (pip install 'modelicagym[plots]')", path)
        return None
    steps, returns, lengths = np.array(curve, dtype=float).reshape(-1, 3).T
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5), layout="constrained")
    top.plot(steps, returns, label="training episodes")
    if reference is not None:
        label, value = reference
        top.axhline(value, color="tab:gray", linestyle="--", linewidth=1.0, label=f"{label}: {value:.4g}")
        top.legend(loc="lower right", fontsize=8, frameon=False)
    if not curve:
        top.text(0.5, 0.5, empty, transform=top.transAxes, ha="center", va="center", fontsize=9, wrap=True)
    top.set_ylabel("mean episode return")
    bottom.plot(steps, lengths)
    bottom.set_ylabel("mean episode length")
    bottom.set_xlabel("env steps")
    top.set_title(title)
    with atomic_write(Path(path), "wb") as f:
        fig.savefig(f, format="png", dpi=110)
    plt.close(fig)
    return Path(path)


def plot_sweep(
    result: SweepResult,
    path: str | Path,
    *,
    window: int = WINDOW,
    title: str | None = None,
    elsewhere: str = "choose another folder for it",
) -> Path | None:
    """Draw the learning curves of ``result`` into a PNG at ``path``; ``None`` without matplotlib.
    ``elsewhere`` is what a `DiskFullError` suggests besides freeing space."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        logger.warning("matplotlib is not installed: skipping the plot %s (pip install 'modelicagym[plots]')", path)
        return None

    path = Path(path)
    smoothed = moving_average(result.lengths, window)  # (settings, repeats, episodes - window + 1)
    episodes = np.arange(smoothed.shape[-1]) + min(window, result.lengths.shape[-1])
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    for s, setting in enumerate(result.config.settings):
        (line,) = ax.plot(episodes, smoothed[s].mean(axis=0), label=setting.label)
        ax.fill_between(episodes, smoothed[s].min(axis=0), smoothed[s].max(axis=0), color=line.get_color(), alpha=0.2)
    ax.set_xlabel("episode")
    ax.set_ylabel(f"episode length [steps], moving average of {window}")
    ax.set_title(title or f"{result.config.name}: mean of {result.config.repeats} repeats, band = min..max")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend()
    with atomic_write(path, "wb", elsewhere=elsewhere) as f:
        fig.savefig(f, format="png", dpi=110)
    plt.close(fig)
    return path
