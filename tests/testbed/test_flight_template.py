"""A flight's traffic flown once, the EMA's answers recomputed: the same recording, byte for
byte, as flying the faulty EMA over the loopback bus; and ``mapr fleet-archive``."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

import pytest

from drivers.chapter10.writer import Chapter10Writer
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.icd import load_icd
from mapr_daemon.pipeline.settings import DEFAULT_ICD
from mapr_daemon.testbed.backend import RATE_HZ
from mapr_daemon.testbed.fleet import fly_flight
from mapr_daemon.testbed.flight_template import FlightTemplate
from mapr_daemon.testbed.profiles import steady_profile

START = datetime(2026, 3, 1, 9, 0, tzinfo=UTC)


@pytest.mark.parametrize("bit", [True, False])
def test_a_templated_flight_is_the_flight_flown_over_the_bus(tmp_path: Path, bit: bool) -> None:
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE_HZ)
    template = FlightTemplate(load_icd(DEFAULT_ICD), steady_profile(RATE_HZ, "cruise"),
                              params, 0.6, bit=bit)
    for name, faults in (("esr", FaultSet.of([Fault("esr", 0.6)])),
                         ("friction", FaultSet.of([Fault("friction", 4.0)])),
                         ("healthy", FaultSet())):
        flown = tmp_path / f"{name}-flown.ch10"
        fly_flight(flown, faults, seed=31, start=START, bit=bit, flight_s=0.6)
        templated = tmp_path / f"{name}-templated.ch10"
        with Chapter10Writer(templated, start_time=START) as writer:
            writer.write(template.flight(faults, seed=31))
        assert templated.read_bytes() == flown.read_bytes(), name


def test_fleet_archive_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "archive"
    assert main(["fleet-archive", str(out), "--tails", "2", "--flights", "2", "--flight-s",
                 "0.3", "--bit-every", "2", "--jobs", "1", "--seed", "4"]) == exitcodes.OK
    printed = capsys.readouterr().out
    assert printed.startswith("fleet-archive: 4 recordings (2 tails x 2 flights of 0.3 s, "
                              "2 with a BIT)")
    assert "s per recording" in printed
    manifest = json.loads((out / "fleet.json").read_text())
    assert sorted(r["path"] for r in manifest["recordings"]) == sorted(
        str(p.relative_to(out)) for p in out.rglob("*.ch10"))
    # an archive is written into a new folder; an unknown aging kind is a config error
    assert main(["fleet-archive", str(out)]) == exitcodes.USAGE
    assert "not empty" in capsys.readouterr().err
    assert main(["fleet-archive", str(tmp_path / "other"), "--kinds", "esr,rust"]) == \
        exitcodes.CONFIG
    assert "'rust'" in capsys.readouterr().err


def test_a_templated_flight_of_a_built_unit_is_that_unit_flown_over_the_bus(
        tmp_path: Path) -> None:
    """A unit that is not the data sheet's twin (its own parameters and model form) answers
    in the template's traffic exactly as it does flown over the bus; the twin's recording
    differs from it."""
    from mapr_daemon.testbed.mismatch import fleet

    sheet = load_actuator(default_actuator_path())
    (unit,) = fleet(sheet, 1, seed=8)
    template = FlightTemplate(load_icd(DEFAULT_ICD), steady_profile(RATE_HZ, "cruise"),
                              with_sample_rate(sheet, RATE_HZ), 0.6, bit=True)
    faults = FaultSet.of([Fault("friction", 2.0)])
    flown = tmp_path / "flown.ch10"
    fly_flight(flown, faults, seed=5, start=START, flight_s=0.6, params=unit.params,
               form=unit.form)
    templated = tmp_path / "templated.ch10"
    with Chapter10Writer(templated, start_time=START) as writer:
        writer.write(template.flight(faults, seed=5,
                                     params=with_sample_rate(unit.params, RATE_HZ),
                                     form=unit.form))
    twin = tmp_path / "twin.ch10"
    with Chapter10Writer(twin, start_time=START) as writer:
        writer.write(template.flight(faults, seed=5))
    assert templated.read_bytes() == flown.read_bytes()
    assert twin.read_bytes() != flown.read_bytes()
