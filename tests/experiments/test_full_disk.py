"""``reproduce`` and ``report`` onto a full file system: one line naming the file and what to do,
no traceback, nothing half-written, the sweeps already written intact, the run not marked complete.

The disk is real: a small tmpfs (`small_filesystem`), filled up between commands; the commands are
the real ones (``python -m modelicagym.cli``, the cart-pole FMU in the pool), run in a subprocess.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import pytest
from extras import requires
from small_filesystem import FILL, run_with_small_filesystem

from modelicagym.experiments.results import completed_sweeps

pytestmark = [pytest.mark.processes, requires("plots")]  # the real commands; the report's figures

#: the smallest run of the paper's sweeps: 3 and 6 episodes per (setting, repeat)
SMALL = "--episodes-scale 0.03 --bounds-budget 0 --no-progress"

SCRIPT = f"""
set -u
modelicagym() {{ "$PY" -m modelicagym.cli "$@"; }}
modelicagym reproduce --out "$FS/results" --sweeps force {SMALL} > /dev/null 2> "$OUT/first.err" || exit 98
cp -a "$FS/results" "$OUT/before"
"$PY" -c "$FILL" "$FS" 100000
modelicagym reproduce --out "$FS/results" --resume --sweeps force,reward {SMALL} > /dev/null 2> "$OUT/reproduce.err"
echo $? > "$OUT/reproduce.rc"
"$PY" -c "$FILL" "$FS" 0
modelicagym report --results "$FS/results" > /dev/null 2> "$OUT/report.err"
echo $? > "$OUT/report.rc"
cp -a "$FS/results" "$OUT/after"
"""


def _error_line(stderr: str) -> str:
    """The one line of stderr that is not a log record (the log goes to stderr too)."""
    assert "Traceback" not in stderr, stderr
    lines = [line for line in stderr.splitlines() if not re.match(r"(DEBUG|INFO|WARNING) modelicagym", line)]
    assert len(lines) == 1, stderr
    return lines[0]


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_reproduce_and_report_on_a_full_disk_say_so_in_one_line_and_leave_nothing_half_written(tmp_path: Path) -> None:
    """A sweep (``force``) is written, the disk filled to 100 kB of room, and ``--resume`` runs the
    next (``reward``): its episodes fit, its Q-tables (2.4 MB) do not. Then, with no room at all,
    ``report`` cannot draw its first figure."""
    fs, out = tmp_path / "fs", tmp_path / "out"
    out.mkdir()
    environment = {**os.environ, "PY": sys.executable, "OUT": str(out), "FILL": FILL}
    done = run_with_small_filesystem(SCRIPT, fs, "8m", environment)
    assert done.returncode == 0, f"exit {done.returncode}: {done.stderr[-3000:]}"

    assert (out / "reproduce.rc").read_text().strip() == "1"
    line = _error_line((out / "reproduce.err").read_text())
    assert line.startswith(f"error: cannot write {fs}/results/reward/agent.npz: no space left on device"), line
    assert "free space" in line and "--out" in line

    after = out / "after"
    assert completed_sweeps(after) == ["force"]
    assert _files(after / "force") == _files(out / "before" / "force")  # the finished sweep is intact
    assert (after / "episodes.csv").read_bytes() == (out / "before" / "episodes.csv").read_bytes()
    assert not (after / "reward" / "run.json").exists()  # not marked complete
    assert list((after / "reward").iterdir()) == []  # its episodes, written before, removed again
    assert not [p for p in after.rglob("*") if p.name.startswith(".") or p.suffix == ".tmp"]

    assert (out / "report.rc").read_text().strip() == "1"
    line = _error_line((out / "report.err").read_text())
    assert line.startswith(f"error: cannot write {fs}/results/figures/force.png: no space left on device"), line
    assert "free space" in line and "report --out" in line
    assert not (after / "report.md").exists() and not [p for p in (after / "figures").rglob("*") if p.is_file()]
