"""The pipeline's in-flight tracking: a flight's traffic between BITs ends as one stored row.

A short whole flight (the whole-flight profile at a fifth of its length, 51 s of bus) is
flown on the plant at the bus rate and handed to the actuator's :class:`InflightWatch` as the
ICD's decoded series would be (the shipped testbed ICD's signal names), in batches, with a
BIT request in the middle: the BIT's samples are not flight traffic.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.icd import Series, load_icd
from mapr_daemon.pipeline.bitcut import BitCutter
from mapr_daemon.pipeline.inflight import InflightWatch
from mapr_daemon.reasoner.inflight.baseline import COMMISSIONING_FLIGHTS
from mapr_daemon.testbed.flight_series import flight_series
from mapr_daemon.testbed.whole_flight import flight_profile, fly
from mapr_daemon.views.figures import inflight_lines

ROOT = Path(__file__).resolve().parents[2]
ICD = load_icd(ROOT / "configs" / "icd" / "ema-testbed.yaml")
@pytest.fixture(scope="module")
def params() -> ActuatorParams:
    return load_actuator(default_actuator_path())


@pytest.fixture(scope="module")
def flights(params: ActuatorParams) -> list[dict[str, np.ndarray]]:
    """Four flights of one unit: three healthy (commissioning), the fourth at 2.2x friction."""
    rate = params.sensors.sample_rate_hz
    out = []
    for k in range(4):
        prof = flight_profile(rate, seed=60 + k, scale=0.2)
        faults = FaultSet.of([Fault("friction", 2.2)]) if k == 3 else FaultSet()
        flown = fly([RunSpec(params, faults, seed=700 + k)], prof)
        out.append({**flown.channels[0], "q": prof.dynamic_pressure_pa})
    return out


def _batches(ch: dict[str, np.ndarray], t0: int, rate: float, bit_at_s: float
             ) -> list[dict[str, Series]]:
    return flight_series(ch, ch["q"], rate, t0, (bit_at_s,), icd=ICD)


def test_each_flight_ends_with_a_row_and_a_worn_unit_reads_its_friction_change(
        params: ActuatorParams, flights: list[dict[str, np.ndarray]], tmp_path: Path) -> None:
    rate = params.sensors.sample_rate_hz
    cutter = BitCutter(params.bit, rate)
    watch = InflightWatch("EMA1", params, cutter)
    rows = []
    for k, ch in enumerate(flights):
        watch.flight = k + 1
        for batch in _batches(ch, int(1e12) * (k + 1), rate, bit_at_s=20.0):
            watch.feed(batch)
        row = watch.finish("N1")
        assert row is not None, f"flight {k + 1} gave no in-flight estimate"
        rows.append(row)
        # the BIT (1.5 s) and the half second after it are not flight traffic
        assert row.flight_s == pytest.approx(ch["position_deg"].size / rate - 2.0, abs=0.3)
    first = rows[0].parameters["friction"]
    assert first["change"] is None and first["baseline"] == f"pending 1/{COMMISSIONING_FLIGHTS}"
    worn = rows[3].parameters["friction"]
    assert worn["change"] is not None
    # 2.2x friction on a unit commissioned healthy: a change near +1.2 (grease scatters ~10 %)
    assert 0.9 < worn["change"] < 1.5
    assert worn["sd_change"] > 0.0
    # stored, read back, shown by the one formatter
    with CatalogWriter(tmp_path / "c.sqlite") as writer:
        writer.open_session(backend="replay", config_hash="x")
        writer.add_inflight(rows)
        _, _, stored = writer.history("N1")
    assert [r.flight for r in stored] == [1, 2, 3, 4]
    text = "\n".join(inflight_lines(stored[-1]))
    assert "friction" in text and "+1." in text
    assert "pending" in "\n".join(inflight_lines(stored[0]))


def test_a_restart_continues_the_baseline_from_the_stored_rows(
        params: ActuatorParams, flights: list[dict[str, np.ndarray]]) -> None:
    rate = params.sensors.sample_rate_hz
    first = InflightWatch("EMA1", params, BitCutter(params.bit, rate))
    rows = []
    for k, ch in enumerate(flights[:3]):
        first.flight = k + 1
        for batch in _batches(ch, int(1e12) * (k + 1), rate, bit_at_s=20.0):
            first.feed(batch)
        row = first.finish("N1")
        assert row is not None
        rows.append(row)
    again = InflightWatch("EMA1", params, BitCutter(params.bit, rate))
    again.resume(rows)
    assert again.baseline.value("friction") == pytest.approx(
        first.baseline.value("friction"))


def test_unreadable_samples_cost_their_stretch_not_the_flight(
        params: ActuatorParams, flights: list[dict[str, np.ndarray]]) -> None:
    """A short message decodes to NaN: those samples never reach the estimator (which would
    fail on them), the batch is not lost, and the flight still ends with its row."""
    rate = params.sensors.sample_rate_hz
    watch = InflightWatch("EMA1", params, BitCutter(params.bit, rate))
    watch.flight = 1
    for i, batch in enumerate(_batches(flights[0], int(1e12), rate, bit_at_s=20.0)):
        if i == 1:
            current = watch.signals["phase_a_current_a"]
            s = batch[current]
            value = np.array(s.value, dtype=np.float64, copy=True)
            value[: min(10, value.size)] = np.nan
            batch = {**batch, current: dataclasses.replace(s, value=value)}
        watch.feed(batch)
    row = watch.finish("N1")
    assert row is not None
    assert watch.skipped == 0   # the NaN samples were left out, nothing had to be skipped
    assert row.flight_s > 0.8 * (flights[0]["position_deg"].size / rate - 2.0)
