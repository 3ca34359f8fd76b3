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
def fleet_dictionary(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner import build
    from mapr_daemon.reasoner.dictionary import DictionarySpec

    spec = DictionarySpec(pressures_pa=(0.0, 1600.0), nominal_per_pressure=4,
                          severities=(0.25, 0.5, 0.75, 1.0), kinds=("esr", "friction"),
                          shorts=("A_high",), opens=("A_high",), healthy_runs=120,
                          calibration_runs=20, envelope=True, ground_share=0.2,
                          threshold_margin=1.5)
    path = tmp_path_factory.mktemp("dictionary") / "dictionary.npz"
    build.build(load_actuator(default_actuator_path()), spec).save(path)
    return path


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
    from mapr_daemon.fleet.runner import close_client, local_client

    client = local_client(2, dashboard=False)
    yield client
    close_client(client)
