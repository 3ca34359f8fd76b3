"""The CLI's read-only connection: while a writer writes, and after it has gone.

The trap (STYLE.md): once the writer has closed, SQLite has removed ``-wal`` and ``-shm``;
``file:...?mode=ro`` must re-create ``-shm`` and, in a directory the reader cannot write,
fails with "attempt to write a readonly database". The reader falls back to ``immutable=1``.
The read-only directory is real: ``chmod 555``, and when the tests run as root (which
ignores file modes) the reader process also drops CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH
from its capability bounding set before it starts, so it is refused like any other user.
"""

from __future__ import annotations

import ctypes
import json
import os
import random
import signal
import sqlite3
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from mapr_daemon.catalog import CatalogReader, CatalogWriter

from .conftest import random_events

ROOT = Path(__file__).resolve().parents[2]
WRITER = Path(__file__).with_name("writer_proc.py")
PR_CAPBSET_DROP, CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH = 24, 1, 2

PROBE = """
import json, sqlite3, sys
from mapr_daemon.catalog import CatalogReader
path = sys.argv[1]
try:
    sqlite3.connect(f"file:{path}?mode=ro", uri=True).execute("SELECT 1 FROM events")
    plain = "ok"
except sqlite3.Error as error:
    plain = str(error)
with CatalogReader(path) as reader:
    print(json.dumps({"plain_ro": plain, "mode": reader.mode,
                      "ids": sorted(e.id for e in reader.events())}))
"""


def _drop_dac_capabilities() -> None:
    libc = ctypes.CDLL(None, use_errno=True)
    for cap in (CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH):
        if libc.prctl(PR_CAPBSET_DROP, cap, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")


def as_unprivileged(args: list[str]) -> subprocess.CompletedProcess[str]:
    """Run ``args`` so that file modes apply to it, also under root."""
    pre: Callable[[], None] | None = _drop_dac_capabilities if os.geteuid() == 0 else None
    return subprocess.run(args, capture_output=True, text=True, timeout=60, check=False,
                          cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)},
                          preexec_fn=pre)


@pytest.fixture
def readonly_dir(tmp_path: Path) -> Iterator[Path]:
    folder = tmp_path / "state"
    folder.mkdir()
    yield folder
    folder.chmod(0o755)


def _lock(folder: Path) -> None:
    folder.chmod(0o555)
    try:
        probe = as_unprivileged([sys.executable, "-c",
                                 f"open({str(folder / 'probe')!r}, 'w')"])
    except (OSError, subprocess.SubprocessError) as error:  # root without CAP_SETPCAP
        folder.chmod(0o755)
        pytest.skip(f"cannot drop root's file-access capabilities here: {error}")
    if probe.returncode == 0:
        folder.chmod(0o755)
        pytest.skip("cannot make a directory read-only for a child process here")


def _closed_catalog(folder: Path) -> Path:
    path = folder / "catalog.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="x")
        writer.add_events(random_events(random.Random(3), 25))
    assert sorted(p.name for p in folder.iterdir()) == ["catalog.sqlite"]  # WAL files gone
    return path


def test_cli_reads_while_a_writer_writes(tmp_path: Path) -> None:
    path = tmp_path / "catalog.sqlite"
    proc = subprocess.Popen([sys.executable, str(WRITER), str(path), "5"],
                            stdout=subprocess.PIPE, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.stdout is not None
    try:
        reported = {int(x) for _ in range(5) for x in proc.stdout.readline().split()}
        with CatalogReader(path) as reader:
            assert reader.mode == "ro"
            assert reported <= {e.id for e in reader.iter_events()}
        listed = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "catalog",
                                 "list", "--json", "--limit", "0", "--catalog", str(path)],
                                cwd=ROOT, capture_output=True, text=True, timeout=60,
                                check=False)
        assert listed.returncode == 0, listed.stderr
        assert reported <= {row["id"] for row in json.loads(listed.stdout)}
        assert proc.poll() is None  # the writer was writing all along
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.communicate(timeout=30)


def test_after_the_writer_stopped_in_a_writable_directory(tmp_path: Path) -> None:
    path = _closed_catalog(tmp_path)
    result = as_unprivileged([sys.executable, "-c", PROBE, str(path)])
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout)
    assert (seen["plain_ro"], seen["mode"], seen["ids"]) == ("ok", "ro", list(range(1, 26)))


def test_after_the_writer_stopped_in_a_readonly_directory(readonly_dir: Path) -> None:
    path = _closed_catalog(readonly_dir)
    _lock(readonly_dir)
    result = as_unprivileged([sys.executable, "-c", PROBE, str(path)])
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout)
    assert seen["plain_ro"] == "attempt to write a readonly database"  # the trap is real here
    assert (seen["mode"], seen["ids"]) == ("immutable", list(range(1, 26)))
    cli = as_unprivileged([sys.executable, "-m", "mapr_daemon.cli.main", "catalog", "list",
                           "--limit", "0", "--catalog", str(path)])
    assert cli.returncode == 0, cli.stderr
    assert len(cli.stdout.splitlines()) == 26


def test_after_a_kill_in_a_readonly_directory(readonly_dir: Path) -> None:
    """Killed writer: -wal and -shm are left; the reader must see the WAL's commits."""
    path = readonly_dir / "catalog.sqlite"
    proc = subprocess.Popen([sys.executable, str(WRITER), str(path), "9"],
                            stdout=subprocess.PIPE, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.stdout is not None
    reported = {int(x) for _ in range(8) for x in proc.stdout.readline().split()}
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=30)
    assert Path(f"{path}-wal").stat().st_size > 0
    _lock(readonly_dir)
    result = as_unprivileged([sys.executable, "-c", PROBE, str(path)])
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout)
    assert seen["mode"] == "ro" and reported <= set(seen["ids"])
    readonly_dir.chmod(0o755)
    with sqlite3.connect(path) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone() == ("ok",)
