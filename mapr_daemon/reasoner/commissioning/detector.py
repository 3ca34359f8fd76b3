"""The unit's own anomaly detector: the BIT's reading against its commissioned baseline,
thresholded where the unit's held-out healthy BITs put it.

A reading (:func:`~mapr_daemon.reasoner.commissioning.severity.read`) gives two numbers, both
mean squares of the residual in units of the unit's held-out healthy spread:

* ``no_fault`` — the "no fault" cost (``Reading.healthy_cost``): how far the BIT sits from the
  unit's healthy prediction. It catches a departure whatever causes it, one no fault
  hypothesis explains included;
* ``explained`` — the generalized likelihood ratio statistic: the "no fault" cost minus the
  best fault hypothesis's (``healthy_cost - cost``), how much of the departure one known fault
  takes away. It catches a small fault whose signature is a direction the healthy scatter
  does not go in, before the no-fault cost has grown out of the scatter.

**Calibration** (at commissioning, :func:`calibrate`). Each commissioning BIT is read against
a baseline that has not seen it: the discrepancy relearned without that BIT
(:func:`~mapr_daemon.reasoner.commissioning.discrepancy.held_out_discrepancies`, each signal's
choice kept), as the discrepancy's own held-out spread is measured. Per statistic, a scaled
chi-square ``g * chi2(nu)`` is fitted to the held-out values by their mean ``m`` and variance
``v`` (``g = v / 2m``, ``nu = 2m^2 / v``: a mean square of correlated Gaussian residuals is
such a variable, with ``nu`` the effective count of independent terms), and the threshold is
its upper ``ALPHA / 2`` quantile, never below the largest held-out value (a healthy BIT of the
unit's own already went there). The two thresholds together hold a healthy BIT's false-alarm
probability to at most :data:`ALPHA` (one in a thousand BITs) as far as the tail fit holds.
A statistic whose held-out values are all below the least positive drop
:data:`FLOOR_EXPLAINED` (no fault ever explained anything on a healthy BIT, or next to nothing)
is fitted as if the largest of them were that floor; a non-finite held-out value fits no tail
(:func:`calibrate` refuses: no detector).

The thresholds, the fitted tails and the held-out values are kept in the commissioning record
(``detector``, :meth:`Detector.to_json`); a record without them (written before) loads without
a detector and the dictionary keeps detecting alone.

Cost: one reading per commissioning BIT at commissioning (about 0.7-0.8 s CPU each at the
default grid), and one per BIT in service.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning.bits import BitRecord
from mapr_daemon.reasoner.commissioning.discrepancy import Discrepancy, held_out_discrepancies
from mapr_daemon.reasoner.commissioning.severity import Reading, read

ALPHA = 1e-3
"""False-alarm target: healthy BITs flagged by the detector, at most one in a thousand."""
STATISTICS = ("no_fault", "explained")
FLOOR_EXPLAINED = 1e-3
"""Stand-in for an all-zero column of held-out drops (healthy spreads squared)."""
MIN_HELD_OUT = 4
"""Fewer held-out readings than this fit no tail: no detector."""


def statistics(reading: Reading) -> dict[str, float]:
    """The reading's two detection statistics (module docstring)."""
    return {"no_fault": float(reading.healthy_cost),
            "explained": float(max(reading.healthy_cost - reading.cost, 0.0))}


@dataclasses.dataclass(frozen=True)
class Tail:
    """A scaled chi-square ``scale * chi2(dof)`` fitted to one statistic's held-out values."""

    scale: float
    dof: float
    threshold: float
    largest: float
    """The largest held-out value."""

    @classmethod
    def fit(cls, values: Sequence[float], alpha: float) -> Tail:
        """The tail of ``values`` (>= 0) by moments and its upper-``alpha`` threshold."""
        x = np.asarray(values, dtype=np.float64)
        if x.size < 2 or not np.all(np.isfinite(x)):
            raise ValueError(f"held-out values {list(values)}: at least two, all finite")
        if not np.any(x >= FLOOR_EXPLAINED):
            # all zero, or nearly: fitted as if the largest were the floor (a tail fitted to
            # one tiny drop among zeros would put the threshold below the all-zero case's)
            x = np.r_[np.delete(x, int(np.argmax(x))), FLOOR_EXPLAINED]
        m, v = float(np.mean(x)), float(np.var(x, ddof=1))
        v = max(v, 1e-12 * m * m)
        scale, dof = v / (2.0 * m), 2.0 * m * m / v
        q = float(scale * stats.chi2.isf(alpha, dof))
        return cls(scale, dof, max(q, float(x.max())), float(x.max()))

    def exceedance(self, value: float) -> float:
        """The fitted probability that a healthy BIT's statistic is above ``value``."""
        return float(stats.chi2.sf(value / self.scale, self.dof))


