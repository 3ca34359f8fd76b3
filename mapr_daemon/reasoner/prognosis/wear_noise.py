"""How good one BIT's degradation estimate is: its scale error and its scatter, measured.

A degradation estimator (:mod:`~mapr_daemon.reasoner.prognosis.wear_estimators`) reads a BIT as a
fraction ``h`` of the failure
threshold. Against BITs flown at known degradations (calibration BITs, seeds of their own)
it reads ``estimate = offset + gain*h + e``. The trend (:func:`.trend.fit_rul`) and the
evidence test (:mod:`~mapr_daemon.reasoner.prognosis.assessment`) weigh each estimate by the sd of
``e``, so that sd has to be
the one the BIT really has:

* **over the envelope** it depends on the flight condition as much as on ``h``: on the aileron
  the capacitance estimate errs by sd ~0.43 of the threshold with the aircraft bus near its
  low limit and ~0.15 near nominal (the ripple the estimator reads shrinks as the converter
  nears drop-out). One envelope-wide figure overstates the noise of a BIT flown at nominal
  conditions two- to four-fold (which holds a real trend back from the evidence gate) and
  understates it at the edges (which makes the intervals there too narrow);
* the scale error depends on the condition too: near the bus's low limit the estimates are
  compressed (ESR reads ~0.3 + 0.5h there, ~h at nominal), so one envelope-wide line
  ``offset + gain*h`` (ESR: 0.15 + 0.75h) biases every nominal BIT low (ESR: by -0.09 of
  the threshold on the run-to-failure bench, with an error sd of 0.07) and the trend
  places the crossing late;
* so the calibration is **linear in the condition**: ``estimate = a . k(c) + (g . k(c)) h + e``
  with ``k(c) = (1, v, v^2, t, t^2, q)`` — ``q, v, t`` the scaled dynamic pressure, supply
  voltage above nominal and ambient temperature — least squares on the calibration BITs; a
  BIT is read as ``h = (estimate - a . k(c)) / (g . k(c))``, the gain floored at
  :data:`MIN_GAIN` (a condition where the estimate barely follows the degradation says
  little, and its sd in units of the threshold says so);
* and the sd is a **log-linear function of the degradation and the condition**:
  ``log sd(e) = b . (1, h, v, v^2, t, t^2, q)`` (:func:`log_sd_terms`), fitted to ``log|e|``
  (``E log|z| = -0.635`` for a normal ``z``) and rescaled so the standardised residuals have
  unit variance. Where a BIT's condition is not known (a catalog written before conditions
  were stored) the envelope-wide line and ``sd0 + sd1*h`` are used.

``floor``: an estimator's dead zone, a value it reports for every degradation too small to
tell from healthy scatter; an estimate there says only "at most this much" and the trend
treats it as censored (:attr:`Noise.detection`: where half the estimates leave it).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError

FLOOR_TOLERANCE = 1e-6
"""Estimates within this of the lowest calibration estimate count as at the floor."""
LOG_ABS_NORMAL = -0.5 * (0.5772156649015329 + math.log(2.0))
"""``E log|z|`` of a standard normal ``z`` (-0.635): ``log|e|`` sits this far below ``log sd``."""
CONDITION_TERMS = ("1", "h", "v", "v^2", "t", "t^2", "q")
"""The terms of the log-sd model, in order."""
MIN_PER_TERM = 8
"""Calibration BITs per term below which the condition model is not fitted (sd0 + sd1*h)."""
MIN_GAIN = 0.1
"""Floor of the condition's gain ``g . k(c)`` (a BIT there is read with a sd to match)."""


def gain_terms(c: FloatArray) -> FloatArray:
    """``(n, 6)`` terms ``k(c)`` of the condition's offset and gain: 1, v, v^2, t, t^2, q."""
    cc = np.atleast_2d(np.asarray(c, dtype=np.float64))
    q, v, t = cc[:, 0], cc[:, 1], cc[:, 2]
    return np.stack([np.ones_like(q), v, v * v, t, t * t, q], axis=1)


def log_sd_terms(h: FloatArray, c: FloatArray) -> FloatArray:
    """``(n, 7)`` terms of the log-sd model: :func:`gain_terms` with ``h`` (clipped to 0-1.5)
    after the constant, as :data:`CONDITION_TERMS` names them."""
    hh = np.clip(np.atleast_1d(np.asarray(h, dtype=np.float64)), 0.0, 1.5)
    k = gain_terms(np.broadcast_to(np.asarray(c, dtype=np.float64), (hh.size, 3)))
    out: FloatArray = np.insert(k, 1, hh, axis=1)
    return out


