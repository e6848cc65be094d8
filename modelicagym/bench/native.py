"""The benchmarks' own C (``bench/csrc``): no part of the library envs and pools load.

``mg_loop`` steps one env in a C loop, the limit a step path is compared with (`throughput.c_loop`,
``bench step-paths``); ``mg_wake_round_trip_ns`` measures what a wake-up costs on this machine, a
condition every benchmark reports (`machine.wake_round_trip_us`). Both are built on first use, as a
small library linked against the native one (`modelicagym.native.library.load_extension`).
"""

from __future__ import annotations

import ctypes
import functools
from pathlib import Path

from modelicagym.native.library import load_extension

__all__ = ["SIGNATURES", "SOURCES_DIR", "bench_library"]

SOURCES_DIR = Path(__file__).resolve().parent / "csrc"
#: ctypes signatures of the library's functions: name -> (restype, argtypes)
SIGNATURES = {
    "mg_loop": (ctypes.c_int64, (ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p)),
    "mg_wake_round_trip_ns": (ctypes.c_int64, (ctypes.c_int64,)),
}


@functools.cache
def bench_library() -> ctypes.CDLL:
    """The benchmarks' C library of this process, built on a cache miss; raises `NativeBuildError`."""
    return load_extension(SOURCES_DIR, "libmodelicagym_bench.so", SIGNATURES, "the benchmarks' C library")
