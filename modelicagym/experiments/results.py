"""Result files of sweeps, written atomically so an interrupted run never leaves half a file.

Layout of a results directory::

    episodes.csv            all completed sweeps in one tidy table (made again from the verified
                            sweeps after every sweep and on every run, so --resume repairs it)
    <name>/episodes.csv     tidy episodes of one sweep: experiment,setting,repeat,episode,length,reward
    <name>/agent.npz        the trained Q-tables, one per (setting, repeat) in env order (see below)
    <name>/run.json         the sweep's config, timing, machine and the manifest of the files above
                            (bytes, SHA-256, rows); written last: marks completion
    <name>/episode_lengths.png   the learning curves (see plots.py)

Every file is written to a temporary file in the same directory, synced and renamed over the target.
A sweep counts as complete only while its files match the manifest in its ``run.json``: a file cut
short or changed after the run (a full disk, a crash while copying) makes it incomplete, so
``--resume`` runs it again and the combined table leaves it out, each with a warning that says why.
A full disk is a `~modelicagym.errors.DiskFullError` naming the file; the sweep's files written so
far are removed again, and its ``run.json`` is not written.
"""

from __future__ import annotations

import contextlib
import csv
import json
import logging
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from modelicagym.agents import QLearningAgent
from modelicagym.cache import file_record, mismatch
from modelicagym.disk import atomic_write
from modelicagym.errors import ArgumentTypeError, DataError, NotFoundError
from modelicagym.experiments.config import SweepConfig

__all__ = [
    "COLUMNS",
    "ELSEWHERE",
    "PLOT_PNG",
    "SweepResult",
    "atomic_write",
    "completed_sweeps",
    "is_complete",
    "read_sweep",
    "sweep_damage",
    "sweep_dir",
    "write_combined_csv",
    "write_sweep",
]

logger = logging.getLogger(__name__)

COLUMNS = ("experiment", "setting", "repeat", "episode", "length", "reward")
EPISODES_CSV = "episodes.csv"
RUN_JSON = "run.json"
AGENT_NPZ = "agent.npz"
PLOT_PNG = "episode_lengths.png"
#: what to do, besides freeing space, when a results file finds its disk full
ELSEWHERE = "choose another results folder (reproduce --out)"


@dataclass
class SweepResult:
    """Everything one sweep produced.

    ``lengths[s, r, k]`` and ``returns[s, r, k]`` are the length and total reward of episode ``k``
    of repeat ``r`` of setting ``s`` (in config order). ``timing`` holds wall-clock numbers (see
    :mod:`modelicagym.experiments.runner`), ``machine`` where and with what it ran, ``bounds`` the
    longest episode possible per setting label (see :mod:`modelicagym.experiments.bounds`; ``None``:
    not found by the search), ``agent`` the trained agent (not read back by :func:`read_sweep`; load
    ``<name>/agent.npz`` with ``QLearningAgent.load``: Q-table ``s * repeats + r`` is repeat ``r`` of
    setting ``s``).
    """

    config: SweepConfig
    lengths: np.ndarray
    returns: np.ndarray
    timing: dict[str, Any] = field(default_factory=dict)
    machine: dict[str, Any] = field(default_factory=dict)
    bounds: dict[str, int | None] = field(default_factory=dict)
    agent: QLearningAgent | None = None

    def steps_per_setting(self) -> np.ndarray:
        """Env steps learned from, per setting (all repeats)."""
        return self.lengths.sum(axis=(1, 2))


def _paths(results_dir: Path, name: str) -> tuple[Path, Path]:
    return sweep_dir(results_dir, name) / EPISODES_CSV, sweep_dir(results_dir, name) / RUN_JSON


def _rows(result: SweepResult) -> Iterator[tuple[Any, ...]]:
    name = result.config.name
    for s, setting in enumerate(result.config.settings):
        for r in range(result.config.repeats):
            for k in range(result.config.episodes):
                yield name, setting.label, r, k, int(result.lengths[s, r, k]), f"{result.returns[s, r, k]:.12g}"


def write_sweep(results_dir: str | Path, result: SweepResult) -> None:
    """Write the sweep's episodes, its agent (if any) and last ``run.json`` (the completion
    marker), each atomically. If one cannot be written (a full disk: `DiskFullError`), the
    files this call already wrote are removed again: no incomplete set is left behind."""
    csv_path, json_path = _paths(Path(results_dir), result.config.name)
    written: list[Path] = []
    try:
        with atomic_write(csv_path, elsewhere=ELSEWHERE) as f:
            writer = csv.writer(f)
            writer.writerow(COLUMNS)
            writer.writerows(_rows(result))
        written.append(csv_path)
        if result.agent is not None:
            with atomic_write(csv_path.parent / AGENT_NPZ, "wb", elsewhere=ELSEWHERE) as f:
                result.agent.save(f)
            written.append(csv_path.parent / AGENT_NPZ)
        files = {path.name: file_record(path) for path in written}
        files[EPISODES_CSV]["rows"] = result.lengths.size
        document = {
            "experiment": result.config.name,
            "config": result.config.to_dict(),
            "timing": result.timing,
            "machine": result.machine,
            "bounds": result.bounds,
            "files": files,
        }
        with atomic_write(json_path, elsewhere=ELSEWHERE) as f:
            json.dump(document, f, indent=2, default=_json_default)
            f.write("\n")
    except BaseException:
        for path in written:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
        raise
    logger.info("wrote %s and %s", csv_path, json_path)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise ArgumentTypeError(f"not JSON serializable: {type(value).__name__}")


