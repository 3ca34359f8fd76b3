"""Fault episodes in the catalog file: rows to :class:`~.episodes.Episode` and back, the
queries ``mapr catalog episodes`` runs, and the one write the CLI makes (acknowledgment).

The writer calls :func:`load_open` and :func:`save` inside the transaction that stores a batch
of BITs, so an episode and the events that point at it are committed together.

:func:`acknowledge` is the CLI's only write. It is safe beside a running daemon: the file is
in WAL mode, the acknowledgment is one short ``BEGIN IMMEDIATE`` transaction that waits up to
the busy timeout (:data:`~.connect.BUSY_TIMEOUT_MS`) for the daemon's write lock, and the
daemon's episode updates never write the acknowledgment columns; both sides re-read the row
under the lock, so neither overwrites the other.
"""

from __future__ import annotations

import json
import os
import sqlite3
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from mapr_daemon.catalog.connect import BUSY_TIMEOUT_MS, describe
from mapr_daemon.catalog.episodes import Episode
from mapr_daemon.catalog.schema import check_readable
from mapr_daemon.errors import CatalogError, EpisodeError
from mapr_daemon.utc import fmt_time

EPISODES_SINCE = 4
"""Schema version that added the ``episodes`` table and ``events.episode_id``."""

COLUMNS = ("id, asset, part, mode, modes, opened_ns, last_ns, closed_ns, bits, span_bits, "
           "clear_bits, sev_first, sev_last, sev_min, sev_max, fit_n, fit_sx, fit_sy, fit_sxx, "
           "fit_sxy, acked_by, acked_ns, ack_note")
MAX_NAME = 200
"""Longest ``--by`` name and (times 20) ``--note`` accepted."""


def from_row(row: tuple[Any, ...]) -> Episode:
    (eid, asset, part, mode, modes, opened_ns, last_ns, closed_ns, bits, span, clear,
     sev_first, sev_last, sev_min, sev_max, n, sx, sy, sxx, sxy, by, at, note) = row
    return Episode(id=eid, asset=asset, part=part, mode=mode, modes=tuple(json.loads(modes)),
                   opened_ns=opened_ns, last_ns=last_ns, closed_ns=closed_ns, bits=bits,
                   span=span, clear=clear, sev_first=sev_first, sev_last=sev_last,
                   sev_min=sev_min, sev_max=sev_max, fit=(n, sx, sy, sxx, sxy),
                   acked_by=by, acked_ns=at, ack_note=note)


def load_open(conn: sqlite3.Connection) -> dict[tuple[str, str], Episode]:
    """Every open episode, keyed by ``(asset, part)``."""
    rows = conn.execute(f"SELECT {COLUMNS} FROM episodes WHERE closed_ns IS NULL")
    return {(ep.asset, ep.part): ep for ep in map(from_row, rows)}


def next_id(conn: sqlite3.Connection) -> int:
    """The first free episode id (under the write lock it is the writer's to give)."""
    return int(conn.execute("SELECT coalesce(max(id), 0) + 1 FROM episodes").fetchone()[0])


def save(conn: sqlite3.Connection, episodes: Iterable[Episode], first_new: int) -> None:
    """Insert the episodes with ids >= ``first_new``, update the others' trend columns (never
    the acknowledgment's)."""
    new, old = [], []
    for ep in episodes:
        trend = (ep.mode, json.dumps(list(ep.modes)), ep.last_ns, ep.closed_ns, ep.bits,
                 ep.span, ep.clear, ep.sev_first, ep.sev_last, ep.sev_min, ep.sev_max,
                 *ep.fit)
        if ep.id >= first_new:
            new.append((ep.id, ep.asset, ep.part, ep.opened_ns, *trend))
        else:
            old.append((*trend, ep.id))
    if new:
        conn.executemany(
            "INSERT INTO episodes (id, asset, part, opened_ns, mode, modes, last_ns, closed_ns,"
            " bits, span_bits, clear_bits, sev_first, sev_last, sev_min, sev_max, fit_n,"
            " fit_sx, fit_sy, fit_sxx, fit_sxy)"
            " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", new)
    if old:
        conn.executemany(
            "UPDATE episodes SET mode = ?, modes = ?, last_ns = ?, closed_ns = ?, bits = ?,"
            " span_bits = ?, clear_bits = ?, sev_first = ?, sev_last = ?, sev_min = ?,"
            " sev_max = ?, fit_n = ?, fit_sx = ?, fit_sy = ?, fit_sxx = ?, fit_sxy = ?"
            " WHERE id = ?", old)


