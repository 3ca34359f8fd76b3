"""``mapr icd check FILE``, ``mapr icd dump FILE``, ``mapr icd discover``: validate and draw
a message table, or write a skeleton one from observed traffic.

``check`` loads the file with every validation and prints a one-line summary with the bus
load of its schedule; an invalid file is reported as one ``file:line: field: problem`` line
and exit code 78 (by :mod:`mapr_daemon.cli.main`, which maps :class:`ConfigError`).
``dump`` draws each message's bit layout in ASCII, as ``cantools dump`` does.
``discover`` reads a Chapter 10 recording (a file, or a stream on ``-``), a capture or a live
backend (bounded by ``--count``/``--duration``) and writes every RT/SA/direction it saw as a
skeleton table (:mod:`mapr_daemon.icd.discover`) that ``check`` accepts as written; a
recording of several 1553 channels gives each channel its own terminals (``channel: N``).
"""

from __future__ import annotations

import argparse
import sys

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.traffic.source import add_c10_channel_argument
from mapr_daemon.cli.validate import add_backend_options
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
    discover = commands.add_parser(
        "discover", help="write a skeleton ICD from observed traffic",
        description="Write a skeleton ICD (every RT/SA/direction seen, word counts, rates, "
                    "mode codes, placeholder names) from a Chapter 10 recording, a capture or "
                    "a live backend.")
    discover.add_argument("source", metavar="FILE", nargs="?",
                          help="Chapter 10 recording or bit-level capture, '-' for stdin "
                               "(or use --backend)")
    discover.add_argument("--backend", help="read a live backend instead of a file")
    add_backend_options(discover, old_dash_o=False)
    discover.add_argument("--count", type=int, metavar="N",
                          help="stop after N messages (live backend)")
    discover.add_argument("--duration", type=float, metavar="S",
                          help="stop after S seconds (live backend)")
    discover.add_argument("--samplerate", type=float, metavar="HZ",
                          help="sample rate of a raw capture")
    discover.add_argument("--name", default="discovered", help="the table's name")
    add_c10_channel_argument(discover, "discover only this 1553 channel ID of a Chapter 10 "
                                       "recording (repeat for more; default: every channel, "
                                       "each its own terminals)")
    discover.add_argument("-o", "--output", metavar="OUT", help="write here (default: stdout)")
    discover.set_defaults(func=run_discover)


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


def run_discover(args: argparse.Namespace) -> int:
    from drivers.backends.capture import check_capture_file
    from drivers.rtstats import TrafficStatistics
    from mapr_daemon.cli.traffic.source import (
        backend_batches,
        capture_batches,
        channel_statistics,
        open_chapter10,
        what_it_holds,
    )
    from mapr_daemon.icd.discover import skeleton_yaml

    prog = "mapr icd discover"
    if (args.source is None) == (args.backend is None):
        print(f"{prog}: error: give a FILE or --backend NAME (one of them)", file=sys.stderr)
        return exitcodes.USAGE
    if args.backend is not None and args.count is None and args.duration is None:
        print(f"{prog}: error: a live backend needs --count N or --duration S",
              file=sys.stderr)
        return exitcodes.USAGE
    for flag, value in (("--count", args.count), ("--duration", args.duration)):
        if value is not None and not value > 0:
            print(f"{prog}: error: {flag} must be above 0, got {value}", file=sys.stderr)
            return exitcodes.USAGE
    stats: TrafficStatistics | dict[int, TrafficStatistics]
    status = exitcodes.OK
    if args.source is not None:
        reader = open_chapter10(args.source, args.c10_channels, None)
        where = "stdin" if args.source == "-" else args.source
        if reader is not None:   # each 1553 channel a bus: its own terminals and rates
            stats = channel_statistics(reader, window_ns=round(1e9))
            status = what_it_holds(reader, args.c10_channels, prog)
            if status != exitcodes.OK and not stats:
                return status
        elif args.c10_channels:
            print(f"{prog}: error: {where}: --c10-channel applies to a Chapter 10 recording, "
                  "not to a bit-level capture", file=sys.stderr)
            return exitcodes.USAGE
        else:
            check_capture_file(args.source, args.samplerate, rate_hint="--samplerate HZ")
            stats = TrafficStatistics()
            for batch in capture_batches(args.source, samplerate=args.samplerate):
                stats.add_batch(batch)
    else:
        stats = TrafficStatistics()
        for batch in backend_batches(args.backend, dict(args.option),
                                     count=args.count, duration=args.duration):
            stats.add_batch(batch)
        where = f"the {args.backend} backend"
    text = skeleton_yaml(stats, name=args.name, source=where)
    if args.output is None:
        sys.stdout.write(text)
    else:
        with open(args.output, "w", encoding="utf-8") as out:
            out.write(text)
        tables = stats.values() if isinstance(stats, dict) else [stats]
        keys = sum(len(table.rows()) for table in tables)
        on = f" on {len(stats)} channels" if isinstance(stats, dict) and len(stats) > 1 else ""
        print(f"{args.output}: {keys} RT/SA/direction and mode-code keys{on}",
              file=sys.stderr)
    return int(status)
