"""``mapr record``: write what a bus monitor sees to an IRIG 106 Chapter 10 file.

    mapr record --backend loopback --duration 10 flight.c10
    mapr record --backend serial -O port=/dev/ttyUSB0 flight.c10      (Ctrl-C to stop)
    mapr record --backend capture -O path=bus.sr --count 1000 first1000.c10

The backend is opened as ``mapr monitor`` opens it (``-O KEY=VALUE`` options, numbers and
true/false converted). Recording stops at ``--duration`` seconds, ``--count`` messages, the end
of the source, or Ctrl-C / SIGTERM; every message received is in the file when it stops. One
summary line follows: messages, messages with errors, packets and bytes. Exit 0, or 130 after
Ctrl-C / SIGTERM (the file is complete either way), 2 for a bad argument or an output file that
cannot be written, 69 for a backend that cannot be opened.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from types import FrameType
from typing import TYPE_CHECKING, Any

from drivers.backends import available_backends
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.validate import add_backend_options, positive_int, positive_seconds

if TYPE_CHECKING:
    from drivers.chapter10.writer import Chapter10Writer, RecordingStats
    from drivers.monitor import BusMonitor

FLUSH_EVERY_S = 1.0
"""Wall-clock seconds between flushes to disk (fsync) while recording."""


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("record", help="record the bus to a Chapter 10 file",
                                   description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("output", metavar="OUT.c10", help="the Chapter 10 file to write")
    parser.add_argument("--backend", default="loopback", choices=available_backends(),
                        help="one of: %(choices)s (default loopback)")
    add_backend_options(parser, old_dash_o=True)
    parser.add_argument("--duration", type=positive_seconds, metavar="S",
                        help="stop after S seconds")
    parser.add_argument("--count", type=positive_int("message count"), metavar="N",
                        help="stop after N messages")
    parser.add_argument("--channel", type=_channel_id, default=1, metavar="ID",
                        help="Chapter 10 channel id of the 1553 bus, 1-65534 (default 1; "
                             "time packets use ID+1)")
    parser.add_argument("--tail", default="", metavar="TAIL",
                        help="the aircraft's tail number, written into the TMATS record "
                             "(G\\TA: read by 'mapr fleet --tail-tmats G\\TA')")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from drivers.chapter10.writer import Chapter10Writer
    from drivers.monitor import open_monitor

    monitor = open_monitor(args.backend, **dict(args.option))
    with monitor:
        try:
            writer = Chapter10Writer(args.output, channel_id=args.channel, tail=args.tail)
        except OSError as error:
            print(f"mapr record: cannot write {args.output}: {error.strerror or error}",
                  file=sys.stderr)
            return exitcodes.USAGE
        except ValueError as error:   # a tail TMATS cannot hold
            print(f"mapr record: --tail: {error}", file=sys.stderr)
            return exitcodes.USAGE
        stop = _StopSignals()
        try:
            with stop, writer:
                _record(monitor, writer, stop, duration=args.duration, count=args.count)
        except OSError as error:
            print(f"mapr record: writing {args.output} failed: {error.strerror or error}",
                  file=sys.stderr)
            return exitcodes.USAGE
        finally:
            print(summary_line(writer.stats, args.output))
    return exitcodes.INTERRUPTED if stop.signalled else exitcodes.OK


def _record(monitor: BusMonitor, writer: Chapter10Writer, stop: _StopSignals, *,
            duration: float | None, count: int | None) -> None:
    """Move records from the monitor to the writer until a limit, the end or a signal."""
    start = last_flush = time.monotonic()
    written = 0
    while not stop.signalled and (count is None or written < count):
        left = None if duration is None else duration - (time.monotonic() - start)
        if left is not None and left <= 0:
            break
        record = monitor.recv(timeout=0.25 if left is None else min(left, 0.25))
        if record is not None:
            writer.write((record,))
            written += 1
        elif monitor.ended:
            break
        if time.monotonic() - last_flush >= FLUSH_EVERY_S:
            writer.flush()
            last_flush = time.monotonic()


def summary_line(stats: RecordingStats, path: str) -> str:
    """The line ``mapr record`` ends with."""
    skipped = f"; {stats.skipped} with a time tag the file cannot hold, skipped" \
        if stats.skipped else ""
    return (f"recorded {stats.messages} messages ({stats.error_messages} with errors) in "
            f"{stats.packets} packets, {stats.bytes} bytes to {path}{skipped}")


class _StopSignals:
    """While entered, SIGINT and SIGTERM set :attr:`signalled` instead of interrupting, so a
    record is never cut in half; the previous handlers come back on exit."""

    def __init__(self) -> None:
        self.signalled = False
        self._previous: dict[int, Any] = {}

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.signalled = True

    def __enter__(self) -> _StopSignals:
        for signum in (signal.SIGINT, signal.SIGTERM):
            self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)


def _channel_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"channel id must be 1-65534, not {text!r}") from None
    if not 1 <= value <= 0xFFFE:
        raise argparse.ArgumentTypeError(f"channel id must be 1-65534, not {value}")
    return value
