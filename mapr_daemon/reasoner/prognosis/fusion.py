"""One RUL from per-BIT estimates and per-flight in-flight estimates, each with its own noise.

The trend (:func:`~mapr_daemon.reasoner.prognosis.trend.fit_rul`) is a weighted fit of the
kind's aging shape: observations with their variances. A BIT's degradation estimate carries
the measured noise of its estimator at that BIT's flight condition
(:class:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise`); an in-flight estimate
(:mod:`mapr_daemon.reasoner.inflight`) carries its change's sd against the unit's slow path
(:mod:`mapr_daemon.reasoner.inflight.scatter`), stated in two parts: the flight's own (the
tracker's and the unit's learned flight-to-flight scatter) and the baseline's (the unit's
first flights' scatter, the SAME error on every later flight). Both kinds of estimate are
points on the same degradation path, so :func:`fit_rul_fused` fits them together.

**How the two are weighed, and why.** The flights' own errors are independent from one
flight to the next: each in-flight observation enters the fit with its flight sd, as an
extra independent observation after the BITs' AR(1) chain. The baseline's error is not: it
is one scale error ``beta`` of the baseline (a ratio parameter: ``1 + change = beta (1 +
true change)``), shared by all of them; fitted as if independent, fifty flights would
average it away, which they cannot. It is marginalised instead: the trend is fitted at
:data:`STRATA` values of ``beta ~ N(1, sd_beta^2)`` (the normal's quantiles), the in-flight
observations rescaled to each, and the RUL draws pooled alike. ``sd_beta`` is the latest
observation's baseline sd over its ``1 + change`` (the scatter is relearned as flights
accrue; the latest is the best measured). ``beta`` is drawn from what the baseline's
flights say of it, not from what the later flights and the BITs add (that would need the
fit's evidence at each ``beta``, which :func:`~.trend.fit_rul` does not return): the
interval is the wider for it. A baseline so uncertain that ``sd_beta`` exceeds
:data:`MAX_SD_BETA` places no flight: the BITs' RUL alone. Measured in memory
(``bench/inflight_band.py``, 60 units of life ~200, a PBIT every flight, 10 % grease; fresh
seeds, docs/reasoner.md): the 90 % interval held the truth at 83 % / 80 % (lambda 0.5 /
0.75) this way against 70 % / 67 % with each flight's total sd fitted as independent, and
alpha-lambda 73 % / 73 % against 77 % / 72 % (BITs only: 82 % / 67 %, covering 88 % / 77 %).
Weighting ``beta`` by how well the BITs agree with the rescaled flights was tried on design
seeds (101, 102) and not kept: alpha-lambda rose at life 200 but the interval covered less
(68 % against 78 % at lambda 0.75), and at life 60 both fell.

The same flight's grease moves both that flight's PBIT and its in-flight estimate; the
BIT's measured noise already holds the grease (its calibration BITs fly with it), so the
pair's shared part is counted twice. Not corrected here (the trend takes the extra
observations as independent of the BITs' chain); measured with the same bench, the BITs'
grease shared with the flight's or drawn apart moved the fused figures by no more than
their sampling (60 units, +-6 %): coverage 83 % / 80 % shared, 87 % / 82 % apart;
alpha-lambda 73 % / 73 % and 78 % / 78 %.

Which in-flight parameter trends which aging kind (:data:`INFLIGHT_KINDS`): only
``friction`` (its per-flight change over the commissioned baseline, in units of the failure
threshold's change, ``FAILURE - 1``).
The tracker's other parameters do not map to a trended mode at a usable noise: the loop
resistance has no fault mode; phase-A high-side Ron is not resolved per flight (sd ~9
failure thresholds); the DC-bus proxy reads ESR at 0.5-0.8 of its threshold per flight.
So the modes BITs cannot trend stay untrended from flight data too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.reasoner.prognosis import trend
from mapr_daemon.reasoner.prognosis.rul import RulEstimate, quantiles
from mapr_daemon.reasoner.prognosis.wear_paths import PathNoise

RATIO: tuple[str, ...] = ("friction",)
"""In-flight parameters whose change is a ratio to the unit's baseline (the rest: a
difference): the in-flight baseline (:mod:`mapr_daemon.reasoner.inflight.baseline`) computes
them so and the fused trend here undoes the baseline's error as a scale on them. Declared here,
on the prognosis's floor, so both read the one list."""
INFLIGHT_KINDS: dict[str, str] = {"friction": "friction"}
"""In-flight parameter -> the aging kind whose degradation its change measures."""
RATIO_KINDS: frozenset[str] = frozenset(k for n, k in INFLIGHT_KINDS.items() if n in RATIO)
"""Kinds whose in-flight change is a ratio to the baseline (its error a scale ``beta``)."""
STRATA = 16
"""Values of the baseline's common error at which the trend is fitted: the normal's
quantiles at ``(j + 0.5) / STRATA``, each giving ``1 / STRATA`` of the draws (a stratified
draw of ``beta``; ~3 ms a fit)."""
MAX_SD_BETA = 0.2
"""Largest ``sd_beta`` at which the flights are placed (the outermost stratum's ``beta``,
at 1.86 sd, stays above 0.6)."""

