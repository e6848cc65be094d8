"""The load trial (modelicagym/fmu/trial.py): an FMU binary that crashes, exits or hangs while it is
loaded gives a one-line error instead of taking the process down; a verdict is kept per binary; the
working directory survives every load; a model identifier that matches no binary is said so.

Whether a load started a child process is observed through the CPU time of this process's ended
children (``getrusage(RUSAGE_CHILDREN)``): a trial's child starts Python, which costs CPU time;
a load that starts none leaves it exactly as it was.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import subprocess
import sys
import textwrap
import time
import zipfile
from collections.abc import Callable
from pathlib import Path

import fmpy
import pytest
from fmu_family import rewrite
from vector_leaks import descendants, process_state

from modelicagym import make_vec
from modelicagym.fmu import FMUError, FMUInstance, InvalidFMUError, LoadTrialError, open_fmu
from modelicagym.fmu.build import bundled_fmus
from modelicagym.fmu.trial import TIMEOUT_VARIABLE
from modelicagym.models.cartpole import cartpole_fmu

pytestmark = [pytest.mark.timeout(120), pytest.mark.processes]  # trials run in child processes

REPO = Path(__file__).resolve().parents[2]

#: variant -> (the FMI call it dies in, for FMI 2.0 and 3.0 co-simulation; how; the log line)
MISBEHAVING = {
    "crashy_segfault": (("fmi2Instantiate", "fmi3InstantiateCoSimulation"), "crashed (SIGSEGV)",
                        "license file was not found"),
    "crashy_exit": (("fmi2Instantiate", "fmi3InstantiateCoSimulation"), "ended its process with exit(0)",
                    "no runtime licence"),
    "crashy_abort": (("fmi2ExitInitializationMode", "fmi3ExitInitializationMode"), "crashed (SIGABRT)",
                     "the nonlinear solver did not converge"),
    "crashy_hang": (("fmi2Instantiate", "fmi3InstantiateCoSimulation"), f"within 2 s (if it only initializes "
                    f"slowly, set ${TIMEOUT_VARIABLE}", "waiting for the license server"),
}


#: loads, resets and steps the FMU given as argument; prints the CPU time of the children it started
LOAD_SCRIPT = textwrap.dedent("""
    import resource, sys
    from modelicagym.fmu import FMUInstance
    started = resource.getrusage(resource.RUSAGE_CHILDREN)
    with FMUInstance(sys.argv[1], inputs=["u"], outputs=["y"]) as fmu:
        fmu.reset()
        fmu.step(0.1)
    ended = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(ended.ru_utime + ended.ru_stime - started.ru_utime - started.ru_stime)
""")


def children_cpu() -> float:
    """CPU seconds of this process's ended children: it grows whenever a load runs a trial."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


@pytest.fixture
def first_load(family_fmu: Callable[[str, int], Path], tmp_path: Path,
               monkeypatch: pytest.MonkeyPatch) -> Callable[[str, int], Path]:
    """``first_load(name, fmi_version)``: a copy of a test FMU, in a cache of its own (so its binary
    was never tried), with a trial timeout of 2 s (the start of the child's Python is not counted)."""
    def copy(name: str, fmi_version: int) -> Path:
        built = family_fmu(name, fmi_version)  # in the shared build cache, before the cache moves
        monkeypatch.setenv("MODELICAGYM_CACHE", str(tmp_path / "cache"))
        monkeypatch.setenv(TIMEOUT_VARIABLE, "2")
        return Path(shutil.copy(built, tmp_path / f"{name}-fmi{fmi_version}.fmu"))

    return copy


def verdicts(tmp_path: Path) -> dict[str, dict]:
    """The trial verdicts kept in the test's own cache, by file name."""
    folder = tmp_path / "cache" / "load-trials"
    return {p.name: json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))} if folder.is_dir() else {}


