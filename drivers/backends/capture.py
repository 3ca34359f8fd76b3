"""The ``capture`` backend: replays a bit-level capture file (raw or sigrok ``.sr``).

    open_monitor("capture", path="flight.sr")
    open_monitor("capture", path="bus.bin", sample_rate=10e6, realtime=True)

Records come out as the file is read, chunk by chunk, through the same decoder and assembler
as live hardware. ``realtime=True`` paces the replay to the capture's own clock.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from drivers.capturefile import open_capture
from drivers.chapter10.walker import looks_like_chapter10
from drivers.errors import CaptureFormatError
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.monitor import BusMonitor, MonitorFilter
from drivers.pipeline import SamplePipeline

CHAPTER10_SUFFIXES = (".c10", ".ch10")
"""File name endings of IRIG 106 Chapter 10 recordings."""


def check_capture_file(path: str, sample_rate: float | None, *, rate_hint: str) -> None:
    """Refuse, with the reason, a file the capture reader would misread: a Chapter 10
    recording (another backend reads it), a file named like one that is not one, or a raw
    capture without its sample rate (``rate_hint``: how the caller's user gives it).
    A file that cannot be opened is left to :func:`~drivers.capturefile.open_capture`."""
    if path == "-":
        if sample_rate is None:
            raise CaptureFormatError(f"{path}: a raw capture needs its sample rate: {rate_hint}")
        return
    try:
        with open(path, "rb") as probe:
            sigrok = probe.read(4) == b"PK\x03\x04"
    except OSError:
        return
    if looks_like_chapter10(path):
        raise CaptureFormatError(f"{path}: a Chapter 10 recording, not a bit-level capture: "
                                 "use the chapter10 backend")
    if path.lower().endswith(CHAPTER10_SUFFIXES):
        raise CaptureFormatError(f"{path}: not a Chapter 10 file (no valid packet header in "
                                 "its first bytes)")
    if not sigrok and sample_rate is None:
        raise CaptureFormatError(f"{path}: a raw capture needs its sample rate: {rate_hint}")


class CaptureMonitor(BusMonitor):
    """Replay a capture file as if it were the bus."""

    def __init__(self, *, path: str, sample_rate: float | None = None,
                 channels: Sequence[str] | None = None, realtime: bool = False,
                 timing: BusTiming | None = None,
                 filters: Sequence[MonitorFilter] | None = None, **config: Any) -> None:
        super().__init__(filters=filters, **config)
        check_capture_file(path, sample_rate, rate_hint="-O sample_rate=HZ (e.g. 10e6)")
        self.source = open_capture(path, sample_rate, channels)
        self.pipeline = SamplePipeline(self.source.sample_rate, timing=timing)
        self.realtime = realtime
        self._samples = 0
        self._started = time.monotonic()
        self._flushed = False

    def _recv_internal(self, timeout: float | None) -> list[MonitorRecord] | None:
        if self._flushed:
            return None
        chunk = next(self.source.chunks, None)
        if chunk is None:
            self._flushed = True
            return self.pipeline.flush()
        self._samples += chunk.size
        if self.realtime:
            due = self._started + self._samples / self.source.sample_rate
            time.sleep(max(0.0, due - time.monotonic()))
        return self.pipeline.feed(chunk)