Observation = tuple[float, ...]
"""``(flight, h, sd)`` or ``(flight, h, sd_flight, sd_baseline)``, ``h`` and the sds in
units of the kind's failure threshold (:func:`observation`)."""


def observation(name: str, parameter: Mapping[str, Any]
                ) -> tuple[str, float, float, float] | None:
    """A stored in-flight parameter as ``(kind, h, sd_flight, sd_baseline)`` in units of
    the kind's failure threshold (None: no trended kind, or its baseline still pending). A
    row stored before the sd was split gives its ``sd_change`` as the flight's sd and no
    baseline sd."""
    kind = INFLIGHT_KINDS.get(name)
    change, sd = parameter.get("change"), parameter.get("sd_change")
    if kind is None or not isinstance(change, (int, float)) or \
            not isinstance(sd, (int, float)) or not sd > 0.0:
        return None
    own, base = parameter.get("sd_flight"), parameter.get("sd_baseline")
    if isinstance(own, (int, float)) and own > 0.0 and isinstance(base, (int, float)):
        sd, common = float(own), float(base)
    else:
        common = 0.0
    scale = abs(FAILURE[kind] - 1.0)
    return kind, float(change) / scale, float(sd) / scale, common / scale


def scale_sd(kind: str, inflight: Sequence[Observation]) -> float:
    """The sd of the baseline's common error, from the latest observation: for a ratio
    kind the scale ``beta``'s (relative), else the offset's (in ``h``)."""
    last = max(inflight, key=lambda o: o[0])
    common = float(last[3]) if len(last) > 3 else 0.0
    if kind not in RATIO_KINDS:
        return common
    s = abs(FAILURE[kind] - 1.0)
    return s * common / max(1.0 + s * float(last[1]), 1e-6)


def placed(kind: str, inflight: Sequence[Observation], z: float, sd_beta: float
           ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The observations as the trend takes them, given the baseline's error at ``z`` sds:
    ``(flights, h, sd)`` with ``h`` rescaled (ratio kinds: ``1 + S h = beta (1 + S h_true)``,
    ``S = FAILURE - 1``) or shifted (other kinds)."""
    a = np.asarray([(o[0], o[1], o[2]) for o in inflight], dtype=np.float64).reshape(-1, 3)
    if kind in RATIO_KINDS:
        s = abs(FAILURE[kind] - 1.0)
        beta = 1.0 + z * sd_beta
        return a[:, 0], ((1.0 + s * a[:, 1]) / beta - 1.0) / s, a[:, 2] / beta
    return a[:, 0], a[:, 1] - z * sd_beta, a[:, 2]


def fit_rul_fused(flights: FloatArray, h_est: FloatArray, now: float, kind: str,
                  noise: trend.Noise | PathNoise, prior: trend.ShapePrior | None,
                  inflight: Sequence[Observation], n_draws: int = 2000,
                  seed: int = 0, horizon: float = 2000.0,
                  conditions: FloatArray | None = None, offset_sd: float | None = None,
                  offset_mean: float | None = None) -> RulEstimate:
    """RUL at flight ``now`` from BIT estimates (as :func:`~.trend.fit_rul`) and in-flight
    observations of the same kind (:data:`Observation`), the baseline's common error
    marginalised (:data:`STRATA`); with no in-flight observation, or a baseline too
    uncertain to place them (:data:`MAX_SD_BETA`), it is :func:`~.trend.fit_rul` itself.
    ``noise`` and ``offset_sd``/``offset_mean``: the BITs' noise (one, or each BIT's path's)
    and unit offset prior, as :func:`~.trend.fit_rul` takes them."""
    sd_beta = scale_sd(kind, inflight) if inflight else 0.0
    if not inflight or sd_beta > MAX_SD_BETA:
        return trend.fit_rul(flights, h_est, now, kind, noise, prior, n_draws, seed, horizon,
                             conditions, offset_sd=offset_sd, offset_mean=offset_mean)
    if sd_beta == 0.0:
        return trend.fit_rul(flights, h_est, now, kind, noise, prior, n_draws, seed, horizon,
                             conditions, extra=placed(kind, inflight, 0.0, 0.0),
                             offset_sd=offset_sd, offset_mean=offset_mean)
    each = max(n_draws // STRATA, 1)
    draws = np.concatenate([
        trend.fit_rul(flights, h_est, now, kind, noise, prior, each, seed + i, horizon,
                      conditions, extra=placed(kind, inflight, float(z), sd_beta),
                      offset_sd=offset_sd, offset_mean=offset_mean).draws
        for i, z in enumerate(stats.norm.ppf((np.arange(STRATA) + 0.5) / STRATA))])
    q5, q50, q95 = quantiles(draws)
    return RulEstimate(q50, q5, q95, draws, horizon=horizon)
