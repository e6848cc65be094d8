"""How the command-line tools run a command: our errors as one line, exit status 1.

A user of ``modelicagym`` (or ``python -m modelicagym.experiments``) should see what went wrong
and what to do, not a traceback: any :class:`~modelicagym.errors.ModelicaGymError` (and a missing
file, a full disk) is printed as one line on stderr and the command exits with status 1; ``--debug``
shows the full traceback instead. Ctrl-C exits with status 130, quietly.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from modelicagym.disk import disk_full, is_disk_full
from modelicagym.errors import ModelicaGymError

__all__ = ["add_debug_flag", "run_command"]

DEBUG_HINT = "run with --debug for the details"


def add_debug_flag(parser: argparse.ArgumentParser, *, subcommand: bool = False) -> None:
    """``--debug``: let errors propagate with their traceback. On a ``subcommand``'s parser it
    defaults to nothing, so ``prog --debug command`` and ``prog command --debug`` both work (a
    subparser's default would overwrite the main parser's value)."""
    default = argparse.SUPPRESS if subcommand else False
    parser.add_argument("--debug", action="store_true", default=default, help="show the traceback of an error")


def run_command(command: Callable[[argparse.Namespace], int], args: argparse.Namespace) -> int:
    """Run ``command(args)``; its errors become one line on stderr and exit status 1."""
    try:
        return command(args)
    except KeyboardInterrupt:
        if args.debug:
            raise
        print(f"{sys.argv[0].rsplit('/', 1)[-1]}: interrupted", file=sys.stderr)
        return 130
    except (ModelicaGymError, FileNotFoundError) as error:
        if args.debug:
            raise
        print(f"error: {one_line(error)}", file=sys.stderr)
        return 1
    except OSError as error:  # a full disk where no writer of ours named the file
        if args.debug or not is_disk_full(error):
            raise
        print(f"error: {disk_full(error.filename or 'a file', code=error.errno)}", file=sys.stderr)
        return 1


def one_line(error: BaseException) -> str:
    """The first line of the error's message; a hint to ``--debug`` when there is more."""
    lines = str(error).strip().splitlines() or [type(error).__name__]
    return lines[0] if len(lines) == 1 else f"{lines[0]} ({DEBUG_HINT})"
