"""Batches of records from a file or a live backend, and the statistics printed from them.

Shared by ``mapr decode --stats``, ``mapr monitor --stats`` and ``mapr icd discover``: a
Chapter 10 recording (found by its sync pattern, in a file or on stdin) is read with the
Chapter 10 reader and counted per 1553 channel (each channel is a bus), any other file as a
bit-level capture; a live backend is read through the monitor API, bounded by a message count
and/or a duration. Statistics count the messages the filters keep.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TextIO

from drivers.chapter10.holdings import holdings
from mapr_daemon.cli import exitcodes

if TYPE_CHECKING:   # imported where used: registering the subcommands stays light
    from drivers.chapter10.reader import Chapter10Reader
    from drivers.mil1553.record import MonitorRecord
    from drivers.monitor import BusMonitor, BusStatistics
    from drivers.rtstats import RecordArrays, TrafficStatistics
    from mapr_daemon.cli.traffic.decode_filter import DecodeFilter

BATCH = 4096
"""Records per batch read from a live backend."""


def positive_seconds(text: str) -> float:
    """A duration in seconds above 0 (an argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be above 0 s, got {text}")
    return value


def add_c10_channel_argument(parser: Any, help_text: str = "read only this 1553 channel ID "
                             "(repeat for more; default: every channel)") -> None:
    """``--c10-channel ID`` (repeatable, into ``args.c10_channels``): the one option every
    command that reads a Chapter 10 recording takes to pick its buses."""
    from mapr_daemon.cli.validate import bounded_int

    parser.add_argument("--c10-channel", type=bounded_int(1, 0xFFFF, "channel ID"),
                        action="append", dest="c10_channels", metavar="ID", help=help_text)


@dataclass(frozen=True, slots=True)
class Chapter10Input:
    """A Chapter 10 recording to read: ``path`` is a file (for a stream, a spooled copy the
    reader opens and :meth:`done_opening` removes), ``name`` what messages call it (the path
    given, or ``stdin``)."""

    path: str
    name: str
    spooled: bool = False

    def done_opening(self) -> None:
        """Remove a spooled copy once the reader holds it open (it reads on from the open
        file; nothing is left behind whatever happens next). Calling it again does nothing."""
        if self.spooled:
            with contextlib.suppress(FileNotFoundError):   # once is enough
                os.unlink(self.path)


def chapter10_input(path: str) -> Chapter10Input | None:
    """``path`` as a Chapter 10 input, or None when it is not one (then it is a capture).

    A regular file is recognised by :func:`~drivers.chapter10.walker.looks_like_chapter10`.
    ``-`` (stdin) is peeked at: when its first bytes are a valid packet header (sync pattern
    0xEB25) it is spooled to a temporary file, since the reader seeks to resynchronize after
    damage; otherwise it is left unread for the capture path. A pipe or device named by path
    (``/dev/stdin``, a FIFO) cannot be peeked at: it is spooled, then recognised. Raises
    :class:`~drivers.errors.CaptureFormatError` naming the input when it cannot be read."""
    import stat

    from drivers.chapter10.walker import HEADER_BYTES, Header, looks_like_chapter10, parse_header
    from drivers.errors import CaptureFormatError

    if path == "-":
        stream = sys.stdin.buffer
        try:
            head = stream.peek(HEADER_BYTES)[:HEADER_BYTES] if hasattr(stream, "peek") else b""
        except OSError as error:
            raise CaptureFormatError(f"stdin: cannot read: {error.strerror or error}") from error
        if len(head) < HEADER_BYTES or not isinstance(parse_header(head, 0), Header):
            return None
        return _spool(stream, "stdin")
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None   # the capture path says it is not there, naming it
    if stat.S_ISREG(mode):
        return Chapter10Input(path, path) if looks_like_chapter10(path) else None
    try:
        with open(path, "rb") as stream:
            spooled = _spool(stream, path)
    except OSError as error:
        raise CaptureFormatError(f"{path}: cannot read: {error.strerror or error}") from error
    if looks_like_chapter10(spooled.path):
        return spooled
    spooled.done_opening()   # read once, gone: a raw capture streams on '-' instead
    raise CaptureFormatError(f"{path}: not a Chapter 10 stream (no packet header at its "
                             "start); a raw capture streams on '-'")


def _spool(stream: Any, name: str) -> Chapter10Input:
    """Copy a stream to a temporary file (the reader seeks; a pipe cannot)."""
    import shutil
    import tempfile

    from drivers.errors import CaptureFormatError

    with tempfile.NamedTemporaryFile("wb", prefix="mapr-c10-", suffix=".c10",
                                     delete=False) as copy:
        try:
            shutil.copyfileobj(stream, copy, 1 << 20)
        except OSError as error:
            copy.close()
            os.unlink(copy.name)
            raise CaptureFormatError(f"{name}: cannot read: {error.strerror or error}"
                                     ) from error
    return Chapter10Input(copy.name, name, spooled=True)


def open_chapter10(path: str, channels: Sequence[int] | None, year: int | None, *,
                   arinc429: bool = False) -> Chapter10Reader | None:
    """A reader of ``path`` when it is a Chapter 10 recording (a file, ``-`` or a pipe),
    else None (a capture). The reader's ``name`` is what messages call the input."""
    from drivers.chapter10.reader import Chapter10Reader

    found = chapter10_input(path)
    if found is None:
        return None
    try:
        return Chapter10Reader(found.path, channels=channels, year=year, arinc429=arinc429,
                               name=found.name)
    finally:
        found.done_opening()


def what_it_holds(reader: Chapter10Reader, wanted: Sequence[int] | None, prog: str, *,
                  err: TextIO | None = None, other_data: bool = False) -> int:
    """Exit code 65 and one line when a recording held no 1553 data, or none on an asked
    ``--c10-channel``, naming what it does hold (packet types and channels), so an empty
    output is never mistaken for a quiet bus; 0 otherwise. ``other_data``: the command also
    read ARINC 429 words, so a channel of those counts as there."""
    err = err or sys.stderr
    have = set(reader.channels_seen)
    if other_data:
        have |= reader.arinc429_channels_seen
    absent = sorted(set(wanted or ()) - have)
    if absent:
        err.write(f"{prog}: {reader.name}: channel {', '.join(map(str, absent))} not in the "
                  f"recording (it holds: {holdings(reader)})\n")
        return exitcodes.DATAERR
    if not reader.channels_seen and not (other_data and reader.arinc429_channels_seen):
        err.write(f"{prog}: {reader.name}: no MIL-STD-1553 data in the recording (it holds: "
                  f"{holdings(reader)})\n")
        return exitcodes.DATAERR
    return exitcodes.OK


def capture_batches(path: str, *, samplerate: float | None = None,
                    channels: Sequence[str] | None = None) -> Iterator[list[MonitorRecord]]:
    """The 1553 records of a bit-level capture file (or ``-``), a batch at a time (a
    Chapter 10 recording is read by :func:`open_chapter10` instead)."""
    from drivers.capturefile import open_capture
    from drivers.pipeline import SamplePipeline

    source = open_capture(path, samplerate, list(channels) if channels else None)
    pipeline = SamplePipeline(source.sample_rate)
    for chunk in source.chunks:
        yield pipeline.feed(chunk)
    yield pipeline.flush()


def channel_arrays(reader: Chapter10Reader, wanted: DecodeFilter | None = None
                   ) -> Iterator[tuple[int, RecordArrays]]:
    """A Chapter 10 recording's 1553 messages as statistics columns, one channel at a time:
    (channel ID, columns) per channel of each batch, of the messages ``wanted`` keeps (all
    by default). Each 1553 channel of a recording is a bus of its own, so its messages are
    counted apart (merging them would add the loads of eight buses into one and multiply
    every rate by the number of channels carrying it). Stays in numpy: no record objects.
    Damaged packets are warned about as they come, naming the input (a file or ``stdin``)."""
    import numpy as np

    from drivers.rtstats import batch_arrays

    reported = 0
    try:
        for batch in reader.batches():
            messages = batch.ms1553
            if messages is not None and wanted is not None and wanted.active:
                messages = messages.take(wanted.mask(messages))
            if messages is not None and len(messages):
                ids = np.unique(messages.channel)
                for channel in ids.tolist():
                    part = messages if ids.size == 1 else messages.take(
                        messages.channel == channel)
                    yield int(channel), batch_arrays(part)
            reported = _warn_issues(reader, reported)
    finally:
        reader.close()
    _warn_issues(reader, reported)


def _warn_issues(reader: Chapter10Reader, reported: int) -> int:
    """Warn about the reader's issues from ``reported`` on; how many there are now."""
    from mapr_daemon.cli import notes

    for issue in reader.issues[reported:]:
        notes.warn(f"{reader.name}: {issue}")
    return len(reader.issues)


def channel_statistics(reader: Chapter10Reader, *, window_ns: int,
                       wanted: DecodeFilter | None = None) -> dict[int, TrafficStatistics]:
    """Per-RT/SA statistics of a recording, one :class:`TrafficStatistics` per 1553 channel
    (a bus each), of the messages ``wanted`` keeps, whose rows are the sides it selects."""
    from drivers.rtstats import TrafficStatistics

    per_channel: dict[int, TrafficStatistics] = {}
    for channel, arrays in channel_arrays(reader, wanted):
        stats = per_channel.get(channel)
        if stats is None:
            stats = per_channel[channel] = TrafficStatistics(window_ns=window_ns)
            if wanted is not None and wanted.active:
                stats.sides = (wanted.rts, wanted.sas, wanted.transmit)
        stats.add_arrays(arrays)
    return per_channel


def backend_batches(backend: str, options: dict[str, Any], *, count: int | None,
                    duration: float | None) -> Iterator[list[MonitorRecord]]:
    """Records from a live backend until ``count`` messages, ``duration`` s or its end."""
    from drivers.monitor import open_monitor

    batch: list[MonitorRecord] = []
    with open_monitor(backend, **options) as monitor:
        for record in bounded(monitor, count=count, duration=duration):
            batch.append(record)
            if len(batch) >= BATCH:
                yield batch
                batch = []
    if batch:
        yield batch


def bounded(monitor: BusMonitor, *, count: int | None, duration: float | None
            ) -> Iterator[MonitorRecord]:
    """An open monitor's records until ``count`` messages, ``duration`` s or its end (shared
    by ``monitor`` and the live ``--stats``/``discover`` sources)."""
    start = time.monotonic()
    taken = 0
    while count is None or taken < count:
        left = None if duration is None else duration - (time.monotonic() - start)
        if left is not None and left <= 0:
            break
        record = monitor.recv(timeout=0.5 if left is None else min(left, 0.5))
        if record is None:
            if monitor.ended:
                break
            continue
        taken += 1
        yield record


class ShownStatistics:
    """Statistics of the messages a command shows (those its filters keep), per Chapter 10
    channel when records name one (each channel is a bus): the per-bus totals
    (:class:`~drivers.monitor.BusStatistics`) and the per-RT/SA table with windowed load,
    whose rows are the sides the filter selects. ``mapr monitor --stats`` prints them."""

    def __init__(self, *, window_ns: int, wanted: DecodeFilter | None = None) -> None:
        self.window_ns = window_ns
        self.sides = (None if wanted is None or not wanted.active
                      else (wanted.rts, wanted.sas, wanted.transmit))
        self.buses: dict[int | None, BusStatistics] = {}
        self.traffic: dict[int | None, TrafficStatistics] = {}
        self._pending: dict[int | None, list[MonitorRecord]] = {}

    def add(self, record: MonitorRecord) -> None:
        """Count one shown record (its per-RT/SA share a batch at a time)."""
        channel = record.extra.get("channel")
        bus = self.buses.get(channel)
        if bus is None:
            from drivers.monitor import BusStatistics
            from drivers.rtstats import TrafficStatistics

            bus = self.buses[channel] = BusStatistics()
            traffic = self.traffic[channel] = TrafficStatistics(window_ns=self.window_ns)
            traffic.sides = self.sides
            self._pending[channel] = []
        bus.add(record)
        pending = self._pending[channel]
        pending.append(record)
        if len(pending) >= BATCH:
            self._flush(channel)

    def _flush(self, channel: int | None) -> None:
        self.traffic[channel].add_batch(self._pending[channel])
        self._pending[channel] = []

    def bus_tables(self) -> str:
        """The per-bus totals, a ``channel N (1553)`` heading before each channel's."""
        if not self.buses:
            from drivers.monitor import BusStatistics

            return BusStatistics().table()
        return "\n".join(_heading(channel) + self.buses[channel].table()
                         for channel in _ordered(self.buses))

    def print(self, *, as_json: bool, out: TextIO, err: TextIO) -> None:
        """Everything: per-bus totals (on ``err`` with ``as_json``), then the per-RT/SA
        tables and loads (JSON lines with a ``"channel"`` key for a recording's)."""
        for channel in list(self._pending):
            self._flush(channel)
        channels = _ordered(self.traffic)
        if not channels or channels == [None]:
            from drivers.rtstats import TrafficStatistics

            traffic = self.traffic.get(None) or TrafficStatistics(window_ns=self.window_ns)
            print(self.bus_tables(), file=err if as_json else out)
            if not as_json:
                out.write("\n")
            print_stats(traffic, as_json=as_json, out=out)
            return
        if as_json:
            print(self.bus_tables(), file=err)
            for channel in channels:
                for line in self.traffic[channel].json_lines():
                    out.write(json.dumps({"channel": channel, **line}) + "\n")
            return
        for k, channel in enumerate(channels):
            if k:
                out.write("\n")
            out.write(f"{_heading(channel)}{self.buses[channel].table()}\n\n"
                      f"{self.traffic[channel].table()}\n")


def _heading(channel: int | None) -> str:
    return "" if channel is None else f"channel {channel} (1553)\n"


def _ordered(keys: dict[int | None, Any]) -> list[int | None]:
    """Channels in order, records without one (a capture, a card) first."""
    return sorted(keys, key=lambda c: -1 if c is None else c)


def print_stats(stats: TrafficStatistics, *, as_json: bool, out: TextIO) -> None:
    """The per-RT/SA table and windowed load, or the same as JSON lines."""
    if as_json:
        for line in stats.json_lines():
            out.write(json.dumps(line) + "\n")
    else:
        out.write(stats.table() + "\n")


def print_channel_stats(per_channel: dict[int, TrafficStatistics], *, as_json: bool,
                        out: TextIO) -> None:
    """Statistics of a Chapter 10 recording, one 1553 channel (one bus) after the other: a
    ``channel N`` heading before each table, or a ``"channel"`` key on each JSON line."""
    for channel in sorted(per_channel):
        stats = per_channel[channel]
        if as_json:
            for line in stats.json_lines():
                out.write(json.dumps({"channel": channel, **line}) + "\n")
        else:
            if channel != min(per_channel):
                out.write("\n")
            out.write(f"channel {channel} (1553)\n{stats.table()}\n")


def run_decode_stats(args: Any) -> int:
    """``mapr decode FILE --stats [text|json]``: statistics instead of the messages, of the
    messages the filter flags keep (rows: the sides they select; load: of those messages);
    per 1553 channel for a Chapter 10 recording (each channel is a bus)."""
    from drivers.rtstats import TrafficStatistics
    from mapr_daemon.cli import exitcodes
    from mapr_daemon.cli.traffic.decode_filter import filter_from_args

    wanted = filter_from_args(args)   # checked by the subcommand's validate hook already
    window_ns = round(args.stats_window * 1e9)
    reader = open_chapter10(args.capture, args.c10_channels, args.year)
    if reader is not None:
        per_channel = channel_statistics(reader, window_ns=window_ns, wanted=wanted)
        print_channel_stats(per_channel, as_json=args.stats == "json", out=sys.stdout)
        sys.stdout.flush()
        return what_it_holds(reader, args.c10_channels, "mapr decode")
    stats = TrafficStatistics(window_ns=window_ns)
    if wanted.active:
        stats.sides = (wanted.rts, wanted.sas, wanted.transmit)
    for records in capture_batches(args.capture, samplerate=args.samplerate,
                                   channels=args.channels):
        stats.add_batch([r for r in records if wanted.matches(r)] if wanted.active
                        else records)
    print_stats(stats, as_json=args.stats == "json", out=sys.stdout)
    sys.stdout.flush()
    return int(exitcodes.OK)
