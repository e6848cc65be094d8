"""A system's step: one env, the Ecos co-simulation engine from Python, and the default pool, side by side.

Each system is written as one SSP 1.0 archive (in a temporary folder), which both tools read:

* ``drive``: our motor (FMI 2.0) driving our shaft (FMI 3.0), its speed fed back, both in
  co-simulation (the sample system's FMUs, built from ``modelicagym/samples``); the action is the
  motor's command;
* ``linear-transformation``: OpenModelica's Gain feeding its Add through a linear transformation
  (OMSimulator's test suite: ``--oms``);
* ``dcmotor``: OMSimulator's DC motor flattened into its three FMUs (its load from the stimuli FMU,
  the machine and the shaft connected both ways, its parameters as its SSP sets them), the machine's
  voltage the action (``--oms``).

Candidates, interleaved in every round (``--rounds`` of ``--seconds`` each):

* ``one env``: `FMUEnv` on the archive, ``env.step(action)`` in a loop (actions sampled up front),
  in 500-step episodes, as the pools run;
* ``one env, run on``: the same with no episode end, as Ecos runs, against
* ``Ecos set/step/get``: the same in Ecos's Python API: ``set_real`` of the same actions,
  ``step(1)``, ``get_real`` of each observed output;
* ``one env, held``: ``env.step`` run on with the action held at 0 (no new input), against
* ``Ecos step(1)``: Ecos's ``EcosSimulation.step(1)`` alone, its inputs held at their start values;
* ``pool n=8``, ``pool n=2``: ``modelicagym.make_vec(config, n)`` with its default layout, warmed
  ``--warm`` seconds first so that its adaptive layout has made its first try.

Ecos is optional, a maintainers' comparison: ``pip install ecospy tbb``, set the run bit of the
wheel's ``ecospy/binaries/ecos`` and ``proxyfmu`` (``chmod +x``) and put the environment's
``lib/`` (``libtbb.so.12``) on ``LD_LIBRARY_PATH``; without ``ecospy`` its columns are skipped,
with a line that says why. Ecos 0.7 reads SSP 1.0 only.
"""

from __future__ import annotations

import argparse
import ctypes
import logging
import os
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

import modelicagym
from benchmarks.pool_gain import pool_run, single_run
from modelicagym.bench import conditions, format_table, median, write_json
from modelicagym.errors import ArgumentError, ConfigError
from modelicagym.fmu.build import build_source_fmu
from modelicagym.samples.writer import SAMPLES_DIR

logger = logging.getLogger(__name__)

#: the pools measured against one env
POOL_SIZES = (8, 2)
#: the envs' episodes, in steps: a pool moves envs between its processes at episode boundaries only
EPISODE_STEPS = 500
#: steps between two readings of the clock in the held env's and Ecos's loops, and Ecos's values
#: (as many as the env's actions sampled up front: `pool_gain.SINGLE_ACTIONS`)
ECOS_VALUES = 50


@dataclass(frozen=True)
class Component:
    """One FMU of a system: its file, the connectors the system uses, its parameter values."""

    fmu: Path
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    parameters: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class System:
    """A system as both tools read it: components, connections ``(source, target, factor, offset)``
    (``component.variable``), the action (one Real input) and the observed outputs."""

    name: str
    label: str
    components: Mapping[str, Component]
    connections: tuple[tuple[str, str, float, float], ...]
    action: str
    outputs: tuple[str, ...]
    time_step: float = 0.001

    def config(self, ssp: Path, episodes: bool = True) -> dict[str, Any]:
        """The env's config over the archive, in episodes of `EPISODE_STEPS` or run on."""
        return {"fmu": str(ssp), "inputs": [self.action], "outputs": list(self.outputs), "time_step": self.time_step,
                "max_episode_steps": EPISODE_STEPS if episodes else None}


