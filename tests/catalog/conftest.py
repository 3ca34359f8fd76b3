"""Shared pieces of the catalog tests: events that look like the reasoner's, real files."""

from __future__ import annotations

import random
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from mapr_daemon.catalog import CatalogWriter, Event

T0 = 1_778_300_000_000_000_000  # 2026-05-09 04:13:20 UTC, in ns
HOUR = 3_600_000_000_000


def event(i: int, *, asset: str = "EMA1", fault: str = "esr", severity: float | None = 0.4,
          **extra: Any) -> Event:
    """A plausible reasoner event; ``i`` spreads them one minute apart from :data:`T0`."""
    fields: dict[str, Any] = dict(
        t_ns=T0 + i * 60_000_000_000, asset=asset, fault=fault, confidence=0.9,
        severity=severity, severity_value=None if severity is None else 0.05 + severity * 0.95,
        severity_unit=None if severity is None else "ohm", rt=5, soh=1.0 - 0.001 * i,
        rul=500.0 - i, rul_low=400.0 - i, rul_high=620.0 - i, rul_unit="h",
        params={"esr_ohm": 0.05 + 0.001 * i, "capacitance_f": 2.88e-4},
        evidence={"score": 3.2, "threshold": 1.0, "window": [i, i + 1]})
    fields.update(extra)
    return Event(**fields)


def random_events(rng: random.Random, n: int, start: int = 0) -> list[Event]:
    assets, faults = ["EMA1", "EMA2", "EMA3"], ["esr", "capacitance", "friction", "short"]
    return [event(start + k, asset=rng.choice(assets), fault=(f := rng.choice(faults)),
                  severity=None if f == "short" else round(rng.random(), 3))
            for k in range(n)]


@pytest.fixture
def make_event() -> Callable[..., Event]:
    return event


@pytest.fixture
def catalog_path(tmp_path: Path) -> Path:
    return tmp_path / "catalog.sqlite"


@pytest.fixture
def filled(catalog_path: Path) -> Path:
    """A closed catalog: one session, 40 events over three assets, stats and one gap."""
    with CatalogWriter(catalog_path) as writer:
        writer.open_session(backend="loopback", config_hash="cafe", started_ns=T0)
        writer.add_events(random_events(random.Random(7), 40))
        for k in range(3):
            writer.add_stats(T0 + k * 10**10, T0 + (k + 1) * 10**10, {
                "A": {"messages": 500 + k, "words": 9000, "load_percent": 18.2,
                      "errors": {"parity": k}},
                "B": {"messages": 0, "words": 0, "load_percent": 0.0, "errors": {}}})
        writer.record_gap(T0 + 5 * 10**10, T0 + 6 * 10**10, "backend: USB card unplugged")
        writer.close_session("SIGTERM", stopped_ns=T0 + 50 * 60_000_000_000)
    return catalog_path
