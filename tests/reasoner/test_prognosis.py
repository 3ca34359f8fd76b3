"""SoH, the RUL estimate's JSON form, and the prognostic metrics on cases with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.prognosis import rul, soh
from mapr_daemon.reasoner.training import rul_metrics

PARAMS = load_actuator(default_actuator_path())


def test_soh_is_one_at_nominal_and_zero_at_the_failure_threshold() -> None:
    assert soh.soh(PARAMS, "esr", 0.05) == 1.0
    assert soh.soh(PARAMS, "esr", 0.10) == pytest.approx(0.0)
    assert soh.soh(PARAMS, "esr", 0.075) == pytest.approx(0.5)
    assert soh.soh(PARAMS, "capacitance", 288e-6 * 0.85) == pytest.approx(0.5)
    assert soh.soh(PARAMS, "friction", 2.0) == pytest.approx(0.5)
    assert soh.soh(PARAMS, "short", None) == 0.0
    assert soh.failure_severity(PARAMS, "capacitance") == pytest.approx(0.3)
    with pytest.raises(ConfigError):
        soh.soh(PARAMS, "warp_drive", 1.0)


def test_metrics() -> None:
    assert rul_metrics.relative_accuracy(50.0, 40.0) == pytest.approx(0.8)
    assert rul_metrics.alpha_lambda_pass(50.0, np.array([45.0, 55.0, 90.0]), 0.2)
    assert not rul_metrics.alpha_lambda_pass(50.0, np.array([45.0, 80.0, 90.0]), 0.2)
    times = np.array([10.0, 20.0, 30.0, 40.0])
    true = 50.0 - times
    est = np.array([10.0, 31.0, 19.0, 10.5])  # within 20 % from t = 20 on
    assert rul_metrics.prognostic_horizon(times, true, est, 50.0, 0.2) == 30.0


def test_rul_estimate_reports_a_bound_beyond_the_horizon_as_null_never_nan() -> None:
    draws = np.array([30.0, 40.0, 50.0, 60.0] + [math.inf] * 2)
    lo, mid, hi = rul.quantiles(draws)
    assert (lo, mid) == (30.0, 50.0) and math.isinf(hi)
    r = rul.RulEstimate(mid, lo, hi, draws, horizon=400.0)
    ev = r.as_event()
    assert ev["high"] is None and "beyond the 400-flight horizon" in ev["note"]
    assert ev["rul"] == 50.0 and ev["low"] == 30.0
    assert "note" not in rul.RulEstimate(1.0, 0.5, 2.0, draws[:4]).as_event()
