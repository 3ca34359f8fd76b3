"""How a fleet run reads its cluster's failures, without a cluster: a scheduler address
checked before anything is contacted, a lost connection raised as one ClusterError, a task
that killed its workers stored as a failed recording."""

from __future__ import annotations

from concurrent.futures import CancelledError
from pathlib import Path
from typing import Any

import pytest

from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.errors import ClusterError
from mapr_daemon.fleet.archive import Recording
from mapr_daemon.fleet.cluster import scheduler_problem
from mapr_daemon.fleet.config import FleetConfig
from mapr_daemon.fleet.runner import FleetRun
from mapr_daemon.service.config import Config


@pytest.mark.parametrize(("address", "problem"), [
    ("tcp://127.0.0.1:8786", None), ("127.0.0.1:8786", None), ("tls://head:8786", None),
    ("bogus://x", "the scheme must be one of"), ("inproc://x", "the scheme must be one of"),
    ("tcp://head", "missing port"), ("tcp://head:0", "PORT 1-65535"),
    ("tcp://:8786", "HOST:PORT"), ("tcp://a b:1", "HOST:PORT"),
])
def test_scheduler_addresses(address: str, problem: str | None) -> None:
    found = scheduler_problem(address)
    if problem is None:
        assert found is None
    else:
        assert found is not None and problem in found and found.startswith(
            f"--scheduler {address!r}: ")


class Failing:
    """A future whose result raises ``error``."""

    def __init__(self, error: BaseException) -> None:
        self.error = error

    def result(self) -> Any:
        raise self.error


class KilledWorker(Exception):
    """Stands for distributed's: any exception of the task's own."""


def test_a_lost_connection_is_a_cluster_error_and_a_killed_worker_a_failed_recording(
        tmp_path: Path) -> None:
    recording = Recording(str(tmp_path / "N1" / "flight-0001.ch10"), "N1", 1, "ab" * 32)
    with CatalogWriter(tmp_path / "c.db") as catalog:
        fleet = FleetRun(client=None, catalog=catalog,  # type: ignore[arg-type]
                         configs=FleetConfig(Config()))
        failed = fleet._result(Failing(KilledWorker("attempted 3 times\non 2 workers")),
                               recording, "cfg")
        assert not failed.ok and failed.config_digest == "cfg"
        assert failed.error == "KilledWorker: attempted 3 times on 2 workers"
        with pytest.raises(ClusterError, match="lost the connection mid-run"):
            fleet._result(Failing(CancelledError()), recording, "cfg")
        with pytest.raises(ClusterError, match="CommClosed"):
            fleet._result(Failing(ConnectionError("CommClosed")), recording, "cfg")
