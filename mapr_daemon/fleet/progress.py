"""The fleet run's progress on stderr: recordings done, flight hours processed, the rate.

On a terminal, one line rewritten at most ten times a second::

    [########------------]  41%  82/200 recordings  123.0/300.0 flight h  2710 flight h/h  ETA 1m05s

Elsewhere (a log, a pipe), a plain line at each tenth of the run and at the end, so a log is
not flooded and still shows the run moving.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TextIO

from mapr_daemon.fleet.archive import Recording


class FleetProgress:
    """Counts recordings and flight hours as the client stores them."""

    def __init__(self, out: TextIO, total: int, hours_total: float, *, tty: bool,
                 enabled: bool = True, width: int = 20) -> None:
        self.out, self.total, self.hours_total = out, max(total, 0), hours_total
        self.tty, self.enabled, self.width = tty, enabled, width
        self.done = 0
        self.failed = 0
        self.hours = 0.0
        self.started = time.monotonic()
        self._shown = 0.0
        self._tenth = 0
        self._printed = -1

    def start(self, todo: Sequence[Recording]) -> None:
        """The run's recordings to process are known: the totals (flight hours as declared;
        a recording without declared hours adds its recorded time as it is stored)."""
        self.total = len(todo)
        self.hours_total = sum(r.flight_hours or 0.0 for r in todo)
        self.started = time.monotonic()

    def add(self, hours: float, ok: bool) -> None:
        """One recording stored: its flight hours count only when it succeeded."""
        self.done += 1
        self.failed += not ok
        if ok:
            self.hours += hours
        self.show()

    def rate(self) -> float:
        """Flight hours processed per wall-clock hour so far."""
        elapsed = time.monotonic() - self.started
        return self.hours / (elapsed / 3600.0) if elapsed > 0 else 0.0

    def line(self) -> str:
        share = self.done / self.total if self.total else 1.0
        elapsed = time.monotonic() - self.started
        eta = ""
        if 0 < self.done < self.total:
            left = elapsed / self.done * (self.total - self.done)
            eta = f"  ETA {int(left // 60)}m{int(left % 60):02d}s"
        failed = f"  {self.failed} failed" if self.failed else ""
        return (f"{share:4.0%}  {self.done}/{self.total} recordings  {self.hours:.1f}/"
                f"{self.hours_total:.1f} flight h  {self.rate():.0f} flight h/h{failed}{eta}")

    def show(self, *, final: bool = False) -> None:
        if not self.enabled:
            return
        if self.tty:
            now = time.monotonic()
            if not final and now - self._shown < 0.1:
                return
            self._shown = now
            share = self.done / self.total if self.total else 1.0
            filled = round(share * self.width)
            self.out.write(f"\r[{'#' * filled}{'-' * (self.width - filled)}] {self.line()}"
                           "\033[K" + ("\n" if final else ""))
        else:
            tenth = self.done * 10 // self.total if self.total else 10
            if (not final and tenth <= self._tenth) or self._printed == self.done:
                return
            self._tenth, self._printed = tenth, self.done
            self.out.write(f"mapr fleet: {self.line()}\n")
        self.out.flush()
