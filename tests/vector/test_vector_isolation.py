"""Crash isolation by default: an env whose native code is not ours never runs in the calling
process unless the user asks for it; an FMU that crashes, aborts, calls exit() or hangs gives an
exception naming the env; where the user put it in the calling process, one line names it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmu_family import build
from step_paths import probe_env
from vector_envs import MadeElsewhere, SafeCountEnv, count_fns

import modelicagym
from modelicagym.cores import usable_cores
from modelicagym.models.cartpole import OUTPUTS, cartpole_fmu
from modelicagym.vector import RESTART_INFO_KEY, PoolVectorEnv, WorkerDiedError, WorkerTimeoutError
from modelicagym.vector.dispatch.dispatcher import CROWDED_COLLECT_SPIN, collect_poll_time, go_poll_time
from modelicagym.vector.wire.sync import pool_native_library

pytestmark = [pytest.mark.timeout(120), pytest.mark.usefixtures("pool_services")]

TESTS_DIR = Path(__file__).resolve().parents[1]
#: the quitter FMU's ``quit`` parameter: how its doStep ends the process
QUITS = {"exit": 1, "abort": 2, "segfault": 3}
EXIT_CODES = {"exit": 0, "abort": -signal.SIGABRT, "segfault": -signal.SIGSEGV}


def quitter_config(**parameters: Any) -> dict[str, Any]:
    return {"fmu": str(build("quitter", 2)), "inputs": ["u"], "outputs": ["x"], "time_step": 0.1,
            "parameters": parameters}


def users_cartpole(**options: Any) -> modelicagym.FMUEnv:
    """Our cart-pole FMU, given as a user gives any FMU: a plain FMUEnv over its path."""
    return modelicagym.FMUEnv(fmu=cartpole_fmu(), inputs=["f"], outputs=list(OUTPUTS), time_step=0.05,
                              action_table=[[-15.0], [15.0]], termination={"x": (-2.4, 2.4)}, **options)


def loaded_in_this_process(library_name: str) -> bool:
    with open("/proc/self/maps") as maps:
        return library_name in maps.read()


@pytest.mark.usefixtures("no_leaks")
@pytest.mark.parametrize("quit", list(QUITS))
def test_an_fmu_ending_its_process_under_the_default_pool_is_an_exception_naming_the_env(quit: str) -> None:
    per_env = [{}, {}, {"parameters": {"quit": QUITS[quit], "quit_after": 2}}]
    pool = modelicagym.make_vec(quitter_config(), n=3, options_per_env=per_env)
    assert not pool.caller_steps and pool.layout.envs_in_caller == 0, pool.layout
    assert "do not all say they are safe in the calling process" in pool.layout.reason
    assert not loaded_in_this_process("Quitter"), "the FMU was loaded in the calling process"
    pool.reset(seed=0)
    with pytest.raises(WorkerDiedError, match="during step of env 2") as info:
        for _ in range(4):
            pool.step(np.zeros((3, 1)))
    assert info.value.env_index == 2 and info.value.exitcode == EXIT_CODES[quit]
    if quit == "exit":
        assert "exited with code 0" in str(info.value) and "called exit()" in str(info.value)
    assert pool.closed


@pytest.mark.usefixtures("no_leaks")
def test_an_fmu_calling_exit_is_restarted_with_restart_dead_workers() -> None:
    per_env = [{}, {"parameters": {"quit": QUITS["exit"], "quit_after": 2}}]
    with modelicagym.make_vec(quitter_config(), n=2, options_per_env=per_env, restart_dead_workers=True,
                              cores=2) as pool:  # a worker per env: the restart leaves env 0 alone
        pool.reset(seed=0)
        for _ in range(2):
            pool.step(np.zeros((2, 1)))
        _, _, terminations, truncations, infos = pool.step(np.zeros((2, 1)))
        assert truncations[1] and not terminations[1] and not truncations[0]
        assert "env 1" in infos[RESTART_INFO_KEY][1] and "called exit()" in infos[RESTART_INFO_KEY][1]


@pytest.mark.usefixtures("no_leaks")
def test_an_fmu_hanging_under_the_default_pool_is_a_timeout_naming_the_env() -> None:
    probe = build("probe", 2)
    fns = [partial(probe_env, probe)] * 2 + [partial(probe_env, probe, parameters={"fault": 4, "fault_after": 1})]
    pool = PoolVectorEnv(fns, cores=2)
    assert not pool.caller_steps
    pool.reset(seed=0)
    actions = np.zeros((3, 1))
    pool.step(actions)
    pool.step_async(actions)
    with pytest.raises(WorkerTimeoutError, match="env 2") as info:
        pool.step_wait(timeout=1.0)
    assert info.value.env_index == 2
    pool.close()


def test_the_bundled_models_keep_the_caller_stepping_layout() -> None:
    with modelicagym.make_vec("cartpole", n=4, cores=2) as pool:  # one core would plan no worker to adapt with
        layout = pool.layout
        assert pool.caller_steps and layout.envs_in_caller > 0, layout
        assert layout.adaptive or pool_native_library() is None, layout
    with modelicagym.make_vec("pendulum", n=2) as pool:
        assert pool.caller_steps, pool.layout


@pytest.mark.usefixtures("no_leaks")
def test_the_worker_that_learnt_an_env_is_safe_in_the_caller_is_gone() -> None:
    """The caller's slice is first made in one more worker; once its envs say they are safe there,
    that worker stops and the calling process makes its own."""
    with PoolVectorEnv([partial(SafeCountEnv, max_len=4 + i) for i in range(4)], cores=2) as pool:
        assert pool.caller_steps and len(pool.worker_pids) == pool.num_workers
        assert os.getpid() in pool.call("pid")
        assert set(pool.call("pid")) - {os.getpid()} == set(pool.worker_pids)


@pytest.mark.usefixtures("no_leaks")
def test_envs_that_cannot_move_get_plain_workers_and_no_stand_in() -> None:
    """A stand-in's copies serve only a layout that moves envs: for envs that cannot move (here
    toy envs that do not say their reset is deterministic), the pool replaces it by a plain worker of
    the caller's slice."""
    with PoolVectorEnv([MadeElsewhere(fn, os.getpid()) for fn in count_fns(4)], cores=2) as pool:
        layout = pool.layout
        assert not layout.adaptive and layout.envs_in_stand_in == 0 and "standing in" not in str(layout), layout
        assert "does not reset deterministically" in layout.reason
        assert pool.num_workers == 2 and os.getpid() not in pool.call("pid")  # cores=2: two parties
        assert pool.call("max_len") == (4, 7, 10, 13)