def select(conn: sqlite3.Connection, *, open_only: bool = False, asset: str | None = None
           ) -> list[Episode]:
    """Episodes, most recently active first (fixed SQL; the asset is a bound value)."""
    clauses, values = [], []
    if open_only:
        clauses.append("closed_ns IS NULL")
    if asset is not None:
        clauses.append("asset = ?")
        values.append(asset)
    where = " WHERE " + " AND ".join(clauses) if clauses else ""
    return [from_row(r) for r in conn.execute(
        f"SELECT {COLUMNS} FROM episodes{where} ORDER BY last_ns DESC, id DESC", values)]


def acknowledge(path: str | os.PathLike[str], episode_id: int, by: str, note: str | None,
                at_ns: int) -> Episode:
    """Record that ``by`` acknowledged the episode at ``at_ns`` (epoch ns, UTC), with a note.

    Raises :class:`EpisodeError` for an unknown id or one already acknowledged (the first
    acknowledgment stands), :class:`CatalogError` when the file cannot be written.
    """
    name = os.fspath(path)
    who = by.strip()
    if not who or len(who) > MAX_NAME:
        raise EpisodeError(f"--by must name who acknowledges (1..{MAX_NAME} characters)")
    if note is not None and len(note) > 20 * MAX_NAME:
        raise EpisodeError(f"--note is longer than {20 * MAX_NAME} characters")
    if not Path(name).is_file():
        raise CatalogError("no such file (--catalog or MAPR_CATALOG)", path=name)
    try:
        conn = sqlite3.connect(f"{Path(name).resolve().as_uri()}?mode=rw", uri=True,
                               isolation_level=None, timeout=BUSY_TIMEOUT_MS / 1000)
    except sqlite3.Error as error:
        raise CatalogError(f"cannot open for writing: {describe(error)}", path=name) from error
    try:
        conn.execute(f"PRAGMA busy_timeout = {BUSY_TIMEOUT_MS:d}")
        conn.execute("BEGIN IMMEDIATE")
        try:
            episode = _acknowledge(conn, name, episode_id, who, note, at_ns)
            conn.execute("COMMIT")
        except BaseException:
            if conn.in_transaction:
                conn.execute("ROLLBACK")
            raise
        return episode
    except sqlite3.Error as error:
        if getattr(error, "sqlite_errorcode", None) in _BUSY:
            hint = (f"another writer held the file for over {BUSY_TIMEOUT_MS // 1000} s; "
                    "try again")
        else:
            hint = ("it needs write access to the file and its directory: run as the "
                    "service user or a member of its group")
        raise CatalogError(f"cannot write the acknowledgment: {describe(error)} ({hint})",
                           path=name) from error
    finally:
        conn.close()


_BUSY = {getattr(sqlite3, "SQLITE_BUSY", 5), getattr(sqlite3, "SQLITE_LOCKED", 6)}


def _acknowledge(conn: sqlite3.Connection, name: str, episode_id: int, who: str,
                 note: str | None, at_ns: int) -> Episode:
    version = check_readable(conn, name)
    if version < EPISODES_SINCE:
        raise EpisodeError(f"no episode {episode_id}: the catalog is schema v{version}, from "
                           "before episodes (the daemon or mapr replay migrates it)")
    rows = conn.execute(f"SELECT {COLUMNS} FROM episodes WHERE id = ?",
                        (int(episode_id),)).fetchall()
    if not rows:
        raise EpisodeError(f"no episode {episode_id} in {name}")
    episode = from_row(rows[0])
    if episode.acked_by is not None:
        raise EpisodeError(f"episode {episode_id} was already acknowledged by "
                           f"{episode.acked_by} at {fmt_time(episode.acked_ns)}")
    conn.execute("UPDATE episodes SET acked_by = ?, acked_ns = ?, ack_note = ? "
                 "WHERE id = ? AND acked_by IS NULL", (who, int(at_ns), note, episode.id))
    return from_row(conn.execute(f"SELECT {COLUMNS} FROM episodes WHERE id = ?",
                                 (episode.id,)).fetchone())
