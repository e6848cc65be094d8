"""What one Cart-Pole step costs, layer by layer: doStep alone, the FMI calls around it, FMUEnv.step.

Measured side by side in one run on the co-simulation Cart-Pole FMU:

* ``doStep only``: the FMU's own cost (raw ``fmi2DoStep`` through our binding);
* ``runtime loop``: ``FMUInstance.step`` = set input, doStep, get outputs (preallocated arrays);
* ``fmpy convenience``: the same three calls through fmpy's ``setReal``/``doStep``/``getReal``;
* ``C loop``: our native library's loop over the same calls plus bounds and reward (the physical
  limit of one core);
* ``FMUEnv.step``: the whole environment step (action check, mapping, reward, termination) on its
  native path, and ``FMUEnv.step (python)`` on the Python path.

Targets (docs/design.md, performance budget): ``FMUEnv.step`` reaches at least half the C loop's
steps per second; the Python runtime's FMI calls around doStep cost no more than doStep did at
the old 1 ms internal step (~8 us).
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

import numpy as np

from modelicagym.bench import format_table, median, time_rounds, write_json
from modelicagym.bench.throughput import c_loop

logger = logging.getLogger(__name__)

OUTPUTS = ["x", "x_dot", "theta", "theta_dot"]


def _make_env(fmi_version: int, cs_step_size: float | None, step_path: str = "auto") -> Any:
    from modelicagym.models.cartpole.env import CartPoleEnv

    # Bounds that never end an episode: the pole swings freely, no reset pollutes the timing.
    return CartPoleEnv(fmi_version=fmi_version, x_threshold=1e9, theta_threshold=1e9, cs_step_size=cs_step_size,
                       step_path=step_path)


def measure(steps: int = 20_000, repeats: int = 7, fmi_version: int = 2, cs_step_size: float | None = None) -> dict[str, Any]:
    """Seconds per step of each layer (medians over ``repeats`` interleaved rounds of ``steps``)."""
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    from modelicagym.fmu import FMUInstance

    env = _make_env(fmi_version, cs_step_size)
    env.reset(seed=0)
    python_env = _make_env(fmi_version, cs_step_size, step_path="python")
    python_env.reset(seed=0)
    limit = _make_env(fmi_version, cs_step_size)
    run_c_loop = c_loop(limit)
    dt = env.time_step
    parameters = env.episode_parameters
    instance = FMUInstance(env.description, inputs=["f"], outputs=OUTPUTS)
    instance.reset(parameters)
    bare = FMUInstance(env.description, inputs=["f"], outputs=OUTPUTS)
    bare.reset(parameters)
    do_step = bare.binding.do_step_call()
    bare_time = [bare.time]
    actions = np.random.default_rng(0).integers(0, 2, size=steps)
    forces = np.where(actions == 1, env.force, -env.force)

    description = env.description
    cls = FMU2Slave if description.fmi_version == 2 else FMU3Slave
    fmpy_fmu = cls(guid=description.guid, modelIdentifier=description.interface("cs").modelIdentifier,
                   unzipDirectory=str(description.unzip_dir), instanceName="bench")
    fmpy_fmu.instantiate()
    if description.fmi_version == 2:
        fmpy_fmu.setupExperiment(startTime=0.0)
        fmpy_fmu.enterInitializationMode()
    else:
        fmpy_fmu.enterInitializationMode(startTime=0.0)
    fmpy_fmu.exitInitializationMode()
    f_ref = [description.variables["f"].value_reference]
    out_refs = [description.variables[n].value_reference for n in OUTPUTS]
    set_float = fmpy_fmu.setReal if description.fmi_version == 2 else fmpy_fmu.setFloat64
    get_float = fmpy_fmu.getReal if description.fmi_version == 2 else fmpy_fmu.getFloat64
    fmpy_time = [0.0]

    def do_step_only() -> int:
        t = bare_time[0]
        for k in range(steps):
            do_step(t + k * dt, dt)
        bare_time[0] = t + steps * dt
        return steps

    def runtime_loop() -> int:
        inputs, step = instance.inputs.flat, instance.step
        for force in forces.tolist():
            inputs[0] = force
            step(dt)
        return steps

    def fmpy_loop() -> int:
        t = fmpy_time[0]
        for force in forces.tolist():
            set_float(f_ref, [force])
            fmpy_fmu.doStep(t, dt)
            get_float(out_refs)
            t += dt
        fmpy_time[0] = t
        return steps

    def env_loop(stepped: Any) -> Any:
        def run() -> int:
            step = stepped.step
            for action in actions.tolist():
                step(action)
            return steps

        return run

    samples = time_rounds(
        {"doStep only": do_step_only, "runtime loop": runtime_loop, "fmpy convenience": fmpy_loop,
         "C loop": lambda: run_c_loop(steps), "FMUEnv.step": env_loop(env),
         "FMUEnv.step (python)": env_loop(python_env)},
        repeats,
    )
    for closable in (env, python_env, limit, instance, bare):
        closable.close()
    fmpy_fmu.terminate()
    fmpy_fmu.freeInstance()
    result = {name: median(values) for name, values in samples.items()}
    around = result["runtime loop"] - result["doStep only"]
    return {
        "fmi_version": fmi_version,
        "cs_step_size": cs_step_size,
        "steps": steps,
        "repeats": repeats,
        "seconds_per_step": result,
        "calls_around_doStep_s": around,
        "fmpy_calls_around_doStep_s": result["fmpy convenience"] - result["doStep only"],
        "ratio_calls_around_to_doStep": around / result["doStep only"],
        "ratio_env_rate_to_runtime_loop_rate": result["runtime loop"] / result["FMUEnv.step"],
        "ratio_env_rate_to_c_loop_rate": result["C loop"] / result["FMUEnv.step"],
    }


def report(result: dict[str, Any]) -> str:
    per_step = result["seconds_per_step"]
    base = per_step["runtime loop"]
    rows = [(name, f"{1e6 * s:.2f}", f"{1 / s:,.0f}", f"{base / s:.2f}") for name, s in per_step.items()]
    table = format_table(("layer", "us/step", "steps/s", "rate vs runtime loop"), rows)
    return (
        f"{table}\n\n"
        f"FMI calls around doStep: {1e6 * result['calls_around_doStep_s']:.2f} us "
        f"= {result['ratio_calls_around_to_doStep']:.2f}x doStep; "
        f"through fmpy's convenience methods: {1e6 * result['fmpy_calls_around_doStep_s']:.2f} us\n"
        f"FMUEnv.step rate / C loop rate: {result['ratio_env_rate_to_c_loop_rate']:.2f} (target >= 0.5)"
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--steps", type=int, default=20_000, help="steps per round")
    parser.add_argument("--repeats", type=int, default=7, help="interleaved rounds (median reported)")
    parser.add_argument("--fmi-version", type=int, default=2, choices=(2, 3))
    parser.add_argument("--json", default="bench-results/fmi_calls.json", help="where to write the JSON")


def run(args: argparse.Namespace) -> int:
    result = measure(args.steps, args.repeats, args.fmi_version)
    print(report(result))
    print(f"\nwrote {write_json(args.json, result)}")
    return 0
