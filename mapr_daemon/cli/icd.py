"""``mapr icd check FILE`` and ``mapr icd dump FILE``: validate and draw a message table.

``check`` loads the file with every validation and prints a one-line summary with the bus
load of its schedule; an invalid file is reported as one ``file:line: field: problem`` line
and exit code 78 (by :mod:`mapr_daemon.cli.main`, which maps :class:`ConfigError`).
``dump`` draws each message's bit layout in ASCII, as ``cantools dump`` does.
"""

from __future__ import annotations

import argparse
import sys

from mapr_daemon.cli import exitcodes
from mapr_daemon.icd import Icd, load_icd
from mapr_daemon.icd.layout import dump_icd


def add_subparser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "icd", help="check or draw an RT/SA message table (ICD YAML)",
        description="Check or draw an RT/SA message table (ICD YAML, see docs/icd.md).")
    commands = parser.add_subparsers(dest="icd_command", metavar="ACTION")
    commands.required = True
    check = commands.add_parser("check", help="validate FILE and print a summary",
                                description="Validate an ICD file; exit 78 if it is invalid.")
    check.add_argument("file", metavar="FILE")
    check.set_defaults(func=run_check)
    dump = commands.add_parser("dump", help="draw each message's bit layout",
                               description="Draw each message's bit layout in ASCII.")
    dump.add_argument("file", metavar="FILE")
    dump.set_defaults(func=run_dump)


def _load(path: str) -> Icd | None:
    try:
        return load_icd(path)
    except OSError as error:
        print(f"mapr icd: cannot read {path}: {error.strerror or error}", file=sys.stderr)
        return None


def summary(icd: Icd) -> str:
    """The line ``check`` prints for a valid table."""
    n_params = len(icd.parameter_names)
    text = (f"{icd.path}: ok: {len(icd.terminals)} terminals, {len(icd.messages)} messages, "
            f"{n_params} parameters")
    load = icd.bus_load()
    if load is not None:
        text += (f"; bus load {100 * load.load:.1f} % (busiest minor frame "
                 f"{100 * load.peak_frame_load:.1f} %)")
    return text


def run_check(args: argparse.Namespace) -> int:
    icd = _load(args.file)
    if icd is None:
        return exitcodes.USAGE
    print(summary(icd))
    return exitcodes.OK


def run_dump(args: argparse.Namespace) -> int:
    icd = _load(args.file)
    if icd is None:
        return exitcodes.USAGE
    sys.stdout.write(dump_icd(icd))
    return exitcodes.OK