def _connector(name: str, kind: str) -> str:
    return f'<ssd:Connector name={quoteattr(name)} kind="{kind}"><ssc:Real/></ssd:Connector>'


def system_structure(system: System) -> str:
    """The SSP 1.0 ``SystemStructure.ssd`` of ``system``: its components as co-simulation FMUs under
    ``resources/``, their parameter values inline, the connections (a linear transformation where
    the factor or the offset is not the identity's)."""
    elements = []
    for name, component in system.components.items():
        connectors = [_connector(v, "input") for v in component.inputs] + [_connector(v, "output")
                                                                          for v in component.outputs]
        parameters = "".join(f'<ssv:Parameter name={quoteattr(k)}><ssv:Real value="{v!r}"/></ssv:Parameter>'
                             for k, v in component.parameters.items())
        bindings = (f'<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>'
                    f'<ssv:ParameterSet version="1.0" name={quoteattr(name)}><ssv:Parameters>{parameters}'
                    f'</ssv:Parameters></ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding>'
                    f'</ssd:ParameterBindings>') if parameters else ""
        elements.append(f'<ssd:Component name={quoteattr(name)} type="application/x-fmu-sharedlibrary" '
                        f'source="resources/{name}.fmu" implementation="CoSimulation">'
                        f'<ssd:Connectors>{"".join(connectors)}</ssd:Connectors>{bindings}</ssd:Component>')
    connections = []
    for source, target, factor, offset in system.connections:
        (start, start_connector), (end, end_connector) = source.split(".", 1), target.split(".", 1)
        transformation = "" if (factor, offset) == (1.0, 0.0) else \
            f'<ssc:LinearTransformation factor="{factor!r}" offset="{offset!r}"/>'
        connections.append(f'<ssd:Connection startElement="{start}" startConnector="{start_connector}" '
                           f'endElement="{end}" endConnector="{end_connector}">{transformation}</ssd:Connection>')
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<ssd:SystemStructureDescription version="1.0" name={quoteattr(system.name)} '
            'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
            'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
            'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues">\n'
            f'<ssd:System name={quoteattr(system.name)}><ssd:Elements>{"".join(elements)}</ssd:Elements>'
            f'<ssd:Connections>{"".join(connections)}</ssd:Connections></ssd:System>\n'
            '</ssd:SystemStructureDescription>\n')


def write_archive(system: System, folder: Path) -> Path:
    """``system`` as an SSP archive in ``folder``: its structure and a copy of each FMU."""
    path = folder / f"{system.name}.ssp"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("SystemStructure.ssd", system_structure(system))
        for name, component in system.components.items():
            archive.write(component.fmu, f"resources/{name}.fmu")
    return path


def drive() -> System:
    """Our motor (FMI 2.0) and shaft (FMI 3.0), each fed the other's output (`tests/system_cases.py`)."""
    motor, inertia = build_source_fmu(SAMPLES_DIR / "motor", 2), build_source_fmu(SAMPLES_DIR / "inertia", 3)
    return System("drive", "our motor + shaft (FMI 2.0 + 3.0)",
                  {"motor": Component(motor, ("u", "w"), ("tau",)), "plant": Component(inertia, ("tau",), ("w",))},
                  (("motor.tau", "plant.tau", 1.0, 0.0), ("plant.w", "motor.w", 1.0, 0.0)),
                  "motor.u", ("plant.w", "motor.tau"), time_step=0.01)


def linear_transformation(oms: Path) -> System:
    """OMSimulator's LinearTransformation: Gain1.y into Add1.u1, times 2 plus 3."""
    folder = oms / "LinearTransformation" / "resources"
    return System("linear-transformation", "OMS LinearTransformation (Gain + Add)",
                  {"Gain1": Component(folder / "Gain.fmu", ("u",), ("y",)),
                   "Add1": Component(folder / "Add.fmu", ("u1",), ("y",))},
                  (("Gain1.y", "Add1.u1", 2.0, 3.0),), "Gain1.u", ("Add1.y",))


