"""Each actuator's BIT history and each aircraft's flights, in the catalog (schema v5, v8, v10).

Every diagnosed BIT is a ``bits`` row, nominal ones too: its flight, the degradation estimate
of every aging kind and which path read it (the estimators or the unit's baseline), the
flight condition it was flown at and the health the trend gave after it. That history is
what the trend is refitted on after each BIT (the daemon reloads it at start, so a restart
continues the trend, each estimate weighed by the path that read it), what ``mapr health``
and the trend plot read, and what ``catalog export --what bits`` writes. ``flights`` holds
each aircraft's flights: measured from the bus (the span of the actuator traffic) or
declared by a replay or a fleet run.

Functions take an open connection; the writer calls the ``insert``/``upsert`` ones inside its
transaction, the reader and the daemon's trend the ``load`` ones.
"""

from __future__ import annotations

import json
import math
import sqlite3
from collections.abc import Sequence
from typing import Any

from mapr_daemon.catalog.model import BitOutcome, BitRecord, Flight
from mapr_daemon.findings import Health

BIT_SELECT = ("id, session_id, tail, asset, t_ns, bus_ns, abs_ns, flight, flight_hours, fault, "
              "event_id, wear, mode, soh, rul, rul_low, rul_high, rul_hours, rul_hours_low, "
              "rul_hours_high, note, modes")
"""The ``bits`` columns :func:`bit_record` reads, in its order (for other readers' queries)."""
CONDITIONS_SINCE = 8
"""Schema version that added ``bits.conditions`` (older files read it as ``{}``)."""
WEAR_SOURCE_SINCE = 10
"""Schema version that added ``bits.wear_source`` (older files read it as ``{}``)."""


def _num(value: float | None) -> float | None:
    """A figure as stored: None for unknown and for ``inf`` (the note says which)."""
    return None if value is None or not math.isfinite(value) else float(value)


