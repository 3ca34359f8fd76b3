"""The bus-reader thread: monitor records into a bounded queue, retrying a failed backend.

The reader owns the backend. Records go to the main loop in batches through a bounded
:class:`queue.Queue`; when it is full for ``wait_s`` (the reasoner has fallen behind) the batch
is dropped and counted in :attr:`BusReader.dropped` instead of the queue growing without
bound — the main loop reports it. A backend that fails to open or dies while running (card
unplugged, capture file missing, a terminal that raises) is closed and reopened with
exponential backoff; the outage goes to the main loop as ``gap``/``resumed`` items, so the
catalog records it. Nothing here ever ends the process.
"""

from __future__ import annotations

import dataclasses
import logging
import queue
import threading
import time
from collections.abc import Callable

from drivers.mil1553.record import MonitorRecord
from drivers.monitor import BusMonitor

log = logging.getLogger("mapr.reader")
BATCH = 1024
"""Most records per queue item."""
BATCH_WINDOW_S = 0.02
"""How long a batch collects records that come one at a time (a live bus): the work per
batch (decoding, the BIT watcher's buffers) is then paid every 20 ms, not per message."""


@dataclasses.dataclass(frozen=True)
class Item:
    """One thing for the main loop: ``records``, ``gap`` (backend down), ``resumed``,
    ``ended`` (the source has no more records)."""

    kind: str
    records: tuple[MonitorRecord, ...] = ()
    t_ns: int = 0
    reason: str = ""


class BusReader(threading.Thread):
    """Reads ``open_monitor()``'s records until :meth:`stop`; see the module docstring."""

    def __init__(self, open_monitor: Callable[[], BusMonitor], out: queue.Queue[Item], *,
                 retry_initial_s: float, retry_max_s: float, wait_s: float,
                 wake: Callable[[], None] = lambda: None) -> None:
        super().__init__(name="mapr-bus-reader", daemon=True)
        self.open_monitor = open_monitor
        self.out = out
        self.retry_initial_s = retry_initial_s
        self.retry_max_s = retry_max_s
        self.wait_s = wait_s
        self.wake = wake
        """Called after every item queued or dropped (rings the main loop's doorbell)."""
        self.dropped = 0
        """Records dropped because the queue stayed full (read by the main loop)."""
        self.dropped_batches = 0
        self.received = 0
        """Records read from the backend (queued or dropped)."""
        self.high_water = 0
        """The most items the queue ever held (right after a put): how close it came to full."""
        self.failures = 0
        self.delay = retry_initial_s
        """The current backoff (doubles per failure up to ``retry_max_s``)."""
        self.ended = False
        """The source ended normally (a replayed file, a testbed with a duration)."""
        self.heartbeat = time.monotonic()
        """Last time the thread came back from the backend (proves it is not stuck)."""
        self._stop_event = threading.Event()

    def stop(self) -> None:
        self._stop_event.set()

    @property
    def stopping(self) -> bool:
        return self._stop_event.is_set()

    def _queued(self) -> None:
        self.high_water = max(self.high_water, self.out.qsize())
        self.wake()

    def _control(self, item: Item) -> None:
        """Queue a control item; these are never dropped (they are rare and tiny)."""
        while not self.stopping:
            try:
                self.out.put(item, timeout=0.1)
                self._queued()
                return
            except queue.Full:
                continue

    def _records(self, batch: list[MonitorRecord]) -> None:
        self.received += len(batch)
        try:
            self.out.put(Item("records", tuple(batch)), timeout=self.wait_s)
        except queue.Full:
            self.dropped += len(batch)
            self.dropped_batches += 1
            self.wake()
            return
        self._queued()

    def run(self) -> None:
        self.delay = self.retry_initial_s
        down_since: int | None = None
        while not self.stopping:
            monitor: BusMonitor | None = None
            try:
                monitor = self.open_monitor()
                if down_since is not None:
                    self._control(Item("resumed", t_ns=time.time_ns()))
                    down_since = None
                if self._pump(monitor):
                    return
            except Exception as error:  # every backend failure is retried
                self.failures += 1
                reason = f"backend: {type(error).__name__}: {error}"
                if down_since is None:
                    down_since = time.time_ns()
                    self._control(Item("gap", t_ns=down_since, reason=reason))
                log.warning("%s; retrying in %.1f s", reason, self.delay)
                self._pause(self.delay)
                self.delay = min(self.retry_max_s, self.delay * 2.0)
            finally:
                if monitor is not None:
                    try:
                        monitor.close()
                    except Exception as error:  # closing a dead card
                        log.debug("closing the backend: %s", error)

    def _pause(self, seconds: float) -> None:
        """Wait before a retry, keeping the heartbeat fresh: retrying is work being done."""
        until = time.monotonic() + seconds
        while not self.stopping and (left := until - time.monotonic()) > 0:
            self._stop_event.wait(min(1.0, left))
            self.heartbeat = time.monotonic()

    def alive(self, within_s: float = 5.0) -> bool:
        """True while the thread is reading or retrying (heartbeat within ``within_s``), and
        after the source ended normally (idle is not hung)."""
        return self.ended or time.monotonic() - self.heartbeat < within_s

    def _pump(self, monitor: BusMonitor) -> bool:
        """Move records until stopped (True) or the stream ends (True); errors propagate."""
        while not self.stopping:
            batch: list[MonitorRecord] = []
            try:
                record = monitor.recv(timeout=0.1)
                until = time.monotonic() + BATCH_WINDOW_S
                while record is not None:
                    batch.append(record)
                    if len(batch) >= BATCH:
                        break
                    record = monitor.recv(timeout=max(0.0, until - time.monotonic()))
            finally:  # what came before a failure is kept
                self.heartbeat = time.monotonic()
                if batch:
                    self._records(batch)
                    self.delay = self.retry_initial_s
            if monitor.ended:
                self.ended = True
                self._control(Item("ended", t_ns=time.time_ns(),
                                   reason="the backend's stream ended"))
                return True
        return True
