"""The anomaly threshold for a stated false-alarm rate, from healthy calibration runs.

The anomaly score of a healthy run is the energy the best fault template explains of a nearly
white residual: roughly a scaled chi-square variable. Its scale ``g`` and degrees of freedom
``h`` are matched to the calibration scores' mean and variance (Satterthwaite's moment match:
``g = var/(2 mean)``, ``h = 2 mean^2/var``), and the threshold is the ``1 - rate`` quantile of
``g * chi2(h)`` — but never below the largest calibration score: where the fitted law's tail
is lighter than the data's, the data wins (``tail_governs``). The calibration runs are not
used to fit the healthy model (their scores are out of sample, like a flight's), and they are
flown at random pressures, supply voltages and temperatures. The largest calibration score
is reported beside the threshold, so a fit that does not describe the tail shows up at once.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import stats

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError


@dataclasses.dataclass(frozen=True)
class Calibration:
    """A threshold and how it was reached."""

    threshold: float
    rate: float
    scale: float
    dof: float
    runs: int
    score_max: float
    score_median: float
    expected_above_max: float
    """How many of the calibration runs the fitted law expects above their largest score."""
    tail_governs: bool
    """True when the largest calibration score, not the fitted quantile, set the threshold."""


def calibrate(scores: FloatArray, rate: float) -> Calibration:
    """The threshold that healthy runs exceed with probability ``rate`` (fitted law)."""
    s = _checked(scores, rate)
    s = np.maximum(s, 0.0)
    mean = float(s.mean())
    var = float(max(s.var(ddof=1), 1e-12))
    scale = var / (2.0 * mean) if mean > 0 else 1.0
    dof = 2.0 * mean * mean / var if mean > 0 else 1.0
    fitted = float(scale * stats.chi2.isf(rate, dof))
    above = float(s.size * stats.chi2.sf(s.max() / scale, dof))
    threshold = max(fitted, float(s.max()))
    return Calibration(threshold, rate, scale, dof, int(s.size), float(s.max()),
                       float(np.median(s)), above, fitted < float(s.max()))


@dataclasses.dataclass(frozen=True)
class GaussianCalibration:
    """A one-sided threshold on a statistic that is Gaussian on healthy runs."""

    threshold: float
    rate: float
    mean: float
    sd: float
    runs: int
    score_max: float
    tail_governs: bool


def calibrate_gaussian(scores: FloatArray, rate: float) -> GaussianCalibration:
    """The threshold that healthy runs exceed with probability ``rate``, for a statistic whose
    healthy law is normal (one healthy-model cell in its healthy spreads): ``mean + sd * z``
    with ``z`` the normal's upper ``rate`` point, never below the largest calibration score."""
    s = _checked(scores, rate)
    mean, sd = float(s.mean()), float(max(s.std(ddof=1), 1e-12))
    fitted = mean + sd * float(stats.norm.isf(rate))
    return GaussianCalibration(max(fitted, float(s.max())), rate, mean, sd, int(s.size),
                               float(s.max()), fitted < float(s.max()))


def _checked(scores: FloatArray, rate: float) -> FloatArray:
    """The calibration scores as float64, once the run count and the rate are valid."""
    s = np.asarray(scores, dtype=np.float64)
    if s.size < 10:
        raise ConfigError("need >= 10 healthy calibration runs", field="calibration_runs")
    if not 0.0 < rate < 0.5:
        raise ConfigError("the false-alarm rate is a probability below 0.5",
                          field="false_alarm_rate")
    return s


CALIBRATION_QUANTILES = (0.5, 0.75, 0.9, 0.95, 0.975, 0.99)
"""Quantiles of the calibration runs' scores a dictionary keeps for unit calibrations."""


def quantile_entries(name: str, scores: FloatArray) -> dict[str, float]:
    """Calibration entries holding the calibration runs' ``name`` scores at
    :data:`CALIBRATION_QUANTILES` (what :func:`calibrate_unit` compares a unit's with)."""
    values = np.quantile(scores, CALIBRATION_QUANTILES)
    return {f"{name}_quantile_{k}": float(v) for k, v in enumerate(values)}


def stored_quantiles(calibration: dict[str, float], name: str) -> FloatArray | None:
    """The quantiles :func:`quantile_entries` stored, or None (a dictionary built before)."""
    keys = [f"{name}_quantile_{k}" for k in range(len(CALIBRATION_QUANTILES))]
    if not all(k in calibration for k in keys):
        return None
    return np.array([calibration[k] for k in keys])
