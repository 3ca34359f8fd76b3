"""Card emulators for the hardware backends' tests, at the lowest seam only.

:class:`SerialCard` plays an open1553 card on the master side of a real pty pair (one pty per
bus): it runs the loopback :class:`BusController` and writes each word as the card's line.
The monitor opens the slave path with pyserial, as it would open /dev/ttyUSB0. ``unplug()``
closes the pty (the slave path disappears, reads fail) and ``replug()`` makes a new one behind
the same symlink, as udev's /dev/serial/by-id links behave.

Pacing: the card's link is slower than the bus, so the backend sees an idle bus only as an idle
link (drivers/backends/open1553.py). The emulator therefore waits until the monitor has read
every line written (a condition it polls, with a generous time-out) and then keeps the link
quiet for ``pause_s`` wherever the bus was idle for longer than the no-response time-out.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

from drivers.backends.loopback import BusController, Injector, Traffic
from drivers.backends.loopback.controller import BusWord
from drivers.backends.open1553 import LineWord, format_line

from .backtoback import Setup

IDLE_LINK_NS = 4_000
"""The card's gap flag: at least 4 µs of idle bus before the word."""
PAUSE_AFTER_NS = 14_000
"""Bus idle longer than this (the no-response time-out) becomes a quiet link."""


def line_for(word: BusWord, idle_before_ns: int | None) -> bytes:
    """The open1553 line for a loopback word. Faults the line cannot express (Manchester,
    bit count) are assumed reported as a parity failure (P0): the card's decoder fails the word."""
    fault = word.fault
    bad = fault.parity or fault.no_transition is not None or fault.bit_count != 0
    gap = idle_before_ns is None or idle_before_ns >= IDLE_LINK_NS
    return format_line(LineWord(word.sync ^ int(fault.inverted_sync), gap, not bad, False,
                                word.value))


def traffic_of(setup: Setup) -> Iterator[Traffic]:
    """The setup's frames from the loopback bus controller."""
    controller = BusController(setup.schedule, setup.terminals,
                               injector=Injector(list(setup.injections)))
    for _ in range(setup.frames):
        yield controller.run_frame()


class SerialCard:
    """One open1553 card per bus on pty pairs; ``path(bus)`` is the stable (symlink) path."""

    def __init__(self, buses: int = 2, pause_s: float = 0.03) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="mapr-pty-")
        self.pause_s = pause_s
        self.lines_written = 0
        self._fds: dict[int, tuple[int, int]] = {}
        self._last_stop: dict[int, int] = {}
        self.thread: threading.Thread | None = None
        for bus in range(buses):
            self._make(bus)

    def _make(self, bus: int) -> None:
        master, slave = os.openpty()
        self._fds[bus] = (master, slave)
        link = Path(self._dir.name) / f"card{bus}"
        link.unlink(missing_ok=True)
        link.symlink_to(os.ttyname(slave))

    def path(self, bus: int) -> str:
        return str(Path(self._dir.name) / f"card{bus}")

    def write(self, bus: int, data: bytes) -> None:
        """Raw bytes onto the card's link (lines, or garbage)."""
        master = self._fds[bus][0]
        view = memoryview(data)
        while view:
            view = view[os.write(master, view):]
        self.lines_written += data.count(b"\r") + data.count(b"\n")

    def write_traffic(self, traffic: Traffic) -> list[list[tuple[int, bytes]]]:
        """The frame's lines, in bus time order, cut where the bus was idle long enough
        for a no-response: each chunk is a list of (bus, line)."""
        chunks: list[list[tuple[int, bytes]]] = [[]]
        last_any: int | None = None
        for word in traffic.words:
            if last_any is not None and word.t_ns - last_any > PAUSE_AFTER_NS and chunks[-1]:
                chunks.append([])
            previous = self._last_stop.get(word.bus)
            chunks[-1].append((word.bus, line_for(word, None if previous is None
                                                  else word.t_ns - previous)))
            self._last_stop[word.bus] = word.stop_ns or word.end_ns + 500
            last_any = max(last_any or 0, self._last_stop[word.bus])
        return [c for c in chunks if c]

    def wait(self, condition: Callable[[], bool], timeout_s: float = 20.0) -> bool:
        """Poll ``condition`` until true or the time-out (a condition, not a race)."""
        deadline = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > deadline:
                return False
            time.sleep(0.001)
        return True

    def play(self, setup: Setup, drained: Callable[[], bool], stopped: Callable[[], bool],
             end: bool = True) -> None:
        """Write the setup's traffic, pausing at idle bus; then unplug (the stream ends)."""
        for traffic in traffic_of(setup):
            for chunk in self.write_traffic(traffic):
                for bus, line in chunk:
                    self.write(bus, line)
                if not self.wait(lambda: drained() or stopped()) or stopped():
                    return
                time.sleep(self.pause_s)  # the quiet link the backend reads as idle bus
        if end:
            self.unplug()

    def start(self, setup: Setup, drained: Callable[[], bool], stopped: Callable[[], bool]
              ) -> None:
        self.thread = threading.Thread(target=self.play, args=(setup, drained, stopped),
                                       daemon=True)
        self.thread.start()

    def unplug(self) -> None:
        """Close every pty: the slave paths vanish and the monitor's reads fail."""
        for master, slave in self._fds.values():
            os.close(master)
            os.close(slave)
        self._fds.clear()

    def replug(self, buses: int = 1) -> None:
        for bus in range(buses):
            self._make(bus)
        self._last_stop.clear()

    def close(self) -> None:
        if self._fds:
            self.unplug()
        self._dir.cleanup()
