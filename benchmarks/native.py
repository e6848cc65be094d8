"""The C only ``python -m benchmarks barrier`` runs (``benchmarks/csrc``): a pool step's synchronisation
between forked workers, in C on both sides. Built on first use as a small library linked against the
native one (`modelicagym.native.library.load_extension`), whose signals and barrier it calls."""

from __future__ import annotations

import ctypes
import functools
from pathlib import Path

from modelicagym.native.library import load_extension

__all__ = ["SIGNATURES", "SOURCES_DIR", "sync_library"]

SOURCES_DIR = Path(__file__).resolve().parent / "csrc"
#: ctypes signatures of the library's functions: name -> (restype, argtypes)
SIGNATURES = {
    "mg_step_sync_ns": (ctypes.c_int64, (ctypes.c_int64, ctypes.c_int64, ctypes.c_int32, ctypes.c_int64, ctypes.c_int64)),
}


@functools.cache
def sync_library() -> ctypes.CDLL:
    """The synchronisation benchmark's C library, built on a cache miss; raises `NativeBuildError`."""
    return load_extension(SOURCES_DIR, "libmodelicagym_sync_bench.so", SIGNATURES,
                          "the synchronisation benchmark's C library")
