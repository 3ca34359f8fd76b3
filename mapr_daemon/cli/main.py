"""Entry point of the ``mapr`` command.

Subcommands live in :mod:`mapr_daemon.cli.commands`, one module each, named in
:data:`SUBCOMMANDS` (helpers they share are in ``cli/`` and its packages); each exposes
``add_subparser(subparsers)`` and sets ``func(args) -> int`` on its parser. Errors from the
:mod:`drivers.errors` tree become one line on stderr and a distinct exit code; nothing else
is swallowed.

Start-up is lazy, so ``mapr --help`` and a typo answer at once: only the subcommand named on
the command line is imported (the others get a placeholder parser carrying their one-line
help from :data:`SUBCOMMANDS`), and a subcommand module imports only the standard library and
light MAPR modules at its top. Numerical and hardware work (numpy-heavy pipelines, numba
kernels, scipy, filterpy, matplotlib, libusb, pyserial) is imported inside the function that
runs it. To add a subcommand ``foo``:

1. write ``mapr_daemon/cli/commands/foo.py`` with ``add_subparser(subparsers)`` declaring every
   argument (validated by ``type=``/``choices=`` so a bad one exits 2 before any work) and
   ``parser.set_defaults(func=run)``;
2. in ``run(args)``, import what the command needs, then do it; return an exit code from
   :mod:`mapr_daemon.cli.exitcodes`, or raise a :class:`~drivers.errors.MaprError`;
3. add ``"foo": "one-line help"`` to :data:`SUBCOMMANDS` (the same text as its ``help=``; a
   test compares them, and another checks that building its parser stays light).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Iterable, Sequence
from typing import NoReturn

from drivers.errors import (
    BackendError,
    BackendOptionError,
    BackendUnavailable,
    CaptureFormatError,
    EncodeError,
    MaprError,
)
from mapr_daemon import __version__
from mapr_daemon.cli import exitcodes, notes
from mapr_daemon.errors import ClusterError, ConfigError, RecordError

SUBCOMMANDS: dict[str, str] = {
    "demo": "fly the simulated aircraft and monitor its bus",
    "decode": "decode a bit-level capture (raw or sigrok .sr) or a Chapter 10 recording to "
              "JSON lines",
    "monitor": "watch a bus live (one line per message)",
    "record": "record the bus to a Chapter 10 file",
    "replay": "run a Chapter 10 recording through the reasoner into the catalog",
    "fleet": "run a fleet's Chapter 10 archive through the reasoner on Dask, into one catalog",
    "fleet-archive": "write a synthetic fleet archive of Chapter 10 recordings",
    "encode": "write a bit-level capture from a JSON-lines word list",
    "icd": "check or draw an RT/SA message table (ICD YAML)",
    "simulate": "simulate fault-seeded EMA runs into an .npz",
    "dictionary": "build or plot the reasoner's fault dictionary",
    "commission": "identify an actuator from its healthy BITs, build its dictionary",
    "diagnose": "anomaly, fault, severity of BIT runs (JSON)",
    "prognose": "score RUL along a run-to-failure trajectory",
    "catalog": "query the fault catalog",
    "health": "state of health and remaining useful life of every actuator",
    "report": "write the actuators' health as one self-contained HTML file",
    "run": "run the daemon (monitor, reason, catalog)",
    "devices": "list attached interface cards",
    "completion": "print a bash or zsh completion script",
}
"""Modules of :mod:`mapr_daemon.cli.commands` that add a subcommand -> their one-line help,
in help order."""
MODULES: dict[str, str] = {
    "demo": "mapr_daemon.testbed.cli_demo",
    "simulate": "mapr_daemon.testbed.cli_simulate",
    "fleet-archive": "mapr_daemon.testbed.cli_fleet_archive",
}
"""Subcommands whose module is not ``mapr_daemon.cli.commands.<name>``: the simulator's front ends
live in :mod:`mapr_daemon.testbed` (nothing outside it imports the simulator)."""


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``mapr decode: error: ...``), exit 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(exitcodes.USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(commands: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """The ``mapr`` parser with full parsers for ``commands`` (default: every subcommand) and
    a placeholder (name and help only, nothing imported) for the others."""
    wanted = set(SUBCOMMANDS if commands is None else commands)
    parser = OneLineParser(
        prog="mapr",
        description="Model-based Avionic Prognostic Reasoner: passive MIL-STD-1553B monitor "
                    "and EMA fault reasoner.",
    )
    parser.add_argument("--version", action="version", version=f"mapr {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    subparsers.required = True
    for name, summary in SUBCOMMANDS.items():
        if name in wanted:
            module = importlib.import_module(MODULES.get(name, f"mapr_daemon.cli.commands.{name}"))
            module.add_subparser(subparsers)
        else:
            subparsers.add_parser(name, help=summary, add_help=False)
    _add_quiet(parser, top=True)
    return parser


def _add_quiet(parser: argparse.ArgumentParser, *, top: bool) -> None:
    """``-q/--quiet`` on ``parser`` and every subcommand under it (wherever a user puts it,
    ``mapr -q decode`` or ``mapr catalog list -q``), unless a command already has one."""
    if not any("-q" in a.option_strings for a in parser._actions):
        parser.add_argument("-q", "--quiet", action="store_true",
                            default=False if top else argparse.SUPPRESS,
                            help="no warnings on stderr (errors still)")
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                if sub.add_help:   # not a placeholder
                    _add_quiet(sub, top=False)


def innermost(parser: argparse.ArgumentParser, args: argparse.Namespace
              ) -> argparse.ArgumentParser:
    """The (sub)subcommand parser ``args`` came through, to name it in an error."""
    while True:
        chosen = None
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                name = getattr(args, action.dest, None) if action.dest != "==SUPPRESS==" \
                    else None
                chosen = action.choices.get(name) if isinstance(name, str) else None
        if chosen is None:
            return parser
        parser = chosen


def named_command(argv: Sequence[str]) -> list[str]:
    """The subcommand an argument list names (its first word not starting with ``-``), as a
    list of zero or one names, so that only that subcommand's module is imported."""
    for word in argv:
        if not word.startswith("-"):
            return [word] if word in SUBCOMMANDS else []
    return []


