"""The cache checks what it holds before anyone loads it: a damaged entry (a shared library cut
short, an extracted FMU binary overwritten) is made again with a warning, not mapped (a truncated
library used to kill every later run with SIGBUS); the same FMU bytes anywhere are one entry; a
read-only cache keeps serving what it holds; an FMU that would expand beyond the limits is refused
before anything is written."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from modelicagym.cache import damage, ensure
from modelicagym.errors import CacheError
from modelicagym.fmu import InvalidFMUError, open_fmu
from modelicagym.native.library import load_library

LOAD_AND_STEP = """
import numpy as np
import modelicagym
env = modelicagym.make("cartpole")
env.reset(seed=1)
env.step(np.int64(1))
env.close()
print("stepped")
"""


def _run(code: str, cache: Path) -> subprocess.CompletedProcess:
    environment = {**os.environ, "MODELICAGYM_CACHE": str(cache)}
    return subprocess.run([sys.executable, "-c", code], env=environment, capture_output=True, text=True, timeout=300)


@pytest.fixture
def warm_cache(tmp_path: Path) -> Path:
    """A cache of its own holding the native library, the cart-pole FMU and its extraction."""
    cache = tmp_path / "cache"
    library_dir = Path(load_library()._name).parent
    shutil.copytree(library_dir, cache / "native" / library_dir.name)
    result = _run(LOAD_AND_STEP, cache)
    assert result.returncode == 0, result.stderr
    return cache


def _cut_short(path: Path) -> None:
    os.truncate(path, path.stat().st_size // 3)


@pytest.mark.processes
def test_a_truncated_native_library_is_rebuilt_not_mapped(warm_cache: Path) -> None:
    [library] = (warm_cache / "native").glob("*/*.so")
    _cut_short(library)
    result = _run(LOAD_AND_STEP, warm_cache)
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-2000:]}"
    assert "stepped" in result.stdout
    assert "damaged" in result.stderr and library.name in result.stderr
    assert damage(library) is None


@pytest.mark.processes
def test_a_truncated_extracted_fmu_binary_is_extracted_again(warm_cache: Path) -> None:
    [binary] = (warm_cache / "extracted").glob("*/binaries/*/*.so")
    _cut_short(binary)
    result = _run(LOAD_AND_STEP, warm_cache)
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-2000:]}"
    assert "damaged" in result.stderr and binary.name in result.stderr


@pytest.mark.processes
def test_a_truncated_built_fmu_is_built_again(warm_cache: Path) -> None:
    fmus = list((warm_cache / "fmus").glob("*.fmu"))
    for fmu in fmus:
        _cut_short(fmu)
    shutil.rmtree(warm_cache / "extracted")
    result = _run(LOAD_AND_STEP, warm_cache)
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-2000:]}"
    assert "damaged" in result.stderr
    assert all(damage(fmu) is None for fmu in fmus)


@contextlib.contextmanager
def read_only(folder: Path) -> Iterator[Path]:
    """``folder`` seen read-only: a read-only bind mount for root (who writes through permissions),
    the write bits removed for anyone else."""
    if os.geteuid() != 0:
        folders = [folder, *(p for p in folder.rglob("*") if p.is_dir())]
        for each in folders:
            each.chmod(0o555)
        try:
            yield folder
        finally:
            for each in folders:
                each.chmod(0o755)
        return
    view = folder.with_name(folder.name + "-read-only")
    view.mkdir(exist_ok=True)
    mounted = subprocess.run(["mount", "--bind", str(folder), str(view)], capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"root cannot bind-mount here, so nothing is read-only to root: {mounted.stderr.strip()}")
    try:
        subprocess.run(["mount", "-o", "remount,ro,bind", str(view)], check=True, capture_output=True)
        yield view
    finally:
        subprocess.run(["umount", str(view)], check=True)


@pytest.mark.processes
def test_a_read_only_cache_serves_what_it_holds_and_names_what_it_cannot_repair(warm_cache: Path) -> None:
    [binary] = (warm_cache / "extracted").glob("*/binaries/*/*.so")
    with read_only(warm_cache) as cache:
        result = _run(LOAD_AND_STEP, cache)
        assert result.returncode == 0, result.stderr
    _cut_short(binary)
    with read_only(warm_cache) as cache:
        result = _run(LOAD_AND_STEP, cache)
    assert result.returncode == 1, f"exit {result.returncode}: {result.stderr[-2000:]}"
    assert "CacheError" in result.stderr and "MODELICAGYM_CACHE" in result.stderr


def test_the_same_fmu_bytes_anywhere_are_extracted_once(tmp_path: Path, cartpole_fmu, monkeypatch) -> None:
    fmu = cartpole_fmu(2)  # built in the session's cache first (the first test of its process may be this one)
    monkeypatch.setenv("MODELICAGYM_CACHE", str(tmp_path / "cache"))
    first = open_fmu(fmu)
    copy = tmp_path / "elsewhere" / "CartPole.fmu"
    copy.parent.mkdir()
    shutil.copyfile(fmu, copy)
    os.utime(copy, ns=(1, 1))
    second = open_fmu(copy)
    assert second.unzip_dir == first.unzip_dir
    assert len([p for p in (tmp_path / "cache" / "extracted").iterdir() if p.is_dir()]) == 1


def _bomb(path: Path, megabytes: int) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("modelDescription.xml", "<fmiModelDescription/>")
        archive.writestr("resources/zeros.bin", bytes(megabytes << 20))
    return path


def test_an_fmu_expanding_beyond_the_limits_is_refused_before_anything_is_written(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("MODELICAGYM_CACHE", str(tmp_path / "cache"))
    bomb = _bomb(tmp_path / "Bomb.fmu", 64)
    with pytest.raises(InvalidFMUError, match=r"Bomb\.fmu would expand to [\d,]+ times its size, over the limit of "
                                              r"200 \(set \$MODELICAGYM_MAX_FMU_RATIO higher"):
        open_fmu(bomb)
    assert not any(p.is_file() and p.suffix != ".lock" for p in (tmp_path / "cache").rglob("*"))
    monkeypatch.setenv("MODELICAGYM_MAX_FMU_BYTES", "1e6")
    with pytest.raises(InvalidFMUError, match=r"[\d,]+ bytes, over the limit of 1,000,000"):
        open_fmu(bomb)
    monkeypatch.setenv("MODELICAGYM_MAX_FMU_RATIO", "1e6")
    monkeypatch.setenv("MODELICAGYM_MAX_FMU_BYTES", "1e9")
    with pytest.raises(InvalidFMUError, match="cannot read modelDescription.xml"):
        open_fmu(bomb)  # within raised limits it is extracted, and fails later for what it is


def test_a_damaged_entry_that_cannot_be_made_again_is_a_cache_error(tmp_path: Path, monkeypatch) -> None:
    entry = tmp_path / "entry.bin"
    with pytest.raises(CacheError, match=r"entry\.bin .* does not check out .*manifest"):
        ensure(entry, lambda: entry.write_bytes(b"no manifest written"), "a test entry")