def _transition(h: FloatArray, at_floor: npt.NDArray[np.bool_]) -> tuple[float, float]:
    """Where (and how sharply) the estimate leaves its floor as the degradation grows: the
    degradation where the share of floored estimates, per calibration level, crosses one
    half (interpolated), and as its sd a quarter of the span from the last all-floored to the
    first never-floored level (the span taken as +/- 2 sd), at least 0.02."""
    levels = np.unique(h)
    share = np.array([at_floor[h == v].mean() for v in levels])
    below = np.nonzero(share >= 0.5)[0]
    if below.size == 0:
        return float(levels[0]), 0.02
    i = int(below.max())
    if i + 1 >= levels.size:
        mid = float(levels[-1])
    else:
        f0, f1 = share[i], share[i + 1]
        mid = float(levels[i] + (f0 - 0.5) / max(f0 - f1, 1e-9) * (levels[i + 1] - levels[i]))
    full = levels[share >= 1.0]
    none = levels[share <= 0.0]
    lo = float(full.max()) if full.size else float(levels[0])
    hi = float(none[none > lo].min()) if (none > lo).any() else float(levels[-1])
    return mid, max(0.25 * (hi - lo), 0.02)


@dataclasses.dataclass(frozen=True)
class Noise:
    """The per-BIT degradation estimate as measured against known degradations.

    ``estimate = offset + gain*h + e`` over the envelope, ``a . k(c) + (g . k(c)) h + e`` at a
    known condition ``c``; ``sd(e)`` is ``exp(log_sd . terms(h, c))`` there (:meth:`sd`), else
    ``sd0 + sd1*h``, both in the estimate's units. :meth:`calibrate` and :meth:`h_sd` give
    the reading and its sd in units of the threshold (divided by the gain at ``c``, floored
    at :data:`MIN_GAIN`, or by ``gain``).
    """

    sd0: float
    sd1: float = 0.0
    offset: float = 0.0
    gain: float = 1.0
    floor: float | None = None
    detection: float = 0.0
    """Degradation at which half the estimates leave the floor (measured)."""
    detection_sd: float = 0.02
    """Width of that transition (measured; at least 0.02)."""
    log_sd: tuple[float, ...] = ()
    """Coefficients of the log-sd model on :data:`CONDITION_TERMS`; empty: none fitted."""
    offset_c: tuple[float, ...] = ()
    gain_c: tuple[float, ...] = ()
    """Coefficients ``a`` and ``g`` of the calibration at a condition, on :func:`gain_terms`
    (empty with ``log_sd``)."""
    c_low: tuple[float, ...] = ()
    c_high: tuple[float, ...] = ()
    """The scaled conditions the calibration BITs spanned: a BIT outside them is read at the
    nearest edge (the quadratic terms are not extrapolated)."""

    @classmethod
    def measure(cls, h_true: FloatArray, h_est: FloatArray,
                conditions: FloatArray | None = None) -> Noise:
        """Linear calibration of the estimate on the truth (above its floor), its scatter;
        with the calibration BITs' scaled ``conditions (n, 3)``, the log-sd model too."""
        x = np.asarray(h_true, dtype=np.float64)
        y = np.asarray(h_est, dtype=np.float64)
        c = None if conditions is None else np.asarray(conditions, dtype=np.float64)
        low = float(y.min())
        at_floor = y <= low + FLOOR_TOLERANCE
        floor = low if at_floor.sum() >= 2 else None
        detection, detection_sd = 0.0, 0.02
        if floor is not None:
            detection, detection_sd = _transition(x, at_floor)
            x, y = x[~at_floor], y[~at_floor]
            c = None if c is None else c[~at_floor]
        if x.size < 4 or np.ptp(x) <= 0.0:
            raise ConfigError("need at least four estimates above the floor at two or more "
                              "degradations", field="noise")
        gain, offset = np.polyfit(x, y, 1)
        if gain <= 0.05:
            raise ConfigError(f"the estimate does not follow the degradation (gain {gain:.3g})",
                              field="noise")
        e = y - (offset + gain * x)
        resid = np.abs(e) * math.sqrt(math.pi / 2.0)  # E|e| -> sd
        s1, s0 = np.polyfit(x, resid, 1)
        if s0 <= 0.0 or s1 < 0.0:  # keep the growth non-negative and the floor positive
            s1 = max(s1, 0.0)
            s0 = max(float(np.mean(resid - s1 * x)), 1e-3)
        log_sd: tuple[float, ...] = ()
        offset_c: tuple[float, ...] = ()
        gain_c: tuple[float, ...] = ()
        c_low: tuple[float, ...] = ()
        c_high: tuple[float, ...] = ()
        if c is not None and x.size >= MIN_PER_TERM * len(CONDITION_TERMS):
            c_low = tuple(float(v) for v in np.nanmin(c, axis=0))
            c_high = tuple(float(v) for v in np.nanmax(c, axis=0))
            k = gain_terms(c)
            coef = np.linalg.lstsq(np.concatenate([k, k * x[:, None]], axis=1), y,
                                   rcond=None)[0]
            offset_c = tuple(float(v) for v in coef[:6])
            gain_c = tuple(float(v) for v in coef[6:])
            log_sd = _fit_log_sd(x, y - (k @ coef[:6] + _floored(k @ coef[6:]) * x), c)
        return cls(float(s0), float(s1), float(offset), float(gain), floor, detection,
                   detection_sd, log_sd, offset_c, gain_c, c_low, c_high)

    def calibrate(self, h_est: FloatArray, conditions: FloatArray | None = None
                  ) -> FloatArray:
        """Estimates read as degradations (units of the threshold): at each BIT's scaled
        condition (rows; NaN rows unknown) where the model has one, else on the line."""
        y = np.asarray(h_est, dtype=np.float64)
        flat: FloatArray = (y - self.offset) / self.gain
        if conditions is None or not self.gain_c:
            return flat
        k, known = self._known(conditions, y.size)
        g = _floored(k @ np.asarray(self.gain_c))
        out: FloatArray = np.where(known, (y.ravel() - k @ np.asarray(self.offset_c)) / g,
                                   flat.ravel())
        return out.reshape(y.shape)

    def h_sd(self, h: FloatArray, conditions: FloatArray | None = None) -> FloatArray:
        """The sd of :meth:`calibrate`'s reading at degradation ``h`` (units of the
        threshold)."""
        hh = np.asarray(h, dtype=np.float64)
        if conditions is None:
            flat: FloatArray = self.sd(hh) / self.gain
            return flat
        k, known = self._known(conditions, hh.size)
        g = _floored(k @ np.asarray(self.gain_c)) if self.gain_c else np.full(hh.size, self.gain)
        out: FloatArray = np.where(known, self.sd(hh, conditions).ravel() / g,
                                   self.sd(hh).ravel() / self.gain)
        return out.reshape(hh.shape)

    def _known(self, conditions: FloatArray, n: int
               ) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
        c = np.broadcast_to(self._clip(np.asarray(conditions, dtype=np.float64)), (n, 3))
        known: npt.NDArray[np.bool_] = np.asarray(np.isfinite(c).all(axis=1))
        return gain_terms(np.where(known[:, None], c, 0.0)), known

    def _clip(self, c: FloatArray) -> FloatArray:
        """Conditions clipped to the calibrated span (NaN stays NaN: unknown)."""
        if not self.c_low:
            return c
        out: FloatArray = np.clip(c, np.asarray(self.c_low), np.asarray(self.c_high))
        return out

    def sd(self, h: FloatArray, conditions: FloatArray | None = None) -> FloatArray:
        """The estimate's sd at degradation ``h``; at the scaled ``conditions`` (one row per
        ``h``, or one for all; a row with a NaN falls back to ``sd0 + sd1*h``) when known."""
        hh = np.asarray(h, dtype=np.float64)
        flat: FloatArray = self.sd0 + self.sd1 * np.clip(hh, 0.0, 1.5)
        if conditions is None or not self.log_sd:
            return flat
        c = self._clip(np.asarray(conditions, dtype=np.float64))
        terms = log_sd_terms(hh.ravel(), c)
        known: npt.NDArray[np.bool_] = np.asarray(np.isfinite(terms).all(axis=1))
        cond = np.exp(np.where(known[:, None], terms, 0.0) @ np.asarray(self.log_sd))
        out: FloatArray = np.where(known, cond, np.broadcast_to(flat, hh.shape).ravel())
        return out.reshape(hh.shape)

    def censored(self, h_est: FloatArray) -> npt.NDArray[np.bool_]:
        """Which estimates sit at the floor."""
        y = np.asarray(h_est, dtype=np.float64)
        if self.floor is None:
            return np.zeros(y.shape, dtype=bool)
        out: npt.NDArray[np.bool_] = y <= self.floor + FLOOR_TOLERANCE
        return out


