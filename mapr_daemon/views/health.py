"""Each actuator's health at a glance: ``mapr health``'s lines and the report's summary.

One :class:`ActuatorHealth` per actuator (tail and asset) with a BIT history: the health the
trend gave after its newest BIT (SoH, leading mode, RUL with its 90 % interval in flights
and flight hours, or the note saying why there is none), its open fault episodes and when it
entered service (its first BIT). One SQL pass over ``bits`` (a window per actuator) finds the
newest row, the count and the first BIT, so the view stays quick on a long history.
"""

from __future__ import annotations

import dataclasses
import sqlite3
from collections.abc import Sequence
from typing import Any

from mapr_daemon.catalog import episode_store, history
from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.catalog.model import BitRecord, Health
from mapr_daemon.views.text import fmt_time, text_table

_LATEST = (
    f"SELECT {history.BIT_SELECT}, n, first_ns, first_flight FROM ("
    f"SELECT {history.BIT_SELECT}, row_number() OVER w_desc AS rn, count(*) OVER w AS n, "
    "min(t_ns) OVER w AS first_ns, min(flight) OVER w AS first_flight FROM bits "
    "WINDOW w AS (PARTITION BY tail, asset), w_desc AS (PARTITION BY tail, asset ORDER BY "
    "coalesce(flight, 0) DESC, t_ns DESC, id DESC)) WHERE rn = 1 ORDER BY tail, asset")


def display_name(tail: str, asset: str) -> str:
    """How an actuator is named to a maintainer: ``TAIL/ASSET``."""
    return f"{tail}/{asset}" if tail and not asset.startswith(f"{tail}/") else asset


def episode_names(tail: str, asset: str) -> tuple[str, ...]:
    """The asset names an actuator's fault episodes may be kept under: its own (the daemon's)
    and ``TAIL/ASSET`` (a fleet run's, the episodes having no tail column)."""
    name = display_name(tail, asset)
    return (asset,) if name == asset else (asset, name)


def episodes_of(conn: sqlite3.Connection, tail: str, asset: str, *, open_only: bool = False
                ) -> list[Episode]:
    """The actuator's episodes (:func:`episode_names`), most recently active first."""
    found = [ep for name in episode_names(tail, asset)
             for ep in episode_store.select(conn, open_only=open_only, asset=name)]
    return sorted(found, key=lambda ep: (ep.last_ns, ep.id), reverse=True)


