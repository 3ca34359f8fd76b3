"""The aging-shape trend fit: RUL on the aging model's own paths with known noise, its
bounds, measured noise, the fleet prior, and a bound beyond the horizon."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mapr_daemon.ema.degradation import trajectory
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner import prognosis, trend
from mapr_daemon.reasoner.features import FloatArray
from mapr_daemon.reasoner.trajectory import learn_prior

PARAMS = load_actuator(default_actuator_path())


def _path(kind: str, seed: int) -> tuple[float, FloatArray, FloatArray]:
    t = trajectory(PARAMS, kind, 400, seed, 200.0)
    n = np.arange(0, math.floor(t.eol_flight) + 1, dtype=np.float64)
    h = np.array([prognosis.degradation(PARAMS, kind, float(t.values[int(f)])) for f in n])
    return t.eol_flight, n, h


@pytest.mark.parametrize("kind", ["smps_ron_high", "capacitance", "esr", "friction"])
def test_rul_at_three_quarters_of_life_within_20_percent(kind: str) -> None:
    """Each kind's own shape, a BIT every flight with 0.05 noise: the median RUL at 3/4 of
    the life is within 20 % of the truth and the 5-95 % bounds contain it."""
    eol, n, h = _path(kind, 3)
    now = round(0.75 * eol)
    seen = n <= now
    rng = np.random.default_rng(1)
    noisy = h[seen] + 0.05 * rng.standard_normal(int(seen.sum()))
    r = trend.fit_rul(n[seen], noisy, now, kind, trend.Noise(0.05),
                      learn_prior(PARAMS, kind, 8))
    true = eol - now
    assert r.rul == pytest.approx(true, rel=0.2)
    assert r.lower <= true <= r.upper
    assert prognosis.alpha_lambda_pass(true, r.draws)


def test_more_noise_widens_the_bounds() -> None:
    eol, n, h = _path("smps_ron_high", 5)
    now = round(0.6 * eol)
    seen = n <= now
    rng = np.random.default_rng(2)
    e = rng.standard_normal(int(seen.sum()))
    prior = learn_prior(PARAMS, "smps_ron_high", 8)
    tight = trend.fit_rul(n[seen], h[seen] + 0.02 * e, now, "smps_ron_high",
                          trend.Noise(0.02), prior)
    wide = trend.fit_rul(n[seen], h[seen] + 0.2 * e, now, "smps_ron_high",
                         trend.Noise(0.2), prior)
    assert wide.upper - wide.lower > 2 * (tight.upper - tight.lower)


def test_healthy_unit_has_no_finite_rul_and_never_nan() -> None:
    n = np.arange(0.0, 40.0)
    rng = np.random.default_rng(4)
    r = trend.fit_rul(n, 0.02 * rng.standard_normal(n.size), 39.0, "esr", trend.Noise(0.02),
                      horizon=500.0)
    assert math.isinf(r.upper) and not math.isnan(r.rul) and not math.isnan(r.lower)
    assert r.as_event()["high"] is None


def test_noise_is_measured_with_the_estimates_scale_error() -> None:
    rng = np.random.default_rng(5)
    h = np.repeat([0.0, 0.25, 0.5, 0.75, 1.0], 40)
    est = 0.1 + 0.8 * h + (0.05 + 0.1 * h) * rng.standard_normal(h.size)
    noise = trend.Noise.measure(h, est)
    assert noise.gain == pytest.approx(0.8, abs=0.05)
    assert noise.offset == pytest.approx(0.1, abs=0.03)
    assert noise.sd0 == pytest.approx(0.05, abs=0.02)
    assert noise.sd1 == pytest.approx(0.1, abs=0.04)
    with pytest.raises(ConfigError):
        trend.Noise.measure(h, rng.standard_normal(h.size) * 0.01)


def test_fleet_prior_learns_the_shape_of_other_units() -> None:
    # the friction paths of the aging model all wear as n**1.5
    p = learn_prior(PARAMS, "friction", 6)
    assert math.exp(p.mean) == pytest.approx(1.5, rel=0.05)
    # exponential Ron aging: a few e-foldings over lives of 140-260 flights
    r = learn_prior(PARAMS, "smps_ron_high", 6)
    assert 2.0 / 260 < math.exp(r.mean) < 4.0 / 140


def test_a_dead_zone_is_measured_and_its_estimates_censored_not_fitted_as_zero() -> None:
    """An estimator that reads 0 until the degradation passes 0.15: the floor and the
    transition are measured, and the RUL from a path read through it stays within 20 %,
    where fitting the zeros as values pulls the curve steep (RUL far too short)."""
    rng = np.random.default_rng(6)
    levels = np.repeat([0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0, 1.25], 6)

    def read(h: FloatArray) -> FloatArray:
        e = h + 0.03 * rng.standard_normal(h.size)
        return np.where(h < 0.15, 0.0, np.maximum(e, 0.0))

    noise = trend.Noise.measure(levels, read(levels))
    assert noise.floor == 0.0
    assert noise.detection == pytest.approx(0.15, abs=0.05)
    eol, n, h = _path("capacitance", 4)
    now = round(0.75 * eol)
    seen = n <= now
    est = read(h[seen])
    assert (est == 0.0).sum() > 10
    prior = learn_prior(PARAMS, "capacitance", 8)
    r = trend.fit_rul(n[seen], est, now, "capacitance", noise, prior)
    assert r.rul == pytest.approx(eol - now, rel=0.2)
    naive = trend.fit_rul(n[seen], est, now, "capacitance",
                          trend.Noise(noise.sd0, noise.sd1, noise.offset, noise.gain), prior)
    assert abs(naive.rul - (eol - now)) > abs(r.rul - (eol - now))


def test_fleet_prior_learns_the_life_and_the_scatter() -> None:
    """From 30 units' true paths: lives around the aging model's mean of 200 flights, the
    exponential's rate tied to the life (a unit that bends late must start low: negative
    correlation), and the part's own scatter about its smooth path (1 % of the value)."""
    prior = learn_prior(PARAMS, "smps_ron_high", 30)
    assert 170.0 < math.exp(prior.life_mean) < 230.0
    assert 0.05 < prior.life_sd < 0.3
    assert prior.corr < -0.3
    sd = prior.scatter(np.array([0.0, 1.0]))
    assert 0.003 < sd[0] < 0.03 and sd[1] >= sd[0]
    esr = learn_prior(PARAMS, "esr", 30)
    assert esr.life_sd == 0.0  # the amplitude is fixed: no joint life prior
