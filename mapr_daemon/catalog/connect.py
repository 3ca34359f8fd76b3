"""Opening the catalog file: the daemon's read-write connection and the CLI's read-only one.

Writer (the daemon, one process). WAL journal, so readers never block it nor it them, and
``synchronous`` set by the durability the caller asks for:

- ``"power-loss"`` -> ``synchronous=FULL``: the WAL is fsynced at every commit, so a commit
  that has returned survives kill -9 *and* a power cut or kernel panic. The default.
- ``"crash"`` -> ``synchronous=NORMAL``: the WAL is fsynced only at checkpoints, so a
  returned commit survives the process being killed (the data is in the OS page cache) but
  the last commits may roll back if the machine loses power. Faster on slow flash.

The database stays consistent in both cases; only the *durability* of the latest commits
differs.

Reader (the CLI). ``file:...?mode=ro`` in autocommit, plus ``PRAGMA query_only``. It reads
while the daemon writes (WAL readers see the last commit). The trap: once the daemon has
closed cleanly SQLite removes ``-wal`` and ``-shm``, and a read-only connection must
re-create ``-shm`` to read a WAL-mode file; in a directory the reader cannot write (the
service's StateDirectory, owned by ``mapr``) that fails with *attempt to write a readonly
database* (SQLITE_READONLY_DIRECTORY). Then nobody is writing the file and there is no WAL
to miss, so the reader reopens it with ``immutable=1``, which needs neither file. If a
non-empty ``-wal`` is there but cannot be used, the reader refuses (an immutable read would
silently miss committed events) and says why.
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path
from typing import Literal

from mapr_daemon.catalog.schema import check_readable, migrate
from mapr_daemon.errors import CatalogError

Durability = Literal["power-loss", "crash"]
SYNCHRONOUS: dict[str, str] = {"power-loss": "FULL", "crash": "NORMAL"}
BUSY_TIMEOUT_MS = 5000


def describe(error: sqlite3.Error) -> str:
    """SQLite's message, with its error name when Python gives one."""
    name = getattr(error, "sqlite_errorname", None)
    return f"{error} ({name})" if name else str(error)


def open_writer(path: str | os.PathLike[str], durability: Durability = "power-loss",
                ) -> sqlite3.Connection:
    """A read-write connection in WAL mode, the schema migrated to the latest version.

    Creates the file if needed (not its directory: that is the service's StateDirectory).
    The connection is in autocommit mode; the writer issues its own BEGIN/COMMIT.
    """
    name = os.fspath(path)
    if durability not in SYNCHRONOUS:
        raise ValueError(f"durability must be one of {sorted(SYNCHRONOUS)}")
    if not Path(name).parent.is_dir():
        raise CatalogError(f"directory {Path(name).parent} does not exist", path=name)
    try:
        _create_private(name)
        conn = sqlite3.connect(name, isolation_level=None, timeout=BUSY_TIMEOUT_MS / 1000)
    except OSError as error:
        raise CatalogError(f"cannot create: {error.strerror}", path=name) from error
    except sqlite3.Error as error:
        raise CatalogError(f"cannot open: {describe(error)}", path=name) from error
    try:
        mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
        if str(mode).lower() != "wal":
            raise CatalogError(f"cannot switch to WAL journal (got {mode})", path=name)
        conn.execute(f"PRAGMA synchronous = {SYNCHRONOUS[durability]}")
        conn.execute("PRAGMA foreign_keys = ON")
        migrate(conn, name)
    except sqlite3.DatabaseError as error:
        conn.close()
        raise CatalogError(f"unusable: {describe(error)}", path=name) from error
    except BaseException:
        conn.close()
        raise
    return conn


FILE_MODE = 0o640
"""A new catalog's mode (the process umask can only make it stricter): fault data is for the
daemon's user and group, not every local user. SQLite gives ``-wal`` and ``-shm`` the
database file's mode."""


def _create_private(name: str) -> None:
    """Create the catalog file with :data:`FILE_MODE` if it does not exist yet (SQLite would
    create it 0644 less the umask: world-readable outside systemd's ``UMask=0027``). An
    existing file keeps the mode its owner gave it."""
    try:
        fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, FILE_MODE)
    except FileExistsError:
        return
    os.close(fd)


def _uri(path: Path, query: str) -> str:
    return f"{path.resolve().as_uri()}?{query}"


def open_reader(path: str | os.PathLike[str]) -> tuple[sqlite3.Connection, str, int]:
    """A read-only connection: ``(connection, mode, schema version)``.

    ``mode`` is ``"ro"`` or ``"immutable"`` (the fallback described in the module docstring).
    Raises :class:`CatalogError`, naming the file, when it is missing, unreadable, corrupt,
    not a catalog, or from a newer MAPR.
    """
    name = os.fspath(path)
    file = Path(name)
    if not file.exists():
        raise CatalogError("no such file (is the daemon configured to write here? "
                           "--catalog or MAPR_CATALOG)", path=name)
    if not file.is_file():
        raise CatalogError("not a regular file", path=name)
    if not os.access(file, os.R_OK):
        raise CatalogError("permission denied (add yourself to the catalog's group)", path=name)
    try:
        return _try_open(file, name, "mode=ro", "ro")
    except sqlite3.OperationalError as error:
        if getattr(error, "sqlite_errorcode", None) not in _READONLY_TRAP:
            raise CatalogError(f"unreadable: {describe(error)}", path=name) from error
        wal = Path(name + "-wal")
        if wal.exists() and wal.stat().st_size > 0:
            raise CatalogError(f"cannot read its write-ahead log {wal.name} (no -shm and the "
                               "directory is read-only): run once as the service user, or "
                               "give the group write access to the directory",
                               path=name) from error
    except sqlite3.DatabaseError as error:
        raise CatalogError(f"corrupt or not SQLite: {describe(error)}", path=name) from error
    try:
        return _try_open(file, name, "mode=ro&immutable=1", "immutable")
    except sqlite3.DatabaseError as error:
        raise CatalogError(f"unreadable: {describe(error)}", path=name) from error


_READONLY_TRAP = {
    getattr(sqlite3, "SQLITE_READONLY_DIRECTORY", 1544),
    getattr(sqlite3, "SQLITE_READONLY", 8),
    getattr(sqlite3, "SQLITE_CANTOPEN", 14),
    getattr(sqlite3, "SQLITE_READONLY_CANTINIT", 1288),
}
"""Extended result codes of the read-only trap (names as Python 3.11 exports them)."""


def _try_open(file: Path, name: str, query: str, mode: str
              ) -> tuple[sqlite3.Connection, str, int]:
    conn = sqlite3.connect(_uri(file, query), uri=True, isolation_level=None,
                           timeout=BUSY_TIMEOUT_MS / 1000)
    try:
        conn.execute("PRAGMA query_only = 1")
        version = check_readable(conn, name)  # the first read: where the trap springs
    except BaseException:
        conn.close()
        raise
    return conn, mode, version
