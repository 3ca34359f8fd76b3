"""What the daemon's log says about health: one line when something changed, not per BIT.

A persistent fault gives an event at every BIT; a maintainer reading ``journalctl -p warning``
wants to know when an actuator's health *changed*. :class:`HealthLog` keeps, per actuator,
the state its last BIT left and returns a line only when that state moves:

* a **fault episode** opened or closed (the catalog's episodes, :mod:`mapr_daemon.catalog.
  episodes`, compared before and after each write: the catalog's rule, not a copy of it);
* **SoH** crossing one of :data:`SOH_BANDS` (down: a warning; back up, after a repair or as
  the trend settles: info);
* **RUL** falling below ``health.rul_warn_flights`` (the low end of its 90 % interval, so
  the warning comes while there is time; a warning once, info when it rises above again).

The first BIT of each actuator in a session states its health once (info): the state the
lines that follow change. Every figure is written by :mod:`mapr_daemon.views.figures`, as
``mapr health`` writes it.

:class:`Pace` watches the input: a source that delivers bus time slower than real time (a
simulator on a loaded machine, a replay throttled by its disk) or a reader queue that keeps
growing means the daemon is, or will be, behind; it says so once, and once when it is over.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
from collections.abc import Iterable, Mapping, Sequence

from mapr_daemon.catalog import BitOutcome, display_name
from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.findings import Health
from mapr_daemon.views.figures import health_summary, rul_text, soh_text

SOH_BANDS: tuple[float, ...] = (0.75, 0.5, 0.25)
"""SoH band edges, highest first: crossing one is a change of state worth a line."""

Line = tuple[int, str]
"""A log line: its :mod:`logging` level and its text."""


def band(soh: float | None) -> int | None:
    """How many :data:`SOH_BANDS` edges ``soh`` is below (0: above the first); None without
    a SoH."""
    return None if soh is None else sum(soh < edge for edge in SOH_BANDS)


def _band_text(index: int) -> str:
    edges = (1.0, *SOH_BANDS, 0.0)
    return f"{edges[index + 1]:.2f}-{edges[index]:.2f}"


@dataclasses.dataclass
class _State:
    band: int | None
    mode: str | None
    rul_low: bool


class HealthLog:
    """Per actuator of one aircraft, the health state its last BIT left; see the module doc.

    ``rul_warn_flights``: the RUL (low end of its interval, in flights) below which an
    actuator is reported once; None: never."""

    def __init__(self, tail: str, rul_warn_flights: float | None) -> None:
        self.tail = tail
        self.rul_warn_flights = rul_warn_flights
        self.state: dict[str, _State] = {}
        self.episodes: dict[int, Episode] | None = None
        """The open episodes after the last write (None: not read yet)."""

    def _name(self, asset: str) -> str:
        return display_name(self.tail, asset)

    def _rul_low(self, h: Health) -> bool:
        low = h.rul_low if h.rul_low is not None else h.rul
        return self.rul_warn_flights is not None and low is not None and \
            low < self.rul_warn_flights

    def observe(self, outcomes: Iterable[BitOutcome]) -> list[Line]:
        """The lines the BITs' health changes call for, in order."""
        lines: list[Line] = []
        for o in outcomes:
            h = o.health
            if h is None or h.soh is None:
                continue
            name = self._name(o.asset)
            now = _State(band(h.soh), h.mode, self._rul_low(h))
            before = self.state.get(o.asset)
            self.state[o.asset] = now
            if before is None:
                lines.append((logging.INFO, f"{name} health: {health_summary(h)}"))
                if now.rul_low:
                    lines.append((logging.WARNING, self._rul_line(name, h)))
                continue
            if now.band != before.band and now.band is not None and before.band is not None:
                down = now.band > before.band
                lines.append((logging.WARNING if down else logging.INFO,
                              f"{name} SoH {'fell' if down else 'rose'} to {soh_text(h.soh)} "
                              f"(band {_band_text(now.band)}, was {_band_text(before.band)}): "
                              f"{health_summary(h)}"))
            if now.rul_low and not before.rul_low:
                lines.append((logging.WARNING, self._rul_line(name, h)))
            elif before.rul_low and not now.rul_low:
                lines.append((logging.INFO, f"{name} RUL back above {self.rul_warn_flights:g} "
                                            f"flights: {health_summary(h)}"))
        return lines

    def _rul_line(self, name: str, h: Health) -> str:
        return (f"{name} RUL {rul_text(h.rul, h.rul_low, h.rul_high)} ({h.mode}): below "
                f"health.rul_warn_flights {self.rul_warn_flights:g}; plan the replacement")

    def episodes_now(self, open_episodes: Mapping[tuple[str, str], Episode]) -> list[Line]:
        """Lines for the episodes opened or closed since the last call (the first call only
        takes note: episodes open at start were reported when they opened)."""
        now = {ep.id: ep for ep in open_episodes.values()}
        before, self.episodes = self.episodes, now
        if before is None:
            return []
        lines: list[Line] = []
        for eid in sorted(now.keys() - before.keys()):
            ep = now[eid]
            lines.append((logging.WARNING,
                          f"episode {eid} opened: {self._name(ep.asset)} {ep.part} "
                          f"({'+'.join(ep.modes)}); `mapr catalog episodes` follows it"))
        for eid in sorted(before.keys() - now.keys()):
            ep = before[eid]
            lines.append((logging.INFO,
                          f"episode {eid} closed: {self._name(ep.asset)} {ep.part} "
                          f"({'+'.join(ep.modes)}), no longer detected"))
        return lines


