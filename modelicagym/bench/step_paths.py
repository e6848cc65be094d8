"""What one step of any FMU costs on the native step path, against the Python path and the C loop.

For an FMU (its inputs and outputs of any type: by default every input and output it declares that
holds numbers), measured side by side in one run, with random actions of the env's action space:

* ``C loop``: the benchmarks' C loop (``mg_loop``, `modelicagym.bench.native`) over the env's own
  ``mg_env``: the same C step the native path takes, without Python (the limit of one core);
* ``FMUEnv.step (native)``: the whole env step on the native path (action check, the C step, the
  observation as the env's space holds it);
* ``FMUEnv.step (python)``: the same env forced onto the Python path.

Target: the native env step costs within 2x the C loop.
"""

from __future__ import annotations

import argparse
import ctypes
import logging
from pathlib import Path
from typing import Any

from modelicagym.bench import format_table, median, time_rounds, write_json
from modelicagym.bench.native import bench_library
from modelicagym.errors import ConfigError
from modelicagym.fmu import open_fmu
from modelicagym.fmu.errors import FMUError

logger = logging.getLogger(__name__)

#: kinds of variables the native path does not move; a default config leaves them out
_NOT_NUMBERS = ("string", "binary", "clock")
#: distinct actions cycled through (sampled once, before timing)
_ACTIONS = 64


def _names(variables: list[Any]) -> list[str]:
    return [v.name for v in variables if v.kind not in _NOT_NUMBERS]


def make_env(fmu: str | Path, inputs: list[str] | None, outputs: list[str] | None, step_path: str, **config: Any) -> Any:
    """An env over ``fmu`` that never ends an episode (no bounds, no step limit: no reset is timed)."""
    from modelicagym import FMUEnv

    description = open_fmu(fmu)
    return FMUEnv(fmu=fmu, inputs=inputs or _names(description.inputs), outputs=outputs or _names(description.outputs),
                  step_path=step_path, **config)


def measure(fmu: str | Path, inputs: list[str] | None = None, outputs: list[str] | None = None,
            steps: int = 20_000, repeats: int = 7, **config: Any) -> dict[str, Any]:
    """Seconds per step of each path (medians over ``repeats`` interleaved rounds of ``steps``)."""
    native = make_env(fmu, inputs, outputs, "auto", **config)
    python = make_env(fmu, inputs, outputs, "python", **config)
    loop_env = make_env(fmu, inputs, outputs, "auto", **config)
    if native.native_step is None or native.python_edges:
        raise ConfigError(f"{fmu}: the C loop needs the whole step in C: {native.step_path_reason}")
    native.action_space.seed(0)
    actions = [native.action_space.sample() for _ in range(_ACTIONS)]
    cycle = [actions[k % _ACTIONS] for k in range(steps)]
    for env in (native, python, loop_env):
        env.reset(seed=0)
    loop_step = loop_env.native_step
    loop_step.step(actions[0])  # fills the action row (or index) mg_loop then repeats
    run_loop, state = bench_library().mg_loop, ctypes.byref(loop_step.state)

    def c_loop() -> int:
        if run_loop(state, steps, loop_step.action_pointer) != steps:
            raise FMUError(f"{fmu}: the C loop stopped on an FMU error")
        return steps

    def env_loop(env: Any) -> Any:
        def run() -> int:
            step = env.step
            for action in cycle:
                step(action)
            return steps

        return run

    samples = time_rounds({"C loop": c_loop, "FMUEnv.step (native)": env_loop(native),
                           "FMUEnv.step (python)": env_loop(python)}, repeats)
    for env in (native, python, loop_env):
        env.close()
    result = {name: median(values) for name, values in samples.items()}
    return {
        "fmu": str(fmu),
        "fmi_version": native.description.fmi_version,
        "inputs": list(native.config.inputs),
        "outputs": list(native.config.outputs),
        "action_space": str(native.action_space),
        "steps": steps,
        "repeats": repeats,
        "seconds_per_step": result,
        "ratio_native_env_to_c_loop": result["FMUEnv.step (native)"] / result["C loop"],
        "ratio_python_env_to_native_env": result["FMUEnv.step (python)"] / result["FMUEnv.step (native)"],
    }


def report(result: dict[str, Any]) -> str:
    rows = [(name, f"{1e6 * s:.2f}", f"{1 / s:,.0f}") for name, s in result["seconds_per_step"].items()]
    table = format_table(("path", "us/step", "steps/s"), rows)
    return (f"{result['fmu']} (FMI {result['fmi_version']}), {len(result['inputs'])} inputs, "
            f"{len(result['outputs'])} outputs, action space {result['action_space']}\n{table}\n\n"
            f"native env step / C loop: {result['ratio_native_env_to_c_loop']:.2f}x (target <= 2); "
            f"python / native: {result['ratio_python_env_to_native_env']:.2f}x")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("fmu", help="the .fmu file")
    parser.add_argument("--inputs", help="comma-separated inputs (default: every numeric input)")
    parser.add_argument("--outputs", help="comma-separated outputs (default: every numeric output)")
    parser.add_argument("--time-step", type=float, help="seconds per step (default: the model's)")
    parser.add_argument("--mode", choices=("cs", "me"), help="co-simulation or model exchange (default: the FMU's first)")
    parser.add_argument("--steps", type=int, default=20_000, help="steps per round")
    parser.add_argument("--repeats", type=int, default=7, help="interleaved rounds (median reported)")
    parser.add_argument("--json", default="bench-results/step_paths.json", help="where to write the JSON")


def _split(text: str | None) -> list[str] | None:
    return text.split(",") if text else None


def run(args: argparse.Namespace) -> int:
    config = {"time_step": args.time_step} if args.time_step else {}
    if args.mode:
        config["mode"] = args.mode
    result = measure(args.fmu, _split(args.inputs), _split(args.outputs), args.steps, args.repeats, **config)
    print(report(result))
    print(f"\nwrote {write_json(args.json, result)}")
    return 0