def test_a_users_fmu_is_never_made_in_the_calling_process_even_when_it_is_ours_by_path() -> None:
    with PoolVectorEnv([MadeElsewhere(users_cartpole, os.getpid())] * 4, cores=2) as pool:
        assert not pool.caller_steps and pool.layout.envs_in_caller == 0, pool.layout
        pool.reset(seed=0)
        pool.step(np.zeros(4, dtype=np.int64))


def test_a_pool_mixing_a_users_fmu_with_ours_makes_no_env_in_the_calling_process() -> None:
    """The caller's own slice would be the bundled cart-pole, but the adaptive layout would copy
    the workers' envs (a user's FMU) there: a worker stands in for the calling process instead."""
    fns = [MadeElsewhere(users_cartpole, os.getpid())] * 2 + [partial(modelicagym.make, "cartpole")] * 2
    with PoolVectorEnv(fns, cores=2) as pool:
        layout = pool.layout
        assert not pool.caller_steps and layout.envs_in_caller == 0 and layout.envs_in_stand_in == 2, layout
        pool.reset(seed=0)
        pool.step(np.zeros(4, dtype=np.int64))


CALLER_SCRIPT = """
import numpy as np
import modelicagym

config = {config!r}
config["step_path"] = {path!r}
per_env = [{{}}, {{}}, {{"parameters": {{"quit": {quit}, "quit_after": 2}}}}]
with modelicagym.make_vec(config, n=3, options_per_env=per_env, caller_steps=True) as pool:
    assert pool.caller_steps and pool.layout.envs_in_caller >= 1, pool.layout
    pool.reset(seed=0)
    for _ in range(5):
        pool.step(np.zeros((3, 1)))
print("the pool survived")
"""


@pytest.mark.skipif(pool_native_library() is None, reason="the last word is the native library's")
@pytest.mark.parametrize("path", ["auto", "python"])
@pytest.mark.parametrize("quit", list(QUITS))
def test_an_fmu_ending_the_calling_process_that_opted_in_names_the_env_and_never_exits_0(quit: str, path: str) -> None:
    config = quitter_config()
    script = textwrap.dedent(CALLER_SCRIPT.format(config=config, path=path, quit=QUITS[quit]))
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=100,
                            env={**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS_DIR), *sys.path])})
    assert "the pool survived" not in result.stdout
    lines = [line for line in result.stderr.splitlines() if line.startswith("modelicagym: ")]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"modelicagym: env 2 (FMU {config['fmu']}), which the calling process steps itself")
    expected = {"exit": "called exit(0)", "abort": "crashed with SIGABRT", "segfault": "crashed with SIGSEGV"}[quit]
    assert expected in lines[0]
    assert result.returncode == {"exit": 70, "abort": -signal.SIGABRT, "segfault": -signal.SIGSEGV}[quit]