def _floored(gain: FloatArray) -> FloatArray:
    """The gain at a condition, floored at :data:`MIN_GAIN`."""
    out: FloatArray = np.maximum(gain, MIN_GAIN)
    return out


def _fit_log_sd(h: FloatArray, e: FloatArray, c: FloatArray) -> tuple[float, ...]:
    """Least squares of ``log|e|`` on the terms, shifted by ``E log|z|``, then rescaled so the
    standardised residuals ``e/sd`` have unit mean square (what the trend's weights assume)."""
    terms = log_sd_terms(h, c)
    keep = np.isfinite(terms).all(axis=1) & (np.abs(e) > 0.0)
    coef = np.linalg.lstsq(terms[keep], np.log(np.abs(e[keep])), rcond=None)[0]
    coef[0] -= LOG_ABS_NORMAL
    z = e[keep] / np.exp(terms[keep] @ coef)
    coef[0] += 0.5 * math.log(float(np.mean(z * z)))
    return tuple(float(b) for b in coef)


def scaled_rows(conditions: Sequence[Sequence[float] | None], n: int) -> FloatArray:
    """``(n, 3)`` scaled conditions, NaN rows where a BIT's condition is unknown."""
    out = np.full((n, 3), np.nan)
    for i, c in enumerate(conditions[:n]):
        if c is not None and len(c) == 3:
            out[i] = c
    return out