def _json(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"), allow_nan=False, default=float)


def insert_bits(conn: sqlite3.Connection, session_id: int | None,
                bits: Sequence[BitOutcome], first_event_id: int) -> None:
    """Store one batch's BITs; their anomaly events were given ids from ``first_event_id`` in
    order."""
    rows = []
    next_event = first_event_id
    flights = []
    for b in bits:
        event_id = None
        if b.event is not None:
            event_id, next_event = next_event, next_event + 1
            if b.flight is not None:
                flights.append((int(b.flight), event_id))
        h = b.health
        rows.append((
            session_id, b.tail, b.asset, int(b.t_ns), b.bus_ns, b.abs_ns, b.flight,
            _num(b.flight_hours), b.fault if b.event is None else b.event.fault, event_id,
            _json({k: float(v) for k, v in b.wear.items()}),
            None if h is None else h.mode, None if h is None else _num(h.soh),
            *((None,) * 6 if h is None else (
                _num(h.rul), _num(h.rul_low), _num(h.rul_high), _num(h.rul_hours),
                _num(h.rul_hours_low), _num(h.rul_hours_high))),
            None if h is None else h.note, _json({} if h is None else dict(h.modes)),
            _json({k: float(v) for k, v in b.conditions.items()}),
            _json({k: dict(v) for k, v in b.wear_source.items()})))
    conn.executemany(
        "INSERT INTO bits (session_id, tail, asset, t_ns, bus_ns, abs_ns, flight, flight_hours,"
        " fault, event_id, wear, mode, soh, rul, rul_low, rul_high, rul_hours, rul_hours_low,"
        " rul_hours_high, note, modes, conditions, wear_source) VALUES (?, ?, ?, ?, ?, ?, ?,"
        " ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", rows)
    if flights:
        conn.executemany("UPDATE events SET flight = ? WHERE id = ?", flights)


def upsert_flights(conn: sqlite3.Connection, flights: Sequence[Flight]) -> None:
    conn.executemany(
        "INSERT INTO flights (tail, flight, start_ns, end_ns, hours, source) VALUES "
        "(?, ?, ?, ?, ?, ?) ON CONFLICT (tail, flight) DO UPDATE SET start_ns = "
        "coalesce(min(excluded.start_ns, flights.start_ns), excluded.start_ns, "
        "flights.start_ns), end_ns = coalesce(max(excluded.end_ns, flights.end_ns), "
        "excluded.end_ns, flights.end_ns), hours = excluded.hours, source = excluded.source",
        [(f.tail, f.flight, f.start_ns, f.end_ns, float(f.hours), f.source) for f in flights])


def bit_record(row: Sequence[Any], conditions: str = "{}", wear_source: str = "{}"
               ) -> BitRecord:
    """A BIT from its :data:`BIT_SELECT`, its stored conditions and wear sources (``{}``:
    none, or not selected: the health view does not need them)."""
    (rid, sid, tail, asset, t_ns, bus_ns, abs_ns, flight, hours, fault, event_id, wear, mode,
     soh, rul, low, high, rh, rhl, rhh, note, modes) = row
    return BitRecord(rid, sid, tail, asset, t_ns, bus_ns, abs_ns, flight, hours, fault,
                     event_id, json.loads(wear),
                     Health(soh, mode, rul, low, high, rh, rhl, rhh, note, json.loads(modes)),
                     json.loads(conditions), wear_sources(wear_source))


def wear_sources(text: str) -> dict[str, dict[str, Any]]:
    """A stored ``wear_source`` cell as ``{kind: source}``, keeping only the kinds whose entry
    is a JSON object: a cell or entry that is not (a file damaged or edited by hand) reads as
    unknown, as a BIT stored before schema v10 does, so it can neither stop the daemon
    resuming its trend nor a reader (the trend weighs an unknown reading by the asset's path
    now, :mod:`~mapr_daemon.reasoner.prognosis.wear_paths`)."""
    try:
        doc = json.loads(text)
    except (TypeError, ValueError):
        return {}
    if not isinstance(doc, dict):
        return {}
    return {str(k): v for k, v in doc.items() if isinstance(v, dict)}


def equal_to(**columns: str | None) -> tuple[str, list[str]]:
    """`` WHERE a = ? AND b = ?`` over the columns given a value (None: any), and its
    arguments; ``""`` when none is given."""
    given = [(name, value) for name, value in columns.items() if value is not None]
    if not given:
        return "", []
    return (" WHERE " + " AND ".join(f"{name} = ?" for name, _ in given),
            [value for _, value in given])


def load_bits(conn: sqlite3.Connection, asset: str | None = None, tail: str | None = None,
              last: int | None = None, version: int | None = None) -> list[BitRecord]:
    """BIT history (all assets, or one), oldest first; ``last``: only the newest N per call;
    ``version``: the file's schema version when it may predate :data:`CONDITIONS_SINCE` or
    :data:`WEAR_SOURCE_SINCE` (a reader does not migrate), None for a file at the latest."""
    where, args = equal_to(asset=asset, tail=tail)
    conditions = "conditions" if version is None or version >= CONDITIONS_SINCE else "'{}'"
    source = "wear_source" if version is None or version >= WEAR_SOURCE_SINCE else "'{}'"
    sql = f"SELECT {BIT_SELECT}, {conditions}, {source} FROM bits{where}"
    sql += " ORDER BY coalesce(flight, 0), t_ns, id"
    rows = [bit_record(r[:-2], r[-2], r[-1]) for r in conn.execute(sql, args)]
    return rows if last is None else rows[-last:]


def load_flights(conn: sqlite3.Connection, tail: str | None = None) -> list[Flight]:
    """Flights of one aircraft (or all), by tail and number."""
    sql = "SELECT tail, flight, start_ns, end_ns, hours, source FROM flights"
    args: list[Any] = []
    if tail is not None:
        sql += " WHERE tail = ?"
        args.append(tail)
    return [Flight(*r) for r in conn.execute(sql + " ORDER BY tail, flight", args)]


def assets(conn: sqlite3.Connection) -> list[tuple[str, str]]:
    """(tail, asset) of every actuator with a BIT history or an event, sorted."""
    rows = conn.execute("SELECT DISTINCT tail, asset FROM bits UNION SELECT '', asset FROM "
                        "events WHERE asset NOT IN (SELECT asset FROM bits) ORDER BY 1, 2")
    return [(str(t), str(a)) for t, a in rows]