def dcmotor(oms: Path) -> System:
    """OMSimulator's dcmotor, its nested system flattened: the stimuli's load torque into the shaft,
    the machine's torque into the shaft, the shaft's speed and angle back into the machine; the
    machine's voltage is the action (the stimuli's voltage step is left unconnected)."""
    folder = oms / "dcmotor" / "resources"
    return System("dcmotor", "OMS dcmotor, flat (3 FMUs)",
                  {"stimuli": Component(folder / "stimuli_model.fmu", (), ("M_load",), {"MLoad.k": -0.5}),
                   "machine": Component(folder / "emachine_model.fmu", ("U", "w", "phi"), ("M", "I"),
                                        {"inductor.L": 0.001, "emf.k": 0.1, "resistor.R": 0.5}),
                   "shaft": Component(folder / "edrive_mass.fmu", ("M_A", "M_B"), ("wA", "phiA", "wB"),
                                      {"inertia.J": 0.002, "damper.d": 0.001})},
                  (("stimuli.M_load", "shaft.M_B", 1.0, 0.0), ("machine.M", "shaft.M_A", 1.0, 0.0),
                   ("shaft.wA", "machine.w", 1.0, 0.0), ("shaft.phiA", "machine.phi", 1.0, 0.0)),
                  "machine.U", ("shaft.wB", "machine.I"))


#: what ``--systems`` names: the function making each (given ``--oms``, or None)
SYSTEMS: dict[str, Callable[[Path | None], System]] = {
    "drive": lambda oms: drive(),
    "linear-transformation": lambda oms: linear_transformation(_needs(oms, "linear-transformation")),
    "dcmotor": lambda oms: dcmotor(_needs(oms, "dcmotor")),
}


def _needs(oms: Path | None, name: str) -> Path:
    if oms is None:
        raise ArgumentError(f"systems: {name} is built from OMSimulator's test suite: give --oms "
                            "OMSimulator/testsuite/tests/resources, or leave it out (--systems drive)")
    if not oms.is_dir():
        raise ArgumentError(f"systems --oms {oms}: no such folder")
    return oms


def load_ecos() -> tuple[Any, str]:
    """Ecos's ``EcosSimulation`` class and version, or ``(None, why not)``. A ``libtbb.so.12`` in
    this environment's ``lib/`` (``pip install tbb``) is loaded first, so that ``LD_LIBRARY_PATH``
    is not needed there."""
    tbb = Path(sys.prefix) / "lib" / "libtbb.so.12"
    if tbb.is_file():
        ctypes.CDLL(str(tbb), mode=ctypes.RTLD_GLOBAL)
    try:
        from ecospy import EcosSimulation
        from ecospy.lib import EcosLib
    except (ImportError, OSError) as error:
        return None, (f"Ecos not measured: {error} (pip install ecospy tbb, chmod +x its binaries, and the "
                      "environment's lib/ on LD_LIBRARY_PATH: see python -m benchmarks systems --help)")
    return EcosSimulation, str(EcosLib.version())


def _ecos_run(simulation: Any, system: System, values: list[float], io: bool) -> Callable[[float], float]:
    """Ecos stepped for ``seconds``: steps per second; with ``io`` each step sets the action and
    reads the outputs (Ecos names a variable ``component::variable``)."""
    action = system.action.replace(".", "::", 1)
    outputs = [name.replace(".", "::", 1) for name in system.outputs]
    step, set_real, get_real = simulation.step, simulation.set_real, simulation.get_real

    def run(seconds: float) -> float:
        steps, started = 0, time.perf_counter()
        while time.perf_counter() - started < seconds:
            if io:
                for value in values:
                    set_real(action, value)
                    step(1)
                    for name in outputs:
                        get_real(name)
            else:
                for _ in values:
                    step(1)
            steps += len(values)
        return steps / (time.perf_counter() - started)

    return run


