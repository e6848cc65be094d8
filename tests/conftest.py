"""The fixtures every test module shares: FMI versions and interface types to run over, the FMUs
(built once per session, from the content-hashed build cache) and the pool's leak check.

Tests are laid out like the package (``fmu/``, ``native/``, ``env/``, ``models/``, ``vector/``,
``agents/``, ``experiments/``, ``distributed/``, ``bench/``, ``examples/``; the package's top-level
modules at the top), and ``benchmarks/`` for a clone's ``benchmarks/``. The helpers they share sit
here beside this file (pytest puts this folder on ``sys.path``), in modules named for what they
hold: ``fmu_family`` (the test FMUs), ``episodes`` (driving an env through an episode),
``step_paths`` (envs on the native and the Python step path), ``vector_envs`` and
``vector_rollouts`` (envs and comparisons for the pool), ``vector_leaks`` (processes, /dev/shm
entries and fds), ``toy_envs`` (tiny envs for the agent and the experiments), ``reference_cartpole``
(independent cart-pole physics), ``ray_cluster`` and ``sweep_checks`` (a local Ray, and sweeps
compared with a local run), ``extras`` (skipping what needs an optional extra that is not
installed), ``process_guard`` (the ``processes`` marker kept true), ``bench_runs`` (a benchmark run
in a fresh process), ``help_texts`` (a command's ``--help`` as its reader sees it).

Tests that start processes are marked ``processes``: every test of the folders in
`PROCESS_FOLDERS` or using a fixture of `PROCESS_FIXTURES`, and elsewhere by hand; the guard fails
a test that starts one unmarked. The rest is the fast subset, ``pytest -m "not processes"``.
"""

from __future__ import annotations

import atexit
import functools
import gc
import os
import platform
import sys
import threading
from pathlib import Path
from typing import Callable, Iterator

import pytest
from fmu_family import FMI_VERSIONS, build
from process_guard import MARKER, ProcessGuard, failure_message
from vector_envs import CountEnv
from vector_leaks import Snapshot

from modelicagym.models.cartpole import cartpole_fmu as build_cartpole_fmu
from modelicagym.vector import PoolVectorEnv
from modelicagym.vector.layout.machine_load import machine_crowded

TESTS = Path(__file__).resolve().parent
#: folders (of ``tests/``) whose every test starts processes: the pool's, Ray's, the examples',
#: the benchmarks' (scripts run in subprocesses) and the docs' code blocks
PROCESS_FOLDERS = ("vector", "distributed", "examples", "bench", "benchmarks", "docs")
#: fixtures whose setup starts processes (the fork server, the resource tracker)
PROCESS_FIXTURES = {"pool_services", "no_leaks"}
GUARD = ProcessGuard()
#: the status the test session ends with (`pytest_sessionfinish`), for `pytest_unconfigure`
_SESSION_STATUS: list[int] = []


def pytest_configure(config: pytest.Config) -> None:
    platform.processor()  # Python runs `uname -p` for it once per process: here, not in whichever test asks first
    GUARD.install()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark ``processes`` every test of `PROCESS_FOLDERS` and every one using `PROCESS_FIXTURES`."""
    for item in items:
        folder = item.path.relative_to(TESTS).parts[0] if item.path.is_relative_to(TESTS) else None
        if folder in PROCESS_FOLDERS or set(getattr(item, "fixturenames", ())) & PROCESS_FIXTURES:
            item.add_marker(MARKER)


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> Iterator[None]:
    GUARD.begin(item.nodeid)
    return (yield)


@pytest.hookimpl(wrapper=True, trylast=True)
def pytest_runtest_teardown(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    """Fail a test not marked ``processes`` that started one (in its setup, body or teardown)."""
    result = yield
    starts = GUARD.end()
    if starts and item.get_closest_marker(MARKER) is None:
        pytest.fail(failure_message(item.nodeid, starts), pytrace=False)
    return result


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    _SESSION_STATUS[:] = [int(exitstatus)]


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config: pytest.Config) -> None:
    """End a test process that runs threads Python does not know of without the interpreter's teardown.

    Ray leaves its gRPC threads running after ``ray.shutdown()`` (ten of them here), and libraries
    such as torch keep thread pools; when the interpreter exits, C++ static destructors free what
    those threads use, and one of them may jump into freed memory: the process dies of SIGSEGV
    after every test passed (seen in CI: exit status 139, the fault in a thread other than the
    main one, at an address in the heap). So the exit handlers run now, as the interpreter would
    run them, and the process leaves with pytest's status by ``os._exit``. Not in a pytest-xdist
    worker, which reports to its controller after this.
    """
    if hasattr(config, "workerinput") or not _SESSION_STATUS or not _foreign_threads():
        return
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__):
        if stream is not None:
            stream.flush()
    os._exit(_SESSION_STATUS[0])


def _foreign_threads() -> bool:
    """Whether this process runs threads that Python did not start (or Ray was loaded, which
    starts them; where ``/proc`` cannot say)."""
    try:
        threads = len(os.listdir("/proc/self/task"))
    except OSError:
        return "ray._raylet" in sys.modules
    return threads > threading.active_count()


@pytest.fixture(params=FMI_VERSIONS, ids=[f"fmi{v}" for v in FMI_VERSIONS])
def fmi_version(request: pytest.FixtureRequest) -> int:
    """Runs the test once per FMI version (2 and 3)."""
    return request.param


@pytest.fixture(params=["cs", "me"])
def fmu_mode(request: pytest.FixtureRequest) -> str:
    """Runs the test once per FMI interface type: co-simulation and model exchange."""
    return request.param


@pytest.fixture(scope="session")
def cartpole_fmu() -> Callable[[int], Path]:
    """``cartpole_fmu(fmi_version)``: path of the library's Cart-Pole FMU for that FMI version."""
    return functools.cache(build_cartpole_fmu)


@pytest.fixture(scope="session")
def family_fmu() -> Callable[[str, int], Path]:
    """``family_fmu(name, fmi_version)``: path of a test FMU (a name of `fmu_family.VARIANTS`)."""
    return functools.cache(build)


@pytest.fixture(scope="session")
def pool_services() -> None:
    """Start the fork server and the resource tracker once, and open the native library's reading
    of the machine's load (one descriptor a process keeps), so they are not counted as leaks.

    ``num_workers=1``: a single env alone would be stepped by the calling process, starting nothing.
    """
    PoolVectorEnv([CountEnv], num_workers=1).close()
    machine_crowded()


@pytest.fixture
def no_leaks(pool_services: None) -> Iterator[None]:
    """Fail the test if it leaves processes, /dev/shm entries or file descriptors behind."""
    before = Snapshot.take()
    yield
    gc.collect()
    before.assert_restored()
