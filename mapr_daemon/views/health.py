"""Each actuator's health at a glance: ``mapr health``'s lines and JSON, the trend's BITs.

The rows are the catalog's (:class:`~mapr_daemon.catalog.actuators.ActuatorHealth`, one per
actuator, read by :meth:`~mapr_daemon.catalog.CatalogReader.health`; a BIT history by
:meth:`~mapr_daemon.catalog.CatalogReader.bits`). This module turns them into text and JSON:
SoH, leading mode, RUL with its 90 % interval in flights and flight hours (or the note saying
why there is none), the open fault episodes and the UTC times.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from mapr_daemon.catalog.actuators import ActuatorHealth
from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.catalog.model import BitRecord
from mapr_daemon.findings import Health
from mapr_daemon.utc import fmt_time
from mapr_daemon.views.figures import health_rul, soh_text
from mapr_daemon.views.text import text_table


def health_json(a: ActuatorHealth) -> dict[str, Any]:
    """One actuator's standing, JSON-ready (``mapr health --json``)."""
    h = a.health
    return {
        "tail": a.tail, "asset": a.asset, "soh": h.soh, "mode": h.mode,
        "rul_flights": {"median": h.rul, "low": h.rul_low, "high": h.rul_high},
        "rul_hours": {"median": h.rul_hours, "low": h.rul_hours_low,
                      "high": h.rul_hours_high},
        "interval": h.interval, "note": h.note, "modes": dict(h.modes),
        "open_episodes": [{"id": ep.id, "part": ep.part, "mode": ep.mode,
                           "opened_utc": fmt_time(ep.opened_ns)}
                          for ep in a.open_episodes],
        "last_bit_utc": fmt_time(a.last.t_ns), "last_bit_ns": a.last.t_ns,
        "last_flight": a.last.flight, "last_fault": a.last.fault,
        "flight_hours": a.last.flight_hours, "bits": a.bits,
        "in_service_since_utc": fmt_time(a.first_ns), "first_flight": a.first_flight,
    }


def fmt_rul(h: Health, hours: bool = False) -> str:
    """``42 (30-61) flights``; ``hours``: the same in flight hours. The note when no figure
    (:func:`.figures.health_rul`, as every view writes it)."""
    return health_rul(h, hours)


def fmt_soh(h: Health) -> str:
    """``0.79`` (:func:`.figures.soh_text`)."""
    return soh_text(h.soh)


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
