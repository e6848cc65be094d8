"""How the command-line tools run a command: our errors as one line, exit status 1.

A user of ``modelicagym`` (or ``python -m modelicagym.experiments``) should see what went wrong
and what to do, not a traceback: any :class:`~modelicagym.errors.ModelicaGymError` (and a missing
file, a full disk) is printed as one line on stderr and the command exits with status 1; ``--debug``
shows the full traceback instead. Ctrl-C exits with status 130, quietly.

A command's module is imported when the command runs (`add_module_commands`), not when the parser
is built: ``modelicagym info`` does not pay for importing every benchmark.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence
from typing import Any

from modelicagym.disk import disk_full, is_disk_full
from modelicagym.errors import ModelicaGymError

__all__ = ["ModuleParser", "add_debug_flag", "add_module_commands", "run_command"]

DEBUG_HINT = "run with --debug for the details"


def add_debug_flag(parser: argparse.ArgumentParser, *, subcommand: bool = False) -> None:
    """``--debug``: let errors propagate with their traceback. On a ``subcommand``'s parser it
    defaults to nothing, so ``prog --debug command`` and ``prog command --debug`` both work (a
    subparser's default would overwrite the main parser's value)."""
    default = argparse.SUPPRESS if subcommand else False
    parser.add_argument("--debug", action="store_true", default=default, help="show the traceback of an error")


class ModuleParser(argparse.ArgumentParser):
    """The parser of a command whose arguments and handler come from a module, imported only when
    the command is parsed or its help shown. The module gives ``add_arguments(parser)`` and
    ``run(args) -> int`` (set as the command's ``func``); its docstring's first line describes it."""

    def __init__(self, *args: Any, module: str | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._module = module

    def _load(self) -> None:
        if self._module is None:
            return
        module, self._module = importlib.import_module(self._module), None
        doc = (module.__doc__ or "").strip().splitlines()
        self.description = doc[0] if doc else None
        module.add_arguments(self)
        self.set_defaults(func=module.run)

    def parse_known_args(self, args: Sequence[str] | None = None, namespace: Any = None) -> Any:
        self._load()
        return super().parse_known_args(args, namespace)

    def format_usage(self) -> str:
        self._load()
        return super().format_usage()

    def format_help(self) -> str:
        self._load()
        return super().format_help()


def add_module_commands(parser: argparse.ArgumentParser, commands: Sequence[tuple[str, str, str]],
                        **subparsers: Any) -> argparse._SubParsersAction:
    """One command of ``parser`` per ``(name, module, summary)`` of ``commands``, each a `ModuleParser`
    of that module: the parser's help lists them by their summaries, and nothing is imported until
    one of them runs. ``subparsers``: keywords of ``add_subparsers`` (``dest``, ``title``, ...)."""
    which = parser.add_subparsers(parser_class=ModuleParser, **subparsers)
    for name, module, summary in commands:
        which.add_parser(name, module=module, help=summary, formatter_class=argparse.RawDescriptionHelpFormatter)
    return which


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
