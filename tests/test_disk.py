"""A full disk under the cache: building our native library, building an FMU and extracting it each
end in one line naming the cache entry and what to do, with nothing half-made left in the cache.

The disk is real: a small tmpfs (`small_filesystem`) as ``$MODELICAGYM_CACHE``, filled up; the
command is the real ``modelicagym reproduce`` in a subprocess, its results on an ordinary disk.
"""

from __future__ import annotations

import argparse
import errno
import os
import re
import sys
from pathlib import Path

import pytest
from small_filesystem import FILL, run_with_small_filesystem

from modelicagym import errors
from modelicagym.cache import FOLDER_MANIFEST, damage
from modelicagym.console import run_command
from modelicagym.disk import atomic_write, disk_full
from modelicagym.experiments.results import completed_sweeps

#: each kind of entry, removed from a warm cache before the disk is filled to leave so many bytes:
#: too few for the library's link, the FMU's sources, the FMU's CMake build, the extraction
SCENARIOS = {"native": 16384, "fmu": 16384, "fmu-build": 300_000, "extraction": 16384}
ENTRIES = {"native": "native/*/*.so", "fmu": "fmus/*.fmu", "fmu-build": "fmus/*.fmu", "extraction": "extracted/*/"}

SCRIPT = """
set -u
reproduce() { "$PY" -m modelicagym.cli reproduce --sweeps force --episodes-scale 0.03 --bounds-budget 0 \\
              --no-progress --out "$@" > /dev/null; }
export MODELICAGYM_CACHE="$FS/cache"
reproduce "$OUT/warm" 2> "$OUT/warm.err" || exit 98
for scenario in $SCENARIOS; do
    entry=${scenario%=*}
    case $entry in
        native) rm -r "$FS"/cache/native/*/*.so* ;;
        fmu*) rm -r "$FS"/cache/fmus/*.fmu* ;;
        extraction) rm -r "$FS"/cache/extracted/* ;;
    esac
    rm -f "$FS/filler"
    "$PY" -c "$FILL" "$FS" "${scenario#*=}"
    reproduce "$OUT/results-$entry" 2> "$OUT/$entry.err"
    echo $? > "$OUT/$entry.rc"
    cp -a "$FS/cache" "$OUT/cache-$entry"
    rm -f "$FS/filler"
    reproduce "$OUT/results-$entry-again" 2> /dev/null || exit 97
    cp -a "$FS/cache" "$OUT/cache-$entry-again"
done
"""


def _entries(cache: Path, pattern: str) -> set[str]:
    return {p.relative_to(cache).as_posix() for p in cache.glob(pattern)}


@pytest.mark.processes
def test_a_full_disk_under_the_cache_is_one_line_naming_the_entry(tmp_path: Path) -> None:
    """Each entry is removed from a warm cache, the disk filled to leave too little room for it
    and ``reproduce`` run; then again with room, which makes the entry."""
    fs, out = tmp_path / "fs", tmp_path / "out"
    out.mkdir()
    scenarios = " ".join(f"{entry}={room}" for entry, room in SCENARIOS.items())
    environment = {**os.environ, "PY": sys.executable, "OUT": str(out), "FILL": FILL, "SCENARIOS": scenarios}
    done = run_with_small_filesystem(SCRIPT, fs, "8m", environment)
    assert done.returncode == 0, f"exit {done.returncode}: {done.stderr[-3000:]}"
    for entry, pattern in ENTRIES.items():
        cache, again = out / f"cache-{entry}", out / f"cache-{entry}-again"
        [missing] = _entries(again, pattern) - _entries(cache, pattern)
        assert (out / f"{entry}.rc").read_text().strip() == "1", entry
        stderr = (out / f"{entry}.err").read_text()
        assert "Traceback" not in stderr, stderr
        [line] = [line for line in stderr.splitlines() if not re.match(r"(DEBUG|INFO|WARNING) modelicagym", line)]
        assert line.startswith(f"error: cannot write {fs}/cache/{missing}: no space left on device"), line
        assert "free space" in line and "MODELICAGYM_CACHE" in line
        assert completed_sweeps(out / f"results-{entry}") == []  # the run is not marked complete
        assert not [p for p in cache.rglob("*") if p.suffix == ".tmp" or p.name.startswith(".")
                    and p.name != FOLDER_MANIFEST], entry  # no partial files, no staging folders
        assert not any((cache / "tmp").iterdir())  # no FMU build folders
        for published in [*cache.glob("native/*/*.so"), *cache.glob("fmus/*.fmu"), *cache.glob("extracted/*/")]:
            assert damage(published) is None  # every entry that is there is whole
        assert completed_sweeps(out / f"results-{entry}-again") == ["force"]  # with room, it is made


def test_disk_full_error_is_ours_an_os_error_and_one_line(tmp_path: Path) -> None:
    error = disk_full(tmp_path / "x.csv", "choose another results folder (reproduce --out)", errno.EDQUOT)
    assert isinstance(error, errors.ModelicaGymError) and isinstance(error, OSError)
    assert error.errno == errno.EDQUOT and error.filename == str(tmp_path / "x.csv")
    assert str(error) == (f"cannot write {tmp_path / 'x.csv'}: disk quota exceeded; free space on its file "
                          "system, or choose another results folder (reproduce --out)")


def test_atomic_write_leaves_the_old_file_and_no_temporary_one_when_the_write_fails(tmp_path: Path) -> None:
    target = tmp_path / "table.csv"
    target.write_text("old")
    with pytest.raises(OSError), atomic_write(target) as f:
        f.write("half")
        raise OSError(errno.EIO, "input/output error")
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["table.csv"]


def test_the_command_line_prints_a_full_disk_no_writer_of_ours_named_as_one_line(capsys) -> None:
    def command(args: argparse.Namespace) -> int:
        raise OSError(errno.ENOSPC, "No space left on device", "/data/out.bin")

    assert run_command(command, argparse.Namespace(debug=False)) == 1
    assert capsys.readouterr().err == ("error: cannot write /data/out.bin: no space left on device; free space on "
                                       "its file system, or write it to another folder\n")
    with pytest.raises(OSError, match="No space left"):
        run_command(command, argparse.Namespace(debug=True))
