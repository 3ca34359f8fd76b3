"""The catalog's schema, versioned with ``PRAGMA user_version`` and migrated forward.

:data:`MIGRATIONS` is the whole history: step *n* takes a file from version *n-1* to *n*.
A step is only ever appended, never edited, so a file written by any earlier MAPR is brought
up to date by running the steps it lacks, each in its own transaction together with the
``user_version`` bump (SQLite keeps the header in the same transaction, so a crash mid-step
leaves the file at the previous version, never half-migrated). A file from a *newer* MAPR is
refused rather than guessed at. ``PRAGMA application_id`` marks the file as a MAPR catalog so
an unrelated SQLite file is told apart from an empty one.

History:

1. sessions, events, bus_stats, gaps.
2. indexes for the CLI filters (time, asset, fault; stats and gaps by time) and
   ``sessions.stop_reason`` (why a run ended; ``unclean`` when it was killed).
3. ``events.bus_ns`` and ``events.abs_ns``: an event's bus time and absolute time
   (:class:`~mapr_daemon.catalog.model.Event`). Events written before stay NULL in both:
   their ``t_ns`` was the daemon's wall clock at write, or a replay's rounded recording
   time, and neither is a bus time.
4. ``episodes`` (:mod:`~mapr_daemon.catalog.episodes`: one persistent fault of one
   actuator's part across BITs, its severity trend and its acknowledgment) and
   ``events.episode_id``. Events written before keep it NULL: the BITs that found the
   actuator nominal were never stored, so their episodes cannot be rebuilt.
5. ``bits``: every diagnosed BIT of every actuator (nominal ones too) with its flight, its
   per-kind degradation estimates and the health the trend gave after it (SoH, leading mode,
   RUL with its interval in flights and flight hours); ``flights``: each aircraft's flights
   (tail, number, span, hours); ``events.flight``. Catalogs from before start their BIT
   history empty.
6. ``rt_stats`` (:mod:`~mapr_daemon.catalog.rt_stats`): per interval, one row per RT /
   direction / subaddress or mode code: messages, errors by class, response-time sums and
   extremes, last bus time seen. Sessions before have none.
7. ``recordings`` (:mod:`~mapr_daemon.catalog.recordings`): each archive recording a fleet
   run stored, by content digest, with its tail, flight, flight hours, status and the config
   it was processed with; what makes a fleet run idempotent and resumable.
8. ``bits.conditions``: the flight condition each BIT was flown at (dynamic pressure,
   aircraft-bus voltage, ambient temperature), which the trend weighs its estimates by
   (:mod:`~mapr_daemon.reasoner.prognosis.wear_noise`). BITs stored before keep ``{}`` and are
   weighed by the envelope-wide noise.
9. ``inflight`` (:mod:`~mapr_daemon.catalog.inflight`): each actuator's per-flight in-flight
   estimate (the EKF on the traffic between BITs): per trended parameter its value, sd,
   change from the unit's baseline and unit, and how much of the flight qualified. One row
   per tail, actuator and flight (a rerun replaces it). Catalogs from before have none.
10. ``bits.wear_source``: per aging kind, which path read the BIT's wear: the prognostic
    model's estimators, or the unit's commissioned baseline (the record's digest and the
    offset and sd its reading is weighed by;
    :mod:`~mapr_daemon.reasoner.prognosis.wear_paths`). BITs stored before keep ``{}``:
    not known, taken as read by the path the asset has when the trend is rebuilt.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Sequence

from mapr_daemon.errors import CatalogError

APPLICATION_ID = 0x4D415052
"""``PRAGMA application_id`` of a MAPR catalog: "MAPR" in ASCII."""

MIGRATIONS: tuple[tuple[str, ...], ...] = (
    (  # 1: the tables
        f"PRAGMA application_id = {APPLICATION_ID}",
        """CREATE TABLE sessions (
            id INTEGER PRIMARY KEY,
            started_ns INTEGER NOT NULL,
            stopped_ns INTEGER,
            backend TEXT NOT NULL,
            config_hash TEXT NOT NULL,
            software_version TEXT NOT NULL)""",
        """CREATE TABLE events (
            id INTEGER PRIMARY KEY,
            session_id INTEGER NOT NULL REFERENCES sessions(id),
            t_ns INTEGER NOT NULL,
            asset TEXT NOT NULL,
            rt INTEGER,
            fault TEXT NOT NULL,
            switch TEXT,
            severity REAL,
            severity_value REAL,
            severity_unit TEXT,
            confidence REAL NOT NULL,
            params TEXT NOT NULL DEFAULT '{}',
            soh REAL,
            rul REAL,
            rul_low REAL,
            rul_high REAL,
            rul_unit TEXT,
            evidence TEXT NOT NULL DEFAULT '{}')""",
        """CREATE TABLE bus_stats (
            id INTEGER PRIMARY KEY,
            session_id INTEGER NOT NULL REFERENCES sessions(id),
            start_ns INTEGER NOT NULL,
            end_ns INTEGER NOT NULL,
            bus TEXT NOT NULL,
            messages INTEGER NOT NULL,
            words INTEGER NOT NULL,
            load_percent REAL NOT NULL,
            errors_total INTEGER NOT NULL,
            errors TEXT NOT NULL DEFAULT '{}')""",
        """CREATE TABLE gaps (
            id INTEGER PRIMARY KEY,
            session_id INTEGER REFERENCES sessions(id),
            start_ns INTEGER NOT NULL,
            end_ns INTEGER,
            reason TEXT NOT NULL)""",
    ),
    (  # 2: indexes for the CLI's filters; why a session ended
        "CREATE INDEX events_t ON events(t_ns)",
        "CREATE INDEX events_asset_t ON events(asset, t_ns)",
        "CREATE INDEX events_fault_t ON events(fault, t_ns)",
        "CREATE INDEX bus_stats_t ON bus_stats(start_ns)",
        "CREATE INDEX gaps_t ON gaps(start_ns)",
        "ALTER TABLE sessions ADD COLUMN stop_reason TEXT",
    ),
    (  # 3: an event's bus time and absolute time
        "ALTER TABLE events ADD COLUMN bus_ns INTEGER",
        "ALTER TABLE events ADD COLUMN abs_ns INTEGER",
    ),
    (  # 4: fault episodes and their acknowledgment
        """CREATE TABLE episodes (
            id INTEGER PRIMARY KEY,
            asset TEXT NOT NULL,
            part TEXT NOT NULL,
            mode TEXT NOT NULL,
            modes TEXT NOT NULL,
            opened_ns INTEGER NOT NULL,
            last_ns INTEGER NOT NULL,
            closed_ns INTEGER,
            bits INTEGER NOT NULL,
            span_bits INTEGER NOT NULL,
            clear_bits INTEGER NOT NULL,
            sev_first REAL,
            sev_last REAL,
            sev_min REAL,
            sev_max REAL,
            fit_n REAL NOT NULL DEFAULT 0,
            fit_sx REAL NOT NULL DEFAULT 0,
            fit_sy REAL NOT NULL DEFAULT 0,
            fit_sxx REAL NOT NULL DEFAULT 0,
            fit_sxy REAL NOT NULL DEFAULT 0,
            acked_by TEXT,
            acked_ns INTEGER,
            ack_note TEXT)""",
        "CREATE INDEX episodes_open ON episodes(asset, part) WHERE closed_ns IS NULL",
        "ALTER TABLE events ADD COLUMN episode_id INTEGER REFERENCES episodes(id)",
        "CREATE INDEX events_episode ON events(episode_id)",
    ),
    (  # 5: BIT history with health, and flights
        """CREATE TABLE bits (
            id INTEGER PRIMARY KEY,
            session_id INTEGER REFERENCES sessions(id),
            tail TEXT NOT NULL DEFAULT '',
            asset TEXT NOT NULL,
            t_ns INTEGER NOT NULL,
            bus_ns INTEGER,
            abs_ns INTEGER,
            flight INTEGER,
            flight_hours REAL,
            fault TEXT,
            event_id INTEGER REFERENCES events(id),
            wear TEXT NOT NULL DEFAULT '{}',
            mode TEXT,
            soh REAL,
            rul REAL,
            rul_low REAL,
            rul_high REAL,
            rul_hours REAL,
            rul_hours_low REAL,
            rul_hours_high REAL,
            note TEXT,
            modes TEXT NOT NULL DEFAULT '{}')""",
        "CREATE INDEX bits_asset ON bits(tail, asset, flight, t_ns)",
        """CREATE TABLE flights (
            tail TEXT NOT NULL DEFAULT '',
            flight INTEGER NOT NULL,
            start_ns INTEGER,
            end_ns INTEGER,
            hours REAL NOT NULL,
            source TEXT NOT NULL,
            PRIMARY KEY (tail, flight))""",
        "ALTER TABLE events ADD COLUMN flight INTEGER",
    ),
    (  # 6: per-RT/SA statistics per interval
        """CREATE TABLE rt_stats (
            id INTEGER PRIMARY KEY,
            session_id INTEGER NOT NULL REFERENCES sessions(id),
            start_ns INTEGER NOT NULL,
            end_ns INTEGER NOT NULL,
            rt INTEGER NOT NULL,
            tr TEXT NOT NULL,
            sa INTEGER NOT NULL,
            mode_code INTEGER,
            wc INTEGER,
            messages INTEGER NOT NULL,
            errors_total INTEGER NOT NULL,
            errors TEXT NOT NULL DEFAULT '{}',
            responses INTEGER NOT NULL,
            response_sum_ns INTEGER NOT NULL,
            response_min_ns INTEGER,
            response_max_ns INTEGER,
            last_bus_ns INTEGER NOT NULL)""",
        "CREATE INDEX rt_stats_t ON rt_stats(start_ns)",
    ),
    (  # 7: the recordings a fleet run stored (catalog/recordings.py)
        """CREATE TABLE recordings (
            id INTEGER PRIMARY KEY,
            digest TEXT NOT NULL UNIQUE,
            path TEXT NOT NULL,
            tail TEXT NOT NULL,
            flight INTEGER NOT NULL,
            flight_hours REAL,
            status TEXT NOT NULL,
            error TEXT,
            bits INTEGER NOT NULL DEFAULT 0,
            events INTEGER NOT NULL DEFAULT 0,
            session_id INTEGER REFERENCES sessions(id),
            processed_ns INTEGER NOT NULL,
            config_digest TEXT NOT NULL)""",
        "CREATE INDEX recordings_tail_flight ON recordings(tail, flight)",
    ),
    (  # 8: each BIT's flight condition (reasoner/prognosis/wear_noise.py)
        "ALTER TABLE bits ADD COLUMN conditions TEXT NOT NULL DEFAULT '{}'",
    ),
    (  # 9: per-flight in-flight estimates (catalog/inflight.py)
        """CREATE TABLE inflight (
            id INTEGER PRIMARY KEY,
            session_id INTEGER REFERENCES sessions(id),
            tail TEXT NOT NULL DEFAULT '',
            asset TEXT NOT NULL,
            flight INTEGER,
            t_ns INTEGER NOT NULL,
            flight_s REAL NOT NULL,
            filtered_s REAL NOT NULL,
            parameters TEXT NOT NULL DEFAULT '{}',
            qualified TEXT NOT NULL DEFAULT '{}')""",
        "CREATE UNIQUE INDEX inflight_flight ON inflight(tail, asset, flight)",
    ),
    (  # 10: which path read each BIT's wear (reasoner/prognosis/wear_paths.py)
        "ALTER TABLE bits ADD COLUMN wear_source TEXT NOT NULL DEFAULT '{}'",
    ),
)

LATEST = len(MIGRATIONS)
"""The schema version this program writes."""


def version_of(conn: sqlite3.Connection) -> int:
    """The file's ``PRAGMA user_version`` (0 for a new, empty file)."""
    return int(conn.execute("PRAGMA user_version").fetchone()[0])


