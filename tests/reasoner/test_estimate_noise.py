"""The estimate's noise as a function of the flight condition: measured, stated, and used by
the trend."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.reasoner.prognosis import trend
from mapr_daemon.reasoner.prognosis.wear_noise import Noise, scaled_rows


def _calibration(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Estimates ``0.02 + 0.9 h + e`` whose sd is 0.03 at nominal supply and grows fourfold
    towards the bus's low limit (v = -5 V), as the capacitance estimate does."""
    rng = np.random.default_rng(seed)
    h = rng.uniform(0.0, 1.25, n)
    c = np.c_[rng.uniform(0.0, 1.0, n), rng.uniform(-5.5, 1.5, n), rng.uniform(-6.0, 4.5, n)]
    sd = 0.03 * np.exp(-0.28 * c[:, 1])
    return h, 0.02 + 0.9 * h + sd * rng.standard_normal(n), c


def test_the_stated_sd_follows_the_condition() -> None:
    """Measured on 600 calibration BITs, the sd stated at nominal supply and at the low limit
    is within 25 % of the true one at each, where one envelope-wide figure is off by 2x."""
    h, est, c = _calibration(600, 1)
    noise = Noise.measure(h, est, c)
    assert noise.gain == pytest.approx(0.9, abs=0.03)
    nominal, low = np.array([[0.5, 0.0, 0.0]]), np.array([[0.5, -5.0, 0.0]])
    assert float(noise.sd(np.array([0.5]), nominal)[0]) == pytest.approx(0.03, rel=0.25)
    assert float(noise.sd(np.array([0.5]), low)[0]) == pytest.approx(0.03 * np.exp(1.4),
                                                                    rel=0.25)
    flat = float(noise.sd(np.array([0.5]))[0])
    assert flat > 1.8 * 0.03   # the envelope-wide figure overstates a nominal BIT's noise


def test_standardised_errors_are_calibrated_on_fresh_bits() -> None:
    """On other BITs, 90 % intervals from the stated sd cover 85-95 % in both halves of the
    envelope (nominal and low supply); the envelope-wide sd does not."""
    h, est, c = _calibration(600, 2)
    noise = Noise.measure(h, est, c)
    ht, et, ct = _calibration(2000, 3)
    err = np.abs(et - (noise.offset + noise.gain * ht))
    low = ct[:, 1] < -2.0
    for part in (low, ~low):
        cond = err[part] < 1.645 * noise.sd(ht[part], ct[part])
        assert 0.85 <= cond.mean() <= 0.95
    flat = err < 1.645 * noise.sd(ht)
    assert flat[~low].mean() > 0.97 and flat[low].mean() < 0.85


def test_unknown_conditions_fall_back_to_the_envelope_figure() -> None:
    h, est, c = _calibration(600, 4)
    noise = Noise.measure(h, est, c)
    rows = scaled_rows([None, (0.5, 0.0, 0.0), (1.0,)], 3)   # unknown, known, malformed
    sd = noise.sd(np.full(3, 0.5), rows)
    flat = float(noise.sd(np.array([0.5]))[0])
    assert sd[0] == pytest.approx(flat) and sd[2] == pytest.approx(flat)
    assert sd[1] < flat
    few = Noise.measure(h[:40], est[:40], c[:40])   # too few BITs for the condition model
    assert few.log_sd == ()


def test_the_trend_is_tighter_on_bits_flown_at_nominal_conditions() -> None:
    """The same estimates, once said to be flown at nominal supply and once at the low limit:
    the RUL interval is narrower where the noise model says the estimates are better."""
    h, est, c = _calibration(600, 5)
    noise = Noise.measure(h, est, c)
    n = np.arange(0.0, 120.0, 4.0)
    truth = 0.2 * np.expm1(0.012 * n)   # 0.6 of the threshold by the last BIT
    reading = noise.offset + noise.gain * truth + 0.03 * np.random.default_rng(6).standard_normal(
        n.size)
    width = {}
    for v in (0.0, -5.0):
        cond = np.tile([0.5, v, 0.0], (n.size, 1))
        r = trend.fit_rul(n, reading, float(n[-1]), "capacitance", noise, conditions=cond)
        width[v] = r.upper - r.lower
    assert width[0.0] < 0.7 * width[-5.0]


