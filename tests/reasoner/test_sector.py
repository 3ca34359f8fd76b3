"""The sector-resolved phase-A loop resistance and its one healthy-model cell."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

from mapr_daemon.ema.inverter import NEGATIVE, POSITIVE
from mapr_daemon.reasoner.diagnosis import classifier, healthy_model, matched_filter
from mapr_daemon.reasoner.diagnosis.false_alarm import calibrate_gaussian
from mapr_daemon.reasoner.diagnosis.features import (
    EXTENDED_SIGNALS,
    SECTOR_SIGNALS,
    column_names,
    derived_signals,
)
from mapr_daemon.reasoner.diagnosis.sector import a_high_resistance
from tests.reasoner.conftest import Bench


def _synthetic(r_a_high: float, r_other: float, seed: int) -> dict[str, np.ndarray]:
    """Two runs of a six-step drive obeying ``v = R * i_q + k * omega + offset`` exactly, with
    ``R`` one value in the sectors where phase A's high side is PWM'd and another elsewhere."""
    rng = np.random.default_rng(seed)
    n = 3000
    pos = np.cumsum(rng.normal(0.0, 0.5, (2, n)), axis=1)
    sector = rng.integers(1, 7, (2, n)).astype(np.float64)
    duty = rng.uniform(-0.9, 0.9, (2, n))
    duty[np.abs(duty) < 0.05] = 0.1
    i_q = rng.normal(0.0, 2.0, (2, n))
    sec = sector.astype(np.int64) - 1
    cur = np.zeros((3, 2, n))
    plus, minus = POSITIVE.argmax(axis=1)[sec], NEGATIVE.argmax(axis=1)[sec]
    np.put_along_axis(cur, plus[None], i_q[None], 0)
    np.put_along_axis(cur, minus[None], -i_q[None], 0)
    a_high = ((duty > 0) & np.isin(sector, (1, 2))) | ((duty < 0) & np.isin(sector, (4, 5)))
    omega = np.gradient(pos, axis=-1)
    v = np.where(a_high, r_a_high, r_other) * i_q + 0.3 * omega + 0.05
    return {"commutation_sector": sector, "inverter_duty": duty, "phase_a_current_a": cur[0],
            "phase_b_current_a": cur[1], "phase_c_current_a": cur[2], "position_deg": pos,
            "dc_bus_voltage_v": v / duty}


def test_the_fit_recovers_the_extra_resistance_of_phase_a_high_sectors() -> None:
    ch = _synthetic(0.62, 0.5, 1)
    assert np.allclose(a_high_resistance(ch), 0.12, atol=1e-9)
    assert np.allclose(a_high_resistance(_synthetic(0.5, 0.5, 2)), 0.0, atol=1e-9)


def test_the_resistance_is_one_value_per_record_and_one_healthy_cell() -> None:
    ch = _synthetic(0.7, 0.5, 3)
    sig = derived_signals(ch, None)["a_high_resistance_ohm"]
    assert sig.shape == ch["inverter_duty"].shape
    assert np.allclose(sig, 0.2) and np.all(sig == sig[:, :1])
    one = derived_signals({k: v[0] for k, v in ch.items()}, None)["a_high_resistance_ohm"]
    assert one.shape == (3000,) and np.allclose(one, 0.2)
    columns = column_names((*EXTENDED_SIGNALS, *SECTOR_SIGNALS))
    rows, pool = 122, 6
    cells = healthy_model.record_cells(columns, rows, pool)
    col = columns.index("mean:a_high_resistance_ohm")
    own = cells[(cells % len(columns) == col).any(axis=1)]
    assert own.shape == (1, pool) and np.all(own == own[0, 0])
    without = healthy_model.record_cells(column_names(EXTENDED_SIGNALS), rows, pool)
    assert cells.shape[0] == without.shape[0] + 4 * (rows - 32) // pool + 1


def test_the_normal_threshold_is_the_stated_quantile_and_never_below_the_largest_score() -> None:
    rng = np.random.default_rng(4)
    s = rng.normal(0.5, 2.0, 20_000)
    cal = calibrate_gaussian(s, 1e-6)
    assert abs(cal.threshold - (0.5 + 2.0 * 4.7534)) < 0.1 and not cal.tail_governs
    heavy = np.concatenate([rng.normal(0.0, 1.0, 99), [40.0]])
    assert calibrate_gaussian(heavy, 1e-3).threshold == 40.0


def test_the_matched_filter_weighs_cells_by_the_inverse_healthy_covariance() -> None:
    rng = np.random.default_rng(5)
    n, dim = 4000, 6
    mix = np.eye(dim)
    mix[0, 1] = 0.9  # cell 1 carries cell 0's noise too
    z = rng.normal(size=(n, dim)) @ mix
    mu = np.array([0.0, 1.0, 0.0, 0.5, 0.0, 0.0])
    sev = rng.uniform(0.1, 0.5, 20_000)
    faulted = rng.normal(size=(sev.size, dim)) @ mix + sev[:, None] * mu
    w = matched_filter.fit(z, faulted, sev, shrinkage=0.0)
    cov = mix.T @ mix
    expect = np.linalg.solve(cov, mu)
    assert np.allclose(w / np.linalg.norm(w), expect / np.linalg.norm(expect), atol=0.05)
    # on held-out runs the filter separates a 0.3-severity shift better than its best cell
    test = rng.normal(size=(2000, dim)) @ mix
    shift = 0.3 * mu
    snr = float((shift @ w) / (test @ w).std())
    best_cell = max(float(shift[j] / test[:, j].std()) for j in range(dim))
    assert snr > 1.2 * best_cell


def test_the_matched_filter_raises_an_alarm_the_dictionary_cannot_name(bench: Bench) -> None:
    d = bench.dictionary
    assert d.healthy is not None and d.healthy.matched is None  # no inverter runs in it
    assert "matched_threshold" not in d.calibration
    column = d.columns.index("mean:a_high_resistance_ohm")
    j = int(np.flatnonzero(d.healthy.cells[:, 0] % len(d.columns) == column)[0])
    w = np.zeros(d.healthy.cells.shape[0])
    w[j] = 1.0
    d2 = copy.copy(d)
    d2.healthy = dataclasses.replace(d.healthy, matched=w)
    d2.calibration = {**d.calibration, "matched_mean": 0.0, "matched_sd": 1.0,
                      "matched_threshold": 4.0}
    healthy_m, q = bench.held_m[0], float(bench.held_q[0])
    calm = classifier.decide(d2, healthy_m, q)
    assert not calm.anomaly and calm.evidence["matched"]["alarm"] is False
    raised = healthy_m.copy()
    raised.ravel()[d.healthy.cells[j]] += 12.0 * d.healthy.sd[j]
    score = classifier.matched_score(d2, raised, q)
    assert score is not None and score > 4.0
    alarm = classifier.decide(d2, raised, q)
    assert alarm.anomaly and alarm.evidence["matched"]["alarm"] is True
    if alarm.fault is None:  # the matched test alone: the dictionary has no phase-A Ron
        assert "unexplained" in alarm.evidence
