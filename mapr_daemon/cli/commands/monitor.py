"""``mapr monitor``: watch a bus live, one line per message (like candump).

    mapr monitor --backend loopback
    mapr monitor --backend capture -O path=flight.sr --rt 5 --errors
    mapr monitor --backend loopback --json --count 100
    mapr monitor --backend loopback --stats --duration 2

Filters (all given must match) are ``mapr decode``'s, lists and ranges included: ``--rt``,
``--sa``, ``--tr`` (one terminal's side of a message: an RT-RT transfer matches ``--rt 2 --tr
T`` when RT 2 transmits in it), ``--format``, ``--errors``, ``--error NAMES``, ``--from`` and
``--to`` (bus time, s); a filter no message can match exits 2 before the backend opens.
``-O KEY=VALUE`` passes an option to the backend (numbers and true/false are converted).
``--icd FILE`` shows engineering values under each message the table describes. ``--stats``
prints, of the messages shown (those the filters keep), the per-bus statistics table at the
end (and every ``--stats-every`` seconds), then per RT/SA (the sides the filters select) the
messages, rate, errors by class, response time min/mean/max and last seen, and each bus's
load per ``--stats-window`` (JSON lines with ``"kind": "rtsa"`` / ``"bus_load"`` on stdout
with ``--json``); a Chapter 10 recording's per channel (``channel N (1553)`` headings, or a
``"channel"`` key), each channel a bus. ``--c10-channel ID`` picks channels of a recording
(``--backend chapter10``), whose lines give each message's channel after its time, as
``decode --text``'s ``ch`` column does (a live bus has no channel, and no column).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from drivers.backends import available_backends
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.traffic.source import add_c10_channel_argument
from mapr_daemon.cli.validate import (
    add_backend_options,
    add_filter_arguments,
    non_negative_seconds,
    parse_option,
    positive_int,
    positive_seconds,
)

__all__ = ["add_subparser", "parse_option", "run", "validate"]


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("monitor", help="watch a bus live (one line per message)",
                                   description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--backend", default="loopback", choices=available_backends(),
                        help="one of: %(choices)s (default loopback)")
    add_backend_options(parser, old_dash_o=True)
    add_filter_arguments(parser)
    add_c10_channel_argument(parser, "with --backend chapter10: read only this 1553 channel "
                                     "ID (repeat for more; the same as -O channels=ID,...)")
    parser.add_argument("--json", action="store_true", help="JSON lines instead of text")
    parser.add_argument("--icd", metavar="FILE", help="message table: show engineering values")
    parser.add_argument("--stats", action="store_true",
                        help="print bus statistics at the end: per bus, per RT/SA and "
                             "windowed load (JSON lines on stdout with --json)")
    parser.add_argument("--stats-window", type=positive_seconds, default=1.0, metavar="S",
                        help="bus-load window for --stats, in seconds (default 1)")
    parser.add_argument("--stats-every", type=non_negative_seconds, default=0.0, metavar="S")
    parser.add_argument("--count", type=positive_int("message count"),
                        help="stop after this many messages")
    parser.add_argument("--duration", type=positive_seconds,
                        help="stop after this many seconds")
    parser.set_defaults(func=run, validate=validate)


def validate(args: argparse.Namespace) -> str | None:
    """A filter value that is malformed or can never match, as one line (or None): checked
    before the backend opens, so a typo is an error instead of a silent bus."""
    from mapr_daemon.cli.traffic.decode_filter import filter_problem

    if args.c10_channels:
        if args.backend != "chapter10":
            return (f"--c10-channel picks channels of a Chapter 10 recording (--backend "
                    f"chapter10), not of the {args.backend} backend")
        if any(key == "channels" for key, _ in args.option):
            return "--c10-channel and -O channels= both pick channels: give one of them"
    return filter_problem(args)


def run(args: argparse.Namespace) -> int:
    from drivers.monitor import MonitorFilter, open_monitor
    from mapr_daemon.cli.icdview.view import IcdView
    from mapr_daemon.cli.traffic.decode_filter import filter_from_args
    from mapr_daemon.cli.traffic.render import record_json, record_line
    from mapr_daemon.cli.traffic.source import ShownStatistics, bounded

    view = IcdView(args.icd)
    options = dict(args.option)
    if args.c10_channels:
        options["channels"] = list(args.c10_channels)
    selected = filter_from_args(args)
    wanted = selected.monitor_filter()
    filters = [wanted] if wanted != MonitorFilter() else None
    monitor = open_monitor(args.backend, filters=filters, **options)
    shown = None   # statistics of the messages shown: those the filters keep, per channel
    if args.stats or args.stats_every:
        shown = ShownStatistics(window_ns=round(args.stats_window * 1e9), wanted=selected)
    last_stats = time.monotonic()
    out = sys.stdout
    with monitor:
        for record in bounded(monitor, count=args.count, duration=args.duration):
            if args.json:
                out.write(record_json(record, view.values(record)) + "\n")
            else:
                out.write(record_line(record, view.text(record)) + "\n")
            if shown is not None:
                shown.add(record)
                if args.stats_every and time.monotonic() - last_stats >= args.stats_every:
                    last_stats = time.monotonic()
                    print(shown.bus_tables(), file=sys.stderr)
        out.flush()
        if args.stats and shown is not None:
            shown.print(as_json=args.json, out=out, err=sys.stderr)
            out.flush()
    return exitcodes.OK
