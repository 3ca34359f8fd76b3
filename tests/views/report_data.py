"""Catalogs for the report's tests, written through the catalog writer (no reasoner, no flight).

Two shapes a maintenance chief meets:

- :func:`write_one_flight_catalog`: the first run of ``mapr demo`` - one tail, one flight,
  34 BITs per actuator: EMA1 with an ESR fault past its replace-at threshold from the first
  BIT (SoH 0, RUL 0 (0-0), the case that gave a -0.04..0.04 RUL axis and matplotlib's
  identical-ylims warning), EMA2 healthy, EMA3 with friction wearing but no trend yet (BITs on
  one flight only).
- :func:`write_fleet_catalog`: four tails, two actuators each, 220 flights with two BITs per
  flight (stored as a fleet run stores them: events and episodes under ``TAIL/ASSET``).
  Known answers, most urgent first (:data:`URGENCY`): N104/EMA2 (a switch shorted on the last
  BIT: RUL 0), N103/EMA1 (ESR aging fast, an open episode, RUL low end about 4), N101/EMA2
  (friction, RUL 60 (50-80)),
  N102/EMA2 (capacitance dropping since flight 205, an open episode, 105 (82-150)), then the
  ones without a RUL: N102/EMA1 (wears too slowly to reach its threshold; a closed episode in
  its past), and the healthy ones, N101/EMA1 with per-kind what-if RULs (168/191/88) and no
  headline RUL.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from mapr_daemon.catalog import BitOutcome, CatalogWriter, Event
from mapr_daemon.catalog.model import Flight, display_name
from mapr_daemon.catalog.recordings import fleet_asset, in_fleet
from mapr_daemon.findings import Health
from tests.catalog.conftest import HOUR, T0

KINDS = ("esr", "capacitance", "friction")
PART = {"esr": "dc-link capacitor", "capacitance": "dc-link capacitor",
        "friction": "gear train"}
HEALTHY_NOTE = "no part wears measurably: every trended part is within its healthy scatter"
FEW_FLIGHTS = "BITs on fewer than three flights: no trend yet"
FLEET_FLIGHTS = 220
"""Flights of the fleet catalog (the ">= 200 flights" screenshot)."""
ONE_FLIGHT_BITS = 34
URGENCY = ("N104/EMA2", "N103/EMA1", "N101/EMA2", "N102/EMA2", "N102/EMA1", "N101/EMA1",
           "N103/EMA2", "N104/EMA1")
"""The fleet catalog's actuators, most urgent first."""


def _event(t: int, asset: str, kind: str, severity: float, value: float) -> Event:
    return Event(t_ns=t, asset=asset, fault=kind, confidence=0.93, severity=severity,
                 severity_value=value, severity_unit="ohm" if kind == "esr" else None,
                 evidence={"part": PART[kind]})


def _modes(lead: str | None, h: float, rul: tuple[float, float, float] | None,
           what_if: dict[str, float] | None, wiggle: float, flights: int) -> dict[str, Any]:
    """Per-kind trend figures as the assessment states them: the leading kind's own, the
    others inside their scatter; with BITs on three flights or more every kind has a RUL
    (``rul`` None: beyond the horizon; the others' what-ifs from ``what_if``)."""
    out: dict[str, Any] = {}
    for kind in KINDS:
        if kind == lead:
            row: dict[str, Any] = {"h": round(h, 4), "z": round(3.5 + 40 * h, 2),
                                   "evidenced": True}
            mine = rul
        else:
            row = {"h": round(0.01 * wiggle, 4), "z": round(0.8 * wiggle, 2),
                   "evidenced": False}
            mid = (what_if or {}).get(kind)
            mine = None if mid is None else (mid, round(0.55 * mid, 2), round(2.1 * mid, 2))
        if mine is not None and (flights >= 3 or mine[0] == 0):
            row.update(rul=mine[0], low=mine[1], high=mine[2])
        elif flights >= 3:
            row.update(rul=None, low=None, high=None)
        out[kind] = row
    return out


def _band(rul: float, n_flights: int) -> tuple[float, float, float]:
    """Median and 90 % interval, narrowing as flights accumulate."""
    spread = 0.25 + 1.2 / math.sqrt(max(n_flights, 1))
    return (round(rul, 2), round(max(rul * (1 - spread / 2), 0.0), 2),
            round(rul * (1 + spread), 2))


def write_one_flight_catalog(path: Path) -> Path:
    """The demo's first run (module docstring)."""
    tail, flight, hours = "N101", 1, 1.5
    bits: list[BitOutcome] = []
    for i in range(ONE_FLIGHT_BITS):
        t = T0 + i * 90_000_000_000
        wiggle = math.sin(i)
        h = 1.25 + 0.02 * wiggle
        esr = Health(0.0, "esr", 0.0, 0.0, 0.0, modes=_modes("esr", h, (0.0, 0.0, 0.0), None,
                                                            wiggle, 1))
        bits.append(BitOutcome("EMA1", t, _event(t, "EMA1", "esr", 0.31, 0.6347), tail=tail,
                               flight=flight, flight_hours=hours,
                               wear={k: (h if k == "esr" else 0.01 * wiggle) for k in KINDS},
                               health=esr, fault="esr"))
        bits.append(BitOutcome("EMA2", t + 1000, tail=tail, flight=flight, flight_hours=hours,
                               wear={k: 0.01 * wiggle for k in KINDS},
                               health=Health(1.0, None, note=HEALTHY_NOTE,
                                             modes=_modes(None, 0, None, None, wiggle, 1))))
        hf = 0.3 + 0.005 * i
        bits.append(BitOutcome("EMA3", t + 2000, tail=tail, flight=flight, flight_hours=hours,
                               wear={k: (hf if k == "friction" else 0.0) for k in KINDS},
                               health=Health(round(1 - hf, 3), "friction", note=FEW_FLIGHTS,
                                             modes=_modes("friction", hf, None, None,
                                                          wiggle, 1))))
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="cafe", started_ns=T0)
        writer.add_bits(bits, [Flight(tail, flight, T0, T0 + 2 * HOUR, hours, "bus")])
        writer.add_stats(T0, T0 + 3600 * 10**9, {
            "A": {"messages": 26624, "words": 310000, "load_percent": 18.2, "errors": {}}})
    return path


