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
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.monitor import BusMonitor, MonitorFilter
from drivers.pipeline import SamplePipeline


class CaptureMonitor(BusMonitor):
    """Replay a capture file as if it were the bus."""

    def __init__(self, *, path: str, sample_rate: float | None = None,
                 channels: Sequence[str] | None = None, realtime: bool = False,
                 timing: BusTiming | None = None,
                 filters: Sequence[MonitorFilter] | None = None, **config: Any) -> None:
        super().__init__(filters=filters, **config)
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