@pytest.mark.usefixtures("no_leaks")
@pytest.mark.parametrize("variant", sorted(MISBEHAVING))
def test_a_misbehaving_fmu_is_one_line_naming_the_call_and_its_log(first_load, tmp_path, variant, fmi_version):
    path = first_load(variant, fmi_version)
    functions, how, logged = MISBEHAVING[variant]
    function = functions[fmi_version - 2]
    working_directory = os.getcwd()
    with pytest.raises(LoadTrialError) as raised:
        FMUInstance(path)
    message = str(raised.value)
    assert "\n" not in message
    assert message.startswith(f"{path.name} ") and how in message and f" {function} " in message
    assert logged in message and raised.value.function == function
    assert any(logged in line for line in raised.value.messages)
    assert os.getcwd() == working_directory
    [verdict] = verdicts(tmp_path).values()
    assert verdict["outcome"] in ("crashed", "exited", "hung") and verdict["function"] == function


def test_what_an_fmu_printed_before_crashing_stands_for_its_log(first_load):
    """An FMU that prints its reason to stdout rather than logging it: the error quotes the print."""
    with pytest.raises(LoadTrialError, match=r"SIGSEGV\) in fmi2Instantiate.*\(printed\) license file was not found"):
        FMUInstance(first_load("crashy_segfault_printed", 2))


def test_each_mode_is_tried_on_its_own(first_load, tmp_path, fmi_version):
    path = first_load("crashy", fmi_version)
    FMUInstance(path, mode="cs").close()
    tried = children_cpu()
    FMUInstance(path, mode="me").close()
    assert children_cpu() > tried
    assert sorted(name.rsplit("-", 1)[1] for name in verdicts(tmp_path)) == ["cs.json", "me.json"]
    crashing = first_load("crashy_segfault", fmi_version)
    function = "fmi2Instantiate" if fmi_version == 2 else "fmi3InstantiateModelExchange"
    with pytest.raises(LoadTrialError, match=rf"crashed \(SIGSEGV\) in {function}.*license file was not found"):
        FMUInstance(crashing, mode="me")


def test_a_failed_verdict_is_remembered_until_the_fmu_changes(first_load, tmp_path):
    path = first_load("crashy_segfault", 2)
    before = children_cpu()
    with pytest.raises(LoadTrialError) as first:
        FMUInstance(path)
    tried = children_cpu()
    assert tried > before, "the first load runs the trial in a child process"
    [verdict_file] = (tmp_path / "cache" / "load-trials").glob("*.json")
    written = verdict_file.stat().st_mtime_ns

    with pytest.raises(LoadTrialError) as again:
        FMUInstance(path)
    assert str(again.value) == str(first.value)
    assert children_cpu() == tried, "a remembered failure starts no child"

    changed = rewrite(path, tmp_path / "changed.fmu",
                      edit_description=lambda text: text.replace('description="Test', 'description="A new test'))
    with pytest.raises(LoadTrialError, match=r"\(SIGSEGV\) in fmi2Instantiate"):
        FMUInstance(changed)
    assert children_cpu() > tried, "a changed FMU file is tried again"
    assert verdict_file.stat().st_mtime_ns != written


def test_a_good_fmu_is_tried_once_then_loads_in_any_process_without_a_child(first_load, tmp_path):
    path = first_load("crashy", 3)
    before = children_cpu()
    with FMUInstance(path, inputs=["u"], outputs=["y"]) as fmu:
        fmu.reset()
        fmu.step(0.1)
    assert children_cpu() > before
    [(name, verdict)] = verdicts(tmp_path).items()
    assert verdict["outcome"] == "ok"
    written = (tmp_path / "cache" / "load-trials" / name).stat().st_mtime_ns

    result = subprocess.run([sys.executable, "-c", LOAD_SCRIPT, str(path)], capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": str(REPO)}, check=True)
    assert float(result.stdout) == 0.0, "a load with a kept verdict starts no child process"
    assert (tmp_path / "cache" / "load-trials" / name).stat().st_mtime_ns == written


def test_an_fmu_that_needs_a_parameter_is_tried_once_and_loads_with_it(first_load, tmp_path):
    """Initialization with the default values fails cleanly in the trial: the binary survived it,
    which is the verdict; the env's own values then initialize it."""
    path = first_load("crashy_tau_required", 2)
    before = children_cpu()
    with FMUInstance(path, outputs=["y"]) as fmu:
        with pytest.raises(FMUError, match="need tau > 0"):
            fmu.reset()
        fmu.reset({"tau": 2.0})
    [verdict] = verdicts(tmp_path).values()
    assert verdict["outcome"] == "ok" and "need tau > 0" in verdict["detail"]
    tried = children_cpu()
    assert tried > before
    result = subprocess.run([sys.executable, "-c", LOAD_SCRIPT.replace("fmu.reset()", "fmu.reset({'tau': 2.0})"),
                             str(path)], capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(REPO)},
                            check=True)
    assert float(result.stdout) == 0.0


