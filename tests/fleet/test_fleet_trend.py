"""A fleet run trends every actuator of every tail in flight order: each BIT stored with its
tail, flight and the health after it; a rerun adds nothing; a run resumed halfway continues
the trend exactly; ``mapr health`` lists each tail's actuator."""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.fleet.archive import discover
from mapr_daemon.fleet.config import FleetConfig
from mapr_daemon.fleet.runner import FleetRun, RunSummary
from mapr_daemon.pipeline.settings import AssetConfig, ReasonerConfig
from mapr_daemon.service.config import Config
from mapr_daemon.testbed.fleet import FleetSpec, generate

ROOT = Path(__file__).resolve().parents[2]
FLIGHTS = 4


@pytest.fixture(scope="session")
def fleet_model(fleet_dictionary: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny prognostic model for the fleet dictionary (a few seconds)."""
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.training.prognosis_build import BuildSpec, build_prognostic_model

    model = build_prognostic_model(
        Dictionary.load(fleet_dictionary), load_actuator(default_actuator_path()),
        BuildSpec(training_bits=60, calibration_reps=2, fleet_units=4),
        kinds=("esr", "friction"))
    path = tmp_path_factory.mktemp("prognosis") / "prognosis.npz"
    model.save(path)
    return path


@pytest.fixture(scope="session")
def aging_source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """2 tails x 4 flights, a BIT on every flight, both actuators aging (~15 s)."""
    root = tmp_path_factory.mktemp("aging")
    generate(root, FleetSpec(tails=2, flights=FLIGHTS, seed=58, degrading=1.0,
                             flight_s=2.0, life_flights=5.0))
    return root


def configs(dictionary: Path, model: Path) -> FleetConfig:
    return FleetConfig(Config(reasoner=ReasonerConfig(dictionary=str(dictionary)),
                              assets=(AssetConfig(prognosis=str(model)),)))


def run(client: Any, sources: list[Path], catalog: Path, dictionary: Path, model: Path
        ) -> RunSummary:
    recordings, bad = discover(sources)
    assert bad == []
    with CatalogWriter(catalog) as writer:
        writer.open_session(backend="fleet", config_hash="test")
        return FleetRun(client, writer, configs(dictionary, model)).run(recordings)


def bits(catalog: Path) -> list[tuple[Any, ...]]:
    """Every BIT row without its ids: (tail, asset, flight, flight h, t, soh, mode, rul,
    note), in storage order."""
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        return conn.execute("SELECT tail, asset, flight, flight_hours, t_ns, soh, mode, rul, "
                            "note FROM bits ORDER BY id").fetchall()


def flights(catalog: Path) -> list[tuple[Any, ...]]:
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        return conn.execute("SELECT tail, flight, hours, source FROM flights "
                            "ORDER BY tail, flight").fetchall()


def test_each_tails_bits_are_trended_in_flight_order_and_a_rerun_adds_nothing(
        dask_client: Any, aging_source: Path, fleet_dictionary: Path, fleet_model: Path,
        tmp_path: Path) -> None:
    catalog = tmp_path / "fleet.db"
    first = run(dask_client, [aging_source], catalog, fleet_dictionary, fleet_model)
    assert (first.stored, first.failed, first.bits) == (2 * FLIGHTS, [], 2 * FLIGHTS)
    rows = bits(catalog)
    for tail in ("N101", "N102"):
        mine = [r for r in rows if r[0] == tail]
        assert [r[2] for r in mine] == list(range(1, FLIGHTS + 1))   # in flight order
        assert {r[1] for r in mine} == {"EMA1"}                       # the plain asset
        assert all(r[5] is not None and 0.0 <= r[5] <= 1.0 for r in mine), mine   # SoH
        hours = [r[3] for r in mine]   # 1.5 declared hours a flight: the hours grow
        assert hours == sorted(hours) and hours[-1] >= 1.5 * (FLIGHTS - 1)
    # no RUL before three flights of BITs
    assert all(r[7] is None for r in rows if r[2] < 3)
    assert first.rul == sum(r[7] is not None for r in rows)
    assert flights(catalog) == [(t, n, 1.5, "declared") for t in ("N101", "N102")
                                for n in range(1, FLIGHTS + 1)]
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        named = {r[0] for r in conn.execute(
            "SELECT asset FROM events UNION SELECT asset FROM episodes")}
    assert named <= {"N101/EMA1", "N102/EMA1"}   # two tails' episodes never merge
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        stored = [json.loads(c) for (c,) in conn.execute("SELECT conditions FROM bits")]
    # each BIT's flight condition, as read from its record, is kept for the trend
    assert all(set(c) == {"dynamic_pressure_pa", "supply_v", "ambient_c"} for c in stored)
    assert all(20.0 < c["supply_v"] < 32.0 and -60.0 < c["ambient_c"] < 90.0 for c in stored)
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        read = [(json.loads(w), json.loads(s)) for w, s in conn.execute(
            "SELECT wear, wear_source FROM bits")]
    # and which path read each kind's wear (no commissioned asset: the estimators)
    assert all(w and s == {k: {"path": "estimator"} for k in w} for w, s in read)

    again = run(dask_client, [aging_source], catalog, fleet_dictionary, fleet_model)
    assert (again.stored, again.skipped) == (0, 2 * FLIGHTS)
    assert bits(catalog) == rows and len(flights(catalog)) == 2 * FLIGHTS


def test_a_run_resumed_halfway_continues_each_trend_exactly(
        dask_client: Any, aging_source: Path, fleet_dictionary: Path, fleet_model: Path,
        tmp_path: Path) -> None:
    """Flights 1-2 in one run and 3-4 in the next store what one run of all four stores: the
    second run's trend continues from the catalog's history of each tail."""
    whole = tmp_path / "whole.db"
    run(dask_client, [aging_source], whole, fleet_dictionary, fleet_model)
    half = tmp_path / "half"
    for tail in ("N101", "N102"):
        (half / tail).mkdir(parents=True)
        for n in (1, 2):
            name = f"{tail}/flight-{n:04d}.ch10"
            shutil.copy(aging_source / name, half / name)
    shutil.copy(aging_source / "fleet.json", half / "fleet.json")
    split = tmp_path / "split.db"
    assert run(dask_client, [half], split, fleet_dictionary, fleet_model).stored == 4
    assert run(dask_client, [aging_source], split, fleet_dictionary, fleet_model
               ).stored == 4
    assert sorted(bits(split)) == sorted(bits(whole))


def test_mapr_fleet_with_a_prognosis_then_mapr_health_lists_each_tails_actuator(
        aging_source: Path, fleet_dictionary: Path, fleet_model: Path, tmp_path: Path) -> None:
    catalog = tmp_path / "fleet.db"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    mapr = [sys.executable, "-m", "mapr_daemon.cli.main"]
    fleet = subprocess.run([*mapr, "fleet", str(aging_source), "--dictionary",
                            str(fleet_dictionary), "--prognosis", str(fleet_model),
                            "--catalog", str(catalog), "--workers", "1", "--no-progress"],
                           cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert fleet.returncode == 0, fleet.stderr
    with_rul = sum(r[7] is not None for r in bits(catalog))
    assert f"{2 * FLIGHTS} built-in tests ({with_rul} with a RUL)" in fleet.stdout
    health = [*mapr, "health", "--catalog", str(catalog)]
    listed = json.loads(subprocess.run([*health, "--json"], cwd=ROOT, env=env, check=True,
                                       capture_output=True, text=True).stdout)
    assert [(a["tail"], a["asset"], a["last_flight"], a["bits"]) for a in listed] == \
        [("N101", "EMA1", FLIGHTS, FLIGHTS), ("N102", "EMA1", FLIGHTS, FLIGHTS)]
    assert all(a["soh"] is not None for a in listed)
    text = subprocess.run(health, cwd=ROOT, env=env, check=True, capture_output=True,
                          text=True).stdout
    assert "N101/EMA1" in text and "N102/EMA1" in text and "N101/N101" not in text