def check_readable(conn: sqlite3.Connection, path: str) -> int:
    """The file's schema version, after checking this program can read it.

    Raises :class:`CatalogError` for a file that is not a MAPR catalog, or one that a newer
    MAPR wrote.
    """
    version = version_of(conn)
    app = int(conn.execute("PRAGMA application_id").fetchone()[0])
    if version == 0 or app != APPLICATION_ID:
        raise CatalogError("not a MAPR fault catalog (no catalog schema in this SQLite file)",
                           path=path)
    if version > LATEST:
        raise CatalogError(f"written by a newer MAPR (schema v{version}; this program knows "
                           f"up to v{LATEST})", path=path)
    return version


def migrate(conn: sqlite3.Connection, path: str,
            steps: Sequence[tuple[str, ...]] = MIGRATIONS) -> int:
    """Bring the file up to ``len(steps)``; returns the version it had before.

    ``conn`` must be in autocommit mode (``isolation_level=None``). ``steps`` is only ever
    shortened by tests, to write a file as an older MAPR did.
    """
    conn.execute("BEGIN IMMEDIATE")  # the write lock, so two writers do not both migrate
    try:
        before = version_of(conn)
        if before == 0:
            tables = conn.execute("SELECT count(*) FROM sqlite_schema").fetchone()[0]
            if tables:
                raise CatalogError("not a MAPR fault catalog (an SQLite file with other "
                                   "tables)", path=path)
        else:
            check_readable(conn, path)
        conn.execute("COMMIT")
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    for version in range(before + 1, len(steps) + 1):
        conn.execute("BEGIN IMMEDIATE")
        try:
            if version_of(conn) >= version:  # another writer got there first
                conn.execute("COMMIT")
                continue
            for statement in steps[version - 1]:
                conn.execute(statement)
            conn.execute(f"PRAGMA user_version = {version:d}")
            conn.execute("COMMIT")
        except BaseException:
            conn.execute("ROLLBACK")
            raise
    return before