@dataclasses.dataclass(frozen=True)
class Detector:
    """The unit's thresholds on :func:`statistics`, from its held-out commissioning BITs."""

    alpha: float
    tails: dict[str, Tail]
    held_out: dict[str, tuple[float, ...]]
    """Per statistic the held-out commissioning BITs' values, in the order of the record."""

    def fired(self, reading: Reading) -> dict[str, float]:
        """The statistics above their threshold, each with its fitted healthy exceedance
        probability (empty: the BIT sits within the unit's healthy scatter)."""
        s = statistics(reading)
        return {k: self.tails[k].exceedance(s[k]) for k in STATISTICS
                if s[k] > self.tails[k].threshold}

    def evidence(self, reading: Reading) -> dict[str, Any]:
        """What the event says of the detector: each statistic, its threshold and whether
        it fired."""
        s = statistics(reading)
        return {k: {"value": round(s[k], 4), "threshold": round(self.tails[k].threshold, 4),
                    "fired": s[k] > self.tails[k].threshold} for k in STATISTICS}

    def to_json(self) -> dict[str, Any]:
        return {"rule": RULE, "alpha": self.alpha,
                "statistics": {k: {"scale": t.scale, "dof": t.dof, "threshold": t.threshold,
                                   "largest_held_out": t.largest,
                                   "held_out": [round(v, 6) for v in self.held_out[k]]}
                               for k, t in self.tails.items()}}

    @classmethod
    def from_json(cls, doc: Any, path: str = "<record>") -> Detector:
        """Parse :meth:`to_json`'s output; :class:`ConfigError` naming what is wrong."""
        try:
            st = doc["statistics"]
            tails = {k: Tail(float(st[k]["scale"]), float(st[k]["dof"]),
                             float(st[k]["threshold"]), float(st[k]["largest_held_out"]))
                     for k in STATISTICS}
            held = {k: tuple(float(v) for v in st[k]["held_out"]) for k in STATISTICS}
            alpha = float(doc["alpha"])
            for k, t in tails.items():
                if not (t.scale > 0.0 and t.dof > 0.0 and math.isfinite(t.scale)
                        and math.isfinite(t.dof) and math.isfinite(t.threshold)):
                    raise ValueError(f"{k}: scale {t.scale}, dof {t.dof}, threshold "
                                     f"{t.threshold} (positive and finite)")
            if not 0.0 < alpha < 1.0:
                raise ValueError(f"alpha {alpha} (between 0 and 1)")
            return cls(alpha, tails, held)
        except (KeyError, TypeError, ValueError) as error:
            raise ConfigError(f"malformed detector ({type(error).__name__}: {error})",
                              path=path, field="detector") from None


RULE = ("per statistic (no-fault cost; no-fault minus best fault cost), a scaled chi-square "
        "fitted by moments to the commissioning BITs read held out; threshold its upper "
        "alpha/2 quantile, at least the largest held-out value")


def held_out_readings(params: ActuatorParams, datasheet: ActuatorParams, disc: Discrepancy,
                      bits: Sequence[BitRecord]) -> list[Reading]:
    """Each of ``bits`` (those ``disc`` was learned on) read against the baseline learned
    without it."""
    discs = held_out_discrepancies(disc, params, bits)
    return [read(params, datasheet, d, b, disc.decimate)
            for d, b in zip(discs, bits, strict=True)]


def calibrate(params: ActuatorParams, datasheet: ActuatorParams, disc: Discrepancy,
              bits: Sequence[BitRecord], alpha: float = ALPHA) -> Detector:
    """The unit's detector from its commissioning ``bits`` (module docstring);
    :class:`ConfigError` with fewer than :data:`MIN_HELD_OUT` + 0 usable BITs."""
    if len(bits) < MIN_HELD_OUT:
        raise ConfigError(f"{len(bits)} BITs: the detector's tail needs at least "
                          f"{MIN_HELD_OUT}", field="bits")
    readings = held_out_readings(params, datasheet, disc, bits)
    values = {k: tuple(statistics(r)[k] for r in readings) for k in STATISTICS}
    try:
        tails = {k: Tail.fit(values[k], alpha / len(STATISTICS)) for k in STATISTICS}
    except ValueError as error:
        raise ConfigError(f"the detector's tail cannot be fitted ({error})",
                          field="detector") from None
    return Detector(alpha, tails, values)
