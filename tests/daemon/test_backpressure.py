"""A reasoner that falls behind: the bounded queue drops and says so (log, STATUS, catalog)
instead of growing. The main loop is simply not run while the reader fills the queue."""

from __future__ import annotations

import socket
import sqlite3
import time
from pathlib import Path

from mapr_daemon.daemon.config import CatalogConfig, Config, TestbedConfig
from mapr_daemon.daemon.notify import Notifier
from mapr_daemon.daemon.service import Service


def test_a_full_queue_drops_and_reports(tmp_path: Path) -> None:
    sock_path = tmp_path / "notify.sock"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(str(sock_path))
        sock.settimeout(2.0)
        config = Config(testbed=TestbedConfig(realtime=False),
                        catalog=CatalogConfig(path=str(tmp_path / "catalog.sqlite")),
                        queue_batches=2, queue_wait_s=0.0)
        service = Service(config, None, Notifier(str(sock_path)))
        service.catalog.open_session(backend="loopback", config_hash=config.digest())
        service._start_reader()
        try:
            deadline = time.monotonic() + 20
            while service.reader is not None and service.reader.dropped == 0:
                assert time.monotonic() < deadline, "the reader never found the queue full"
                time.sleep(0.05)
            assert service.queue.qsize() <= 2
            service._check_dropped()
            status = sock.recv(4096).decode()
        finally:
            service._shutdown()
    assert status.startswith("STATUS=reasoner behind:") and "messages dropped" in status
    with sqlite3.connect(f"file:{tmp_path / 'catalog.sqlite'}?mode=ro", uri=True) as conn:
        reasons = [r for (r,) in conn.execute("SELECT reason FROM gaps")]
    assert len(reasons) == 1 and reasons[0].startswith("reasoner behind:")
