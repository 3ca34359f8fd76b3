"""A per-flight change's honest sd: the unit's flight-to-flight scatter and its baseline's.

The tracker's sd (:mod:`.tracker`) is its error against *that flight's* parameter. The trend,
and anyone reading a flight's change as wear, needs the error against the part's slow aging
path, which also holds what moves the parameter from one flight to the next and not from one
month to the next: a healthy unit's grease moves friction by ~10 % a flight (so 0.05 of the
failure threshold when new, 0.13 at 2.5x friction), and on a unit whose model is off, errors
the tracker's covariance does not see. Measured on whole flights, that scatter was 0.10-0.11
of the threshold against a stated 0.008-0.03: the stated 90 % band held the path in 8-19 % of
the flights (docs/reasoner-measured.md, "Whole flights in the product").

**Criterion.** The scatter is measured on the unit itself, from its own successive flights,
with no model of the path (it moves little in one flight). In the parameter's working space
``x`` (the logarithm for a ratio parameter such as friction, whose scatter multiplies it;
the value itself otherwise) the first differences ``d`` of every flight so far (the baseline
flights included) are centred on their median (the path's drift per flight) and, once there
are :data:`MIN_TO_WINSORISE`, winsorised at :data:`WINSOR` robust sds (1.4826 MAD: a few bad
flights do not set it); ``sum(d^2) / (2 (n - 1))`` is the per-flight variance about the
path. What exceeds the flights' mean tracker variance is the scatter ``tau^2``, and each
flight's variance about the path is ``tau^2 + s_k^2``. With few flights the estimate is
uncertain, so the stated sd is widened by Student's t 95 % point over the normal's at the
estimate's degrees of freedom (:attr:`Scatter.widen`; ``(n - 1) / 1.5``: successive
differences share a flight, lag-one correlation -1/2, which costs a third of the sum of
squares' degrees of freedom), and the band covers 90 % on few flights too. Nothing about
the harness is stated: no prior scatter, no constant; the baseline's own flights give the
first two differences, so the first flight with a change already has three.

**The baseline's uncertainty.** The baseline is the mean of the first
:data:`~.baseline.COMMISSIONING_FLIGHTS` values; each carried its own scatter, so the baseline
is off the path's start by ``(tau^2 + mean s_b^2) / n_b`` in variance (a ratio of ~6 % at
10 % grease), and every later change carries that error (scaled by ``1 + change`` for a ratio).
It is the same error on every later flight of the unit: :class:`ChangeSd` states it apart
(``baseline``) from the flight's own (``flight``) so that the trend can weigh it as one
common error, not as many independent ones (:mod:`~mapr_daemon.reasoner.prognosis.fusion`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from scipy import stats

WINSOR = 3.0
"""Differences beyond this many robust sds from their median are clipped to it (normal
consistency of the clipped mean square 0.995: left uncorrected)."""
MIN_TO_WINSORISE = 8
"""Differences needed before clipping (a median of fewer is no scale to clip by)."""
Z90 = float(stats.norm.ppf(0.95))
"""The normal's 95 % point: a stated 90 % band is +- this many sds."""
DOF_PER_DIFFERENCE = 1.0 / 1.5
"""Degrees of freedom per successive difference (MA(1) with lag-one correlation -1/2)."""


@dataclasses.dataclass(frozen=True)
class Scatter:
    """A unit's flight-to-flight scatter of one parameter, in its working space."""

    tau2: float
    """Variance about the slow path beyond the tracker's own (working-space units^2)."""
    dof: float
    """Degrees of freedom of the estimate."""

    @property
    def widen(self) -> float:
        """Student's t 95 % point over the normal's at :attr:`dof` (>= 1): an sd this much
        wider makes the +-1.645 sd band a 90 % band despite the estimate's own error."""
        return float(stats.t.ppf(0.95, max(self.dof, 1.0))) / Z90


@dataclasses.dataclass(frozen=True)
class ChangeSd:
    """A flight's change sd, split: its own (``flight``: the tracker's and the scatter) and
    the baseline's (``baseline``, common to all the unit's later flights); ``total`` is the
    one a reader of a single flight's change needs."""

    flight: float
    baseline: float

    @property
    def total(self) -> float:
        return math.hypot(self.flight, self.baseline)


def working(values: Sequence[float], sds: Sequence[float], ratio: bool
            ) -> tuple[np.ndarray, np.ndarray]:
    """Values and sds in the working space (the logarithm and relative sds for a ratio)."""
    v = np.asarray(values, dtype=np.float64)
    s = np.asarray(sds, dtype=np.float64)
    if ratio:
        pos = np.maximum(v, 1e-12)
        return np.log(pos), s / pos
    return v, s


def learn(values: Sequence[float], sds: Sequence[float], ratio: bool) -> Scatter | None:
    """The scatter from a unit's successive flights' values and tracker sds (in flight
    order; None: fewer than three flights, two differences)."""
    x, s = working(values, sds, ratio)
    ok = np.isfinite(x) & np.isfinite(s)
    x, s = x[ok], s[ok]
    if x.size < 3:
        return None
    d = np.diff(x)
    d = d - np.median(d)
    robust = 1.4826 * float(np.median(np.abs(d)))
    if d.size >= MIN_TO_WINSORISE and robust > 0.0:
        d = np.clip(d, -WINSOR * robust, WINSOR * robust)
    total = float(np.sum(d * d)) / (2.0 * (d.size - 1))
    tau2 = max(total - float(np.mean(s * s)), 0.0)
    return Scatter(tau2, max((d.size - 1) * DOF_PER_DIFFERENCE, 1.0))


def change_sd(scatter: Scatter | None, sd: float, value: float, base_values: Sequence[float],
              base_sds: Sequence[float], base: float, ratio: bool) -> ChangeSd:
    """The sd of a flight's change (``value`` with tracker sd ``sd``) from the baseline
    ``base`` (the mean of ``base_values``, their tracker sds ``base_sds``). Without a
    scatter yet (None) only the tracker's sds count: the change is then as honest as the
    tracker, and the caller states so."""
    tau2, widen = (0.0, 1.0) if scatter is None else (scatter.tau2, scatter.widen)
    _, s_k = working([value], [sd], ratio)
    _, s_b = working(base_values, base_sds, ratio)
    flight = math.sqrt(tau2 + float(s_k[0]) ** 2) * widen
    baseline = math.sqrt((tau2 + float(np.mean(s_b * s_b))) / max(len(base_values), 1)) * widen
    scale = value / base if ratio else 1.0   # d(v/b - 1) = (v/b) d(log v - log b)
    return ChangeSd(flight * scale, baseline * scale)