def test_concurrent_first_loads_run_one_trial(first_load, tmp_path):
    """Three processes load the same never-tried FMU at once: one runs the trial, the others wait
    for its verdict under the lock (each prints the CPU time of the children its load started)."""
    path = first_load("crashy", 2)
    processes = [subprocess.Popen([sys.executable, "-c", LOAD_SCRIPT, str(path)], stdout=subprocess.PIPE, text=True,
                                  env={**os.environ, "PYTHONPATH": str(REPO)}) for _ in range(3)]
    children = [float(process.communicate(timeout=60)[0]) for process in processes]
    assert all(process.returncode == 0 for process in processes)
    assert sum(seconds > 0 for seconds in children) == 1, children


def test_bundled_models_skip_the_trial_and_test_fmus_do_not(family_fmu, tmp_path, monkeypatch):
    """The cart-pole where the builder puts it (built from our sources) loads without a trial; a
    test FMU built by the same builder into the same place is tried like any other."""
    built = {"cartpole": cartpole_fmu(), "crashy": family_fmu("crashy", 2)}
    monkeypatch.setenv("MODELICAGYM_CACHE", str(tmp_path / "cache"))
    (tmp_path / "cache" / "fmus").mkdir(parents=True)
    for fmu in built.values():  # the builds and their manifests, as the builder publishes them
        for source in (fmu, fmu.with_name(fmu.name + ".manifest.json")):
            shutil.copy(source, tmp_path / "cache" / "fmus" / source.name)
    assert tmp_path / "cache" / "fmus" / built["cartpole"].name in bundled_fmus()

    before = children_cpu()
    FMUInstance(cartpole_fmu()).close()
    assert children_cpu() == before and not verdicts(tmp_path)
    FMUInstance(tmp_path / "cache" / "fmus" / built["crashy"].name).close()
    assert children_cpu() > before and [v["outcome"] for v in verdicts(tmp_path).values()] == ["ok"]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not available")
def test_a_missing_system_library_is_an_error_and_the_working_directory_stays(first_load, tmp_path):
    """The FMU's binary, compiled from its own sources, is linked against a tiny library that is
    then not shipped (as an FMU that needs ``libgfortran`` on a machine without it): fmpy moves to
    the binary's folder to load it, and used to stay there when the load failed."""
    path = first_load("crashy", 2)
    unzipped = tmp_path / "unzipped"
    with zipfile.ZipFile(path) as archive:
        archive.extractall(unzipped)
    helper = tmp_path / "helper"
    helper.mkdir()
    (helper / "gone.c").write_text("int modelicagym_gone(void) { return 0; }\n")
    gcc = shutil.which("gcc")
    subprocess.run([gcc, "-shared", "-fPIC", "-o", str(helper / "libmodelicagym_gone.so"), str(helper / "gone.c")],
                   check=True)
    library = unzipped / "binaries" / fmpy.platform / "Crashy.so"
    sources = sorted(str(p) for p in (unzipped / "sources").glob("*.c"))
    subprocess.run([gcc, "-shared", "-fPIC", "-std=c99", "-O1", f"-I{unzipped / 'sources'}",
                    f"-I{Path(fmpy.__file__).parent / 'c-code'}", *sources, "-o", str(library), "-lm",
                    "-Wl,--no-as-needed", f"-L{helper}", "-lmodelicagym_gone"], check=True)
    shutil.rmtree(helper)
    broken = tmp_path / "needs-a-missing-library.fmu"
    with zipfile.ZipFile(broken, "w") as archive:
        for file in sorted(p for p in unzipped.rglob("*") if p.is_file()):
            archive.write(file, file.relative_to(unzipped).as_posix())

    working_directory = os.getcwd()
    for _ in range(2):
        with pytest.raises(FMUError, match=r"cannot load .*Crashy\.so.*libmodelicagym_gone\.so") as raised:
            FMUInstance(broken)
        assert not isinstance(raised.value, LoadTrialError), "a clean refusal is the load's own error"
        assert os.getcwd() == working_directory
    assert not verdicts(tmp_path), "a clean refusal is no verdict: once the library is installed, it loads"


