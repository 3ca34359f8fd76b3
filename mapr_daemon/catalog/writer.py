"""The daemon's side of the catalog: sessions, events in batches, bus statistics, gaps.

One :class:`CatalogWriter` per daemon process::

    with CatalogWriter("/var/lib/mapr/catalog.sqlite") as catalog:
        catalog.open_session(backend="loopback", config_hash=digest)
        ids = catalog.add_events(batch)          # one transaction; durable when it returns
        ids = catalog.add_bits(outcomes)         # the same, with the nominal BITs too
        catalog.add_stats(t0_ns, t1_ns, interval_stats)
        catalog.add_rt_stats(t0_ns, t1_ns, per_rt_sa_rows)
        catalog.record_gap(t0_ns, t1_ns, "backend: USB card unplugged")
        catalog.close_session("SIGTERM")

Every write method is one transaction, and returns only after its COMMIT: with the default
``durability="power-loss"`` (``synchronous=FULL``) what it returned survives kill -9 and a
power cut, so the daemon may report those ids as written. Batching is the caller's choice
(the daemon collects the reasoner's events per loop turn); a batch of thousands costs about
what one event costs, which is why ``add_events`` takes many.

Every stored event belongs to a fault episode (:mod:`.episodes`), opened or updated in the
same transaction; ``add_bits`` also takes the BITs that found the actuator nominal, which
close episodes after ``clear_after`` consecutive clear BITs.

A session left open by a run that was killed is closed at the next ``open_session`` with
``stop_reason="unclean"`` and a monitoring gap from its last sign of life to the new start.
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
import time
from collections.abc import Callable, Iterable, Mapping
from types import TracebackType
from typing import Any, Protocol

from mapr_daemon import __version__
from mapr_daemon.catalog import episode_store, history, inflight, rt_stats
from mapr_daemon.catalog.connect import Durability, describe, open_writer
from mapr_daemon.catalog.episode_batch import fold
from mapr_daemon.catalog.episodes import DEFAULT_CLEAR_BITS, Detection, Episode, detection_of
from mapr_daemon.catalog.model import BitOutcome, BitRecord, Event, Flight, InflightEstimate
from mapr_daemon.errors import CatalogError

UNCLEAN = "unclean"
"""``stop_reason`` of a session whose process died without closing it."""


class StatisticsLike(Protocol):
    """What :class:`drivers.monitor.BusStatistics` offers (``as_dict()``), without importing
    the monitor here."""

    def as_dict(self) -> dict[str, Any]: ...


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def _plain(value: Any) -> Any:
    """numpy scalars and arrays (duck-typed) to plain Python, for ``json.dumps``."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


_ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_plain)
"""One encoder for every event: ``json.dumps`` with options builds a new one per call, which was
a fifth of a bulk insert's time."""


def to_json(value: Mapping[str, Any]) -> str:
    """Compact JSON; NaN and infinity become null so every export is standard JSON."""
    try:
        return _ENCODER.encode(value)
    except ValueError:
        return json.dumps(_finite(json.loads(json.dumps(value, default=_plain))),
                          separators=(",", ":"), allow_nan=False)


def _opt(value: float | None) -> float | None:
    return None if value is None else float(value)


def _int(value: int | None) -> int | None:
    return None if value is None else int(value)


def now_ns() -> int:
    return time.time_ns()


