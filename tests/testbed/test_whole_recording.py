"""Whole flights recorded as Chapter 10: the PBIT at power-up is the one BIT the product finds
in the recording, the rest of the flight is the actuator's traffic, and the EMA's health
shows in what it answers."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import pytest

from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.icd import load_icd
from mapr_daemon.pipeline.recorded_bits import bits_from_recording
from mapr_daemon.pipeline.settings import DEFAULT_ICD, AssetConfig
from mapr_daemon.testbed.fleet import FIRST_DAY
from mapr_daemon.testbed.flight_template import FlightTemplate
from mapr_daemon.testbed.whole_recording import flight_seconds, record_flight, whole_template

SCALE = 0.02
"""Every phase at 2 % of its length: 5.1 s of bus, room for the PBIT (1.46 s)."""


@pytest.fixture(scope="module")
def template() -> FlightTemplate:
    return whole_template(seed=4, scale=SCALE, bit=True)


def test_a_whole_flight_carries_one_pbit_at_power_up(tmp_path: Path,
                                                     template: FlightTemplate) -> None:
    assert flight_seconds(template) == pytest.approx(5.1)
    path = tmp_path / "N101" / "flight-0001.ch10"
    path.parent.mkdir()
    record_flight(path, template, FaultSet(), seed=9, start=FIRST_DAY, tail="N101")
    found = bits_from_recording(path, load_actuator(default_actuator_path()),
                                load_icd(DEFAULT_ICD), AssetConfig())
    assert found.actuator_seen
    assert found.messages == len(template.records)
    assert len(found.bits) == 1
    when = found.bits[0].time   # requested at power-up: within the flight's first second
    assert when is not None
    assert (datetime.fromisoformat(when) - FIRST_DAY).total_seconds() < 1.0


def test_the_emas_health_is_in_what_it_answers(tmp_path: Path,
                                               template: FlightTemplate) -> None:
    files = {}
    for name, faults in (("healthy", FaultSet()),
                         ("worn", FaultSet.of([Fault("friction", 2.5)])),
                         ("again", FaultSet())):
        files[name] = tmp_path / f"{name}.ch10"
        record_flight(files[name], template, faults, seed=9, start=FIRST_DAY)
    assert files["again"].read_bytes() == files["healthy"].read_bytes()
    assert files["worn"].read_bytes() != files["healthy"].read_bytes()
    assert files["worn"].stat().st_size == files["healthy"].stat().st_size
