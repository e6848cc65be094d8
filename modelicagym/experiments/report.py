"""Render the reproduction report and its figures from a results directory.

A user's report goes beside its results (``results/report.md``, ``results/figures/<sweep>.png``):
``modelicagym report`` writes nowhere else. Every number and every verdict in the report is
computed from the result files; the only prose written by hand is an optional discussion, kept in a
notes file whose ``## <sweep name>`` sections (and ``## method``, ``## summary``,
``## execution_time``) are inserted under the matching headings, so regenerating the report never
loses it. The documentation's page is the same report, rendered by maintainers into ``docs/``
(``report --docs docs``: ``docs/reproduction.md`` with ``docs/reproduction-notes.md``'s discussion).
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from modelicagym.disk import atomic_write
from modelicagym.errors import NotFoundError
from modelicagym.experiments.analysis import LEARNING_RATIO, WINDOW, SettingSummary, summarize
from modelicagym.experiments.config import SweepConfig
from modelicagym.experiments.paper import FINDINGS, PAPER_NUMBERS, PAPER_SECONDS_PER_STEP, PAPER_SWEEPS, PaperNumbers
from modelicagym.experiments.plots import plot_sweep
from modelicagym.experiments.results import SweepResult, completed_sweeps, read_sweep

__all__ = ["DOCS_NOTES", "DOCS_PAGE", "REPORT_NAME", "TITLES", "read_notes", "render_report"]

logger = logging.getLogger(__name__)

TITLES = {
    "force": "Force magnitude",
    "masses": "Cart and pole masses [m_cart, m_pole]",
    "reward": "Negative reward",
    "time_step": "Simulation time step",
}

#: the report's file name in its output folder (the results folder unless told otherwise)
REPORT_NAME = "report.md"
#: the documentation's page of the report, and its hand-written discussion, in the docs folder
DOCS_PAGE = "reproduction.md"
DOCS_NOTES = "reproduction-notes.md"

#: what to do, besides freeing space, when the report finds its disk full
_ELSEWHERE = "choose another folder for the report (report --out)"
_NO_NOTES = "_Discussion not written yet: add a `## {key}` section to `{notes}`._"


def read_notes(path: Path) -> dict[str, str]:
    """The ``## key`` sections of the notes file (empty if it does not exist)."""
    if not path.exists():
        return {}
    parts = re.split(r"^## +(\S+) *$", path.read_text(encoding="utf-8"), flags=re.MULTILINE)
    return {key: body.strip() for key, body in zip(parts[1::2], parts[2::2], strict=True)}


def _discussion(notes: dict[str, str], key: str, notes_path: Path | None) -> list[str]:
    """The hand-written section ``key`` (a reminder to write it if the notes file lacks it), or
    nothing for a report without a notes file."""
    if notes_path is None:
        return []
    return [notes.get(key, _NO_NOTES.format(key=key, notes=notes_path.as_posix()))]


