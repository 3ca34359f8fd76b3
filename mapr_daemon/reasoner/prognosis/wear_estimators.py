"""Per-BIT degradation estimates for the trend: one estimator per aging kind, built for wear.

The classifier's severity model (:func:`classifier.kind_severity`) is made to tell faults
apart over the whole Table 1 range; the failure thresholds sit at its low end (ESR x2 is 5 %
of its range, a MOSFET's Ron x2 11 %), where it reads a floor, or does not follow the
degradation at all. The trend needs the opposite trade: one known component, small changes,
read as finely as the bus allows. So each aging kind gets its own estimator of the
degradation fraction ``h`` (0 healthy, 1 at the failure threshold,
:func:`prognosis.degradation`):

* **Observation**: the record's deviation from the healthy actuator at its own flight
  conditions, whitened, on the fault subspace — the healthy model's coordinates ``y``
  (:meth:`healthy_model.HealthyModel.coordinates`: dynamic pressure, aircraft-bus voltage and
  ambient temperature are removed there), plus those conditions ``c``.
* **Forward model** of the kind, fitted on *training BITs* flown at known degradations
  (0 to 1.5 of the threshold, their own seeds and pressures): ``y = R(h, c) @ coef + e``,
  ``R`` cubic in ``h``, second order in the conditions, with their products with ``h`` (a
  fault's signature changes with air load and supply voltage: the ripple a larger ESR makes
  grows with the current drawn), :func:`regressors`.
* **Noise** ``e``: the kind's own training residuals, covariance shrunk by Ledoit-Wolf
  (:func:`healthy_model.ledoit_wolf`) — flight-to-flight variation as it looks *with* the fault,
  friction scatter included.
* **Estimate**: the ``h`` on a fine grid (-0.5 to 2.5) that minimises the Mahalanobis
  distance of ``y`` from ``R(h, c) @ coef``, refined by a parabola through the best grid
  point's neighbours. It has no dead zone: below the threshold it reads values near 0, above
  and below it, rather than a floor.

Its scale error and scatter are then measured on calibration BITs of yet other seeds
(:meth:`trend.Noise.measure`), so the trend is told how good the estimate really is.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis import healthy_model
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary

GRID: FloatArray = np.linspace(-0.5, 2.5, 601)
"""Degradations the estimator searches (fractions of the failure threshold)."""
TRAINING_RANGE = (0.0, 1.5)
"""Degradations of the training BITs, drawn uniformly (around and beyond the threshold)."""


def observations(d: Dictionary, m: FloatArray, q: Sequence[float]) -> tuple[FloatArray,
                                                                           FloatArray]:
    """Each run's coordinates ``y (n, K)`` and scaled conditions ``c (n, 3)`` from its M
    ``(n, W, C)``: dynamic pressure / 2.5 kPa, supply voltage minus nominal (V), ambient
    temperature as (T - 25 C) / 10 K — the healthy model's scaling."""
    hm = d.healthy
    if hm is None:
        raise ConfigError("the dictionary has no healthy model (rebuild it with "
                          "`mapr dictionary build`)", field="dictionary")
    ys, cs = [], []
    for i in range(m.shape[0]):
        c = healthy_model.conditions(m[i], d.columns, float(q[i]))
        ys.append(hm.coordinates(m[i], c))
        cs.append(healthy_model.scaled(c, hm.supply_nominal_v))
    return np.stack(ys), np.asarray(cs, dtype=np.float64)


def regressors(h: FloatArray, c: FloatArray) -> FloatArray:
    """``R(h, c)`` ``(n, 25)``: the condition terms 1, ``q``, ``q^2``, ``v``, ``t``, ``v^2``,
    ``t^2``, ``qv``, ``qt``, ``vt`` (pressure, supply voltage, temperature); ``h`` times each
    of them; ``h^2``, ``h^3`` (capacitance loss acts on the ripple through ``1/C``) and ``h^2``
    times ``q``, ``v``, ``t``. Second order in the condition because a fault's signature does
    not change linearly over the envelope (the converter's ripple near its drop-out voltage,
    the air load's square): with first-order terms only, the capacitance and ESR estimates
    of BITs flown at nominal conditions erred about twice as much (sd 0.11 and 0.13 of the
    threshold against 0.06, on 300 held-out BITs of each kind)."""
    hh = np.asarray(h, dtype=np.float64)
    cc = np.broadcast_to(np.asarray(c, dtype=np.float64), (hh.size, 3))
    q, v, t = cc[:, 0], cc[:, 1], cc[:, 2]
    one = np.ones_like(hh)
    base = [one, q, q * q, v, t, v * v, t * t, q * v, q * t, v * t]
    h2 = hh * hh
    return np.stack(base + [hh * b for b in base] + [h2, h2 * hh, h2 * q, h2 * v, h2 * t],
                    axis=1)


@dataclasses.dataclass(frozen=True)
class WearModel:
    """One kind's forward model and noise: what :meth:`estimate` inverts."""

    kind: str
    coef: FloatArray
    """``(25, K)``: ``y = regressors(h, c) @ coef``."""
    precision: FloatArray
    """``(K, K)``: the inverse of the residuals' shrunk covariance."""
    shrinkage: float
    runs: int

    @classmethod
    def fit(cls, kind: str, y: FloatArray, c: FloatArray, h: FloatArray) -> WearModel:
        """From training BITs: coordinates ``y (n, K)``, conditions ``c (n, 3)``, truth ``h``."""
        x = regressors(h, c)
        if y.shape[0] < 2 * x.shape[1]:
            raise ConfigError(f"need >= {2 * x.shape[1]} training BITs of {kind}",
                              field="training")
        coef = np.asarray(np.linalg.lstsq(x, y, rcond=None)[0], dtype=np.float64)
        resid = y - x @ coef
        cov, a = healthy_model.ledoit_wolf(resid - resid.mean(axis=0))
        precision = np.asarray(np.linalg.inv(cov), dtype=np.float64)
        return cls(kind, coef, precision, a, int(y.shape[0]))

    def distance(self, y: FloatArray, c: FloatArray) -> FloatArray:
        """Mahalanobis distance of one run's ``y`` from the model at every :data:`GRID` h."""
        e = y[None, :] - regressors(GRID, c) @ self.coef
        out: FloatArray = np.einsum("gk,kl,gl->g", e, self.precision, e)
        return out

    def estimate(self, y: FloatArray, c: FloatArray) -> float:
        """The degradation that explains ``y`` at conditions ``c`` best (parabola-refined)."""
        j = self.distance(y, c)
        i = int(np.argmin(j))
        if 0 < i < GRID.size - 1:
            den = j[i - 1] - 2.0 * j[i] + j[i + 1]
            if den > 0.0:
                step = float(GRID[1] - GRID[0])
                return float(GRID[i] + 0.5 * step * (j[i - 1] - j[i + 1]) / den)
        return float(GRID[i])


def fit_kinds(kinds: Sequence[str], y: FloatArray, c: FloatArray, h: FloatArray,
              labels: Sequence[str]) -> dict[str, WearModel]:
    """One :class:`WearModel` per kind from the training BITs labelled with it."""
    lab = np.asarray(labels)
    return {k: WearModel.fit(k, y[lab == k], c[lab == k], h[lab == k]) for k in kinds}
