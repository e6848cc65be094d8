"""FMUs allowed one instance per process, many in one process: each further live instance loads a
private copy of the binary (`modelicagym.fmu.library_copies`). ``probe_once`` refuses a second live
instance of a loaded library (a global counter in its C code), so without the copies these tests fail."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmu_family import rewrite
from once_copies import REPO, actions, config, copies_in, copy_folders, observed, trajectory, trajectory_in_a_process

from modelicagym.env import FMUEnv
from modelicagym.errors import ConfigError
from modelicagym.fmu import library_copies, open_fmu
from modelicagym.fmu.errors import FMUError
from modelicagym.info import format_info

CASES = [("probe_once", "auto"), ("probe_once", "python"), ("moody_once", "auto")]


@pytest.mark.processes
@pytest.mark.parametrize(("name", "step_path"), CASES, ids=[f"{n}-{p}" for n, p in CASES])
def test_two_live_instances_in_one_process_stay_independent(name: str, step_path: str, fmi_version: int) -> None:
    """Two envs of the FMU alive in this process: stepping one leaves the other's values as they
    were, and each gives, bit for bit, what it gives alone in a process of its own."""
    env_config = config(name, fmi_version, step_path=step_path)
    first, second = FMUEnv(env_config), FMUEnv(env_config)
    try:
        assert first.step_path == second.step_path == ("native" if step_path == "auto" else "python")
        outputs = env_config["outputs"]
        steps_first, steps_second = actions(1, 12), actions(2, 12)
        runs = {"first": [observed(first.reset(seed=0)[0])], "second": [observed(second.reset(seed=0)[0])]}
        for a, b in zip(steps_first, steps_second):
            before = observed(second.fmu.get_values(outputs))
            runs["first"].append(observed(first.step(np.array([a]))[0]))
            assert observed(second.fmu.get_values(outputs)) == before  # the other's state is its own
            runs["second"].append(observed(second.step(np.array([b]))[0]))
        assert runs["first"] != runs["second"]
        assert runs["first"] == trajectory_in_a_process(env_config, steps_first)
        assert runs["second"] == trajectory_in_a_process(env_config, steps_second)
    finally:
        first.close()
        second.close()


def _mapped_libraries() -> set[str]:
    """The shared libraries mapped in this process (Linux)."""
    lines = Path("/proc/self/maps").read_text().splitlines()
    return {line.split(maxsplit=5)[5] for line in lines if line.count(" ") >= 5 and ".so" in line}


@pytest.mark.processes
@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="reads /proc/self/maps (Linux)")
def test_an_fmi1_slave_declaring_once_per_process_gets_a_copy(cartpole_fmu: Any, tmp_path: Path) -> None:
    """FMI 1.0 declares the rule in ``Implementation/.../Capabilities`` (co-simulation only): the
    cart-pole's FMI 1.0 slave so declared loads a copy for its second live instance (mapped in this
    process) whose steps are, bit for bit, those of a process of its own."""
    fmu = rewrite(cartpole_fmu(1, "cs"), tmp_path / "CartPoleOnce.fmu", edit_description=lambda text: text.replace(
        "<Capabilities ", '<Capabilities canBeInstantiatedOnlyOncePerProcess="true" '))
    assert open_fmu(fmu).once_per_process() and not open_fmu(cartpole_fmu(1, "cs")).once_per_process()
    env_config = {"fmu": str(fmu), "inputs": ["f"], "outputs": ["x", "theta"], "time_step": 0.02}
    first, second = FMUEnv(env_config), FMUEnv(env_config)
    try:
        assert second.step_path == "native"
        copies = {path for path in _mapped_libraries() if str(library_copies.copies_root()) in path}
        assert any(path.endswith("/CartPole.so") for path in copies)
        steps = actions(4, 10)
        assert trajectory(second, steps) == trajectory_in_a_process(env_config, steps)
        assert trajectory(first, steps) == trajectory(second, steps)
    finally:
        first.close()
        second.close()


def test_copies_are_made_once_and_reused_by_instances_made_again(fmi_version: int) -> None:
    """A process keeps as many copies as it had instances alive at once: envs closed and made
    again, and resets that re-instantiate, load the copies already made."""
    env_config = config("probe_once", fmi_version, reset_rung="reinstantiate")
    envs = [FMUEnv(env_config) for _ in range(3)]
    [folder] = copy_folders(os.getpid())
    made = copies_in(folder)
    for env in envs:
        env.close()
    envs = [FMUEnv(env_config) for _ in range(3)]
    for env in envs:
        for _ in range(3):
            env.reset()
            env.step(np.array([0.5]))
    assert copies_in(folder) == made
    steps = actions(3, 5)
    assert trajectory(envs[2], steps) == trajectory(envs[0], steps)
    for env in envs:
        env.close()


def test_one_instance_per_process_keeps_the_fmus_rule(fmi_version: int) -> None:
    """``instances_per_process="one"`` loads the FMU's own binary for every instance (the probe then
    refuses a second live one); an env with copies beside such an env gets a copy."""
    one = FMUEnv(config("probe_once", fmi_version, instances_per_process="one"))
    try:
        with pytest.raises(Exception, match="can be instantiated only once per process"):
            FMUEnv(config("probe_once", fmi_version, instances_per_process="one"))
        beside = FMUEnv(config("probe_once", fmi_version))
        assert trajectory(beside, [0.5, 0.5]) == trajectory(one, [0.5, 0.5])
        beside.close()
    finally:
        one.close()


def test_an_unknown_setting_is_a_one_line_config_error() -> None:
    with pytest.raises(ConfigError, match=r"^instances_per_process must be one of \('copies', 'one'\), got 'many'$"):
        FMUEnv(config("probe_once", 2, instances_per_process="many"))


def test_a_copy_that_cannot_be_written_is_a_one_line_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """Where the copies' folder cannot be made (here: its parent is a file), the second instance
    fails with one line that says what, where and the ways out; the first goes on."""
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    monkeypatch.setattr(library_copies, "copies_root", lambda: blocked / "library-copies")
    monkeypatch.setattr(library_copies, "_folder", None)  # this process's folder, made again
    monkeypatch.setattr(library_copies, "_slots", {})  # no copy made yet
    first = FMUEnv(config("probe_once", 2))
    try:
        with pytest.raises(FMUError) as raised:
            FMUEnv(config("probe_once", 2))
        message = str(raised.value)
        assert "\n" not in message and "cannot copy its binary folder" in message
        assert "set MODELICAGYM_CACHE to a writable folder, or instances_per_process='one'" in message
        first.reset()
        assert first.step(np.array([0.5]))[0]["steps"] == 1  # the first instance goes on
    finally:
        first.close()


_HOLDER = """
import sys, time
from fmu_family import rewrite
from once_copies import config
from modelicagym.env import FMUEnv
envs = [FMUEnv(config("probe_once", int(sys.argv[1]))) for _ in range(2)]
print("ready", flush=True)
if sys.argv[2] == "wait":
    time.sleep(300)