def _table(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def _paper_value(value: float | None, numbers: PaperNumbers | None) -> str:
    if value is None:
        return "–"
    return f"~{value:g}" if numbers and numbers.approximate else f"{value:g}"


def _option(value: Any) -> str:
    numeric = isinstance(value, (int, float)) and not isinstance(value, bool)
    return f"{value:g}" if numeric else repr(value)


def _mark(holds: bool) -> str:
    return "yes" if holds else "**no**"


def _longest(label: str, bounds: dict[str, int | None]) -> str:
    if label not in bounds:
        return "–"
    return "not found" if bounds[label] is None else str(bounds[label])


def _difference(s: SettingSummary, paper_last: float | None) -> str:
    """Ours minus the paper's last-``WINDOW`` mean, also in standard errors of our repeats."""
    if paper_last is None:
        return "–"
    difference = s.last - paper_last
    if s.last_standard_error == 0:
        return f"{difference:+.1f}"
    return f"{difference:+.1f} ({difference / s.last_standard_error:+.1f} SE)"


def _setting_rows(name: str, summaries: dict[str, SettingSummary], bounds: dict[str, int | None]) -> list[list[str]]:
    rows = []
    for label, s in summaries.items():
        paper = PAPER_NUMBERS.get(name, {}).get(label)
        rows.append(
            [
                label,
                f"{s.mean:.1f} ± {s.mean_std:.1f}",
                _paper_value(paper.mean if paper else None, paper),
                f"{s.last:.1f} ± {s.last_std:.1f}",
                _paper_value(paper.last if paper else None, paper),
                _difference(s, paper.last if paper else None),
                "–" if s.last_seconds is None else f"{s.last_seconds:.2f}",
                _longest(label, bounds),
                f"{s.first:.1f}",
                "yes" if s.learns else "no",
            ]
        )
    return rows


def _is_paper_sweep(config: SweepConfig) -> bool:
    """Whether ``config`` is one of the paper's sweeps, possibly with another number of episodes."""
    paper = PAPER_SWEEPS.get(config.name)
    return paper is not None and replace(config, episodes=paper.episodes) == paper


def _findings(name: str, summaries: dict[str, SettingSummary]) -> list[tuple[str, bool, str]]:
    return [(f.claim, *f.check(summaries)) for f in FINDINGS if f.sweep == name]


def _identical_settings(results: dict[str, SweepResult]) -> list[str]:
    """Settings that ran with the same options and seeds in several sweeps, and whether their
    episodes came out identical (they should: the env is deterministic)."""
    groups: dict[str, list[tuple[str, str, np.ndarray]]] = {}
    for name, result in results.items():
        c = result.config
        for s, setting in enumerate(c.settings):
            key = json.dumps(
                [c.env, c.options_for(setting), c.episodes, c.repeats, c.seed, c.to_dict()["agent"]], sort_keys=True
            )
            groups.setdefault(key, []).append((name, setting.label, result.lengths[s]))
    lines = []
    for runs in groups.values():
        if len(runs) > 1:
            same = all(np.array_equal(runs[0][2], other[2]) for other in runs[1:])
            where = ", ".join(f"{name} / {label}" for name, label, _ in runs)
            lines.append(f"- {where}: {'identical episodes' if same else '**episodes differ**'}")
    return lines


def _setup_section(results: dict[str, SweepResult]) -> str:
    first = next(iter(results.values()))
    machine = first.machine
    total = sum(r.timing.get("wall_seconds", 0.0) + r.timing.get("setup_seconds", 0.0) for r in results.values())
    started = min(r.timing.get("started", "") for r in results.values())
    spec = first.config.agent
    q = spec.q_learning
    intervals = (
        ", ".join(f"[{low:.4g}, {high:.4g}]" for low, high in spec.intervals)
        if spec.intervals
        else "the observation bounds"
    )
    options = ", ".join(f"`{k}={_option(v)}`" for k, v in first.config.base_options.items())
    packages = ", ".join(f"{k} {v}" for k, v in machine.get("packages", {}).items())
    truncation = "bootstrap" if q.bootstrap_on_truncation else "no bootstrap"
    return "\n".join(
        [
            "## What was run",
            "",
            f'- Env: `modelicagym.make_vec("{first.config.env}", ...)`, one env per (setting, repeat) of a sweep, '
            f"base options {options}; the sweeps override one or two of them.",
            f"- Agent: tabular Q-learning, {spec.n_bins} bins per observation variable over {intervals} "
            "(x, x_dot, theta, theta_dot; outermost bins open), Q-table uniform in "
            f"[{q.q_init_low:g}, {q.q_init_high:g}], learning rate {q.learning_rate:g}, discount {q.discount:g}, "
            f"exploration {q.exploration_rate:g} multiplied by {q.exploration_decay:g} after every step; "
            f"no bootstrap on termination, {truncation} on truncation.",
            f"- {first.config.repeats} repeats of every setting, seeded from (seed {first.config.seed}, repeat): "
            "repeat r uses the same seeds in every setting and every sweep.",
            f"- A setting *learns* when the mean length of its last {WINDOW} episodes is at least {LEARNING_RATIO:g} "
            f"times that of its first {WINDOW} (the paper's failing settings stay flat at about 9-10 steps).",
            "- Tables: *ours* is the mean over repeats ± the standard deviation over repeats; *ours − paper* is "
            f"the difference of the last-{WINDOW} means, also in standard errors of our repeats (sample standard "
            "deviation / sqrt(repeats)); the paper gives no spread.",
            "- *Longest possible*: the longest episode over all action sequences, by exhaustive search (the env is "
            "deterministic and starts from a fixed state); *not found* where the search gave up because long "
            "episodes exist. It bounds what any agent can learn.",
            f"- Machine: {machine.get('platform', '?')}, {machine.get('cpu_count', '?')} CPUs, "
            f"Python {machine.get('python', '?')}; {packages}.",
            f"- Runs started {started}; total wall time of the sweeps shown here {total:.0f} s.",
        ]
    )


def _seconds_range(low: float, high: float) -> str:
    return f"{low:g}" if low == high else f"{low:g}–{high:g}"


def _paper_seconds_per_step(name: str, label: str | None = None) -> str:
    """The paper's Table 1 entry for one setting, or the range over a whole sweep (``label=None``)."""
    if name != "time_step":
        return _seconds_range(*PAPER_SECONDS_PER_STEP["default"])
    if label is None:
        entries = PAPER_SECONDS_PER_STEP.values()
        return _seconds_range(min(low for low, _ in entries), max(high for _, high in entries))
    return _seconds_range(*PAPER_SECONDS_PER_STEP.get(label, PAPER_SECONDS_PER_STEP["default"]))


def _execution_section(results: dict[str, SweepResult], notes: dict[str, str], notes_path: Path | None) -> str:
    rows = []
    for name, result in results.items():
        t = result.timing
        pool_steps = t.get("env_steps_stepped", t["vector_steps"] * t["num_envs"])
        rows.append(
            [
                name,
                t["num_envs"],
                f"{t['env_steps']:,}",
                f"{pool_steps:,}",
                f"{t['wall_seconds']:.1f}",
                f"{1e6 * t['wall_seconds'] / pool_steps:.1f}",
                f"{1e6 * t['seconds_per_step']:.1f}",
                f"{100 * t['agent_seconds'] / t['wall_seconds']:.0f} %",
                _paper_seconds_per_step(name),
            ]
        )
    table = _table(
        [
            "sweep",
            "envs",
            "learned steps",
            "stepped steps",
            "wall time [s]",
            "µs per stepped step",
            "µs per learned step",
            "agent share",
            "paper: s per step (Table 1)",
        ],
        rows,
    )
    fmu_rows = [
        [name, label, f"{1e6 * entry['fmu_seconds_per_step']:.1f}", _paper_seconds_per_step(name, label)]
        for name, result in results.items()
        for label, entry in result.timing.get("per_setting", {}).items()
        if "fmu_seconds_per_step" in entry
    ]
    fmu_table = (
        "Time inside the FMU per env step, per setting (each env's FMU time over all the steps it took, autoresets included), "
        "next to the paper's time per step of the same experiment:\n\n"
        + _table(["sweep", "setting", "ours: FMU µs per step", "paper: s per step"], fmu_rows)
        if fmu_rows
        else "_The envs did not report their FMU time: no per-setting breakdown._"
    )
    per_setting = ", ".join(
        f"{label} {low:g} s" for label, (low, _) in PAPER_SECONDS_PER_STEP.items() if label != "default"
    )
    return "\n\n".join(
        [
            "## Execution time",
            "Ours: wall-clock time of a whole sweep, agent included (its share is shown), divided by env steps. "
            "All (setting, repeat) pairs of a sweep step side by side in one multi-process pool on this machine; "
            "an env that has finished its episodes is no longer stepped, so *stepped steps* exceed *learned steps* "
            "(the episodes' steps) only by the autoreset step that starts each episode. "
            "The paper's Table 1: one run at a time in a single process (PyFMI + JModelica FMU, 2017 laptop), "
            f"about {PAPER_SECONDS_PER_STEP['default'][0]:g}-{PAPER_SECONDS_PER_STEP['default'][1]:g} s per step, "
            f"more with the longest time steps ({per_setting}).",
            table,
            fmu_table,
            *_discussion(notes, "execution_time", notes_path),
        ]
    )


def _sweep_section(
    name: str, result: SweepResult, figure: Path | None, out_dir: Path, notes: dict[str, str], notes_path: Path | None
) -> tuple[str, list[tuple[str, str, bool, str]]]:
    summaries = summarize(result)
    paper_sweep = _is_paper_sweep(result.config)
    parts = [f"## {TITLES.get(name, name)} (`{name}`, {result.config.episodes} episodes)"]
    if name in PAPER_SWEEPS and not paper_sweep:
        parts.append("_This sweep's configuration differs from the paper's: no comparison._")
    if figure is not None:
        parts.append(f"![{name}]({figure.relative_to(out_dir).as_posix()})")
    parts.append(
        _table(
            [
                "setting",
                "mean length (ours)",
                "paper",
                f"last-{WINDOW} mean (ours)",
                "paper",
                "ours − paper",
                f"last-{WINDOW} in simulated s (ours)",
                "longest possible",
                f"first-{WINDOW} mean (ours)",
                "learns",
            ],
            _setting_rows(name if paper_sweep else "", summaries, result.bounds),
        )
    )
    findings = _findings(name, summaries) if paper_sweep else []
    if result.config.episodes < 2 * WINDOW:
        parts.append(
            f"**{result.config.episodes} episodes are fewer than {2 * WINDOW}: the first and last {WINDOW} "
            "episodes overlap, so the learning verdicts below mean nothing (a smoke run?).**"
        )
    if findings:
        parts.append(
            "Paper's findings, checked on our runs:\n\n"
            + "\n".join(f"- {claim}: holds here: {_mark(holds)} ({evidence})" for claim, holds, evidence in findings)
        )
    parts += _discussion(notes, name, notes_path)
    return "\n\n".join(parts), [(name, claim, holds, evidence) for claim, holds, evidence in findings]


def render_report(
    results_dir: str | Path,
    out_dir: str | Path | None = None,
    *,
    notes_path: str | Path | None = None,
    output_name: str = REPORT_NAME,
) -> Path:
    """Write ``<out_dir>/<output_name>`` and ``<out_dir>/figures/<sweep>.png`` from the results.

    ``out_dir`` defaults to ``results_dir``: the report lives beside the results it was made from.
    The discussion comes from ``notes_path`` (see the module's docstring); without one, the report
    holds the tables, figures and verdicts only. Returns the report's path.
    """
    results_dir = Path(results_dir)
    out_dir = results_dir if out_dir is None else Path(out_dir)
    notes_path = None if notes_path is None else Path(notes_path)
    names = completed_sweeps(results_dir)
    if not names:
        raise NotFoundError(f"no completed sweeps in {results_dir}")
    ordered = [n for n in PAPER_SWEEPS if n in names] + [n for n in names if n not in PAPER_SWEEPS]
    results = {name: read_sweep(results_dir, name) for name in ordered}
    notes = {} if notes_path is None else read_notes(notes_path)

    sections, verdicts = [], []
    for name, result in results.items():
        figure = plot_sweep(
            result,
            out_dir / "figures" / f"{name}.png",
            title=f"{TITLES.get(name, name)}: mean of {result.config.repeats} repeats, band = min..max",
            elsewhere=_ELSEWHERE,
        )
        section, found = _sweep_section(name, result, figure, out_dir, notes, notes_path)
        sections.append(section)
        verdicts += found

    summary = _table(
        ["sweep", "paper's finding", "holds here"],
        [[name, claim, _mark(holds)] for name, claim, holds, _ in verdicts],
    )
    identical = _identical_settings(results)
    document = "\n\n".join(
        [
            "# Reproducing the ModelicaGym cart-pole study",
            f"_Generated by `modelicagym report` from `{results_dir.as_posix()}`; do not edit by hand."
            + (f" The discussion paragraphs come from `{notes_path.as_posix()}`." if notes_path else "")
            + "_",
            "Paper: O. Lukianykhin, T. Bogodorova, *ModelicaGym: Applying Reinforcement Learning to Modelica Models*, "
            'EOOLT 2019. Paper numbers are the means over 5 runs it reports; "–": not reported.',
            _setup_section(results),
            *([notes["method"]] if "method" in notes else []),
            "## Summary",
            summary if verdicts else "_No sweep with paper findings among the results._",
            *_discussion(notes, "summary", notes_path),
            *(
                ["Settings run in several sweeps (same options and seeds):\n\n" + "\n".join(identical)]
                if identical
                else []
            ),
            *sections,
            _execution_section(results, notes, notes_path),
        ]
    )
    output = out_dir / output_name
    with atomic_write(output, elsewhere=_ELSEWHERE) as f:
        f.write(document + "\n")
    logger.info("wrote %s", output)
    return output


def console_summary(results_dir: str | Path, names: Sequence[str]) -> str:
    """A plain-text summary of sweeps ``names`` for the terminal: our episode lengths next to the
    paper's, and whether each of the paper's findings holds (the full comparison is the report)."""
    rows, checks = [], []
    for name in names:
        summaries = summarize(read_sweep(results_dir, name))
        for label, s in summaries.items():
            paper = PAPER_NUMBERS.get(name, {}).get(label)
            rows.append([name, label, f"{s.mean:.1f}", _paper_value(paper.mean if paper else None, paper),
                         f"{s.last:.1f}", _paper_value(paper.last if paper else None, paper),
                         "yes" if s.learns else "no"])
        checks += [f"  [{'yes' if holds else 'NO'}] {name}: {claim}" for claim, holds, _ in _findings(name, summaries)]
    headers = ["sweep", "setting", "mean length", "paper", f"last-{WINDOW} mean", "paper", "learns"]
    widths = [max(len(str(r[i])) for r in [headers, *rows]) for i in range(len(headers))]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip() for r in [headers, *rows]]
    findings = ["", "the paper's findings, checked on these runs:", *checks] if checks else []
    command = f"modelicagym report --results {results_dir}"
    report = Path(results_dir) / REPORT_NAME
    return "\n".join(lines + findings + ["", f"the full comparison, with figures: {command}   (writes {report})"])
