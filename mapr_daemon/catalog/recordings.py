"""The recordings a fleet run stored: what makes ``mapr fleet`` idempotent and resumable.

One row per archive recording (a Chapter 10 file of one flight of one tail), keyed by the
SHA-256 of its content, so a file renamed or copied is still the same recording. A
recording's row and its BITs (events, episode updates) are written in ONE transaction
(:func:`store_recording`): after a crash either both are in the catalog or neither is, and a
recording whose row says ``done`` is never stored again, whoever asks. A ``failed`` row (the
file could not be read, the reasoner could not be built) holds the error and no events; the
next run tries that recording again.

A fleet's BITs are stored as the daemon stores them: the ``bits`` row has the actuator's
plain name (``EMA1``) in ``asset`` and the aircraft in ``tail``, with its ``flight`` (what
the trend reloads, per tail, and ``mapr health`` reads). Events and fault episodes have no
tail column, so a fleet's are named ``TAIL/ASSET`` (:func:`fleet_asset`, the name ``mapr
health`` shows): the ``EMA1`` of two tails never share an episode, and ``mapr catalog list
--asset N101/EMA1`` and ``mapr catalog episodes`` are per tail. That choice lives in
:func:`store_recording`.
"""

from __future__ import annotations

import dataclasses
import sqlite3
from collections.abc import Sequence

from mapr_daemon.catalog.inflight import insert_inflight
from mapr_daemon.catalog.model import BitOutcome, Flight, InflightEstimate
from mapr_daemon.catalog.writer import CatalogWriter, now_ns
from mapr_daemon.errors import CatalogError

DONE = "done"
FAILED = "failed"


def fleet_asset(tail: str, asset: str) -> str:
    """The catalog's asset name of ``asset`` on aircraft ``tail``."""
    return f"{tail}/{asset}"


@dataclasses.dataclass(frozen=True)
class RecordingRow:
    """One archive recording as the catalog keeps it."""

    digest: str
    """SHA-256 of the file's bytes (hex)."""
    path: str
    tail: str
    flight: int
    flight_hours: float | None
    status: str
    """:data:`DONE` or :data:`FAILED`."""
    config_digest: str
    """The digest of the configuration it was processed with (:meth:`Config.digest`)."""
    error: str | None = None
    bits: int = 0
    events: int = 0
    processed_ns: int = 0
    """When it was stored (0: now)."""


@dataclasses.dataclass(frozen=True)
class Stored:
    """A recording already in the catalog."""

    status: str
    config_digest: str
    tail: str
    flight: int


def stored(writer: CatalogWriter) -> dict[str, Stored]:
    """Every recording in the catalog, by digest."""
    try:
        rows = writer.conn.execute(
            "SELECT digest, status, config_digest, tail, flight FROM recordings").fetchall()
    except sqlite3.Error as error:
        raise CatalogError(f"cannot read the recordings: {error}", path=writer.path) from error
    return {str(d): Stored(str(s), str(c), str(t), int(f)) for d, s, c, t, f in rows}


def in_fleet(outcome: BitOutcome) -> BitOutcome:
    """The outcome as a fleet catalog stores it: its event under :func:`fleet_asset`."""
    event = outcome.event
    if event is None or not outcome.tail:
        return outcome
    return dataclasses.replace(outcome, event=dataclasses.replace(
        event, asset=fleet_asset(outcome.tail, outcome.asset)))


def _episodes_as(outcome: BitOutcome) -> str:
    return fleet_asset(outcome.tail, outcome.asset) if outcome.tail else outcome.asset


def store_recording(writer: CatalogWriter, row: RecordingRow,
                    outcomes: Sequence[BitOutcome], flights: Sequence[Flight] = (),
                    inflight: Sequence[InflightEstimate] = ()) -> bool:
    """Store one recording's row, its BITs (plain asset and ``tail``; events and episodes
    under ``TAIL/ASSET``), the ``flights`` they were flown on and the flight's ``inflight``
    estimates in one transaction (a recording marked done always has all of them); False
    (nothing written) if the catalog already holds it as done. A failed row is replaced."""
    stamp = row.processed_ns or now_ns()
    session = writer.session_id
    written = False

    def guard(conn: sqlite3.Connection) -> bool:
        nonlocal written
        done = conn.execute("SELECT 1 FROM recordings WHERE digest = ? AND status = ?",
                            (row.digest, DONE)).fetchone()
        if done is not None:
            return False
        conn.execute("DELETE FROM recordings WHERE digest = ?", (row.digest,))
        conn.execute(
            "INSERT INTO recordings (digest, path, tail, flight, flight_hours, status, error, "
            "bits, events, session_id, processed_ns, config_digest) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (row.digest, row.path, row.tail, int(row.flight), row.flight_hours, row.status,
             row.error, int(row.bits), int(row.events), session, stamp, row.config_digest))
        if inflight:
            insert_inflight(conn, session, list(inflight))
        written = True
        return True

    writer.add_bits([in_fleet(o) for o in outcomes], flights, guard=guard,
                    episodes_as=_episodes_as)
    return written