"""


def _holder(fmi_version: int, then: str) -> subprocess.Popen:
    """A process holding two live instances of ``probe_once`` (so one copy), which then exits or waits."""
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(REPO / "tests")])}
    process = subprocess.Popen([sys.executable, "-c", _HOLDER, str(fmi_version), then], stdout=subprocess.PIPE,
                               text=True, env=environment)
    assert process.stdout is not None and process.stdout.readline() == "ready\n"
    return process


@pytest.mark.processes
def test_a_process_leaves_no_copies_behind_even_when_killed(fmi_version: int) -> None:
    """A process that ends removes its copies; one killed leaves them, and the next process that
    makes a copy removes them."""
    ended = _holder(fmi_version, "exit")
    assert ended.wait(60) == 0
    assert copy_folders(ended.pid) == []

    killed = _holder(fmi_version, "wait")
    [folder] = copy_folders(killed.pid)
    assert copies_in(folder)  # the copy is on disk while the process lives
    killed.send_signal(signal.SIGKILL)
    killed.wait(60)
    assert copy_folders(killed.pid) == [folder]

    after = _holder(fmi_version, "exit")
    assert after.wait(60) == 0
    assert copy_folders(killed.pid) == [] and copy_folders(after.pid) == []


def test_info_says_what_happens_to_further_instances(family_fmu: Any) -> None:
    said = format_info(open_fmu(family_fmu("moody_once", 2)))
    assert "one instance per process: each further instance alive in a process loads a private copy" in said
    assert '"instances_per_process": "one" keeps one env per process instead' in said
    assert "private copy" not in format_info(open_fmu(family_fmu("moody", 2)))
