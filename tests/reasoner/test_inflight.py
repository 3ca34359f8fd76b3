"""In-flight tracking: which windows qualify, and what a flight's estimate reads.

Flights are short (the whole-flight profile at a quarter of its length, ~64 s of bus) and
flown on the plant directly at the bus rate; the truth is the plant's own friction for that
flight (the fault times the flight's grease scatter).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.ema.run import run_batch
from mapr_daemon.errors import RecordError
from mapr_daemon.reasoner.ekf.model import Plant
from mapr_daemon.reasoner.inflight import (
    CRITERION,
    FlightAccumulator,
    FlightTracker,
    commission,
    excitation,
    select,
)
from mapr_daemon.testbed.profiles import sine_profile, steady_profile
from mapr_daemon.testbed.whole_flight import Flown, flight_profile, fly


@pytest.fixture(scope="module")
def params() -> ActuatorParams:
    return load_actuator(default_actuator_path())


def _one(params: ActuatorParams, profile_name: str) -> dict[str, FloatArray]:
    rate = params.sensors.sample_rate_hz
    prof = (steady_profile(rate, "cruise", 6.0, command_deg=2.0) if profile_name == "steady"
            else sine_profile(rate, 6.0, 10.0, 1.0, "cruise"))
    res = run_batch([RunSpec(params, seed=11)], prof)
    return {k: v[0] for k, v in res.channels.items()}


def test_commanded_motion_qualifies_and_steady_cruise_does_not(params: ActuatorParams) -> None:
    plant = Plant.of(params)
    held = excitation(plant, _one(params, "steady"))
    moving = excitation(plant, _one(params, "sine"))
    # the first second moves the surface to its trim; after that nothing qualifies
    assert not held.qualifies(CRITERION)[1:].any()
    segs = select(moving)
    assert segs, "a 10 deg, 1 Hz sine gave no qualifying window"
    assert "friction" in set().union(*(s.groups for s in segs))
    # every qualifying window carries more friction information than any held one
    assert np.nanmin(moving.sd[:, 0]) < np.nanmin(held.sd[:, 0])


def test_a_flight_held_throughout_has_nothing_to_track(params: ActuatorParams) -> None:
    held = {k: v[2000:] for k, v in _one(params, "steady").items()}  # after the move to trim
    with pytest.raises(RecordError):
        FlightTracker(params).track(held, 1600.0)


@dataclasses.dataclass
class Flights:
    commissioning: list[Flown]
    healthy: Flown
    worn: Flown


@pytest.fixture(scope="module")
def flights(params: ActuatorParams) -> Flights:
    rate = params.sensors.sample_rate_hz
    worn = FaultSet.of([Fault("friction", 2.2)])
    flown = []
    for k in range(4):
        prof = flight_profile(rate, seed=40 + k, scale=0.25)
        specs = [RunSpec(params, worn if k == 3 else FaultSet(), seed=900 + k,
                         ambient_c=10.0 + 5 * k)]
        flown.append(fly(specs, prof))
    return Flights(flown[:2], flown[2], flown[3])


def test_friction_fault_reads_its_size_and_a_healthy_flight_stays_in_band(
        params: ActuatorParams, flights: Flights) -> None:
    tracker = FlightTracker(params)
    commission(tracker, [(f.channels[0], f.profile.dynamic_pressure_pa)
                         for f in flights.commissioning])
    base_truth = float(np.mean([f.truth[0].friction_factor for f in flights.commissioning]))
    healthy = tracker.track(flights.healthy.channels[0],
                            flights.healthy.profile.dynamic_pressure_pa)
    worn = tracker.track(flights.worn.channels[0], flights.worn.profile.dynamic_pressure_pa)
    h, w = healthy.parameters["friction"], worn.parameters["friction"]
    truth = flights.worn.truth[0].friction_factor / base_truth - 1.0
    assert truth > 1.0
    assert w.change > 0.0
    assert abs(w.change - truth) < 0.3 * truth, (w, truth)
    # the healthy flight: its true change is the grease scatter alone, inside the band
    h_truth = flights.healthy.truth[0].friction_factor / base_truth - 1.0
    assert abs(h.change - h_truth) < 3.0 * h.sd, (h, h_truth)
    assert abs(h.change) < 0.3
    assert w.change - h.change > 3.0 * np.hypot(w.sd, h.sd)
    for est in (healthy, worn):
        assert set(est.parameters) == {"friction", "loop_r", "phase_a_ron", "bus0"}
        assert 0.0 < est.filtered_s < est.flight_s
        assert all(t.sd >= t.ekf_sd > 0.0 for t in est.parameters.values())


def test_a_streamed_flight_keeps_a_fraction_and_reads_as_the_whole_one(
        params: ActuatorParams, flights: Flights) -> None:
    tracker = FlightTracker(params)
    f = flights.worn
    whole = tracker.track(f.channels[0], f.profile.dynamic_pressure_pa)
    acc = FlightAccumulator(tracker)
    n = f.profile.n_samples
    kept = 0
    for start in range(0, n, 3333):  # batches that do not align with the windows
        stop = min(n, start + 3333)
        acc.feed({k: v[start:stop] for k, v in f.channels[0].items()},
                 f.profile.dynamic_pressure_pa[start:stop])
        kept = max(kept, acc.kept_samples)
    assert 0 < kept < 0.5 * n
    streamed = acc.finish()
    assert streamed is not None
    assert streamed.flight_s == pytest.approx(whole.flight_s)
    assert streamed.filtered_s == pytest.approx(whole.filtered_s)
    for name, t in whole.parameters.items():
        assert streamed.parameters[name].value == pytest.approx(t.value, rel=1e-6, abs=1e-9)
        assert streamed.parameters[name].sd == pytest.approx(t.sd, rel=1e-6, abs=1e-9)
    assert acc.finish() is None  # reset for the next flight


def test_a_gap_splits_the_stretch(params: ActuatorParams) -> None:
    """The same moving stretch fed twice with a gap between: two segments, never one that
    filters across the jump in time (without the gap it is one)."""
    sine = _one(params, "sine")
    tracker = FlightTracker(params)
    for mark_gap, expected in ((True, 2), (False, 1)):
        acc = FlightAccumulator(tracker)
        acc.feed(sine, 1600.0)
        if mark_gap:
            acc.gap()
        acc.feed(sine, 1600.0)
        segs = acc.segments()
        assert len(segs) == expected, segs
