"""``python -m benchmarks NAME [...]``: run one benchmark of modelicagym's own parts (from a clone's root)."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from benchmarks import BENCHMARKS
from modelicagym.console import add_debug_flag, add_module_commands, run_command


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks",
        description="Benchmarks of modelicagym's own parts, which its design and its figures rest on. Each runs "
                    "its candidates side by side in interleaved rounds, prints a table with the machine's cores "
                    "and load, and writes JSON to bench-results/. A user's benchmarks: modelicagym bench --help.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    add_debug_flag(parser)
    which = add_module_commands(parser, BENCHMARKS, dest="benchmark", required=True, metavar="BENCHMARK",
                                title="benchmarks (python -m benchmarks BENCHMARK --help)")
    for benchmark in which.choices.values():
        add_debug_flag(benchmark, subcommand=True)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    return run_command(args.func, args)


if __name__ == "__main__":
    sys.exit(main())
