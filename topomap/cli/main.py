"""The ``topomap`` command line: the parser and the dispatch; each command is a module of
:mod:`topomap.cli.commands` (its options and what it does)."""

from __future__ import annotations

import argparse
import gc
import logging
import re
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NoReturn

from maps.errors import TopomapError
from topomap.cli.commands import (
    batch,
    bench,
    build,
    common,
    demo,
    evaluate,
    export,
    generate,
    plan,
    segment,
    view,
)
from topomap.cli.progress import Progress

#: The packages whose loggers ``-v`` turns to DEBUG (third-party loggers stay at WARNING).
PACKAGES = ("maps", "segmentation", "planners", "topomap")

#: The commands in the order ``topomap --help`` lists them.
COMMANDS = (demo, build, generate, segment, evaluate, bench, batch, plan, export, view)

#: Libraries whose bindings check at exit that the collector freed every object of theirs,
#: and print each one left (OMPL's, by nanobind): with one loaded, :func:`run` frees as usual.
COUNTED_AT_EXIT = ("ompl",)


class Terminated(KeyboardInterrupt):
    """SIGTERM (``kill``, ``timeout``, process managers), raised in the main thread as Ctrl-C
    raises :class:`KeyboardInterrupt`, so every output being written is removed as it is."""


def _terminate(signum: int, _frame: object) -> None:
    raise Terminated(signum)


@contextmanager
def _sigterm_stops() -> Iterator[None]:
    """Within: SIGTERM raises :class:`Terminated` (in the main thread only, where Python runs
    signal handlers); the previous handler is restored after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


class Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line, as every other error of the
    command line: the (sub)command, the problem and where the help is, status 2 (``--help``
    prints the usage). argparse makes a parser's subcommands' parsers of its own class."""

    def error(self, message: str) -> NoReturn:
        """Exit with status 2 and ``message`` on one line of stderr."""
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")


def build_parser() -> Parser:
    """The argument parser of every subcommand."""
    parser = Parser(prog="topomap", description="The ``topomap`` command line.")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    _add_output_options(parser)
    parser.set_defaults(verbose=False, quiet=False)
    return parser


def _add_output_options(parser: argparse.ArgumentParser) -> None:
    """``-v`` and ``-q`` on ``parser`` and every subcommand, so they work before and after
    it (SUPPRESS: a subcommand's default does not undo what was given before it)."""
    parser.add_argument(
        "-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="debug logging"
    )
    parser.add_argument(
        "-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress"
    )
    # argparse reads a value starting with a minus sign as an option unless it is a plain
    # negative number ("-5.5"); points west or south of the origin ("-55.6,4.5") and
    # stamps like "-1e3" are values too (no option of this command starts with "-<digit>")
    parser._negative_number_matcher = re.compile(r"^-\.?\d")
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for subcommand in action.choices.values():
                _add_output_options(subcommand)


def _chosen(parser: argparse.ArgumentParser, args: argparse.Namespace) -> argparse.ArgumentParser:
    """The parser of the (sub)command ``args`` were parsed for (``topomap eval segment``'s)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            chosen = action.choices.get(getattr(args, action.dest, ""))
            if chosen is not None:
                return _chosen(chosen, args)
    return parser


def run() -> None:
    """The console script: :func:`main`'s status is the exit status.

    The garbage collector is frozen first. Shutting down, the interpreter would collect
    garbage over every object the libraries made when imported and free, one by one, the
    cycles their modules, classes and functions form (0.15 s of ``topomap segment``, a tenth
    of the command); frozen, they are left for the process's end to reclaim at once.
    ``atexit`` handlers still run, and objects are still released as their last references go.
    Not after planning (:data:`COUNTED_AT_EXIT`): OMPL would report its types as leaked.
    The objects a command's imports make are frozen as soon as they are made
    (:func:`~topomap.cli.commands.common.loading`).
    """
    common.FREEZE_IMPORTS = True
    status = main()
    if not any(name in sys.modules for name in COUNTED_AT_EXIT):
        gc.freeze()
    sys.exit(status)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status.

    Bad input (any :class:`~maps.errors.TopomapError`: a missing or malformed file, a value
    out of range, a file that would be overwritten) ends with one line on stderr and status
    2, as do usage errors; Ctrl-C (SIGINT) with status 130 and SIGTERM with 143, the outputs
    being written removed; anything else is a bug and keeps its traceback.
    """
    parser = build_parser()
    try:
        args, unknown = parser.parse_known_args(argv)
        if unknown:  # named by the (sub)command that does not know them
            _chosen(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    except SystemExit as done:  # a usage error (2) or --help (0), already printed
        return int(done.code or 0)
    logging.basicConfig(format="%(levelname)s %(name)s: %(message)s")
    if args.verbose:
        for package in PACKAGES:
            logging.getLogger(package).setLevel(logging.DEBUG)
    args.progress = Progress(quiet=args.quiet)
    try:
        with _sigterm_stops():
            return int(args.func(args))
    except TopomapError as err:
        print(f"topomap: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as stop:  # outputs are written under temporary names: none is half
        # done; the status of a process ended by the signal (128 + its number), as shells say
        how, status = ("terminated", 143) if isinstance(stop, Terminated) else ("interrupted", 130)
        print(f"topomap: {how}; no output was left half-written", file=sys.stderr)
        return status
