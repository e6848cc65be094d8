"""The Cart-Pole FMU against an independent reference, plus the framework's FMI behaviour and the builder."""

from __future__ import annotations

import ctypes
import json
import math
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.validation import validate_fmu
from reference_cartpole import CartPoleParameters, accelerations, simulate

from modelicagym.fmu.build import FMUBuildError, build_source_fmu
from modelicagym.models.cartpole import DEFAULT_PARAMETERS, MODEL_DIR, OUTPUTS, VALUE_REFERENCES

DT = 0.05
N_STEPS = 100  # 5 s
ALTERNATING_FORCE = [15.0 if k % 2 == 0 else -15.0 for k in range(N_STEPS)]
OUTPUT_VRS = [VALUE_REFERENCES[name] for name in OUTPUTS]


@pytest.fixture
def fmu_path(fmi_version: int, cartpole_fmu: Callable[[int], Path]) -> Path:
    """The Cart-Pole FMU, for each FMI version."""
    return cartpole_fmu(fmi_version)


class Slave:
    """A co-simulation instance through fmpy's low-level API, version-neutral."""

    def __init__(self, path: Path, parameters: dict[str, float] | None = None) -> None:
        md = read_model_description(str(path))
        self.version = int(md.fmiVersion[0])
        self._unzipdir = extract(str(path))
        cls = FMU2Slave if self.version == 2 else FMU3Slave
        self.fmu = cls(guid=md.guid, unzipDirectory=self._unzipdir,
                       modelIdentifier=md.coSimulation.modelIdentifier, instanceName="cartpole")
        self.fmu.instantiate()
        if self.version == 2:
            self.fmu.setupExperiment(startTime=0.0)
        self.set({name: value for name, value in (parameters or {}).items()})
        if self.version == 2:
            self.fmu.enterInitializationMode()
        else:
            self.fmu.enterInitializationMode(startTime=0.0)
        self.fmu.exitInitializationMode()
        self.time = 0.0

    def set(self, values: dict[str, float]) -> None:
        if values:
            vrs = [VALUE_REFERENCES[name] for name in values]
            setter = self.fmu.setReal if self.version == 2 else self.fmu.setFloat64
            setter(vrs, list(values.values()))

    def outputs(self) -> np.ndarray:
        getter = self.fmu.getReal if self.version == 2 else self.fmu.getFloat64
        return np.array(getter(OUTPUT_VRS))

    def step(self, force: float, dt: float = DT) -> np.ndarray:
        self.set({"f": force})
        self.fmu.doStep(self.time, dt)
        self.time += dt
        return self.outputs()

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self._unzipdir, ignore_errors=True)


def run_cs(path: Path, forces: list[float], parameters: dict[str, float] | None = None) -> np.ndarray:
    slave = Slave(path, parameters)
    try:
        return np.array([slave.outputs()] + [slave.step(f) for f in forces])
    finally:
        slave.close()


def reference(forces: list[float], parameters: dict[str, float]) -> np.ndarray:
    p = {**DEFAULT_PARAMETERS, **parameters}
    physics = CartPoleParameters(m_cart=p["m_cart"], m_pole=p["m_pole"], length=p["length"],
                                 diameter=p["diameter"], density=p["density"])
    initial = [p["x_0"], p["x_dot_0"], p["theta_0"], p["theta_dot_0"]]
    return simulate(forces, DT, initial, physics)


# ------------------------------------------------------------ physics


