"""The pipeline runs the in-flight tracker on the bus traffic between BITs (issue 29).

8 s of the simulated aircraft's bus (a 10 deg, 1 Hz aileron sine at cruise, a BIT requested
at 1 s) through :meth:`Pipeline.process`, as a replay with a declared flight runs it: the
flight's end gives one in-flight row for the actuator, from the traffic outside its BIT, and
``reasoner.inflight: false`` gives none.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.backends.loopback import LoopbackMonitor
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.icd import load_icd
from mapr_daemon.icd.yamlsrc import load_text
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import build_pipeline
from mapr_daemon.service.config import parse
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles import sine_profile

ROOT = Path(__file__).resolve().parents[2]
DICTIONARY = ROOT / "mapr_daemon" / "testbed" / "models" / "dictionary-aileron-uav-2000hz.npz"
SECONDS = 8.0


@pytest.fixture(scope="module")
def records() -> list[object]:
    params = load_actuator(default_actuator_path())
    rate = params.sensors.sample_rate_hz
    icd = load_icd(ROOT / "configs" / "icd" / "ema-testbed.yaml")
    aircraft = Aircraft(icd, sine_profile(rate, SECONDS, 10.0, 1.0, "cruise"), params,
                        seed=7, bit_requests_s=(1.0,))
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=int(SECONDS / 0.002)) as monitor:
        return list(monitor)


def _config(tmp_path: Path, inflight: bool) -> object:
    text = (f"catalog:\n  path: {tmp_path / 'c.sqlite'}\naircraft:\n  tail: N1\n"
            f"reasoner:\n  dictionary: {DICTIONARY}\n  inflight: {str(inflight).lower()}\n")
    return parse(load_text(text, "x.yaml"), "x.yaml")


def test_a_declared_flight_ends_with_its_in_flight_row(records: list[object],
                                                       tmp_path: Path) -> None:
    pipe = build_pipeline(_config(tmp_path, True))  # type: ignore[arg-type]
    clock = BusClock("recording")
    pipe.declare_flight(1)
    half = len(records) // 2
    first = pipe.process(records[:half], clock)   # type: ignore[arg-type]
    second = pipe.process(records[half:], clock)  # type: ignore[arg-type]
    assert len(first.bits) + len(second.bits) == 1, "the BIT was not diagnosed"
    assert not first.inflight and not second.inflight   # the flight has not ended yet
    pipe.declare_flight(2)   # the next recording's flight: flight 1 has ended
    ended = pipe.process([], clock).inflight
    assert [(r.tail, r.asset, r.flight) for r in ended] == [("N1", "EMA1", 1)]
    row = ended[0]
    # the BIT (1.46 s from 1 s) and half a second after it are not flight traffic
    assert 4.5 < row.flight_s < SECONDS - 1.9
    assert "friction" in row.parameters
    assert row.parameters["friction"]["baseline"] == "pending 1/3"
    assert pipe.end_flight() == []   # flight 2 had no traffic


def test_in_flight_tracking_can_be_turned_off(records: list[object], tmp_path: Path) -> None:
    pipe = build_pipeline(_config(tmp_path, False))  # type: ignore[arg-type]
    clock = BusClock("recording")
    pipe.declare_flight(1)
    pipe.process(records, clock)  # type: ignore[arg-type]
    assert pipe.inflight == [] and pipe.end_flight() == []


def test_a_reload_within_the_flight_keeps_tracking_it(records: list[object],
                                                      tmp_path: Path) -> None:
    config = _config(tmp_path, True)
    whole = build_pipeline(config)  # type: ignore[arg-type]
    whole.declare_flight(1)
    whole.process(records, BusClock("recording"))  # type: ignore[arg-type]
    [expected] = whole.end_flight()
    before = build_pipeline(config)  # type: ignore[arg-type]
    clock = BusClock("recording")
    before.declare_flight(1)
    half = len(records) // 2
    before.process(records[:half], clock)  # type: ignore[arg-type]
    after = build_pipeline(config)  # type: ignore[arg-type]   # the daemon's reload
    after.declare_flight(1)
    after.carry_inflight(before)
    after.process(records[half:], clock)  # type: ignore[arg-type]
    [row] = after.end_flight()
    assert row.flight_s == expected.flight_s
    assert row.parameters["friction"]["value"] == expected.parameters["friction"]["value"]