@dataclasses.dataclass(frozen=True)
class ActuatorHealth:
    """One actuator's standing: its newest BIT with the health after it, and its episodes."""

    tail: str
    asset: str
    last: BitRecord
    """The newest BIT (by flight, then time): its ``health`` is the actuator's health now."""
    bits: int
    """BITs in its history."""
    first_ns: int
    """In service since: the time of its first BIT (epoch ns, UTC)."""
    first_flight: int | None
    open_episodes: tuple[Episode, ...] = ()

    @property
    def name(self) -> str:
        """``tail/asset`` (just the asset when no tail is known, or when the asset already
        carries its tail, as a fleet run's ``N101/EMA1`` does)."""
        return display_name(self.tail, self.asset)

    @property
    def health(self) -> Health:
        return self.last.health

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (``mapr health --json``)."""
        h = self.health
        return {
            "tail": self.tail, "asset": self.asset, "soh": h.soh, "mode": h.mode,
            "rul_flights": {"median": h.rul, "low": h.rul_low, "high": h.rul_high},
            "rul_hours": {"median": h.rul_hours, "low": h.rul_hours_low,
                          "high": h.rul_hours_high},
            "interval": h.interval, "note": h.note, "modes": dict(h.modes),
            "open_episodes": [{"id": ep.id, "part": ep.part, "mode": ep.mode,
                               "opened_utc": fmt_time(ep.opened_ns)}
                              for ep in self.open_episodes],
            "last_bit_utc": fmt_time(self.last.t_ns), "last_bit_ns": self.last.t_ns,
            "last_flight": self.last.flight, "last_fault": self.last.fault,
            "flight_hours": self.last.flight_hours, "bits": self.bits,
            "in_service_since_utc": fmt_time(self.first_ns), "first_flight": self.first_flight,
        }


def load(conn: sqlite3.Connection, with_episodes: bool) -> list[ActuatorHealth]:
    """Every actuator with a BIT history, sorted by tail and asset; ``with_episodes``:
    the catalog has the ``episodes`` table (schema v4 on)."""
    out = []
    for row in conn.execute(_LATEST):
        record = history.bit_record(row[:-3])
        n, first_ns, first_flight = row[-3:]
        episodes = tuple(episodes_of(conn, record.tail, record.asset, open_only=True)
                         ) if with_episodes else ()
        out.append(ActuatorHealth(record.tail, record.asset, record, int(n), int(first_ns),
                                  first_flight, episodes))
    return out


def _g(value: float | None) -> str:
    return "-" if value is None else f"{value:.0f}" if abs(value) >= 10 else f"{value:.1f}"


def fmt_rul(h: Health, hours: bool = False) -> str:
    """``42 (30-61) flights``; ``hours``: the same in flight hours. The note when no figure."""
    mid, low, high = ((h.rul_hours, h.rul_hours_low, h.rul_hours_high) if hours
                      else (h.rul, h.rul_low, h.rul_high))
    if mid is None:
        return "" if hours else (h.note or "unknown")
    unit = "h" if hours else "flights"
    band = f" ({_g(low)}-{_g(high)})" if low is not None and high is not None else ""
    return f"{_g(mid)}{band} {unit}"


def fmt_soh(h: Health) -> str:
    return "-" if h.soh is None else f"{h.soh:.2f}"


def fmt_episodes(episodes: Sequence[Episode]) -> str:
    """``1 open (dc-link capacitor)``, or ``none``."""
    if not episodes:
        return "none"
    parts = ", ".join(dict.fromkeys(ep.part for ep in episodes))
    return f"{len(episodes)} open ({parts})"


def health_table(rows: Sequence[ActuatorHealth]) -> str:
    """One line per actuator (``mapr health``)."""
    body = [(a.name, fmt_soh(a.health), a.health.mode or "-",
             fmt_rul(a.health) if a.health.rul is not None else "-",
             fmt_rul(a.health, hours=True) or "-", fmt_episodes(a.open_episodes),
             fmt_time(a.last.t_ns), "-" if a.last.flight is None else str(a.last.flight),
             fmt_time(a.first_ns), a.health.note or "") for a in rows]
    return text_table(("ACTUATOR", "SOH", "MODE", "RUL (90% INTERVAL)", "RUL HOURS", "EPISODES",
                   "LAST BIT (UTC)", "FLIGHT", "IN SERVICE SINCE (UTC)", "NOTE"), body,
                  right={1, 7})


def bit_json(r: BitRecord) -> dict[str, Any]:
    """One BIT of the history with the health after it (``catalog trend --json``)."""
    out = r.as_dict()
    out["health"] = {**dataclasses.asdict(r.health), "modes": dict(r.health.modes)}
    return out


def bits_table(records: Sequence[BitRecord]) -> str:
    """One line per BIT of one actuator: flight, hours, time, diagnosis, SoH, mode, RUL."""
    body = [("-" if r.flight is None else str(r.flight),
             "-" if r.flight_hours is None else f"{r.flight_hours:.1f}", fmt_time(r.t_ns),
             r.fault or "nominal", fmt_soh(r.health), r.health.mode or "-",
             fmt_rul(r.health) if r.health.rul is not None else "-", r.health.note or "")
            for r in records]
    return text_table(("FLIGHT", "HOURS", "TIME (UTC)", "BIT", "SOH", "MODE", "RUL (90% INTERVAL)",
                   "NOTE"), body, right={0, 1, 4})