SLOW_RATIO = 0.9
"""Bus time delivered per second of real time below which the input is slower than real
time."""
GROWING_CHECKS = 3
"""Consecutive checks the reader's queue must grow (and stay above a tenth of its bound)
before it is reported."""


class Pace:
    """Whether the input keeps up with real time and the reader's queue stays put.

    :meth:`check` is called with the wall clock, the last record's bus time, the messages so
    far and the queue's depth (the daemon calls it at every STATUS); it returns the lines
    to log. Pure arithmetic on what it is given: a test feeds it numbers."""

    def __init__(self, queue_bound: int) -> None:
        self.queue_bound = queue_bound
        self.last: tuple[float, int | None, int] | None = None
        self.slow = False
        self.depths: list[int] = []
        self.growing = False

    def check(self, wall_s: float, bus_ns: int | None, messages: int,
              queue_depth: int) -> list[Line]:
        lines: list[Line] = []
        last, self.last = self.last, (wall_s, bus_ns, messages)
        if last is not None and bus_ns is not None and last[1] is not None:
            wall = wall_s - last[0]
            got = messages - last[2]
            if wall > 0 and got > 0:   # no traffic is no pace: an idle bus is not slow
                ratio = (bus_ns - last[1]) / 1e9 / wall
                if ratio < SLOW_RATIO and not self.slow:
                    self.slow = True
                    lines.append((logging.WARNING,
                                  f"the input runs slower than real time: {ratio:.2f} s of bus "
                                  f"time per second ({got} messages in {wall:.1f} s); BITs "
                                  "and flights come later than flown"))
                elif ratio >= SLOW_RATIO and self.slow:
                    self.slow = False
                    lines.append((logging.INFO, f"the input keeps up with real time again "
                                                f"({ratio:.2f} s of bus time per second)"))
        self.depths = [*self.depths[-GROWING_CHECKS:], queue_depth]
        grows = (len(self.depths) > GROWING_CHECKS and _rising(self.depths)
                 and queue_depth * 10 >= self.queue_bound)
        if grows and not self.growing:
            self.growing = True
            lines.append((logging.WARNING,
                          f"the reader's queue grows: {queue_depth}/{self.queue_bound} batches "
                          f"after {GROWING_CHECKS} checks in a row; the reasoner is falling "
                          "behind the bus (a full queue drops messages)"))
        elif self.growing and queue_depth * 10 < self.queue_bound:
            self.growing = False
            lines.append((logging.INFO, f"the reader's queue drained ({queue_depth}/"
                                        f"{self.queue_bound} batches)"))
        return lines


def _rising(depths: Sequence[int]) -> bool:
    return all(b > a for a, b in itertools.pairwise(depths))


__all__ = ["SOH_BANDS", "HealthLog", "Line", "Pace", "band"]
