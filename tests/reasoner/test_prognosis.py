"""SoH, RUL from a trend, and the prognostic metrics on cases with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner import prognosis

PARAMS = load_actuator(default_actuator_path())


def test_soh_is_one_at_nominal_and_zero_at_the_failure_threshold() -> None:
    assert prognosis.soh(PARAMS, "esr", 0.05) == 1.0
    assert prognosis.soh(PARAMS, "esr", 0.10) == pytest.approx(0.0)
    assert prognosis.soh(PARAMS, "esr", 0.075) == pytest.approx(0.5)
    assert prognosis.soh(PARAMS, "capacitance", 288e-6 * 0.85) == pytest.approx(0.5)
    assert prognosis.soh(PARAMS, "friction", 2.0) == pytest.approx(0.5)
    assert prognosis.soh(PARAMS, "short", None) == 0.0
    assert prognosis.failure_severity(PARAMS, "capacitance") == pytest.approx(0.3)
    with pytest.raises(ConfigError):
        prognosis.soh(PARAMS, "warp_drive", 1.0)


def test_rul_from_a_clean_quadratic_trend() -> None:
    flights = np.arange(0, 61, 5, dtype=float)
    eol = 100.0
    h = (flights / eol) ** 2  # reaches 1 at flight 100
    r = prognosis.rul_from_trend(flights, h, now=60.0)
    assert r.rul == pytest.approx(40.0, abs=0.5)
    assert r.lower <= r.rul <= r.upper


def test_rul_bounds_widen_with_noise_and_contain_the_truth() -> None:
    rng = np.random.default_rng(3)
    flights = np.arange(0, 61, 3, dtype=float)
    h = flights / 100.0 + 0.03 * rng.standard_normal(flights.size)
    r = prognosis.rul_from_trend(flights, h, now=60.0)
    assert r.lower < 40.0 < r.upper
    assert r.upper - r.lower > 5.0


def test_flat_trend_has_no_finite_rul() -> None:
    flights = np.arange(10, dtype=float)
    r = prognosis.rul_from_trend(flights, np.zeros(10) + 1e-4 * np.arange(10) % 2, now=9.0)
    assert math.isinf(r.rul)


def test_metrics() -> None:
    assert prognosis.relative_accuracy(50.0, 40.0) == pytest.approx(0.8)
    assert prognosis.alpha_lambda_pass(50.0, np.array([45.0, 55.0, 90.0]), 0.2)
    assert not prognosis.alpha_lambda_pass(50.0, np.array([45.0, 80.0, 90.0]), 0.2)
    times = np.array([10.0, 20.0, 30.0, 40.0])
    true = 50.0 - times
    est = np.array([10.0, 31.0, 19.0, 10.5])  # within 20 % from t = 20 on
    assert prognosis.prognostic_horizon(times, true, est, 50.0, 0.2) == 30.0


def test_a_bound_beyond_the_horizon_is_reported_as_such_never_nan() -> None:
    # a slow noisy trend: most draws cross within the horizon, some never do
    rng = np.random.default_rng(11)
    flights = np.arange(0, 41, 2, dtype=float)
    h = flights / 400.0 + 0.02 * rng.standard_normal(flights.size)
    r = prognosis.rul_from_trend(flights, h, now=40.0, horizon_factor=10.0)
    assert np.isinf(r.draws).any() and np.isfinite(r.draws).any()
    assert not any(math.isnan(v) for v in (r.rul, r.lower, r.upper))
    assert math.isinf(r.upper)
    assert r.horizon == pytest.approx(400.0)
    ev = r.as_event()
    assert ev["high"] is None and "beyond the 400-flight horizon" in ev["note"]
    assert ev["low"] is not None and ev["low"] == pytest.approx(r.lower, abs=1e-3)
