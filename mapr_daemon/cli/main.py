"""Entry point of the ``mapr`` command.

Subcommands live in sibling modules named in :data:`SUBCOMMANDS`; each exposes
``add_subparser(subparsers)`` and sets ``func(args) -> int`` on its parser. Errors from the
:mod:`drivers.errors` tree become one line on stderr and a distinct exit code; nothing else
is swallowed.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import NoReturn

from drivers.errors import BackendUnavailable, CaptureFormatError, EncodeError, MaprError
from mapr_daemon import __version__
from mapr_daemon.cli import exitcodes
from mapr_daemon.errors import ConfigError, RecordError

SUBCOMMANDS: tuple[str, ...] = (
    "demo",
    "decode",
    "monitor",
    "record",
    "replay",
    "fleet",
    "encode",
    "icd",
    "simulate",
    "dictionary",
    "commission",
    "diagnose",
    "prognose",
    "catalog",
    "run",
    "devices",
)
"""Modules of :mod:`mapr_daemon.cli` that add a subcommand, in help order."""


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``mapr decode: error: ...``), exit 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(exitcodes.USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="mapr",
        description="Model-based Avionic Prognostic Reasoner: passive MIL-STD-1553B monitor "
                    "and EMA fault reasoner.",
    )
    parser.add_argument("--version", action="version", version=f"mapr {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    subparsers.required = True
    for name in SUBCOMMANDS:
        module = importlib.import_module(f"mapr_daemon.cli.{name}")
        module.add_subparser(subparsers)
    return parser


def exit_code_for(error: MaprError) -> int:
    """The exit code for an expected error."""
    if isinstance(error, ConfigError):
        return exitcodes.CONFIG
    if isinstance(error, RecordError):
        return exitcodes.DATAERR
    if isinstance(error, BackendUnavailable):
        return exitcodes.UNAVAILABLE
    if isinstance(error, (CaptureFormatError, EncodeError)):
        return exitcodes.USAGE
    return exitcodes.FAILURE


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``mapr``; returns the exit code (also used by the console script)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except MaprError as error:
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
