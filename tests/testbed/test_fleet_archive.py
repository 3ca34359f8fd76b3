"""The synthetic fleet archive: one Chapter 10 file per tail and flight, in the path, with
the truth in the manifest and absolute time in the recordings' time packets."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from drivers.chapter10.reader import Chapter10Reader
from mapr_daemon.testbed.fleet import MANIFEST, FleetSpec, generate


def test_archive_layout_manifest_and_recordings(tmp_path: Path) -> None:
    spec = FleetSpec(tails=2, flights=2, seed=3, degrading=0.5, flight_s=0.3, bit_every=2)
    manifest = generate(tmp_path, spec)
    assert json.loads((tmp_path / MANIFEST).read_text()) == manifest
    paths = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*.ch10"))
    assert paths == ["N101/flight-0001.ch10", "N101/flight-0002.ch10",
                     "N102/flight-0001.ch10", "N102/flight-0002.ch10"]
    assert [(r["tail"], r["flight"], r["bit"]) for r in manifest["recordings"]] == [
        ("N101", 1, True), ("N101", 2, False), ("N102", 1, True), ("N102", 2, False)]
    aging = {tail: t for tail, t in manifest["truth"].items() if t}
    assert len(aging) == 1   # half of two tails
    (truth,) = aging.values()
    ema = truth["EMA1"]
    assert ema["kind"] in ("esr", "friction") and len(ema["values"]) == 2
    assert ema["values"][0] == ema["nominal"] and ema["values"][1] != ema["nominal"]
    # each file holds the bus traffic, with the flight's start as absolute time
    reader = Chapter10Reader(tmp_path / "N102" / "flight-0002.ch10")
    records = [r for batch in reader for r in batch.records]
    assert len(records) > 300   # 0.3 s of the schedule
    first = records[0].extra["epoch_ns"]
    assert isinstance(first, int)
    assert first // 10**9 == 1767686460   # 2026-01-06 08:01 UTC: a day after the first


def test_same_seed_same_archive(tmp_path: Path) -> None:
    spec = FleetSpec(tails=2, flights=2, seed=5, degrading=0.5, flight_s=0.2)
    with ThreadPoolExecutor(2) as pool:   # tails written in parallel: the same archive
        one, two = generate(tmp_path / "a", spec), generate(tmp_path / "b", spec, pool.map)
    assert one == two
    for name in ("N101/flight-0001.ch10", "N101/flight-0002.ch10", "N102/flight-0002.ch10"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_fly_flight_records_the_seeded_fault(tmp_path: Path) -> None:
    from datetime import UTC, datetime

    from mapr_daemon.ema.faults import Fault, FaultSet
    from mapr_daemon.testbed.fleet import fly_flight

    start = datetime(2026, 3, 1, 9, 0, tzinfo=UTC)
    worn = FaultSet.of([Fault("esr", 0.5)])
    for name, faults in (("a", worn), ("b", worn), ("healthy", FaultSet())):
        fly_flight(tmp_path / f"{name}.ch10", faults, seed=11, start=start, flight_s=0.3,
                   condition="climb")
    a = (tmp_path / "a.ch10").read_bytes()
    assert a == (tmp_path / "b.ch10").read_bytes()   # one seed, one recording
    assert a != (tmp_path / "healthy.ch10").read_bytes()   # the fault is in the traffic
    records = [r for batch in Chapter10Reader(tmp_path / "a.ch10") for r in batch.records]
    assert len(records) > 300
    assert records[0].extra["epoch_ns"] // 10**9 == int(start.timestamp())


def test_fly_flight_flies_a_units_own_parameters_and_form(tmp_path: Path) -> None:
    """The default flight is the data sheet's twin, unchanged when the sheet and the default
    form are passed explicitly; a built unit's form and condition reach the plant and the
    traffic."""
    from datetime import UTC, datetime

    from mapr_daemon.ema.faults import FaultSet
    from mapr_daemon.ema.form import ModelForm
    from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
    from mapr_daemon.icd import load_icd
    from mapr_daemon.pipeline.settings import DEFAULT_ICD
    from mapr_daemon.testbed.aircraft import Aircraft
    from mapr_daemon.testbed.backend import RATE_HZ
    from mapr_daemon.testbed.fleet import fly_flight
    from mapr_daemon.testbed.mismatch import draw_unit
    from mapr_daemon.testbed.profiles import steady_profile

    start = datetime(2026, 3, 1, 9, 0, tzinfo=UTC)
    sheet = load_actuator(default_actuator_path())
    unit = draw_unit(sheet, 5)
    form = ModelForm(housekeeping_w=3.0, sensor_offset=(("smps_input_current_a", 0.2),))
    flights: dict[str, dict[str, Any]] = {
        "default": {}, "explicit": {"params": sheet, "form": ModelForm()},
        "form": {"params": sheet, "form": form},
        "unit": {"params": unit.params, "form": unit.form, "ambient_c": -30.0, "bus_v": 23.0}}
    for name, kwargs in flights.items():
        fly_flight(tmp_path / f"{name}.ch10", FaultSet(), seed=11, start=start, flight_s=0.3,
                   condition="climb", **kwargs)
    data = {name: (tmp_path / f"{name}.ch10").read_bytes() for name in flights}
    assert data["explicit"] == data["default"]
    assert data["form"] != data["default"] and data["unit"] != data["default"]
    profile = steady_profile(RATE_HZ, "climb", duration_s=1.0)
    aircraft = Aircraft(load_icd(DEFAULT_ICD), profile, with_sample_rate(unit.params, RATE_HZ),
                        seed=1, form=unit.form, ambient_c=-30.0, bus_v=23.0)
    (spec,) = aircraft.ema.plant.specs
    assert spec.form == unit.form and (spec.ambient_c, spec.bus_v) == (-30.0, 23.0)
    assert spec.params.motor == unit.params.motor
    twin = Aircraft(load_icd(DEFAULT_ICD), profile, with_sample_rate(sheet, RATE_HZ), seed=1)
    assert twin.ema.plant.specs[0].form == ModelForm()
