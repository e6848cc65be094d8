"""Our C library (``native/csrc/*.c``): compiled on first use, cached like the FMUs, loaded with ctypes.

The library is built with the machine's C compiler (``$CC``, else ``cc`` or ``gcc``: the
toolchain that builds our FMUs) into the modelicagym cache, under a hash of its sources and
the compiler, so every process of every run shares one build; concurrent first uses are
serialized by a lock and publish with an atomic rename. The library is checked against its
manifest before ``dlopen`` (`modelicagym.cache.ensure`): a copy cut short is rebuilt, not mapped.
Nothing compiled is ever committed.

C that only the benchmarks run is no part of it: `load_extension` builds such a folder the same way
into a small library of its own, linked against this one (``modelicagym/bench/csrc``, and a clone's
``benchmarks/csrc``), so no env or pool carries it.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from modelicagym.cache import cache_dir, ensure, write_manifest
from modelicagym.disk import build_ran_out_of_room, disk_full
from modelicagym.errors import NativeBuildError
from modelicagym.native.abi import check_layout

__all__ = ["NativeBuildError", "SOURCES_DIR", "load_extension", "load_library"]

logger = logging.getLogger(__name__)

SOURCES_DIR = Path(__file__).resolve().parent / "csrc"
_NAME = "libmodelicagym_native.so"
#: -ffp-contract=off: no fused multiply-add, so C does the arithmetic of the Python path and of fmpy's binaries
_FLAGS = ("-O2", "-shared", "-fPIC", "-pthread", "-std=c11", "-Wall", "-ffp-contract=off")
#: how an extension sees the production headers: for ``#include "step.h"`` only, so that ours never
#: stand in for a system header of the same name (``signal.h``, which ``<sys/wait.h>`` includes)
_HEADERS = "-iquote"


def _compiler(what: str = "modelicagym's native step library") -> str:
    for candidate in (os.environ.get("CC"), "cc", "gcc"):
        if candidate and shutil.which(candidate):
            return shutil.which(candidate)
    raise NativeBuildError(f"no C compiler found to build {what}: install gcc (e.g. `apt-get install gcc`) or set $CC")


def _sources(folder: Path = SOURCES_DIR) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix in (".c", ".h"))


def _digest(compiler: str, sources: list[Path], *also: str) -> str:
    """A hash of the compiler, its flags, ``also`` (what else the build depends on) and the sources."""
    digest = hashlib.sha256(" ".join((compiler, *_FLAGS, *also)).encode())
    for source in sources:
        digest.update(source.name.encode() + b"\0" + source.read_bytes())
    return digest.hexdigest()[:20]


#: ctypes signatures of the library's functions: name -> (restype, argtypes)
SIGNATURES = {
    "mg_abi": (ctypes.c_int64, (ctypes.c_void_p,)),
    "mg_now_ns": (ctypes.c_int64, ()),
    "mg_signal_post": (None, (ctypes.c_void_p,)),
    "mg_signal_try": (ctypes.c_int, (ctypes.c_void_p,)),
    "mg_signal_wait": (ctypes.c_int, (ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p)),
    "mg_machine_crowded": (ctypes.c_int, ()),
    "mg_machine_stall_us": (ctypes.c_int64, ()),
    "mg_env_step": (ctypes.c_int32, (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)),
    "mg_env_reset": (ctypes.c_int32, (ctypes.c_void_p,)),
    "mg_step_batch": (ctypes.c_int64, (ctypes.c_void_p,)),
    "mg_step_batch_in_range": (ctypes.c_int64, (ctypes.c_void_p, ctypes.c_void_p)),
    "mg_step_open": (ctypes.c_int64, (ctypes.c_void_p, ctypes.c_void_p)),
    "mg_end_steps": (ctypes.c_int64, (ctypes.c_void_p, ctypes.c_int32, ctypes.c_void_p)),
    "mg_watch_register": (ctypes.c_int32, (ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p)),
    "mg_watch_unregister": (None, (ctypes.c_void_p,)),
    "mg_serve": (ctypes.c_int32, (ctypes.c_void_p,)),
    "mg_collect": (ctypes.c_int32, (ctypes.c_void_p,)),
    "mg_post_step": (None, (ctypes.c_void_p,)),
    "mg_go_post": (None, (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64)),
    "mg_go_wait": (ctypes.c_int, (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64, ctypes.c_int64,
                                  ctypes.c_void_p)),
    "mg_answer": (None, (ctypes.c_void_p, ctypes.c_void_p)),
    "mg_first_outside_int64": (ctypes.c_int64, (ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64, ctypes.c_int64)),
    "mg_first_outside_float64": (
        ctypes.c_int64,
        (ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p),
    ),
    "mg_first_range_outside": (ctypes.c_int64, (ctypes.c_void_p, ctypes.c_int64)),
    "mg_integrator_open": (ctypes.c_int32, (ctypes.c_void_p, ctypes.c_double)),
    "mg_integrator_close": (None, (ctypes.c_void_p,)),
    "mg_integrator_advance": (ctypes.c_int32, (ctypes.c_void_p, ctypes.c_double, ctypes.c_double)),
    "mg_q_states": (None, (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)),
    "mg_q_act": (None, (ctypes.c_void_p,) * 4),
    "mg_q_learn": (None, (ctypes.c_void_p,) * 8),
}


@functools.cache
def load_library() -> ctypes.CDLL:
    """The native library of this process, built on a cache miss, its layout checked against
    `modelicagym.native.abi`; raises `NativeBuildError` (`NativeABIError` for a layout mismatch).

    Foreign calls release the GIL (``ctypes.CDLL``), so a wait in C never blocks other threads.
    """
    what = "the native step library"
    compiler = _compiler()
    sources = _sources()
    path = cache_dir() / "native" / _digest(compiler, sources) / _NAME
    path = ensure(path, lambda: _build(compiler, path, [*_c_files(sources), "-lm"], what), what)
    library = _load(path, SIGNATURES)
    check_layout(library, str(path))
    return library


def load_extension(sources: Path, name: str, signatures: dict[str, tuple], what: str) -> ctypes.CDLL:
    """The library of ``sources`` (a folder of C), apart from the production one: built like it on
    first use into the cache, under a hash of its sources and of the production library it links
    against. Its C includes the production headers (``#include "step.h"``) and calls the production
    library's functions: the very instance `load_library` loaded into this process, one state.

    For C that only benchmarks run (``name``: its file name; ``signatures`` as `SIGNATURES`; ``what``
    names it in messages). Raises `NativeBuildError`, which says so when there is no C compiler.
    """
    compiler = _compiler(what)
    production = Path(load_library()._name)
    files = _sources(sources)
    path = cache_dir() / "native" / "extensions" / _digest(compiler, files, _HEADERS, str(production)) / name
    inputs = [_HEADERS, str(SOURCES_DIR), *_c_files(files), str(production), "-lm"]
    return _load(ensure(path, lambda: _build(compiler, path, inputs, what), what), signatures)


def _c_files(sources: list[Path]) -> list[str]:
    return [str(p) for p in sources if p.suffix == ".c"]


def _load(path: Path, signatures: dict[str, tuple]) -> ctypes.CDLL:
    library = ctypes.CDLL(str(path))
    for name, (restype, argtypes) in signatures.items():
        function = getattr(library, name)
        function.restype, function.argtypes = restype, argtypes
    return library


def _build(compiler: str, path: Path, inputs: list[str], what: str) -> None:
    """Compile ``inputs`` (sources, libraries, include flags) into ``path``, published atomically."""
    folder = path.parent
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=folder, suffix=".so.tmp", delete=False) as handle:
        tmp = handle.name
    try:
        command = [compiler, *_FLAGS, "-o", tmp, *inputs]
        logger.info("building %s: %s", what, " ".join(command))
        result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if result.returncode != 0 and build_ran_out_of_room(result.stdout, folder):
            raise disk_full(path)
        if result.returncode != 0:
            raise NativeBuildError(f"building {what} failed ({' '.join(command)}):\n{result.stdout}")
        if result.stdout.strip():
            logger.warning("compiler output while building %s:\n%s", what, result.stdout)
        write_manifest(Path(tmp), published_as=path)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
