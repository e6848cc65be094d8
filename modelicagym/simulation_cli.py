"""Run an FMU, an SSP system or a task file to a stop time with no agent and write what every variable does to CSV.

``modelicagym simulate drive.ssp --stop-time 2 --input motor.u=0.5 --out run.csv --plot run.png``:
inputs held (``--input NAME=VALUE``) or taken from the columns of a CSV table (``--inputs
table.csv``: ``time`` first), every scalar variable or the chosen ones (``--outputs``) at the start
and after every step (`modelicagym.simulation`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from modelicagym.errors import ArgumentError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("target", help="what to run: an .fmu, an SSP system (.ssp or its folder), a JSON config or "
                                       "a task file (Python defining config = {...})")
    parser.add_argument("--stop-time", type=float, help="when to stop (default: the model's default experiment's)")
    parser.add_argument("--time-step", type=float, help="the communication step (default: the config's, else the "
                                                        "model's default step size)")
    parser.add_argument("--input", "--set", dest="held", action="append", default=[], metavar="NAME=VALUE",
                        help="hold input NAME at VALUE for the whole run (repeat for several inputs)")
    parser.add_argument("--inputs", metavar="TABLE.csv", help="drive inputs by the columns of a CSV table (header "
                        "time,NAME,...; interpolated linearly, the end values held outside it)")
    parser.add_argument("--parameter", action="append", default=[], metavar="NAME=VALUE",
                        help="set a parameter at the start (repeat for several)")
    parser.add_argument("--outputs", nargs="+", metavar="NAME", help="the variables to record (default: every "
                                                                     "scalar variable)")
    parser.add_argument("--out", help="the CSV to write (default: <target name>-run.csv)")
    parser.add_argument("--plot", metavar="PNG", help="also draw the variables over time into this PNG (needs the "
                                                      "plots extra: pip install 'modelicagym[plots]')")
    parser.add_argument("--no-validate", action="store_true", help="skip schema validation of modelDescription.xml")


def _values(settings: list[str], option: str) -> dict[str, float]:
    values = {}
    for text in settings:
        name, sep, value = text.partition("=")
        try:
            values[name.strip()] = float(value)
        except ValueError:
            raise ArgumentError(f"{option} expects NAME=VALUE with a number, got {text!r}") from None
        if not sep or not name.strip():
            raise ArgumentError(f"{option} expects NAME=VALUE, got {text!r}")
    return values


def run(args: argparse.Namespace) -> int:
    from modelicagym.fmu.errors import FMUValidationError, InvalidFMUError
    from modelicagym.simulation import model_config, plot, simulate, write_csv

    target = {**model_config(args.target), "validate": False} if args.no_validate else args.target
    try:
        trajectory = simulate(target, args.stop_time, inputs=_values(args.held, "--input"), table=args.inputs,
                              outputs=args.outputs, parameters=_values(args.parameter, "--parameter"),
                              time_step=args.time_step)
    except FMUValidationError as error:
        if not error.skippable:
            raise
        raise InvalidFMUError(f"{error.summary}; to go on anyway: add --no-validate") from None
    out = write_csv(trajectory, args.out or f"{Path(args.target).stem}-run.csv")
    times = trajectory["time"]
    print(f"{len(trajectory)} rows from t={times[0]:g} to t={times[-1]:g}, {len(trajectory.dtype.names) - 1} "
          f"variables: {out}")
    if args.plot:
        path, left_out = plot(trajectory, args.plot)
        print(f"plot of the variables over time: {path}")
        if left_out:
            print(f"not drawn (the plot holds the first variables only): {', '.join(left_out)}")
    return 0