def exit_code_for(error: MaprError) -> int:
    """The exit code for an expected error."""
    if isinstance(error, ConfigError):
        return exitcodes.CONFIG
    if isinstance(error, RecordError):
        return exitcodes.DATAERR
    if isinstance(error, (BackendOptionError, CaptureFormatError, EncodeError)):
        return exitcodes.USAGE
    if isinstance(error, (BackendUnavailable, BackendError, ClusterError)):
        # no library, no card, no port, the card failed, or a fleet run's Dask scheduler
        # cannot be reached or was lost: what the command needs is unavailable
        return exitcodes.UNAVAILABLE
    return exitcodes.FAILURE


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``mapr``; returns the exit code (also used by the console script)."""
    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(named_command(words))
    args, extra = parser.parse_known_args(words)
    if extra:   # named by the subcommand that refused it, not by plain `mapr`
        innermost(parser, args).error(f"unrecognized arguments: {' '.join(extra)}")
    notes.current = notes.Notes(args.command, quiet=bool(getattr(args, "quiet", False)))
    handler = None
    if args.command != "run":   # the daemon configures its own logging
        handler = notes.NotesHandler(notes.current)
        logging.getLogger().addHandler(handler)
    try:
        return _run(args)
    finally:
        notes.current.finish()
        if handler is not None:
            logging.getLogger().removeHandler(handler)


def _stopped_by_user(error: BaseException) -> bool:
    """Whether ``error`` was raised while a KeyboardInterrupt was being handled."""
    seen: set[int] = set()
    cause: BaseException | None = error
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__context__
    return False


def _run(args: argparse.Namespace) -> int:
    """Validate and run the parsed subcommand, turning expected errors into exit codes."""
    validate = getattr(args, "validate", None)
    problem = validate(args) if validate is not None else None
    if problem:
        print(f"mapr {args.command}: error: {problem} (see mapr {args.command} --help)",
              file=sys.stderr)
        return exitcodes.USAGE
    try:
        return int(args.func(args))
    except MaprError as error:
        if _stopped_by_user(error):
            # Ctrl-C landed inside a backend and its clean-up failed in turn (a loopback's
            # simulator thread cut off mid-block): the user stopped it, the error is the echo
            return exitcodes.INTERRUPTED
        print(f"mapr {args.command}: {error}", file=sys.stderr)
        return exit_code_for(error)
    except BrokenPipeError:
        # `mapr decode ... | head`: the reader went away, which is not an error of ours.
        sys.stderr.close()
        return exitcodes.OK
    except OSError as error:
        # a file a subcommand was given (or defaults to) that cannot be read or written
        print(f"mapr {args.command}: {error}", file=sys.stderr)
        return exitcodes.USAGE
    except KeyboardInterrupt:
        return exitcodes.INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
