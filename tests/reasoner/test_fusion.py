"""The trend fuses per-flight in-flight friction estimates with the BITs' (issue 29).

An aging friction unit (the aging model's path) with per-BIT estimates drawn from a noisy
estimator every fourth flight, and per-flight in-flight changes at the tracker's measured
twin error (0.006 of the failure threshold, stated sd 0.023): fused, the RUL is closer to the
truth than the BITs' alone and its 90 % interval still holds the truth.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.ema.degradation import FAILURE, trajectory
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.prognosis.fusion import fit_rul_fused, observation, placed
from mapr_daemon.reasoner.prognosis.trend import Noise


def test_per_flight_friction_estimates_tighten_the_rul_and_it_still_holds_the_truth() -> None:
    params = load_actuator(default_actuator_path())
    noise = Noise(sd0=0.08)
    rng = np.random.default_rng(5)
    err_bits, err_fused, covered = [], [], 0
    for unit in range(8):
        t = trajectory(params, "friction", 400, seed=100 + unit)
        h = (t.values / t.nominal - 1.0) / (FAILURE["friction"] - 1.0)
        now = int(0.6 * t.eol_flight)
        truth = t.eol_flight - now
        fl = np.arange(0, now + 1, 4, dtype=np.float64)
        est = h[fl.astype(int)] + 0.08 * rng.standard_normal(fl.size)
        obs = [(float(n), float(h[n] + 0.006 * rng.standard_normal()), 0.023)
               for n in range(4, now + 1)]
        alone = fit_rul_fused(fl, est, float(now), "friction", noise, None, [], seed=unit)
        fused = fit_rul_fused(fl, est, float(now), "friction", noise, None, obs, seed=unit)
        err_bits.append(abs(alone.rul - truth) / truth)
        err_fused.append(abs(fused.rul - truth) / truth)
        covered += fused.lower <= truth <= fused.upper
    assert np.mean(err_fused) <= np.mean(err_bits)
    assert covered >= 7, f"the fused 90 % interval held the truth on {covered} of 8 units"


def test_only_a_commissioned_friction_change_is_an_observation() -> None:
    assert observation("friction", {"change": None, "sd_change": None}) is None
    assert observation("loop_r", {"change": 0.1, "sd_change": 0.02}) is None
    s = FAILURE["friction"] - 1.0
    # a row stored before the sd was split: its sd is the flight's, no common part
    assert observation("friction", {"change": 0.5, "sd_change": 0.04}) == \
        ("friction", 0.5 / s, 0.04 / s, 0.0)
    split = {"change": 0.5, "sd_change": 0.05, "sd_flight": 0.04, "sd_baseline": 0.03}
    assert observation("friction", split) == ("friction", 0.5 / s, 0.04 / s, 0.03 / s)


def test_the_baseline_scale_error_rescales_every_flight_alike() -> None:
    s = FAILURE["friction"] - 1.0
    obs = [(10.0, 0.25, 0.02, 0.01), (20.0, 0.5, 0.02, 0.02)]
    n, h, sd = placed("friction", obs, 1.0, 0.1)   # the baseline read 10 % high
    assert list(n) == [10.0, 20.0]
    assert h == pytest.approx([((1 + s * 0.25) / 1.1 - 1) / s, ((1 + s * 0.5) / 1.1 - 1) / s])
    assert sd == pytest.approx([0.02 / 1.1, 0.02 / 1.1])


def test_a_common_baseline_error_widens_the_fused_interval_to_hold_the_truth() -> None:
    """Many flights read through one baseline that is 20 % off (the scale error stated as
    its sd): fitted as independent they would claim to have averaged it away and the 90 %
    interval would miss; marginalised, it holds the truth on most units."""
    params = load_actuator(default_actuator_path())
    noise = Noise(sd0=0.08)
    rng = np.random.default_rng(17)
    s = FAILURE["friction"] - 1.0
    held = {"common": 0, "independent": 0}
    for unit in range(10):
        t = trajectory(params, "friction", 400, seed=300 + unit)
        h = (t.values / t.nominal - 1.0) / s
        now = int(0.6 * t.eol_flight)
        truth = t.eol_flight - now
        fl = np.arange(0, now + 1, 4, dtype=np.float64)
        est = h[fl.astype(int)] + 0.08 * rng.standard_normal(fl.size)
        beta = 1.0 + 0.2 * (1.0 if unit % 2 else -1.0)
        common = [(float(n), float(((1 + s * h[n]) * beta - 1) / s), 0.01,
                   0.2 * (1 + s * h[n]) / s) for n in range(4, now + 1)]
        for name, obs in (("common", common),
                          ("independent", [(n, v, (a * a + b * b) ** 0.5)
                                           for n, v, a, b in common])):
            r = fit_rul_fused(fl, est, float(now), "friction", noise, None, obs, seed=unit)
            held[name] += r.lower <= truth <= r.upper
    assert held["common"] >= 9, held
    assert held["common"] > held["independent"], held