@pytest.mark.parametrize("parameters", [
    {},
    {"m_cart": 5.0, "m_pole": 0.5, "length": 1.5},
    {"m_cart": 20.0, "m_pole": 2.0, "length": 3.0},
    {"density": 0.0},
    {"theta_0": 1.2, "theta_dot_0": 0.5, "x_0": -1.0, "x_dot_0": 0.2, "diameter": 0.1},
    # faster dynamics (short pole, light cart) need a finer internal step: 2.3e-6 at 1e-3
    {"m_cart": 2.0, "m_pole": 0.3, "length": 1.0, "cs_step_size": 2.5e-4},
], ids=["default", "light", "heavy", "point-mass", "initial-state", "fast-fine-step"])
def test_co_simulation_matches_reference(fmu_path: Path, parameters: dict[str, float]) -> None:
    # the physics, isolated from the solver's step: 1 ms unless the case needs finer
    fmu = run_cs(fmu_path, ALTERNATING_FORCE, {"cs_step_size": 1e-3, **parameters})
    ref = reference(ALTERNATING_FORCE, {k: v for k, v in parameters.items() if k != "cs_step_size"})
    assert fmu.shape == ref.shape == (N_STEPS + 1, 4)
    assert np.max(np.abs(fmu - ref)) < 1e-6
    assert np.ptp(ref[:, 2]) > 0.1  # the pole actually moves: the comparison is not vacuous


def test_default_internal_step_keeps_an_episode_accurate(fmu_path: Path) -> None:
    """docs/cartpole-solver.md: the default 5 ms RK4 step stays within 1e-7 over a 2 s episode."""
    forces = ALTERNATING_FORCE[: int(round(2.0 / DT))]
    fmu = run_cs(fmu_path, forces)
    assert np.max(np.abs(fmu - reference(forces, {}))) < 1e-7


def test_parameters_change_the_trajectory(cartpole_fmu: Callable[[int], Path]) -> None:
    default = run_cs(cartpole_fmu(2), ALTERNATING_FORCE[:20])
    heavier = run_cs(cartpole_fmu(2), ALTERNATING_FORCE[:20], {"m_pole": 2.0})
    assert np.max(np.abs(default - heavier)) > 1e-3


def test_model_exchange_matches_co_simulation(fmu_path: Path) -> None:
    cs = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", stop_time=5.0, output_interval=DT)
    me = simulate_fmu(str(fmu_path), fmi_type="ModelExchange", stop_time=5.0, output_interval=DT,
                      relative_tolerance=1e-12)  # CVode: 1.2e-5 off the reference at 1e-10
    assert len(cs) == len(me) == N_STEPS + 1
    for name in OUTPUTS:
        assert np.max(np.abs(cs[name] - me[name])) < 1e-5, name


def test_model_exchange_calls_see_the_states_an_importer_sets(fmu_path: Path, fmi_version: int) -> None:
    """An ODE solver sets states and asks for derivatives many times between two reads of the
    outputs: each derivative is the physics at the states just set, and outputs read afterwards
    are those of the last states (the framework skips calculated values only until they are read)."""
    md = read_model_description(str(fmu_path))
    unzipdir = extract(str(fmu_path))
    cls = FMU2Model if fmi_version == 2 else FMU3Model
    fmu = cls(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.modelExchange.modelIdentifier,
              instanceName="cartpole")
    if fmi_version == 2:
        get, set_, get_derivatives = fmu.getReal, fmu.setReal, fmu.getDerivatives
    else:
        get, set_, get_derivatives = fmu.getFloat64, fmu.setFloat64, fmu.getContinuousStateDerivatives
    physics = CartPoleParameters(**{name: DEFAULT_PARAMETERS[name]
                                    for name in ("m_cart", "m_pole", "length", "diameter", "density")})
    derivative_vrs = [VALUE_REFERENCES[f"der({name})"] for name in OUTPUTS]
    try:
        fmu.instantiate()
        if fmi_version == 2:
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            fmu.newDiscreteStates()
        else:
            fmu.enterInitializationMode(startTime=0.0)
            fmu.exitInitializationMode()
            fmu.updateDiscreteStates()
        fmu.enterContinuousTimeMode()
        set_([VALUE_REFERENCES["f"]], [7.5])
        for states in ([0.1, -0.2, 0.3, 1.5], [-1.0, 0.5, 2.0, -3.0], [0.0, 0.0, -0.4, 0.2]):
            x, dx = (ctypes.c_double * 4)(*states), (ctypes.c_double * 4)()
            fmu.setContinuousStates(x, 4)
            get_derivatives(dx, 4)
            assert list(dx)[0::2] == [states[1], states[3]]
            np.testing.assert_allclose(list(dx)[1::2], accelerations(np.array(states), 7.5, physics),
                                       rtol=1e-12, atol=1e-12)
            assert get(derivative_vrs) == list(dx)
            assert get(OUTPUT_VRS) == states
        fmu.terminate()
    finally:
        fmu.freeInstance()
        shutil.rmtree(unzipdir, ignore_errors=True)


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_simulate_fmu_runs_every_variant(fmu_path: Path, fmi_type: str) -> None:
    result = simulate_fmu(str(fmu_path), fmi_type=fmi_type, stop_time=1.0,
                          start_values={"m_cart": 5.0}, output_interval=DT)
    assert result["time"][-1] == pytest.approx(1.0)
    assert all(np.all(np.isfinite(result[name])) for name in OUTPUTS)
    assert result["theta"][0] == pytest.approx(DEFAULT_PARAMETERS["theta_0"])


