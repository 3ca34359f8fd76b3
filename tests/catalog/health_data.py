"""A catalog with BIT histories and health, as the daemon would leave it (no reasoner)."""

from __future__ import annotations

from pathlib import Path

from mapr_daemon.catalog import BitOutcome, CatalogWriter, Event
from mapr_daemon.catalog.model import Flight
from mapr_daemon.findings import Health

from .conftest import HOUR, T0

FLIGHTS = 12
TAIL = "N101"


def _wearing(k: int) -> BitOutcome:
    """EMA1 after flight ``k``: ESR wearing, faulted from flight 9 on."""
    t = T0 + k * 3 * HOUR
    h = round(0.06 * k, 4)
    rul = 3 * (FLIGHTS + 4 - k) if k >= 2 else None
    health = Health(round(1.0 - h, 3), "esr" if k >= 1 else None,
                    rul, None if rul is None else rul * 0.7, None if rul is None else rul * 1.4,
                    None if rul is None else rul * 2.5, None if rul is None else rul * 1.75,
                    None if rul is None else rul * 3.5,
                    None if rul is not None else "fewer than three BITs: no trend yet",
                    {"esr": {"h": h, "z": 4.0 + k, "evidenced": True, "rul": rul,
                             "low": None if rul is None else rul * 0.7,
                             "high": None if rul is None else rul * 1.4},
                     "capacitance": {"h": 0.01, "z": 0.3, "evidenced": False}})
    event = None
    if k >= 9:
        event = Event(t_ns=t, asset="EMA1", fault="esr", confidence=0.93, severity=0.4 + k / 100,
                      severity_value=0.09, severity_unit="ohm",
                      evidence={"part": "dc-link capacitor"})
    return BitOutcome("EMA1", t, event, tail=TAIL, flight=k, flight_hours=2.5 * k,
                      wear={"esr": h, "capacitance": 0.01}, health=health)


def _healthy(k: int) -> BitOutcome:
    t = T0 + k * 3 * HOUR + 60_000_000_000
    return BitOutcome("EMA2", t, tail=TAIL, flight=k, flight_hours=2.5 * k,
                      wear={"esr": 0.0, "friction": 0.02},
                      health=Health(1.0, None, note="no part wears measurably: every trended "
                                    "part is within its healthy scatter"))


def write_health_catalog(path: Path) -> Path:
    """Tail N101: EMA1 wearing (ESR, an open episode), EMA2 healthy; bus statistics."""
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="cafe", started_ns=T0)
        for k in range(FLIGHTS):
            writer.add_bits([_wearing(k), _healthy(k)],
                            [Flight(TAIL, k, T0 + k * 3 * HOUR, T0 + k * 3 * HOUR + HOUR,
                                    2.5, "declared")])
        writer.add_stats(T0, T0 + 10**10, {
            "A": {"messages": 812, "words": 9000, "load_percent": 21.5,
                  "errors": {"parity": 2}},
            "B": {"messages": 0, "words": 0, "load_percent": 0.0, "errors": {}}})
    return path