PASSING_SCRIPT = """
import ctypes
import sys
import numpy as np
import modelicagym

pool = modelicagym.make_vec({config!r}, n=3, caller_steps=True)
pool.reset(seed=0)
for _ in range(5):
    pool.step(np.zeros((3, 1)))
if {how!r} == "segfault":
    ctypes.string_at(0)  # outside any env's code
sys.exit(3)  # the pool still open, no env running
"""


@pytest.mark.skipif(pool_native_library() is None, reason="the last word is the native library's")
@pytest.mark.parametrize("how", ["exit", "segfault"])
def test_the_last_word_is_silent_when_the_process_ends_outside_an_envs_code(how: str) -> None:
    script = textwrap.dedent(PASSING_SCRIPT.format(config=quitter_config(), how=how))
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=100,
                            env={**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS_DIR), *sys.path])})
    assert "modelicagym: env" not in result.stderr
    assert result.returncode == (3 if how == "exit" else -signal.SIGSEGV), result.stderr


@pytest.mark.parametrize("cores", [2, 4, 16, 64])
def test_the_calling_process_polls_briefly_for_workers_that_fill_the_cores(cores: int) -> None:
    assert collect_poll_time(1e-4, cores - 1, cores) == 1e-4
    assert collect_poll_time(1e-4, cores, cores) == CROWDED_COLLECT_SPIN < 1e-4
    assert collect_poll_time(1e-5, cores + 1, cores) == 1e-5  # never longer than asked


def test_on_one_core_the_calling_process_sleeps_while_a_worker_steps() -> None:
    """A poll there holds the only core the worker needs to finish the step."""
    assert collect_poll_time(1e-4, 1, 1) == 0.0
    assert collect_poll_time(1e-4, 3, 1) == 0.0


@pytest.mark.parametrize("cores", [2, 4, 16, 64])
def test_workers_poll_for_their_next_command_only_while_the_pollers_fit_the_cores(cores: int) -> None:
    """Pollers must not outnumber the cores: the calling process takes part in every step, so a
    worker polls for its next command only while it and the other stepping workers leave the
    calling process a core; otherwise it sleeps as soon as it waits."""
    assert go_poll_time(1e-4, cores, cores) == 0.0
    assert go_poll_time(1e-4, cores - 1, cores) == 1e-4
    # a stand-in's workers on a quiet machine may fill the cores (the adaptive layout leaves a light spread)
    assert go_poll_time(1e-4, cores, cores, quiet_stand_in=True) == 1e-4
    assert go_poll_time(1e-4, cores + 1, cores, quiet_stand_in=True) == 0.0


def test_on_one_core_no_worker_polls() -> None:
    """Its poll would hold the core the calling process needs, even a quiet stand-in's."""
    assert go_poll_time(1e-4, 1, 1) == 0.0
    assert go_poll_time(1e-4, 1, 1, quiet_stand_in=True) == 0.0


def test_the_workers_read_their_poll_time_from_shared_memory_at_every_wait() -> None:
    """The choice lives in shared memory, written for the pool's stepping workers and usable cores."""
    cores = usable_cores()
    fns = [MadeElsewhere(users_cartpole, os.getpid())] * 4
    with PoolVectorEnv(fns, adapt_layout=False, spin_time=1e-4) as pool:
        assert pool.num_workers == min(cores, 4)
        assert pool._workers.buffers.go_spin_ns[0] == (0 if pool.num_workers + 1 > cores else 100_000)
        # the calling process polls for their answers briefly where they fill the cores
        assert pool._dispatcher._collect_spin_ns[0] == round(collect_poll_time(1e-4, pool.num_workers, cores) * 1e9)
        pool.reset(seed=0)
        assert pool.step(np.zeros(4, dtype=np.int64))[0].shape == (4, 4)  # the sleeping workers are woken
    with PoolVectorEnv(fns, num_workers=1, adapt_layout=False, spin_time=1e-4) as pool:
        assert pool._workers.buffers.go_spin_ns[0] == (100_000 if cores >= 2 else 0)
        pool.reset(seed=0)
        assert pool.step(np.zeros(4, dtype=np.int64))[0].shape == (4, 4)
