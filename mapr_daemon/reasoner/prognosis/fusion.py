"""One RUL from per-BIT estimates and per-flight in-flight estimates, each with its own noise.

The trend (:func:`~mapr_daemon.reasoner.prognosis.trend.fit_rul`) is a weighted fit of the
kind's aging shape: observations with their variances. A BIT's degradation estimate carries
the measured noise of its estimator at that BIT's flight condition
(:class:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise`); an in-flight estimate
(:mod:`mapr_daemon.reasoner.inflight`) carries the tracker's stated sd. Both are points on
the same degradation path, so :func:`fit_rul_fused` fits them together: the BITs as
:func:`~.trend.fit_rul` reads them (calibrated, dead-zone readings censored), the flights'
estimates as ``h`` with variance ``sd^2`` (the stated sd widened by the flights' own
scatter, :func:`inflated`), each plus the part's own flight-to-flight scatter
about its smooth path (the fleet prior's), since the threshold is crossed by the smooth path.

Which in-flight parameter trends which aging kind (:data:`INFLIGHT_KINDS`): only
``friction`` (its per-flight change over the commissioned baseline, in units of the failure
threshold's change, ``FAILURE - 1``: rms 0.006 per flight on the twin, docs/reasoner.md).
The tracker's other parameters do not map to a trended mode at a usable noise: the loop
resistance has no fault mode; phase-A high-side Ron is not resolved per flight (sd ~9
failure thresholds); the DC-bus proxy reads ESR at 0.5-0.8 of its threshold per flight.
So the modes BITs cannot trend stay untrended from flight data too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.reasoner.prognosis import trend
from mapr_daemon.reasoner.prognosis.rul import RulEstimate

INFLIGHT_KINDS: dict[str, str] = {"friction": "friction"}
"""In-flight parameter -> the aging kind whose degradation its change measures."""
MIN_FOR_SCATTER = 5
"""In-flight observations needed before their own scatter can widen their stated sd."""
CHI2_1_MEDIAN = 0.454936
"""Median of a chi-square with one degree of freedom (a squared standard normal)."""


def inflated(inflight: Sequence[tuple[float, float, float]]
             ) -> list[tuple[float, float, float]]:
    """The observations with their sd widened by their own flight-to-flight scatter.

    The tracker's stated sd is its error against *that flight's* parameter; what the trend
    needs is the error against the part's smooth aging path, which also holds the flight's
    own scatter (a healthy unit's grease moves friction ~10 % from flight to flight) and,
    on a unit whose model is wrong, errors the stated sd does not cover (docs/reasoner.md:
    rms 0.14 against a stated 0.046 on mismatched units). Successive flights' differences
    measure both without a model of the path (it moves little in one flight): the factor is
    the root of the median of ``d^2 / (s_i^2 + s_j^2)`` over consecutive pairs, over its
    value for honest sds (the chi-square's median), never below 1. Medians, so a few bad
    flights do not set it."""
    obs = sorted(inflight)
    if len(obs) < MIN_FOR_SCATTER:
        return list(obs)
    a = np.asarray(obs, dtype=np.float64)
    d2 = np.diff(a[:, 1]) ** 2
    s2 = a[:-1, 2] ** 2 + a[1:, 2] ** 2
    factor = math.sqrt(max(float(np.median(d2 / np.maximum(s2, 1e-18))) / CHI2_1_MEDIAN, 1.0))
    return [(n, h, sd * factor) for n, h, sd in obs]


def observation(name: str, parameter: Mapping[str, Any]) -> tuple[str, float, float] | None:
    """A stored in-flight parameter as ``(kind, h, sd)`` in units of the kind's failure
    threshold (None: no trended kind, or its baseline still pending)."""
    kind = INFLIGHT_KINDS.get(name)
    change, sd = parameter.get("change"), parameter.get("sd_change")
    if kind is None or not isinstance(change, (int, float)) or \
            not isinstance(sd, (int, float)) or not sd > 0.0:
        return None
    scale = abs(FAILURE[kind] - 1.0)
    return kind, float(change) / scale, float(sd) / scale


def fit_rul_fused(flights: FloatArray, h_est: FloatArray, now: float, kind: str,
                  noise: trend.Noise, prior: trend.ShapePrior | None,
                  inflight: Sequence[tuple[float, float, float]], n_draws: int = 2000,
                  seed: int = 0, horizon: float = 2000.0,
                  conditions: FloatArray | None = None) -> RulEstimate:
    """RUL at flight ``now`` from BIT estimates (as :func:`~.trend.fit_rul`) and in-flight
    observations ``(flight, h, sd)`` of the same kind; with no in-flight observation it is
    :func:`~.trend.fit_rul` itself."""
    if not inflight:
        return trend.fit_rul(flights, h_est, now, kind, noise, prior, n_draws, seed, horizon,
                             conditions)
    obs = np.asarray(inflated(inflight), dtype=np.float64).reshape(-1, 3)
    return trend.fit_rul(flights, h_est, now, kind, noise, prior, n_draws, seed, horizon,
                         conditions, extra=(obs[:, 0], obs[:, 1], obs[:, 2]))