def _fleet_bit(tail: str, asset: str, k: int, j: int) -> BitOutcome:
    """BIT ``j`` (0 or 1) of flight ``k`` of one fleet actuator."""
    t = T0 + (k * 6 + j * 2) * HOUR + sum(map(ord, tail + asset)) * 10**6
    wiggle = math.sin(3 * k + j + len(tail + asset))
    hours = 2.5 * k
    name = display_name(tail, asset)
    health: Health
    fault: str | None = None
    lead: str | None = None
    h = 0.0
    what_if = ({"esr": 168.0, "capacitance": 191.0, "friction": 88.0} if name == "N101/EMA1"
               else {"capacitance": 228.0} if name == "N103/EMA1" else None)
    if name == "N103/EMA1":           # ESR aging fast: fails at about flight 225
        lead, life = "esr", 225.0
        h = (k / life) ** 2 + 0.01 * wiggle
        rul = _band(life - k, k) if k >= 3 else None
        fault = "esr" if k >= 190 else None
    elif name == "N101/EMA2":         # friction: fails at about flight 280
        lead, life = "friction", 280.0
        h = (k / life) ** 1.5 + 0.01 * wiggle
        rul = _band(life - k, k) if k >= 3 else None
    elif name == "N102/EMA2" and k >= 205:   # capacitance dropping since flight 205
        lead, h = "capacitance", 0.02 * (k - 205) + 0.01 * wiggle
        rul = _band(150.0 - 3 * (k - 205), 3 * (k - 205)) if k >= 208 else None
        fault = "capacitance" if k >= 215 else None
    elif name == "N104/EMA2" and k == FLEET_FLIGHTS and j == 1:   # a switch shorted
        return BitOutcome(asset, t, Event(t_ns=t, asset=asset, fault="short", confidence=0.99,
                                          severity=None, evidence={"part": "inverter"}),
                          tail=tail, flight=k, flight_hours=hours, fault="short",
                          health=Health(0.0, "short", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                                        note="terminal fault: the part has failed"))
    elif name == "N102/EMA1":         # slow, past fault episode at flights 50-52
        lead, h, rul = "capacitance", 0.05 + k / 4000, None
        fault = "capacitance" if 50 <= k <= 52 else None
    if lead is None:
        health = Health(1.0, None, note=HEALTHY_NOTE, modes=_modes(None, 0, None, what_if,
                                                                   wiggle, k))
    elif rul is None and name == "N102/EMA1":
        health = Health(round(1 - h, 3), lead, modes=_modes(lead, h, None, what_if, wiggle, k),
                        note="the trend does not reach the failure threshold within 2000 "
                             "flights")
    elif rul is None:
        health = Health(round(1 - h, 3), lead, note="fewer than three BITs: no trend yet",
                        modes=_modes(lead, h, None, what_if, wiggle, k))
    else:
        health = Health(round(max(0.0, 1 - h), 3), lead, *rul, rul[0] * 2.5, rul[1] * 2.5,
                        rul[2] * 2.5, modes=_modes(lead, h, rul, what_if, wiggle, k))
    event = None if fault is None else _event(t, asset, fault, round(0.3 + h / 2, 3),
                                              0.05 * (1 + h))
    return BitOutcome(asset, t, event, tail=tail, flight=k, flight_hours=hours,
                      wear={kind: (h if kind == lead else 0.01 * wiggle) for kind in KINDS},
                      health=health, fault=fault)


def write_fleet_catalog(path: Path) -> Path:
    """Four tails x two actuators x 220 flights (module docstring)."""
    with CatalogWriter(path) as writer:
        writer.open_session(backend="fleet", config_hash="cafe", started_ns=T0)
        for tail in ("N101", "N102", "N103", "N104"):
            bits = []
            for k in range(1, FLEET_FLIGHTS + 1):
                for j in range(2):
                    for asset in ("EMA1", "EMA2"):
                        bits.append(_fleet_bit(tail, asset, k, j))
            bits.sort(key=lambda b: b.t_ns)
            flights = [Flight(tail, k, T0 + k * 6 * HOUR, T0 + (k * 6 + 3) * HOUR, 2.5,
                              "declared") for k in range(1, FLEET_FLIGHTS + 1)]
            writer.add_bits([in_fleet(b) for b in bits], flights,
                            episodes_as=lambda b: fleet_asset(b.tail, b.asset))
    return path