class CatalogWriter:
    """The single read-write user of a catalog file (see the module docstring)."""

    def __init__(self, path: str | os.PathLike[str], *,
                 durability: Durability = "power-loss",
                 clear_after: int = DEFAULT_CLEAR_BITS) -> None:
        if clear_after < 1:
            raise ValueError("clear_after must be at least 1 BIT")
        self.path = os.fspath(path)
        self.durability = durability
        self.clear_after = int(clear_after)
        """Consecutive clear BITs that close a fault episode (:mod:`.episodes`)."""
        self._conn: sqlite3.Connection | None = open_writer(self.path, durability)
        self.session_id: int | None = None

    # --- plumbing ----------------------------------------------------------------------
    @property
    def conn(self) -> sqlite3.Connection:
        if self._conn is None:
            raise CatalogError("the writer is closed", path=self.path)
        return self._conn

    def _transaction(self, work: Any, *args: Any) -> Any:
        """Run ``work(conn, *args)`` inside BEGIN IMMEDIATE ... COMMIT; SQLite errors become
        :class:`CatalogError` (the daemon logs them and goes on)."""
        conn = self.conn
        try:
            conn.execute("BEGIN IMMEDIATE")
            try:
                result = work(conn, *args)
                conn.execute("COMMIT")
            except BaseException:
                if conn.in_transaction:
                    conn.execute("ROLLBACK")
                raise
        except sqlite3.Error as error:
            raise CatalogError(f"write failed: {describe(error)}", path=self.path) from error
        return result

    def _session(self) -> int:
        if self.session_id is None:
            raise CatalogError("no open session: call open_session() first", path=self.path)
        return self.session_id

    # --- sessions ----------------------------------------------------------------------
    def open_session(self, *, backend: str, config_hash: str,
                     software_version: str = __version__,
                     started_ns: int | None = None) -> int:
        """Start a monitoring session; closes any a killed run left open. Returns its id."""
        start = now_ns() if started_ns is None else started_ns

        def work(conn: sqlite3.Connection) -> int:
            self._close_unclean(conn, start)
            cur = conn.execute(
                "INSERT INTO sessions (started_ns, backend, config_hash, software_version) "
                "VALUES (?, ?, ?, ?)", (start, backend, config_hash, software_version))
            return int(cur.lastrowid or 0)

        self.session_id = int(self._transaction(work))
        return self.session_id

    @staticmethod
    def _close_unclean(conn: sqlite3.Connection, start: int) -> None:
        stale = conn.execute("SELECT id, started_ns FROM sessions WHERE stopped_ns IS NULL"
                             ).fetchall()
        for sid, started in stale:
            last = conn.execute(
                "SELECT max(t) FROM (SELECT max(t_ns) AS t FROM events WHERE session_id = ?1 "
                "UNION ALL SELECT max(end_ns) FROM bus_stats WHERE session_id = ?1)",
                (sid,)).fetchone()[0]
            seen = max(int(last if last is not None else started), int(started))
            conn.execute("UPDATE sessions SET stopped_ns = ?, stop_reason = ? WHERE id = ?",
                         (seen, UNCLEAN, sid))
            conn.execute("INSERT INTO gaps (session_id, start_ns, end_ns, reason) "
                         "VALUES (?, ?, ?, ?)",
                         (sid, seen, max(start, seen),
                          "daemon not running: the previous session ended uncleanly "
                          "(killed, crashed or power lost)"))

    def close_session(self, reason: str = "stopped", stopped_ns: int | None = None) -> None:
        """End the current session (idempotent)."""
        if self.session_id is None or self._conn is None:
            return
        sid, stop = self.session_id, now_ns() if stopped_ns is None else stopped_ns
        self._transaction(lambda conn: conn.execute(
            "UPDATE sessions SET stopped_ns = ?, stop_reason = ? WHERE id = ?",
            (stop, reason, sid)))
        self.session_id = None

    # --- events, statistics, gaps ------------------------------------------------------
    def add_events(self, events: Iterable[Event]) -> list[int]:
        """Insert a batch in one transaction; returns the new ids, in order, after COMMIT.

        Each event counts as one BIT that detected it (for its fault episode); a caller that
        also knows the nominal BITs uses :meth:`add_bits`, so episodes can close."""
        batch = list(events)
        return self._store(batch, [(e.asset, int(e.t_ns), detection_of(e)) for e in batch])

    def add_bits(self, outcomes: Iterable[BitOutcome], flights: Iterable[Flight] = (), *,
                 guard: Callable[[sqlite3.Connection], bool] | None = None,
                 episodes_as: Callable[[BitOutcome], str] | None = None) -> list[int]:
        """Store a batch of diagnosed BITs (in time order) in one transaction: each anomaly
        event, with the fault episode it opens or updates, and each BIT's effect on the
        actuator's open episodes (:mod:`.episodes`), each BIT's history row (:mod:`.history`)
        and the ``flights`` they were flown on. Returns the new event ids, in order, after
        COMMIT.

        ``guard(conn)``, when given, runs first inside that transaction (to write what must
        be stored with the events, e.g. :mod:`.recordings`' row); when it returns False
        nothing of the batch is stored and the result is empty.

        ``episodes_as(bit)``, when given, names the actuator a BIT's fault episodes are kept
        under (default: its ``asset``); a fleet run keeps each tail's apart
        (:mod:`.recordings`), the episodes having no tail of their own."""
        bits = list(outcomes)
        name: Callable[[BitOutcome], str] = \
            (lambda b: b.asset) if episodes_as is None else episodes_as
        return self._store([b.event for b in bits if b.event is not None],
                           [(name(b), int(b.t_ns),
                             None if b.event is None else detection_of(b.event)) for b in bits],
                           bits, list(flights), guard)

    def _store(self, events: list[Event], found: list[tuple[str, int, Detection | None]],
               bits: list[BitOutcome] | None = None, flights: list[Flight] | None = None,
               guard: Callable[[sqlite3.Connection], bool] | None = None) -> list[int]:
        """``events`` are the detections of ``found`` (the batch's BITs), in order; ``bits``
        the same BITs as outcomes, for the BIT history (None: events alone), and the
        flights they were flown on."""
        sid = self._session()
        if not found and guard is None:
            return []
        rows = [(e.t_ns, e.asset, e.rt, e.fault, e.switch, _opt(e.severity),
                 _opt(e.severity_value), e.severity_unit, float(e.confidence),
                 to_json(e.params), _opt(e.soh), _opt(e.rul), _opt(e.rul_low),
                 _opt(e.rul_high), e.rul_unit, to_json(e.evidence), _int(e.bus_ns),
                 _int(e.abs_ns)) for e in events]
        clear_after = self.clear_after

        def work(conn: sqlite3.Connection) -> int | None:
            if guard is not None and not guard(conn):
                return None
            # Under BEGIN IMMEDIATE we hold the write lock: ids max+1.. are ours to give.
            first = int(conn.execute("SELECT coalesce(max(id), 0) + 1 FROM events"
                                     ).fetchone()[0])
            first_episode = episode_store.next_id(conn)
            changed, episode_ids = fold(found, episode_store.load_open(conn), clear_after,
                                        first_episode)
            episode_store.save(conn, changed.values(), first_episode)
            of_event = [i for i in episode_ids if i is not None]
            conn.executemany(
                "INSERT INTO events (id, session_id, t_ns, asset, rt, fault, switch, severity,"
                " severity_value, severity_unit, confidence, params, soh, rul, rul_low,"
                " rul_high, rul_unit, evidence, bus_ns, abs_ns, episode_id)"
                " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                [(first + i, sid, *row, episode)
                 for i, (row, episode) in enumerate(zip(rows, of_event, strict=True))])
            if bits is not None:
                history.insert_bits(conn, sid, bits, first)
                history.upsert_flights(conn, flights or [])
            return first

        first = self._transaction(work)
        return [] if first is None else list(range(int(first), int(first) + len(rows)))

    def history(self, tail: str = ""
                ) -> tuple[list[BitRecord], list[Flight], list[InflightEstimate]]:
        """One aircraft's BIT history, flights and in-flight rows, for the trend (and each
        actuator's in-flight baseline) to continue from."""
        conn = self.conn
        return (history.load_bits(conn, tail=tail), history.load_flights(conn, tail),
                inflight.load_inflight(conn, tail=tail))

    def open_episodes(self) -> dict[tuple[str, str], Episode]:
        """Every open fault episode, keyed by ``(asset, part)`` (the daemon compares them
        before and after a write to log what opened and closed)."""
        return episode_store.load_open(self.conn)

    def add_inflight(self, estimates: Iterable[InflightEstimate]) -> None:
        """Store flights' in-flight estimates in one transaction (:mod:`.inflight`; a flight
        stored before is replaced)."""
        batch = list(estimates)
        if batch:
            sid = self._session()
            self._transaction(inflight.insert_inflight, sid, batch)

    def save_flights(self, flights: Iterable[Flight]) -> None:
        """Insert or update flights (by tail and number) in one transaction."""
        batch = list(flights)
        if batch:
            self._transaction(history.upsert_flights, batch)

    def add_stats(self, start_ns: int, end_ns: int,
                  stats: StatisticsLike | Mapping[str, Mapping[str, Any]]) -> None:
        """Store one interval's bus statistics, one row per bus.

        ``stats`` is a :class:`drivers.monitor.BusStatistics` covering just this interval,
        or its ``as_dict()`` form ``{bus: {messages, words, load_percent, errors}}``.
        """
        sid = self._session()
        per_bus = stats if isinstance(stats, Mapping) else stats.as_dict()
        rows = []
        for bus, row in sorted(per_bus.items()):
            errors = {str(k): int(v) for k, v in dict(row.get("errors", {})).items()}
            rows.append((sid, start_ns, end_ns, str(bus), int(row["messages"]),
                         int(row["words"]), float(row["load_percent"]),
                         sum(errors.values()), to_json(errors)))
        if rows:
            self._transaction(lambda conn: conn.executemany(
                "INSERT INTO bus_stats (session_id, start_ns, end_ns, bus, messages, words, "
                "load_percent, errors_total, errors) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", rows))

    def add_rt_stats(self, start_ns: int, end_ns: int,
                     rows: Iterable[Mapping[str, Any]]) -> None:
        """Store one interval's per-RT/SA statistics, one row per RT/direction/SA or mode
        code: mappings with the fields of :class:`drivers.rtstats.RtSaRow`
        (:mod:`.rt_stats`)."""
        params = rt_stats.insert_rows(self._session(), start_ns, end_ns, rows)
        if params:
            self._transaction(lambda conn: conn.executemany(rt_stats.INSERT, params))

    def record_gap(self, start_ns: int, end_ns: int | None, reason: str) -> int:
        """A stretch with no monitoring (``end_ns`` None while it lasts); returns its id."""
        sid = self.session_id

        def work(conn: sqlite3.Connection) -> int:
            cur = conn.execute("INSERT INTO gaps (session_id, start_ns, end_ns, reason) "
                               "VALUES (?, ?, ?, ?)", (sid, start_ns, end_ns, reason))
            return int(cur.lastrowid or 0)

        return int(self._transaction(work))

    def end_gap(self, gap_id: int, end_ns: int) -> None:
        """Close a gap recorded with ``end_ns=None`` (the card is back)."""
        self._transaction(lambda conn: conn.execute(
            "UPDATE gaps SET end_ns = ? WHERE id = ?", (end_ns, gap_id)))

    # --- lifetime ----------------------------------------------------------------------
    def close(self, reason: str = "stopped") -> None:
        """Close the session (if any) and the file; SQLite checkpoints and removes the WAL."""
        if self._conn is None:
            return
        try:
            self.close_session(reason)
        finally:
            self._conn.close()
            self._conn = None

    def __enter__(self) -> CatalogWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close("stopped" if kind is None else f"error: {kind.__name__}")