def _ecos_simulation(ecos: Any, system: System, ssp: Path, stack: ExitStack) -> Any:
    """Ecos's simulation of the archive, initialized, freed when ``stack`` closes."""
    simulation = ecos(step_size=system.time_step, ssp_path=str(ssp))
    stack.callback(simulation.free)
    simulation.init()
    return simulation


def _held_run(env: modelicagym.FMUEnv) -> Callable[[float], float]:
    """One env stepped for ``seconds`` with its action held at 0 (clipped into the space's
    bounds), reset if an episode ends: steps per second."""
    space = env.action_space
    action = np.clip(np.zeros(space.shape, space.dtype), space.low, space.high).astype(space.dtype)
    env.reset(seed=0)

    def run(seconds: float) -> float:
        steps, started = 0, time.perf_counter()
        while time.perf_counter() - started < seconds:
            for _ in range(ECOS_VALUES):
                _, _, terminated, truncated, _ = env.step(action)
                if terminated or truncated:
                    env.reset()
            steps += ECOS_VALUES
        return steps / (time.perf_counter() - started)

    return run


def measure(system: System, ssp: Path, ecos: Any, rounds: int, seconds: float, warm: float) -> dict[str, Any]:
    """Every candidate's steps per second over interleaved rounds, after the pools' warm-up."""
    config = system.config(ssp)
    with ExitStack() as stack:
        runs: dict[str, Callable[[float], float]] = {}
        pools = {}
        for n in POOL_SIZES:  # before the single env, as a user makes them
            pools[n] = envs = modelicagym.make_vec(dict(config), n=n)
            stack.callback(envs.close)
        env = stack.enter_context(modelicagym.FMUEnv(dict(config)))
        runs["one env"] = single_run(env)
        step_path = env.step_path_reason
        if ecos is not None:  # like against like: neither ends an episode
            runs["one env, run on"] = single_run(stack.enter_context(modelicagym.FMUEnv(system.config(ssp, False))))
            env.action_space.seed(0)
            values = [float(np.asarray(env.action_space.sample()).item()) for _ in range(ECOS_VALUES)]
            runs["Ecos set/step/get"] = _ecos_run(_ecos_simulation(ecos, system, ssp, stack), system, values, True)
        held = stack.enter_context(modelicagym.FMUEnv(system.config(ssp, False)))
        runs["one env, held"] = _held_run(held)
        if ecos is not None:
            runs["Ecos step(1)"] = _ecos_run(_ecos_simulation(ecos, system, ssp, stack), system, values, False)
        for n, envs in pools.items():
            runs[f"pool n={n}"] = pool_run(envs)
            runs[f"pool n={n}"](warm)
        rates: dict[str, list[float]] = {label: [] for label in runs}
        cpu_rates: dict[str, list[float]] = {label: [] for label in runs if not label.startswith("pool")}
        for _ in range(rounds):
            for label, run in runs.items():
                wall, cpu = time.perf_counter(), time.process_time()
                rates[label].append(run(seconds))
                wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
                if label in cpu_rates:  # steps per second of this process's CPU time (all its threads)
                    cpu_rates[label].append(rates[label][-1] * wall / cpu)
        layouts = {f"pool n={n}": str(envs.layout) for n, envs in pools.items()}
    medians = {label: median(values) for label, values in rates.items()}
    ratios = {f"pool n={n} / one env": [p / s for p, s in zip(rates[f"pool n={n}"], rates["one env"])]
              for n in POOL_SIZES}
    if ecos is not None:
        for ours, theirs in (("one env, run on", "Ecos set/step/get"), ("one env, held", "Ecos step(1)")):
            ratios[f"{ours} / {theirs}"] = [s / e for s, e in zip(rates[ours], rates[theirs])]
            ratios[f"{ours} / {theirs}, CPU"] = [s / e for s, e in zip(cpu_rates[ours], cpu_rates[theirs])]
    return {"system": system.name, "label": system.label, "config": config, "step_path": step_path,
            "steps_per_second": rates, "steps_per_cpu_second": cpu_rates, "medians": medians, "ratios": ratios,
            "ratio_medians": {k: median(v) for k, v in ratios.items()}, "layouts": layouts}


