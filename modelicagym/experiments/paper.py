"""The ModelicaGym paper's cart-pole study (Lukianykhin & Bogodorova, EOOLT 2019), as data.

Three things live here: the four sweeps as built-in configs, the numbers the paper reports for
them, and the paper's findings as checks that can be evaluated on our results. The thresholds the
checks use are in :mod:`modelicagym.experiments.analysis`.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from modelicagym.experiments.analysis import LEARNING_RATIO, WINDOW, SettingSummary
from modelicagym.experiments.config import AgentSpec, Setting, SweepConfig
from modelicagym.models.cartpole.env import CARTPOLE_INTERVALS

__all__ = [
    "BASE_OPTIONS",
    "FINDINGS",
    "PAPER_NUMBERS",
    "PAPER_SECONDS_PER_STEP",
    "PAPER_SWEEPS",
    "Finding",
    "PaperNumbers",
]

#: The base setting of every sweep (env options of ``modelicagym.make("cartpole")``).
BASE_OPTIONS: dict[str, float | int] = {
    "force": 15.0,
    "m_cart": 10.0,
    "m_pole": 1.0,
    "theta_0": float(np.deg2rad(85.0)),
    "theta_dot_0": 0.0,
    "time_step": 0.05,
    "positive_reward": 1.0,
    "negative_reward": -100.0,
    "max_episode_steps": 500,
}

_AGENT = AgentSpec(n_bins=10, intervals=CARTPOLE_INTERVALS)


def _sweep(name: str, episodes: int, settings: list[tuple[str, dict[str, float]]]) -> SweepConfig:
    return SweepConfig(
        name=name,
        settings=tuple(Setting(label, options) for label, options in settings),
        episodes=episodes,
        env="cartpole",
        repeats=5,
        seed=0,
        base_options=BASE_OPTIONS,
        agent=_AGENT,
    )


#: The paper's four sweeps, in the paper's order.
PAPER_SWEEPS: dict[str, SweepConfig] = {
    sweep.name: sweep
    for sweep in (
        _sweep("force", 100, [(f"{f} N", {"force": float(f)}) for f in (5, 11, 17)]),
        _sweep(
            "masses",
            200,
            [
                (f"[{c}, {p}] kg", {"m_cart": float(c), "m_pole": float(p)})
                for c, p in ((1, 10), (5, 10), (10, 10), (10, 5), (10, 1))
            ],
        ),
        _sweep("reward", 200, [(f"{r}", {"negative_reward": float(r)}) for r in (-200, -100, -50)]),
        _sweep("time_step", 200, [(f"{dt} s", {"time_step": float(dt)}) for dt in (0.01, 0.05, 0.1, 0.5, 1)]),
    )
}


@dataclass(frozen=True)
class PaperNumbers:
    """What the paper reports for one setting: mean episode length over all episodes and over the
    last 20 (means over 5 runs); ``None`` where it gives none; ``approximate`` for "about" values."""

    mean: float | None = None
    last: float | None = None
    approximate: bool = False


PAPER_NUMBERS: dict[str, dict[str, PaperNumbers]] = {
    "force": {"5 N": PaperNumbers(9.3, 9.4), "11 N": PaperNumbers(16.9, 25.6), "17 N": PaperNumbers(22.9, 31.6)},
    "masses": {
        "[1, 10] kg": PaperNumbers(last=44.0),
        "[5, 10] kg": PaperNumbers(last=38.2),
        "[10, 10] kg": PaperNumbers(last=10.1),
        "[10, 5] kg": PaperNumbers(last=41.2),
        "[10, 1] kg": PaperNumbers(last=38.9),
    },
    "reward": {"-200": PaperNumbers(last=60.3), "-100": PaperNumbers(last=38.9), "-50": PaperNumbers(last=32.0)},
    "time_step": {
        "0.01 s": PaperNumbers(last=142.0),
        "0.05 s": PaperNumbers(last=38.9),
        "0.1 s": PaperNumbers(last=26.8),
        "0.5 s": PaperNumbers(last=4.0, approximate=True),
        "1 s": PaperNumbers(last=1.0, approximate=True),
    },
}

#: Table 1 of the paper: seconds per simulation step (2017 laptop, PyFMI, JModelica FMU), as
#: (low, high). About 0.11-0.12 s for every experiment except the two longest time steps.
PAPER_SECONDS_PER_STEP: dict[str, tuple[float, float]] = {
    "default": (0.11, 0.12),
    "0.5 s": (0.145, 0.145),
    "1 s": (0.218, 0.218),
}


@dataclass(frozen=True)
class Finding:
    """A claim of the paper about one sweep and how to test it on our summaries.

    ``check(summaries)`` returns whether the claim holds and the numbers it was decided on.
    """

    sweep: str
    claim: str
    check: Callable[[Mapping[str, SettingSummary]], tuple[bool, str]]


def _learns(label: str, expected: bool) -> Callable[[Mapping[str, SettingSummary]], tuple[bool, str]]:
    def check(summaries: Mapping[str, SettingSummary]) -> tuple[bool, str]:
        s = summaries[label]
        ratio = s.last / s.first
        relation = ">=" if s.learns else "<"
        evidence = (
            f"{label}: last {WINDOW} / first {WINDOW} = {s.last:.1f} / {s.first:.1f} = {ratio:.2f} {relation} "
            f"{LEARNING_RATIO}"
        )
        if s.longest_possible is not None:
            evidence += f", longest possible episode {s.longest_possible} steps"
        return s.learns == expected, evidence

    return check


def _all(*checks: Callable[[Mapping[str, SettingSummary]], tuple[bool, str]]):
    def check(summaries: Mapping[str, SettingSummary]) -> tuple[bool, str]:
        outcomes = [c(summaries) for c in checks]
        return all(ok for ok, _ in outcomes), "; ".join(evidence for _, evidence in outcomes)

    return check


def _decreasing(labels: list[str], statistic: str) -> Callable[[Mapping[str, SettingSummary]], tuple[bool, str]]:
    """The statistic (``"mean"`` or ``"last"``, averaged over repeats) strictly decreases along
    ``labels``; the evidence also counts the repeats in which it does (repeats share seeds)."""

    def check(summaries: Mapping[str, SettingSummary]) -> tuple[bool, str]:
        values = [getattr(summaries[label], statistic) for label in labels]
        per_repeat = np.array([getattr(summaries[label], f"repeat_{statistic}s") for label in labels])
        in_repeats = int(np.all(per_repeat[:-1] > per_repeat[1:], axis=0).sum())
        name = {"mean": "mean length", "last": f"last-{WINDOW} mean"}[statistic]
        evidence = (
            f"{name}: "
            + " > ".join(f"{label} {v:.1f}" for label, v in zip(labels, values, strict=True))
            + f"; in {in_repeats} of {per_repeat.shape[1]} repeats"
        )
        return all(a > b for a, b in itertools.pairwise(values)), evidence

    return check


def _lowest(label: str, statistic: str) -> Callable[[Mapping[str, SettingSummary]], tuple[bool, str]]:
    def check(summaries: Mapping[str, SettingSummary]) -> tuple[bool, str]:
        own = getattr(summaries[label], statistic)
        others = {other: getattr(s, statistic) for other, s in summaries.items() if other != label}
        best_other = min(others, key=others.get)
        evidence = f"last-{WINDOW} mean of {label} {own:.1f} vs lowest other {best_other} {others[best_other]:.1f}"
        return own < others[best_other], evidence

    return check


FINDINGS: tuple[Finding, ...] = (
    Finding("force", "5 N is too weak: the agent fails to learn", _learns("5 N", False)),
    Finding("force", "11 N learns", _learns("11 N", True)),
    Finding("force", "17 N learns faster than 11 N (longer mean episodes)", _decreasing(["17 N", "11 N"], "mean")),
    Finding("masses", "[10, 10] kg fails to learn", _learns("[10, 10] kg", False)),
    Finding(
        "masses",
        "the other mass ratios learn",
        _all(*(_learns(label, True) for label in ("[1, 10] kg", "[5, 10] kg", "[10, 5] kg", "[10, 1] kg"))),
    ),
    Finding("masses", "[10, 10] kg has the shortest episodes", _lowest("[10, 10] kg", "last")),
    Finding(
        "reward", "a larger penalty learns faster: -200 > -100 > -50", _decreasing(["-200", "-100", "-50"], "last")
    ),
    Finding(
        "time_step",
        "smaller time steps give longer episodes (in steps)",
        _decreasing(["0.01 s", "0.05 s", "0.1 s", "0.5 s", "1 s"], "last"),
    ),
    Finding(
        "time_step", "0.5 s and 1 s steps cannot balance the pole", _all(_learns("0.5 s", False), _learns("1 s", False))
    ),
)
