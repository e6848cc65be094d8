"""The ``modelicagym`` command: ``sample``, ``info``, ``try``, ``simulate``, ``build``, ``bench``, ``reproduce``,
``report``."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from modelicagym.console import ModuleParser, add_debug_flag, add_module_commands, run_command
from modelicagym.errors import ArgumentError

if TYPE_CHECKING:
    from modelicagym.try_fmu import TryConfig

logger = logging.getLogger("modelicagym")


def _sample(args: argparse.Namespace) -> int:
    from pathlib import Path

    from modelicagym.samples import SAMPLES, write_sample

    if args.name is None or args.list:
        for sample in SAMPLES.values():
            print(f"{sample.name:<7} {sample.summary}: {', '.join(sample.files)}")
        return 0
    written = write_sample(args.name, args.out, force=args.force)
    print(f"wrote {', '.join(map(str, written))}")
    print("try next:")
    if Path(args.out).resolve() != Path.cwd():
        print(f"  cd {args.out}")
    for command in SAMPLES[args.name].next_steps:
        print(f"  {command}")
    return 0


def _info(args: argparse.Namespace) -> int:
    from modelicagym.info import describe_fmu

    print(describe_fmu(args.fmu, validate=not args.no_validate))
    if args.task:
        from modelicagym.task_draft import write_task

        draft = write_task(args.fmu, args.task, validate=not args.no_validate)
        print(f"\nwrote {args.task}, a task that trains as written (edit any of it):")
        print("\n".join(f"  - {line}" for line in draft.lines))
    return 0


def _try(args: argparse.Namespace) -> int:
    from pathlib import Path

    from modelicagym.try_fmu import prepare, try_fmu

    prepared = prepare(args.target, config_file=args.config, settings=args.set, validate=not args.no_validate)
    if args.step:
        return _step_responses(args, prepared)
    if args.policy == "baseline" and prepared.baseline is None:
        raise ArgumentError(f"--policy baseline: {args.target} defines no baseline (a task file's "
                            "def baseline(observation) -> action, or a class with act(observation) and reset())")
    out = args.out or f"{Path(args.target).stem}-try.png"
    result = try_fmu(prepared.config, out=out, steps=args.steps, seed=args.seed, assumed=prepared.assumed,
                     baseline=prepared.baseline if args.policy == "baseline" else None)
    print("\n".join(result.lines()))
    return 1 if result.fmu_error is not None else 0


def _step_responses(args: argparse.Namespace, prepared: TryConfig) -> int:
    """``try --step INPUT``: each input's step response, the outputs' settling times, a timing
    suggested from them, and the plot."""
    from pathlib import Path

    from modelicagym.step_response import (
        parse_step,
        plot_step_responses,
        step_plot_paths,
        step_response,
        suggest_timing,
    )
    from modelicagym.try_fmu import TRY_BOUNDS

    steps = [parse_step(text) for text in args.step]
    responses = [step_response(prepared.config, name, value, seed=args.seed) for name, value in steps]
    for response in responses:
        print("\n".join(response.lines()))
    timing = suggest_timing(responses)
    print(timing or "no output settled: nothing to suggest a time step from")
    for response, path in zip(responses, step_plot_paths([r.input for r in responses], args.out,
                                                         Path(args.target).stem)):
        plot, left_out = plot_step_responses([response], path)
        print(f"plot of the response to {response.input} over time: {plot}")
    if left_out:
        print(f"not drawn (the plot holds the first outputs only): {', '.join(left_out)}")
    assumed = [name for name, value in steps if value is None and name in prepared.assumed]
    if assumed:
        print(f"stepped to the end of {TRY_BOUNDS}, assumed as nothing in the FMU says the range: "
              f"{', '.join(assumed)} (--step NAME=VALUE steps to a value)")
    return 0


def _build(args: argparse.Namespace) -> int:
    from modelicagym.fmu.build import build_all_models, build_model_folder

    if args.folder is not None:
        print(build_model_folder(args.folder, args.fmi_version, out=args.out))
        return 0
    if args.out is not None:
        raise ArgumentError("--out needs a model folder to build (modelicagym build FOLDER --out MY.fmu)")
    for path in build_all_models(fmi_versions=args.fmi_version):
        print(path)
    return 0


#: what ``modelicagym bench`` runs, before and while training, in the order its help lists them:
#: (name, module, summary); a module is imported only when its benchmark runs
BENCHMARKS = (
    ("fmu", "modelicagym.bench.own_fmu", "your FMU: one env, Sync/AsyncVectorEnv and the pool, side by side"),
    ("step-paths", "modelicagym.bench.step_paths",
     "one env of your FMU on the native step path, the Python path and our C loop"),
    ("throughput", "modelicagym.bench.throughput", "the cart-pole stepped every way a user can, by number of envs"),
    ("shared", "modelicagym.bench.shared_machine",
     "the same on a shared machine: a busy process, two trainings, a learner"),
    ("training", "modelicagym.bench.training",
     "PPO on every vector env, where the time goes; --seeds N: the presets over seeds"),
    ("ray", "modelicagym.bench.ray", "scaling out: Ray actors next to the local pool, per-step calls and rollouts"),
)


def build_parser() -> argparse.ArgumentParser:
    from modelicagym import __version__
    from modelicagym.experiments.cli import add_parsers as experiment_parsers
    from modelicagym.fmu.build import FMI_VERSIONS

    parser = argparse.ArgumentParser(prog="modelicagym", description=__doc__)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    add_debug_flag(parser)
    commands = parser.add_subparsers(dest="command", required=True, parser_class=ModuleParser)

    sample = commands.add_parser("sample", help="write a sample FMU and its task file, to try the commands on")
    sample.add_argument("name", nargs="?", help="the sample: heater, drive or system (none: list them)")
    sample.add_argument("--out", default=".", metavar="DIR",
                        help="the folder to write it into (default: the current folder)")
    sample.add_argument("--list", action="store_true", help="list the samples, one line each")
    sample.add_argument("--force", action="store_true", help="replace files of the same names that are already there")
    sample.set_defaults(func=_sample)

    info = commands.add_parser("info", help="describe an FMU and print an FMUEnv config for it")
    info.add_argument("fmu", help="path of the .fmu file")
    info.add_argument("--no-validate", action="store_true", help="skip schema validation of modelDescription.xml")
    info.add_argument("--task", metavar="FILE", help="also write a task file that trains as written: the config, a "
                                                     "setpoint to track, a reward and a baseline, from what the model "
                                                     "does after a step of its first action")
    info.set_defaults(func=_info)

    try_ = commands.add_parser("try", help="run a config with random actions and plot what the FMU does")
    try_.add_argument("target", help="what to run: an .fmu (the config `info` prints for it), a JSON config file, "
                                     "or a task file (Python defining config = {...})")
    try_.add_argument("--steps", type=int, help="steps to run (default: the config's max_episode_steps, 500)")
    try_.add_argument("--seed", type=int, default=0, help="seed of the reset and of the random actions (default: 0)")
    try_.add_argument("--out", help="where to write the PNG plot (default: <target name>-try.png)")
    try_.add_argument("--config", help="a JSON file of FMUEnv keys that replace the config's")
    try_.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                      help="change one config key, the value read as JSON (e.g. --set time_step=0.01, "
                           "--set parameters.k=2, --set fixed_inputs.T_amb=300, --set action_bounds.u=[0,1])")
    try_.add_argument("--step", action="append", default=[], metavar="INPUT[=VALUE]",
                      help="instead of random actions: step INPUT from its start value (to VALUE, else to the end of "
                           "its range) and show how the outputs respond and when they settle, to choose the time "
                           "step and the episode length (repeat for several inputs)")
    try_.add_argument("--policy", choices=("random", "baseline"), default="random",
                      help="what chooses the actions: random samples (default), or the task file's baseline controller")
    try_.add_argument("--no-validate", action="store_true", help="skip schema validation of modelDescription.xml")
    try_.set_defaults(func=_try)

    commands.add_parser("simulate", module="modelicagym.simulation_cli",
                        formatter_class=argparse.RawDescriptionHelpFormatter,
                        help="run an FMU, an SSP system or a task file to a stop time with no agent; every variable "
                             "to CSV")

    build = commands.add_parser("build", help="build the bundled model FMUs, or a model folder, from their C sources")
    build.add_argument("folder", nargs="?", help="a model folder written with our C framework (e.g. "
                       "modelicagym/samples/heater; modelicagym/models/csrc/model.h); default: the bundled models")
    build.add_argument("--out", help="with a folder: copy the built FMU here (default: print its cache path)")
    build.add_argument("--fmi-version", type=int, nargs="+", choices=FMI_VERSIONS, metavar="N",
                       help=f"FMI versions to build ({', '.join(map(str, FMI_VERSIONS))}; default: all; "
                            "FMI 1.0 builds a co-simulation and a model-exchange FMU)")
    build.set_defaults(func=_build)

    bench = commands.add_parser(
        "bench", help="benchmarks: what a step of your FMU costs, stepped every way; the pool's throughput",
        description="Measure before you train: each benchmark runs its candidates side by side in interleaved "
                    "rounds, prints a table with the machine's cores and load, and writes JSON to bench-results/.")
    add_module_commands(bench, BENCHMARKS, dest="benchmark", required=True, metavar="BENCHMARK",
                        title="benchmarks (modelicagym bench BENCHMARK --help)")

    experiment_parsers(commands)
    _debug_flag_on_subcommands(parser)
    return parser


def _debug_flag_on_subcommands(parser: argparse.ArgumentParser) -> None:
    """``--debug`` after any (sub-)subcommand too: ``modelicagym info X --debug``."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for subparser in action.choices.values():
                add_debug_flag(subparser, subcommand=True)
                _debug_flag_on_subcommands(subparser)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    return run_command(args.func, args)


if __name__ == "__main__":
    sys.exit(main())