def _rate(values: list[float]) -> str:
    """The median in thousands of steps per second, and the rounds' range."""
    return f"{median(values) / 1e3:.0f}k ({min(values) / 1e3:.0f}-{max(values) / 1e3:.0f})"


def _ratio(values: list[float]) -> str:
    return f"{median(values):.2f}x ({min(values):.2f}-{max(values):.2f})"


def report(results: list[dict[str, Any]]) -> str:
    """The rates table, the ratios table and each pool's layout at the end."""
    labels = list(results[0]["steps_per_second"])
    rates = format_table(["system"] + labels, [[r["label"]] + [_rate(r["steps_per_second"][k]) for k in labels]
                                                for r in results])
    single = list(results[0]["steps_per_cpu_second"])
    cpu = format_table(["system"] + single, [[r["label"]] + [_rate(r["steps_per_cpu_second"][k]) for k in single]
                                             for r in results])
    names = list(results[0]["ratios"])
    ratios = format_table(["system"] + names, [[r["label"]] + [_ratio(r["ratios"][k]) for k in names] for r in results])
    layouts = "\n".join(f"  {r['label']}, {k}: {v}" for r in results for k, v in r["layouts"].items())
    return (f"env steps per second, median (range of the rounds):\n{rates}\n\n"
            f"steps per second of the process's CPU time (its share of a busy machine left out):\n{cpu}\n\n"
            f"ratios, median (range):\n{ratios}\n\nthe pools' layout at the end:\n{layouts}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.description = __doc__
    parser.add_argument("--systems", nargs="+", default=list(SYSTEMS), choices=list(SYSTEMS), metavar="SYSTEM",
                        help=f"of {', '.join(SYSTEMS)} (default: all)")
    parser.add_argument("--oms", type=Path, metavar="DIR",
                        help="OMSimulator's testsuite/tests/resources (for linear-transformation and dcmotor)")
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds, medians reported (default 5)")
    parser.add_argument("--seconds", type=float, default=0.3, help="seconds a candidate runs a round (default 0.3)")
    parser.add_argument("--warm", type=float, default=8.0,
                        help="seconds each pool runs first, so that its adaptive layout has made its first try "
                             "(default 8)")
    parser.add_argument("--json", default="bench-results/systems.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    if args.rounds < 1 or args.seconds <= 0 or args.warm < 0:
        raise ArgumentError(f"systems: --rounds at least 1, --seconds more than 0, --warm at least 0; got "
                            f"{args.rounds}, {args.seconds}, {args.warm}")
    systems = [SYSTEMS[name](args.oms) for name in args.systems]  # a missing --oms stops the run before any measures
    ecos, ecos_version = load_ecos()
    if ecos is None:
        print(ecos_version)
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="modelicagym-systems-") as folder:
        results = []
        for system in systems:
            logger.info("measuring %s", system.name)
            try:
                results.append(measure(system, write_archive(system, Path(folder)), ecos, args.rounds, args.seconds,
                                       args.warm))
            except ConfigError as error:
                raise ConfigError(f"systems: {system.name}: {error}") from error
    line, data = conditions(load_before, args.rounds, args.seconds)
    print(report(results))
    print(f"\n{line}; each pool warmed {args.warm} s first" + (f"; Ecos {ecos_version}" if ecos else ""))
    data = {**data, "ecos": ecos_version if ecos else None, "rounds": args.rounds, "seconds": args.seconds,
            "warm": args.warm, "results": results}
    print(f"wrote {write_json(args.json, data)}")
    return 0
