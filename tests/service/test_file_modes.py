"""The catalog and the recordings the daemon creates are not world-readable, whatever the
process umask (systemd's UMask= covers only the unit; a daemon started by hand or from a
script inherits whatever umask its shell had)."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.service.recorder import SessionRecorder


def mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


@pytest.fixture
def permissive_umask() -> Iterator[None]:
    old = os.umask(0)
    try:
        yield
    finally:
        os.umask(old)


def records() -> list[MonitorRecord]:
    command = 5 << 11 | 1 << 5 | 2
    return [MonitorRecord(i * 1_000_000, "A", TransferFormat.BC_RT, command, data=(i, i + 1),
                          status=(5 << 11,), gaps_ns=(6_000,)) for i in range(10)]


def test_a_new_catalog_and_its_wal_are_0640(tmp_path: Path, permissive_umask: None) -> None:
    path = tmp_path / "catalog.sqlite"
    writer = CatalogWriter(path)
    try:
        writer.open_session(backend="loopback", config_hash="x")
        files = [p for p in tmp_path.iterdir() if p.name.startswith("catalog.sqlite")]
        assert path in files and len(files) >= 2   # the database and its -wal (and -shm)
        assert {p.name: mode(p) for p in files} == {p.name: 0o640 for p in files}
    finally:
        writer.close()
    assert mode(path) == 0o640


def test_an_existing_catalog_keeps_its_mode(tmp_path: Path, permissive_umask: None) -> None:
    path = tmp_path / "catalog.sqlite"
    CatalogWriter(path).close()
    path.chmod(0o600)
    CatalogWriter(path).close()
    assert mode(path) == 0o600


def test_a_stricter_umask_is_kept(tmp_path: Path) -> None:
    old = os.umask(0o077)
    try:
        CatalogWriter(tmp_path / "catalog.sqlite").close()
        with Chapter10Writer(tmp_path / "flight.c10") as writer:
            writer.write(records())
    finally:
        os.umask(old)
    assert mode(tmp_path / "catalog.sqlite") == 0o600
    assert mode(tmp_path / "flight.c10") == 0o600


def test_a_recording_is_0640(tmp_path: Path, permissive_umask: None) -> None:
    with Chapter10Writer(tmp_path / "flight.c10") as writer:
        writer.write(records())
    assert mode(tmp_path / "flight.c10") == 0o640


def test_the_daemon_recording_directory_and_files(tmp_path: Path,
                                                  permissive_umask: None) -> None:
    directory = tmp_path / "flights"
    recorder = SessionRecorder(str(directory), 7)
    recorder.write(records())
    recorder.close()
    assert not recorder.failed
    (path,) = recorder.files
    assert mode(directory) == 0o750
    assert mode(path) == 0o640
