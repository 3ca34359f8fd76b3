"""A fleet's recordings in the catalog: BITs under the plain asset and the tail, events and
fault episodes under ``TAIL/ASSET``, so the same actuator name on two tails never shares an
episode, and ``mapr health`` shows each tail's own open episodes."""

from __future__ import annotations

from pathlib import Path

from mapr_daemon.catalog import BitOutcome, CatalogReader, CatalogWriter, Event
from mapr_daemon.catalog.model import Flight
from mapr_daemon.catalog.recordings import DONE, RecordingRow, store_recording
from mapr_daemon.findings import Health

from .conftest import HOUR, T0


def _bit(tail: str, flight: int, fault: str | None) -> BitOutcome:
    t = T0 + flight * 24 * HOUR + (60_000_000_000 if tail == "N102" else 0)
    event = None if fault is None else Event(
        t_ns=t, asset="EMA1", fault=fault, confidence=0.9,
        evidence={"part": "dc-link capacitor" if fault == "esr" else "gearbox"})
    return BitOutcome("EMA1", t, event, tail=tail, flight=flight, flight_hours=1.5 * flight,
                      wear={"esr": 0.1}, health=Health(0.9, "esr"), fault=fault)


def _store(writer: CatalogWriter, tail: str, flight: int, fault: str | None) -> bool:
    row = RecordingRow(f"{tail}-{flight}", f"{tail}/flight-{flight:04d}.ch10", tail, flight,
                       1.5, DONE, "cfg", bits=1, events=fault is not None)
    return store_recording(writer, row, [_bit(tail, flight, fault)],
                           [Flight(tail, flight, None, None, 1.5, "declared")])


def test_two_tails_same_actuator_name_keep_their_own_episodes(tmp_path: Path) -> None:
    path = tmp_path / "fleet.db"
    with CatalogWriter(path, clear_after=1) as writer:
        writer.open_session(backend="fleet", config_hash="cfg")
        assert _store(writer, "N101", 1, "esr")
        assert _store(writer, "N102", 1, "esr")
        assert _store(writer, "N102", 2, None)   # clears N102's episode, not N101's
        assert not _store(writer, "N102", 2, None)   # stored once
    with CatalogReader(path) as reader:
        bits = reader.bits()
        episodes = reader.episodes()
        health = {a.name: a for a in reader.health()}
        events = reader.events()
    assert sorted((b.tail, b.asset, b.flight) for b in bits) == [
        ("N101", "EMA1", 1), ("N102", "EMA1", 1), ("N102", "EMA1", 2)]
    assert sorted(e.asset for e in events) == ["N101/EMA1", "N102/EMA1"]
    state = {ep.asset: ep.closed_ns is None for ep in episodes}
    assert state == {"N101/EMA1": True, "N102/EMA1": False}
    assert set(health) == {"N101/EMA1", "N102/EMA1"}
    assert [ep.asset for ep in health["N101/EMA1"].open_episodes] == ["N101/EMA1"]
    assert health["N102/EMA1"].open_episodes == ()
    assert health["N102/EMA1"].last.flight == 2
