"""The CLI's side of the catalog: read-only queries with filters.

::

    with CatalogReader("/var/lib/mapr/catalog.sqlite") as catalog:
        for event in catalog.events(EventFilter(asset="EMA1", min_severity=0.3), limit=20):
            ...

The connection is read-only (see :mod:`mapr_daemon.catalog.connect` for the fallback when
the daemon has stopped). Every query is a fixed SQL text; filters add fixed ``WHERE``
fragments and pass the user's values as parameters, never as SQL. ``list`` queries walk an
index in time order (newest first) and stop at ``limit``, so they stay fast on a catalog of
millions of events.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sqlite3
from collections.abc import Iterator
from types import TracebackType
from typing import Any

from mapr_daemon.catalog import actuators, episode_store, history, inflight, rt_stats
from mapr_daemon.catalog.actuators import ActuatorHealth, display_name, episode_names
from mapr_daemon.catalog.connect import describe, open_reader
from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.catalog.model import (
    BitRecord,
    Event,
    EventFilter,
    Flight,
    Gap,
    InflightEstimate,
    Session,
    StatsRow,
)
from mapr_daemon.errors import CatalogError

_EVENT_COLUMNS = ("id, session_id, t_ns, asset, rt, fault, switch, severity, severity_value, "
                  "severity_unit, confidence, params, soh, rul, rul_low, rul_high, rul_unit, "
                  "evidence")
STAMPS_SINCE = 3
"""Schema version that added ``bus_ns`` and ``abs_ns`` (older files read them as None)."""
BITS_SINCE = 5
"""Schema version that added the ``bits`` history and ``flights``."""


def _columns(version: int) -> str:
    stamps = "bus_ns, abs_ns" if version >= STAMPS_SINCE else "NULL, NULL"
    episode = "episode_id" if version >= episode_store.EPISODES_SINCE else "NULL"
    return f"{_EVENT_COLUMNS}, {stamps}, {episode}"


def _event(row: tuple[Any, ...]) -> Event:
    (eid, sid, t_ns, asset, rt, fault, switch, sev, sev_value, sev_unit, conf, params, soh,
     rul, rul_low, rul_high, rul_unit, evidence, bus_ns, abs_ns, episode_id) = row
    return Event(t_ns=t_ns, asset=asset, fault=fault, confidence=conf, severity=sev,
                 severity_value=sev_value, severity_unit=sev_unit, rt=rt, switch=switch,
                 soh=soh, rul=rul, rul_low=rul_low, rul_high=rul_high, rul_unit=rul_unit,
                 params=json.loads(params), evidence=json.loads(evidence), bus_ns=bus_ns,
                 abs_ns=abs_ns, episode_id=episode_id, id=eid, session_id=sid)


def _where(flt: EventFilter) -> tuple[str, list[Any]]:
    """``WHERE ...`` from fixed fragments, and the values to bind to them."""
    clauses: list[str] = []
    values: list[Any] = []
    if flt.since_ns is not None:
        clauses.append("t_ns >= ?")
        values.append(int(flt.since_ns))
    if flt.until_ns is not None:
        clauses.append("t_ns < ?")
        values.append(int(flt.until_ns))
    if flt.asset is not None:
        # a fleet run keeps events under TAIL/ASSET: a bare name finds them on every tail
        # (TAIL/ASSET names one), as `catalog trend` and `health` name actuators
        clauses.append("(asset = ? OR (instr(asset, '/') > 0 "
                       "AND substr(asset, instr(asset, '/') + 1) = ?))")
        values += [flt.asset, flt.asset]
    if flt.fault is not None:
        clauses.append("fault = ?")
        values.append(flt.fault)
    if flt.min_severity is not None:
        clauses.append("coalesce(severity, 1.0) >= ?")  # terminal faults count as 1.0
        values.append(float(flt.min_severity))
    return (" WHERE " + " AND ".join(clauses) if clauses else ""), values


class CatalogReader:
    """A read-only view of a catalog file."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = os.fspath(path)
        self._conn, self.mode, self.schema_version = open_reader(self.path)

    def _rows(self, sql: str, values: list[Any] | tuple[Any, ...] = ()
              ) -> Iterator[tuple[Any, ...]]:
        try:
            yield from self._conn.execute(sql, values)
        except sqlite3.DatabaseError as error:
            raise CatalogError(f"read failed: {describe(error)}", path=self.path) from error

    # --- events ------------------------------------------------------------------------
    def iter_events(self, flt: EventFilter | None = None, *, limit: int | None = None,
                    newest_first: bool = True) -> Iterator[Event]:
        """Events matching ``flt`` in time order (newest first by default), lazily."""
        where, values = _where(flt or EventFilter())
        order = "DESC" if newest_first else "ASC"
        sql = (f"SELECT {_columns(self.schema_version)} FROM events{where} "
               f"ORDER BY t_ns {order}, id {order}")
        if limit is not None:
            sql += " LIMIT ?"
            values.append(int(limit))
        tails = self._tails()
        for row in self._rows(sql, values):
            yield self._with_tail(_event(row), tails)

    def _tails(self) -> dict[str, set[str]]:
        """Bare asset name -> the tails whose BIT history carries it (one query)."""
        tails: dict[str, set[str]] = {}
        if self.schema_version >= BITS_SINCE:
            for tail, asset in self._rows("SELECT DISTINCT tail, asset FROM bits"):
                if tail:
                    tails.setdefault(asset, set()).add(tail)
        return tails

    def _with_tail(self, event: Event, tails: dict[str, set[str]]) -> Event:
        """``event`` with its aircraft: the one tail its asset has, or (the daemon run under
        several tails) the tail of the BIT it was written for."""
        known = tails.get(event.asset)
        if not known:
            return event
        if len(known) == 1:
            return dataclasses.replace(event, tail=next(iter(known)))
        rows = list(self._rows("SELECT tail FROM bits WHERE event_id = ? LIMIT 1",
                               (event.id,)))
        return dataclasses.replace(event, tail=rows[0][0]) if rows else event

    def _episodes_with_tails(self, episodes: list[Episode]) -> list[Episode]:
        """Episodes with their aircraft where the catalog knows it (as :meth:`_with_tail`,
        through the episode's events for an asset on several tails)."""
        tails = self._tails()
        out = []
        for ep in episodes:
            known = tails.get(ep.asset)
            if known and len(known) == 1:
                ep = dataclasses.replace(ep, tail=next(iter(known)))
            elif known:
                rows = list(self._rows(
                    "SELECT b.tail FROM events e JOIN bits b ON b.event_id = e.id "
                    "WHERE e.episode_id = ? LIMIT 1", (ep.id,)))
                ep = dataclasses.replace(ep, tail=rows[0][0]) if rows else ep
            out.append(ep)
        return out

    def events(self, flt: EventFilter | None = None, *, limit: int | None = None,
               newest_first: bool = True) -> list[Event]:
        return list(self.iter_events(flt, limit=limit, newest_first=newest_first))

    def count(self, flt: EventFilter | None = None) -> int:
        where, values = _where(flt or EventFilter())
        return int(next(self._rows(f"SELECT count(*) FROM events{where}", values))[0])

    def event(self, event_id: int) -> Event | None:
        """One event by id, or None."""
        rows = list(self._rows(f"SELECT {_columns(self.schema_version)} FROM events WHERE id = ?",
                               (int(event_id),)))
        return self._with_tail(_event(rows[0]), self._tails()) if rows else None

    def trend(self, asset: str, since_ns: int | None = None, until_ns: int | None = None
              ) -> list[Event]:
        """The asset's events that carry SoH or RUL, oldest first (for ``mapr catalog trend``)."""
        flt = EventFilter(since_ns=since_ns, until_ns=until_ns, asset=asset)
        return [e for e in self.iter_events(flt, newest_first=False)
                if e.soh is not None or e.rul is not None]

    def episode_events(self, episode_id: int) -> list[Event]:
        """The events of one fault episode, oldest first (empty before schema v4)."""
        if self.schema_version < episode_store.EPISODES_SINCE:
            return []
        return [_event(r) for r in self._rows(
            f"SELECT {_columns(self.schema_version)} FROM events WHERE episode_id = ? "
            "ORDER BY t_ns, id", (int(episode_id),))]

    # --- fault episodes ------------------------------------------------------------------
    def episodes(self, *, open_only: bool = False, asset: str | None = None,
                 tail: str | None = None) -> list[Episode]:
        """Fault episodes, most recently active first, each with its aircraft where known
        (none before schema v4); ``asset`` (and ``tail``): one actuator's, kept under its
        bare name (the daemon's) or ``TAIL/ASSET`` (a fleet run's)."""
        if self.schema_version < episode_store.EPISODES_SINCE:
            return []
        names: tuple[str | None, ...] = (asset,)
        if asset is not None and tail:
            names = episode_names(tail, asset)
        try:
            found = [ep for name in names
                     for ep in episode_store.select(self._conn, open_only=open_only,
                                                    asset=name)]
        except sqlite3.DatabaseError as error:
            raise CatalogError(f"read failed: {describe(error)}", path=self.path) from error
        found.sort(key=lambda ep: (ep.last_ns, ep.id), reverse=True)
        episodes = self._episodes_with_tails(found)
        if tail and asset is not None:   # a bare name another aircraft also carries
            episodes = [ep for ep in episodes if ep.name == display_name(tail, asset)]
        return episodes

    def episode(self, episode_id: int) -> Episode | None:
        found = [e for e in self.episodes() if e.id == episode_id]
        return found[0] if found else None

    def assets(self) -> list[str]:
        return [r[0] for r in self._rows("SELECT DISTINCT asset FROM events ORDER BY asset")]

    # --- BIT history and health (schema v5) ----------------------------------------------
    def _read(self, work: Any, *args: Any) -> Any:
        try:
            return work(self._conn, *args)
        except sqlite3.DatabaseError as error:
            raise CatalogError(f"read failed: {describe(error)}", path=self.path) from error

    def actuators(self) -> list[tuple[str, str]]:
        """(tail, asset) of every actuator with a BIT history or an event, sorted (tail ''
        for a catalog without tails); what a name on the command line must pick one of."""
        if self.schema_version < BITS_SINCE:
            return [("", a) for a in self.assets()]
        result: list[tuple[str, str]] = self._read(history.assets)
        return result

    def bits(self, asset: str | None = None, tail: str | None = None) -> list[BitRecord]:
        """BIT history (all actuators or one), oldest first; empty before schema v5."""
        if self.schema_version < BITS_SINCE:
            return []
        result: list[BitRecord] = self._read(history.load_bits, asset, tail, None,
                                             self.schema_version)
        return result

    def inflight(self, asset: str | None = None, tail: str | None = None
                 ) -> list[InflightEstimate]:
        """Per-flight in-flight estimates (all actuators or one), oldest flight first; empty
        before schema v9."""
        if self.schema_version < inflight.INFLIGHT_SINCE:
            return []
        result: list[InflightEstimate] = self._read(inflight.load_inflight, asset, tail)
        return result

    def flights(self, tail: str | None = None) -> list[Flight]:
        """Flights of one aircraft (or all); empty before schema v5."""
        if self.schema_version < BITS_SINCE:
            return []
        result: list[Flight] = self._read(history.load_flights, tail)
        return result

    def health(self) -> list[ActuatorHealth]:
        """Every actuator's health after its newest BIT, with its open fault episodes
        (``mapr health``); empty before schema v5."""
        if self.schema_version < BITS_SINCE:
            return []
        result: list[ActuatorHealth] = self._read(
            actuators.load, self.schema_version >= episode_store.EPISODES_SINCE)
        return result

    # --- sessions, statistics, gaps ------------------------------------------------------
    def sessions(self) -> list[Session]:
        reason = "stop_reason" if self.schema_version >= 2 else "NULL"
        return [Session(*row) for row in self._rows(
            "SELECT id, started_ns, stopped_ns, backend, config_hash, software_version, "
            f"{reason} FROM sessions ORDER BY started_ns, id")]

    def session(self, session_id: int) -> Session | None:
        found = [s for s in self.sessions() if s.id == session_id]
        return found[0] if found else None

    def stats(self, since_ns: int | None = None, until_ns: int | None = None,
              bus: str | None = None, limit: int | None = None) -> list[StatsRow]:
        """Per-interval bus statistics, oldest first (the last ``limit`` intervals)."""
        clauses: list[str] = []
        values: list[Any] = []
        if since_ns is not None:
            clauses.append("start_ns >= ?")
            values.append(int(since_ns))
        if until_ns is not None:
            clauses.append("start_ns < ?")
            values.append(int(until_ns))
        if bus is not None:
            clauses.append("bus = ?")
            values.append(bus)
        where = " WHERE " + " AND ".join(clauses) if clauses else ""
        sql = ("SELECT session_id, start_ns, end_ns, bus, messages, words, load_percent, "
               f"errors FROM bus_stats{where} ORDER BY start_ns DESC, bus DESC")
        if limit is not None:
            sql += " LIMIT ?"
            values.append(int(limit))
        rows = [StatsRow(session_id=r[0], start_ns=r[1], end_ns=r[2], bus=r[3], messages=r[4],
                         words=r[5], load_percent=r[6], errors=json.loads(r[7]))
                for r in self._rows(sql, values)]
        return rows[::-1]

    def rt_stats(self, since_ns: int | None = None,
                 until_ns: int | None = None) -> list[rt_stats.RtStatsRow]:
        """Per-RT/SA statistics over the intervals starting in the range, one row per key
        (none from a catalog older than the ``rt_stats`` table)."""
        if self.schema_version < rt_stats.RT_STATS_SINCE:
            return []
        try:
            return rt_stats.summary(self._conn, since_ns, until_ns)
        except sqlite3.DatabaseError as error:
            raise CatalogError(f"read failed: {describe(error)}", path=self.path) from error

    def gaps(self, since_ns: int | None = None, until_ns: int | None = None) -> list[Gap]:
        """Monitoring gaps overlapping the range, oldest first."""
        clauses: list[str] = []
        values: list[Any] = []
        if since_ns is not None:
            clauses.append("coalesce(end_ns, start_ns) >= ?")
            values.append(int(since_ns))
        if until_ns is not None:
            clauses.append("start_ns < ?")
            values.append(int(until_ns))
        where = " WHERE " + " AND ".join(clauses) if clauses else ""
        return [Gap(*row) for row in self._rows(
            f"SELECT id, session_id, start_ns, end_ns, reason FROM gaps{where} "
            "ORDER BY start_ns, id", values)]

    def integrity(self) -> str:
        """``PRAGMA quick_check``'s verdict (``ok`` for a sound file)."""
        return "; ".join(str(r[0]) for r in self._rows("PRAGMA quick_check"))

    # --- lifetime ----------------------------------------------------------------------
    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> CatalogReader:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