def test_a_model_identifier_that_matches_no_binary_names_what_is_there(family_fmu, tmp_path):
    source = family_fmu("crashy", 2)
    here = f"binaries/{fmpy.platform}/"
    renamed = rewrite(source, tmp_path / "renamed.fmu",
                      rename=lambda name: name.replace("Crashy.", "crashy_model.") if name.startswith(here) else name)
    with pytest.raises(InvalidFMUError) as raised:
        FMUInstance(renamed)
    message = str(raised.value)
    assert "model identifier 'Crashy'" in message and "matches no binary" in message
    assert f"expected {here}Crashy.so" in message and "holds only crashy_model.so" in message
    assert "It has binaries for" not in message
    assert open_fmu(renamed).platforms == (fmpy.platform,)


@pytest.mark.usefixtures("no_leaks")
def test_a_pool_of_a_crashing_fmu_raises_in_the_parent(family_fmu):
    """Every env in a worker (the worker's error, with the env named), and the default layout."""
    config = {"fmu": str(family_fmu("crashy_segfault", 2)), "inputs": ["u"], "outputs": ["y"], "time_step": 0.1}
    with pytest.raises(LoadTrialError, match=r"env \d .*SIGSEGV\) in fmi2Instantiate.*license file was not found"):
        make_vec(config, 2, num_workers=2)
    with pytest.raises(LoadTrialError, match=r"SIGSEGV\) in fmi2Instantiate.*license file was not found"):
        make_vec(config, 3)


def test_a_hang_is_tried_again_with_a_longer_timeout(first_load, tmp_path, monkeypatch):
    path = first_load("crashy_hang", 2)
    with pytest.raises(LoadTrialError, match="within 2 s"):
        FMUInstance(path)
    judged = children_cpu()
    with pytest.raises(LoadTrialError, match="within 2 s"):
        FMUInstance(path)
    assert children_cpu() == judged, "the same timeout: the kept verdict holds"
    monkeypatch.setenv(TIMEOUT_VARIABLE, "2.5")
    with pytest.raises(LoadTrialError, match="within 2.5 s"):
        FMUInstance(path)
    assert children_cpu() > judged, "a longer timeout than the verdict's: tried again"


def trial_children(pid: int) -> set[int]:
    """The trial's child processes among the descendants of ``pid``."""
    def command(child: int) -> bytes:
        try:
            return Path(f"/proc/{child}/cmdline").read_bytes()
        except OSError:
            return b""

    return {child for child in descendants(pid) if b"modelicagym.fmu.trial_child" in command(child)}


def test_the_trial_ends_with_its_parent(first_load, monkeypatch):
    """A process killed while its trial's child hangs leaves no child behind."""
    path = first_load("crashy_hang", 2)
    monkeypatch.setenv(TIMEOUT_VARIABLE, "600")
    parent = subprocess.Popen([sys.executable, "-c", LOAD_SCRIPT, str(path)], stdout=subprocess.DEVNULL,
                              env={**os.environ, "PYTHONPATH": str(REPO)})
    deadline = time.monotonic() + 60
    while not (children := trial_children(parent.pid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert children, "the trial's child started"
    time.sleep(1.0)  # most likely hanging in fmi2Instantiate by then; wherever it is, it must end
    parent.kill()
    parent.wait()
    deadline = time.monotonic() + 10
    while any(process_state(pid) not in (None, "Z") for pid in children) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert all(process_state(pid) in (None, "Z") for pid in children)