def test_doStep_with_uneven_step_sizes_matches_reference(cartpole_fmu: Callable[[int], Path]) -> None:
    """Steps that are not multiples of cs_step_size end with an exact partial substep."""
    slave = Slave(cartpole_fmu(3))
    try:
        for dt in (0.0123, 0.0007, 0.03705):
            slave.step(10.0, dt)
        fmu = slave.outputs()
    finally:
        slave.close()
    t_end = 0.0123 + 0.0007 + 0.03705
    p = DEFAULT_PARAMETERS
    ref = simulate([10.0], t_end, [p["x_0"], p["x_dot_0"], p["theta_0"], p["theta_dot_0"]])[-1]
    assert np.max(np.abs(fmu - ref)) < 1e-9


# --------------------------------------------------- FMI behaviour


_PLAIN_C_HOST = r"""
#include <dlfcn.h>
#include <stdio.h>
int main(int argc, char **argv) {
    void *library = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!library) { fprintf(stderr, "%s\n", dlerror()); return 1; }
    const char *(*version)(void) = (const char *(*)(void))dlsym(library, argv[2]);
    if (!version) { fprintf(stderr, "no %s\n", argv[2]); return 2; }
    printf("%s\n", version());
    return 0;
}
"""


@pytest.mark.processes
@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler for the host program")
def test_binary_loads_in_a_c_host_without_libm(fmu_path: Path, fmi_version: int, tmp_path: Path) -> None:
    """The binary links what it uses: a plain C master that never loaded libm can dlopen it."""
    (tmp_path / "host.c").write_text(_PLAIN_C_HOST)
    subprocess.run(["cc", "-o", str(tmp_path / "host"), str(tmp_path / "host.c")], check=True)
    unzipped = Path(extract(str(fmu_path), unzipdir=str(tmp_path / "fmu")))
    (binary,) = (unzipped / "binaries").glob("*/CartPole.so")
    function = "fmi2GetVersion" if fmi_version == 2 else "fmi3GetVersion"
    result = subprocess.run([str(tmp_path / "host"), str(binary), function], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == ("2.0" if fmi_version == 2 else "3.0")


def test_validate_fmu_reports_no_problems(fmu_path: Path) -> None:
    assert validate_fmu(str(fmu_path)) == []


def test_fmu_keeps_its_sources(fmu_path: Path, fmi_version: int) -> None:
    with zipfile.ZipFile(fmu_path) as zf:
        names = set(zf.namelist())
    assert {"modelDescription.xml", "sources/buildDescription.xml", "sources/model.c",
            "sources/fmu_instance.c", f"sources/fmi{fmi_version}Functions.c"} <= names
    assert any(n.startswith("binaries/") and n.endswith("CartPole.so") for n in names)


def test_state_snapshot_restores_exactly(fmu_path: Path) -> None:
    slave = Slave(fmu_path)
    try:
        for f in ALTERNATING_FORCE[:10]:
            slave.step(f)
        state = slave.fmu.getFMUState()
        t0 = slave.time
        first = [slave.step(f) for f in ALTERNATING_FORCE[10:30]]
        slave.fmu.setFMUState(state)
        slave.time = t0
        again = [slave.step(f) for f in ALTERNATING_FORCE[10:30]]
        np.testing.assert_array_equal(first, again)

        serialized = slave.fmu.serializeFMUState(state)
        assert len(serialized) > 0
        slave.fmu.freeFMUState(state)
        restored = (slave.fmu.deSerializeFMUstate if slave.version == 2
                    else slave.fmu.deserializeFMUState)(serialized)
        slave.fmu.setFMUState(restored)
        slave.time = t0
        once_more = [slave.step(f) for f in ALTERNATING_FORCE[10:30]]
        np.testing.assert_array_equal(first, once_more)
        slave.fmu.freeFMUState(restored)
    finally:
        slave.close()


def test_invalid_parameter_fails_initialization(fmu_path: Path) -> None:
    with pytest.raises(FMICallException, match="ExitInitializationMode failed"):
        Slave(fmu_path, {"m_cart": -1.0})


def test_fixed_parameter_cannot_be_set_after_initialization(fmu_path: Path) -> None:
    slave = Slave(fmu_path)
    try:
        with pytest.raises(FMICallException, match="status 3"):
            slave.set({"m_cart": 3.0})
        slave.set({"cs_step_size": 1e-4})  # tunable
    finally:
        slave.close()


def test_the_internal_step_size_sets_the_accuracy(cartpole_fmu: Callable[[int], Path]) -> None:
    """A fine internal step (many substeps per doStep) is accurate; one substep per doStep is not,
    so the tunable step size really reaches the solver."""

    def error(cs_step_size: float) -> float:
        slave = Slave(cartpole_fmu(2))
        try:
            slave.set({"cs_step_size": cs_step_size})
            fmu = slave.step(15.0)
        finally:
            slave.close()
        return float(np.max(np.abs(fmu - reference([15.0], {})[-1])))

    assert error(1e-6) < 1e-9
    assert error(DT) > 1e-8


# ------------------------------------------------------------ builder


@pytest.mark.processes
def test_compile_error_is_reported_with_compiler_output(tmp_path: Path) -> None:
    model = tmp_path / "broken"
    model.mkdir()
    shutil.copy(MODEL_DIR / "modelDescription_fmi2.xml", model)
    shutil.copy(MODEL_DIR / "config.h", model)
    (model / "model.c").write_text('#include "model.h"\nthis is not C;\n')
    with pytest.raises(FMUBuildError, match="error"):
        build_source_fmu(model, 2, cache=tmp_path / "cache")
    assert not list((tmp_path / "cache").rglob("*.fmu"))


@pytest.mark.processes
def test_cache_key_follows_inputs(tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    first = build_source_fmu(MODEL_DIR, 2, cache=cache)
    mtime = first.stat().st_mtime_ns
    assert build_source_fmu(MODEL_DIR, 2, cache=cache) == first
    assert first.stat().st_mtime_ns == mtime  # a hit does not rebuild
    other = build_source_fmu(MODEL_DIR, 2, cache=cache, defines={"UNUSED_FLAG": 1})
    assert other != first and other.is_file()
    assert not any((cache / "tmp").iterdir())  # temporary build folders are cleaned up


_BUILD_SCRIPT = """
import json, sys
from modelicagym.models.cartpole import cartpole_fmu
sys.stdout.write(json.dumps(str(cartpole_fmu(int(sys.argv[1])))))
"""


@pytest.mark.processes
def test_concurrent_builds_with_empty_cache(tmp_path: Path) -> None:
    env = {**os.environ, "MODELICAGYM_CACHE": str(tmp_path / "cache")}
    procs = [subprocess.Popen([sys.executable, "-c", _BUILD_SCRIPT, "3"], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    outputs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err for _, err in outputs]
    paths = {json.loads(out) for out, _ in outputs}
    assert len(paths) == 1
    path = Path(paths.pop())
    assert path.parent.parent == tmp_path / "cache"
    assert validate_fmu(str(path)) == []
    result = simulate_fmu(str(path), stop_time=0.5, output_interval=DT)
    assert math.isfinite(result["theta"][-1])