def test_estimates_compressed_near_the_bus_limit_are_read_at_their_condition() -> None:
    """Estimates that follow the degradation fully at nominal supply and with 0.6 of the gain
    and an offset near the bus's low limit (as ESR's do): read at each BIT's condition they
    are unbiased at both; the envelope-wide line reads a new part at nominal supply low."""
    rng = np.random.default_rng(7)
    n = 800
    h = rng.uniform(0.0, 1.25, n)
    c = np.c_[rng.uniform(0.0, 1.0, n), rng.uniform(-5.5, 1.5, n), rng.uniform(-6.0, 4.5, n)]
    gain, offset = 1.0 + 0.08 * c[:, 1], -0.05 * c[:, 1]
    est = offset + gain * h + 0.03 * rng.standard_normal(n)
    noise = Noise.measure(h, est, c)
    for v in (0.0, -5.0):
        cond = np.tile([0.5, v, 0.0], (50, 1))
        truth = np.linspace(0.0, 1.0, 50)
        reading = -0.05 * v + (1.0 + 0.08 * v) * truth
        assert np.abs(noise.calibrate(reading, cond) - truth).max() < 0.03
        sd = noise.h_sd(truth, cond)
        assert float(np.median(sd)) == pytest.approx(0.03 / (1.0 + 0.08 * v), rel=0.3)
    line_error = noise.calibrate(np.linspace(0.0, 1.0, 50)) - np.linspace(0.0, 1.0, 50)
    assert line_error[0] < -0.08   # one line for the envelope: a new part read 0.1 low


def test_a_bit_outside_the_calibrated_envelope_is_read_at_its_edge() -> None:
    """A bus voltage below any calibration BIT's is read as at the lowest one: the quadratic
    terms are not extrapolated into a vanishing or exploding sd."""
    h, est, c = _calibration(600, 8)
    noise = Noise.measure(h, est, c)
    edge = np.array([[0.5, min(noise.c_low[1], -5.4), 0.0]])
    beyond = np.array([[0.5, -40.0, 0.0]])
    assert noise.h_sd(np.array([0.5]), beyond)[0] == pytest.approx(
        noise.h_sd(np.array([0.5]), np.array([[0.5, noise.c_low[1], 0.0]]))[0])
    assert np.isfinite(noise.calibrate(np.array([0.5]), beyond)).all()
    assert noise.h_sd(np.array([0.5]), edge)[0] > 0.0


def test_the_model_file_keeps_the_noise_model(tmp_path: Path) -> None:
    """A prognostic model saved and loaded has the same noise (tuples, not lists) and the
    nominal supply it scales conditions by."""
    from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
    from mapr_daemon.reasoner.prognosis.wear_estimators import WearModel

    h, est, c = _calibration(600, 9)
    noise = Noise.measure(h, est, c)
    estimators = {k: WearModel(k, np.zeros((25, 2)), np.eye(2), 0.1, 50)
                  for k in ("esr", "friction")}
    model = PrognosticModel("EMA", estimators, {"esr": noise}, {"friction": "why"}, {},
                            supply_nominal_v=28.0)
    path = tmp_path / "p.npz"
    model.save(path)
    back = PrognosticModel.load(path)
    assert back.noise == model.noise and hash(back.noise["esr"]) == hash(noise)
    assert back.supply_nominal_v == 28.0 and back.unobservable == {"friction": "why"}
    assert back.scaled({"dynamic_pressure_pa": 2500.0, "supply_v": 27.0, "ambient_c": 35.0}) \
        == pytest.approx((1.0, -1.0, 1.0))