def _read_document(json_path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(json_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def sweep_damage(results_dir: str | Path, name: str) -> str | None:
    """What makes sweep ``name`` in ``results_dir`` incomplete, or ``None`` if its ``run.json``
    is readable and every file it lists still has the bytes that were written."""
    csv_path, json_path = _paths(Path(results_dir), name)
    document = _read_document(json_path)
    if document is None or "config" not in document:
        return f"{json_path} is missing or unreadable"
    if "files" not in document:  # written before run.json had a manifest: read the table itself
        try:
            read_sweep(results_dir, name)
        except (DataError, OSError) as error:
            return str(error)
        return None
    return mismatch(csv_path.parent, document["files"])


def sweep_dir(results_dir: str | Path, name: str) -> Path:
    """Directory of one sweep's files."""
    return Path(results_dir) / name


def is_complete(results_dir: str | Path, config: SweepConfig) -> bool:
    """Whether ``config`` already ran to completion in ``results_dir``: the same config, and every
    file as it was written (`sweep_damage`)."""
    csv_path, json_path = _paths(Path(results_dir), config.name)
    document = _read_document(json_path)
    if document is None:
        return False
    if document.get("config") != json.loads(json.dumps(config.to_dict())):
        logger.warning("%s holds results of a different configuration of %r: not reusing them", json_path, config.name)
        return False
    problem = sweep_damage(results_dir, config.name)
    if problem is not None:
        logger.warning("sweep %r in %s is incomplete (%s): running it again", config.name, results_dir, problem)
        return False
    return True


def completed_sweeps(results_dir: str | Path) -> list[str]:
    """Names of the complete sweeps (`sweep_damage`), sorted; an incomplete one is left out with
    a warning."""
    names = []
    for json_path in sorted(Path(results_dir).glob(f"*/{RUN_JSON}")):
        problem = sweep_damage(results_dir, json_path.parent.name)
        if problem is None:
            names.append(json_path.parent.name)
        else:
            logger.warning("sweep %r left out: it is incomplete (%s)", json_path.parent.name, problem)
    return names


def read_sweep(results_dir: str | Path, name: str) -> SweepResult:
    """Read back what :func:`write_sweep` wrote."""
    csv_path, json_path = _paths(Path(results_dir), name)
    document = _read_document(json_path)
    if document is None:
        raise NotFoundError(f"no completed sweep {name!r} in {results_dir} ({json_path} missing or unreadable)")
    config = SweepConfig.from_dict(document["config"])
    labels = {setting.label: s for s, setting in enumerate(config.settings)}
    shape = (len(config.settings), config.repeats, config.episodes)
    lengths = np.full(shape, -1, dtype=np.int64)
    returns = np.zeros(shape, dtype=np.float64)
    try:
        with open(csv_path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            for row in reader:
                index = labels[row["setting"]], int(row["repeat"]), int(row["episode"])
                lengths[index] = int(row["length"])
                returns[index] = float(row["reward"])
    except FileNotFoundError:
        raise NotFoundError(f"{csv_path} is missing: sweep {name!r} is incomplete") from None
    except (KeyError, IndexError, ValueError, TypeError, csv.Error) as error:
        raise DataError(f"{csv_path}, line {reader.line_num}: not a row of sweep {name!r} "
                        f"({type(error).__name__}: {error})") from None
    if (lengths < 0).any():
        raise DataError(f"{csv_path} lacks {(lengths < 0).sum()} of the {lengths.size} episodes of {name!r}")
    return SweepResult(
        config, lengths, returns, document.get("timing", {}), document.get("machine", {}), document.get("bounds", {})
    )


def write_combined_csv(results_dir: str | Path) -> Path:
    """Concatenate the CSVs of all completed sweeps into ``episodes.csv``, atomically: the table is
    made again from the sweeps' verified files, whatever it held before."""
    results_dir = Path(results_dir)
    combined = results_dir / EPISODES_CSV
    with atomic_write(combined, elsewhere=ELSEWHERE) as out:
        out.write(",".join(COLUMNS) + "\n")
        for name in completed_sweeps(results_dir):
            with open(results_dir / name / EPISODES_CSV, encoding="utf-8", newline="") as f:
                f.readline()
                out.writelines(f)
    return combined
