"""The trend fuses per-flight in-flight friction estimates with the BITs' (issue 29).

An aging friction unit (the aging model's path) with per-BIT estimates drawn from a noisy
estimator every fourth flight, and per-flight in-flight changes at the tracker's measured
twin error (0.006 of the failure threshold, stated sd 0.023): fused, the RUL is closer to the
truth than the BITs' alone and its 90 % interval still holds the truth.
"""

from __future__ import annotations

import numpy as np

from mapr_daemon.ema.degradation import FAILURE, trajectory
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.prognosis.fusion import fit_rul_fused, inflated, observation
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
    kind, h, sd = observation("friction", {"change": 0.5, "sd_change": 0.04}) or ("", 0, 0)
    assert kind == "friction" and h == 0.5 / (FAILURE["friction"] - 1.0)
    assert sd == 0.04 / (FAILURE["friction"] - 1.0)


def test_in_flight_scatter_beyond_the_stated_sd_widens_it_and_honest_sds_stay() -> None:
    rng = np.random.default_rng(9)
    n = np.arange(4, 80, dtype=np.float64)
    wide = [(float(k), float(0.01 * k / 80 + 0.14 * rng.standard_normal()), 0.046) for k in n]
    honest = [(float(k), float(0.023 * rng.standard_normal()), 0.023) for k in n]
    widened = inflated(wide)[0][2]
    assert 0.1 < widened < 0.2, f"the 0.14 scatter was stated 0.046 and widened to {widened}"
    assert inflated(honest)[0][2] < 0.023 * 1.3
