"""Batches of records from a file or a live backend, and the statistics printed from them.

Shared by ``mapr decode --stats``, ``mapr monitor --stats`` and ``mapr icd discover``: a
Chapter 10 recording (found by its sync pattern) is read with the Chapter 10 reader, any other
file as a bit-level capture; a live backend is read through the monitor API, bounded by a
message count and/or a duration.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:   # imported where used: registering the subcommands stays light
    from drivers.mil1553.record import MonitorRecord
    from drivers.monitor import BusMonitor
    from drivers.rtstats import TrafficStatistics

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


def file_batches(path: str, *, samplerate: float | None = None,
                 channels: Sequence[str] | None = None,
                 c10_channels: Sequence[int] | None = None, year: int | None = None,
                 err: TextIO | None = None, err_prefix: str = "mapr"
                 ) -> Iterator[list[MonitorRecord]]:
    """The 1553 records of a Chapter 10 recording or a capture file, a batch at a time.

    Damaged Chapter 10 packets are named on ``err`` (stderr) and skipped, as ``decode`` does.
    """
    from drivers.chapter10.walker import looks_like_chapter10
    from mapr_daemon.cli import notes

    err = err or sys.stderr
    if path != "-" and looks_like_chapter10(path):
        from drivers.chapter10.reader import Chapter10Reader

        reader = Chapter10Reader(path, channels=c10_channels, year=year, arinc429=False)
        try:
            for batch in reader:
                yield list(batch.records)
        finally:
            reader.close()
        for issue in reader.issues:
            if err is sys.stderr:   # the command's warnings: collapsed, silenced by -q
                notes.warn(f"{path}: {issue}")
            else:
                err.write(f"{err_prefix}: {path}: {issue}\n")
        return
    from drivers.capturefile import open_capture
    from drivers.pipeline import SamplePipeline

    source = open_capture(path, samplerate, list(channels) if channels else None)
    pipeline = SamplePipeline(source.sample_rate)
    for chunk in source.chunks:
        yield pipeline.feed(chunk)
    yield pipeline.flush()


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


def print_stats(stats: TrafficStatistics, *, as_json: bool, out: TextIO) -> None:
    """The per-RT/SA table and windowed load, or the same as JSON lines."""
    if as_json:
        for line in stats.json_lines():
            out.write(json.dumps(line) + "\n")
    else:
        out.write(stats.table() + "\n")


def run_decode_stats(args: Any) -> int:
    """``mapr decode FILE --stats [text|json]``: statistics instead of the messages, of the
    messages the filter flags keep (rows: the sides they select; load: of those messages)."""
    from drivers.rtstats import TrafficStatistics
    from mapr_daemon.cli import exitcodes
    from mapr_daemon.cli.traffic.decode_filter import filter_from_args

    wanted = filter_from_args(args)   # checked by the subcommand's validate hook already
    stats = TrafficStatistics(window_ns=round(args.stats_window * 1e9))
    if wanted.active:
        stats.sides = (wanted.rts, wanted.sas, wanted.transmit)
    for batch in file_batches(args.capture, samplerate=args.samplerate, channels=args.channels,
                              c10_channels=args.c10_channels, year=args.year,
                              err_prefix="mapr decode"):
        stats.add_batch([r for r in batch if wanted.matches(r)] if wanted.active else batch)
    print_stats(stats, as_json=args.stats == "json", out=sys.stdout)
    sys.stdout.flush()
    return exitcodes.OK
