"""The benchmarks' C builds apart from the native library that envs and pools load: its own small
library, linked against that one instance, and a clear error where no C compiler is found."""

from __future__ import annotations

import ctypes
from pathlib import Path

import pytest

from modelicagym.bench.native import SIGNATURES, SOURCES_DIR, bench_library
from modelicagym.errors import NativeBuildError
from modelicagym.native.library import load_extension, load_library


def test_the_native_library_carries_no_benchmark() -> None:
    for function in SIGNATURES:
        assert not hasattr(load_library(), function), function


def _address(function: ctypes._CFuncPtr) -> int:
    return ctypes.cast(function, ctypes.c_void_p).value


def test_the_benchmarks_library_calls_the_native_library_this_process_loaded() -> None:
    """Its C calls the step and the signals of the one native library in this process (the same
    addresses), not copies of its own."""
    library, native = bench_library(), load_library()
    assert all(hasattr(library, function) for function in SIGNATURES)
    assert Path(library._name).parent != Path(native._name).parent
    for function in ("mg_env_step", "mg_env_reset", "mg_signal_wait", "mg_signal_post"):
        assert _address(getattr(library, function)) == _address(getattr(native, function)), function


def test_no_c_compiler_is_a_clear_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(NativeBuildError, match=r"no C compiler found to build the benchmarks' library: install gcc"):
        load_extension(SOURCES_DIR, "libmodelicagym_bench.so", SIGNATURES, "the benchmarks' library")
