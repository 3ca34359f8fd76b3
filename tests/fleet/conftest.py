"""Shared by the fleet tests: a small dictionary (~30 s), a 2-tail x 2-flight archive with a
BIT on every flight (~10 s), and one local Dask cluster of two worker processes."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mapr_daemon.testbed.fleet import FleetSpec, generate


@pytest.fixture(scope="session")
def fleet_dictionary(dictionary: Path) -> Path:
    """The session's small dictionary (tests/conftest.py)."""
    return dictionary


@pytest.fixture(scope="session")
def fleet_source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("archive")
    generate(root, FleetSpec(tails=2, flights=2, seed=21, degrading=1.0, flight_s=2.0,
                             life_flights=2.0))
    return root


@pytest.fixture
def fleet_archive(fleet_source: Path, tmp_path: Path) -> Path:
    """A copy of the session's archive the test may change."""
    return Path(shutil.copytree(fleet_source, tmp_path / "archive"))


@pytest.fixture(scope="session")
def dask_client() -> Iterator[Any]:
    from mapr_daemon.fleet.cluster import close_client, local_client

    client = local_client(2, dashboard=False)
    yield client
    close_client(client)
