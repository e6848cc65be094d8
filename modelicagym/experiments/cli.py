"""Command line for the reproduction: ``reproduce`` runs sweeps, ``report`` renders the comparison.

Wire into the main CLI with ``add_parsers(subparsers)``; each sub-command stores its handler as
``func`` (``args.func(args)`` returns the exit code). Standalone: ``main(argv)`` or
``python -m modelicagym.experiments reproduce ...``.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence
from pathlib import Path

from modelicagym.console import add_debug_flag, run_command
from modelicagym.errors import NotFoundError
from modelicagym.experiments.bounds import DEFAULT_BUDGET
from modelicagym.experiments.config import ConfigError, SweepConfig, load_config
from modelicagym.experiments.paper import PAPER_SWEEPS
from modelicagym.experiments.ray_runner import RayRunner
from modelicagym.experiments.report import DOCS_NOTES, DOCS_PAGE, console_summary, render_report
from modelicagym.experiments.runner import LocalRunner, run_sweeps

__all__ = ["add_parsers", "main", "select_sweeps"]

logger = logging.getLogger(__name__)


def select_sweeps(
    names: str | None, config_files: Sequence[str] = (), episodes_scale: float = 1.0
) -> list[SweepConfig]:
    """The built-in sweeps named in ``names`` (comma-separated; all if ``None`` and no files),
    then the sweeps of ``config_files``, with episodes scaled by ``episodes_scale``."""
    selected: list[SweepConfig] = []
    if names is not None or not config_files:
        wanted = list(PAPER_SWEEPS) if names is None else [n.strip() for n in names.split(",") if n.strip()]
        unknown = [n for n in wanted if n not in PAPER_SWEEPS]
        if unknown:
            raise ConfigError(f"unknown sweeps {unknown}; built-in sweeps: {', '.join(PAPER_SWEEPS)}")
        selected += [PAPER_SWEEPS[n] for n in wanted]
    selected += [load_config(path) for path in config_files]
    duplicates = sorted({c.name for c in selected if [d.name for d in selected].count(c.name) > 1})
    if duplicates:
        raise ConfigError(f"several sweeps named {duplicates}: results would overwrite each other")
    return [config.scaled(episodes_scale) for config in selected]


def _reproduce(args: argparse.Namespace) -> int:
    configs = select_sweeps(args.sweeps, args.config, args.episodes_scale)
    if args.show_config:
        json.dump([c.to_dict() for c in configs], sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    if args.ray is None:
        runner = LocalRunner(num_workers=args.num_workers)
    else:
        runner = RayRunner(address=None if args.ray is True else args.ray, groups=args.ray_groups)
    run_sweeps(configs, args.out, runner=runner, resume=args.resume, progress=not args.no_progress,
               bounds_budget=args.bounds_budget)
    print(console_summary(args.out, [c.name for c in configs]))
    if args.report:
        print(f"report: {_render(args.out, docs=args.docs)}")
    return 0


def _report(args: argparse.Namespace) -> int:
    print(f"report: {_render(args.results, out=args.out, docs=args.docs, notes=args.notes)}")
    return 0


def _render(results: str, *, out: str | None = None, docs: str | None = None, notes: str | None = None) -> Path:
    """The report of ``results``: beside them (or in ``out``) as ``report.md``; with ``docs``, the
    documentation's page ``<docs>/reproduction.md`` with ``<docs>/reproduction-notes.md``'s discussion."""
    if notes is not None and not Path(notes).is_file():
        raise NotFoundError(f"--notes {notes}: no such file")
    if docs is None:
        return render_report(results, out, notes_path=notes)
    return render_report(results, docs, notes_path=notes or Path(docs) / DOCS_NOTES, output_name=DOCS_PAGE)


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``reproduce`` and ``report`` sub-commands to an argparse sub-parser group."""
    reproduce = subparsers.add_parser(
        "reproduce",
        help="run the paper's cart-pole sweeps (or your own) and write results",
        description="Run sweeps of Q-learning on the cart-pole FMU env, every (setting, repeat) of a sweep "
        f"side by side in one pool. Built-in sweeps: {', '.join(PAPER_SWEEPS)}.",
    )
    reproduce.add_argument("--out", default="results", help="results directory (default: results)")
    reproduce.add_argument("--sweeps", help="comma-separated built-in sweeps (default: all, unless --config is given)")
    reproduce.add_argument(
        "--config",
        action="append",
        default=[],
        metavar="FILE",
        help="a sweep config (.toml/.json) to run as well; repeatable",
    )
    reproduce.add_argument("--resume", action="store_true", help="skip sweeps already complete in --out")
    reproduce.add_argument(
        "--episodes-scale",
        type=float,
        default=1.0,
        metavar="X",
        help="multiply every sweep's episodes by X (e.g. 0.1 for a quick smoke run)",
    )
    reproduce.add_argument("--num-workers", type=int, help="worker processes of the pool (default: the pool's)")
    reproduce.add_argument("--no-progress", action="store_true", help="no progress bar")
    reproduce.add_argument(
        "--ray",
        nargs="?",
        const=True,
        metavar="ADDRESS",
        help="run each sweep's (setting, repeat) groups as Ray tasks: on the cluster at ADDRESS (HOST:PORT of "
        "the head node, or 'auto' for the one on this machine); without ADDRESS, ray.init()'s default "
        "($RAY_ADDRESS, else a new Ray on this machine). Needs pip install 'modelicagym[ray]'",
    )
    reproduce.add_argument("--ray-groups", type=int, metavar="N", help="Ray tasks per sweep (default: the cluster's CPUs)")
    reproduce.add_argument(
        "--bounds-budget",
        type=int,
        default=DEFAULT_BUDGET,
        metavar="STEPS",
        help="env steps per setting for the exhaustive search of the longest possible episode (0: skip; "
        f"default {DEFAULT_BUDGET})",
    )
    reproduce.add_argument(
        "--report", action="store_true", help="render the report afterwards: <out>/report.md and <out>/figures/"
    )
    reproduce.add_argument(
        "--docs", metavar="DIR", help=f"with --report, maintainers: refresh <DIR>/{DOCS_PAGE} instead"
    )
    reproduce.add_argument(
        "--show-config",
        action="store_true",
        help="print the selected sweeps as JSON (a template for --config) and exit",
    )
    reproduce.set_defaults(func=_reproduce)

    report = subparsers.add_parser(
        "report",
        help="render the comparison with the paper, and its figures, beside the results (<results>/report.md)",
        description="Compare the results of the paper's sweeps with the paper's numbers and findings: "
        "writes <results>/report.md and its figures in <results>/figures/, nothing elsewhere.",
    )
    report.add_argument("--results", default="results", help="results directory (default: results)")
    where = report.add_mutually_exclusive_group()
    where.add_argument(
        "--out", metavar="DIR", help="write report.md and figures/ here instead of the results directory"
    )
    where.add_argument(
        "--docs",
        metavar="DIR",
        help=f"maintainers: refresh the documentation's page <DIR>/{DOCS_PAGE} and <DIR>/figures/, with the "
        f"discussion of <DIR>/{DOCS_NOTES} (e.g. --docs docs in a clone)",
    )
    report.add_argument(
        "--notes",
        metavar="FILE",
        help="hand-written discussion: its '## <sweep>' sections go under the matching headings "
        f"(default: none; with --docs, <DIR>/{DOCS_NOTES})",
    )
    report.set_defaults(func=_report)


def main(argv: Sequence[str] | None = None) -> int:
    """Standalone entry point: ``reproduce ...`` or ``report ...``."""
    parser = argparse.ArgumentParser(prog="python -m modelicagym.experiments", description=__doc__.splitlines()[0])
    add_debug_flag(parser)
    add_parsers(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    return run_command(args.func, args)
