"""The unit keeps being learned in service: its first flights' healthy BITs refine its
calibration, guarded so that neither a fault nor a slowly developing one is learned as health.

Commissioning calibrates the dictionary to a unit on a few healthy BITs
(:func:`~mapr_daemon.reasoner.commissioning.calibrate.calibrate_unit`); the more BITs, the
better its offsets, spreads and thresholds. :class:`InServiceLearning` keeps deciding every
new BIT with the unit's current dictionary and keeps the BITs it may learn from; at each
count of :data:`SCHEDULE` it calibrates the model's dictionary afresh on the commissioning
BITs and those. A BIT is learned from only when:

* it raised no alarm and was conclusive;
* each of its statistics (likelihood ratio, healthy residual, matched filter) is below the
  :data:`LEARN_QUANTILE` of the unit's own leave-one-out scores at the last calibration: a
  BIT that sits in the tail of the unit's healthy behaviour is evidence of change, not of
  health, and is not learned from;
* no fault mode's severity is drifting: per parametric mode the severity its inverse model
  reads on every candidate BIT since the last calibration
  (:func:`~mapr_daemon.reasoner.diagnosis.classifier.kind_severities`: out of sample, as
  the commissioning BITs' own readings are not), is regressed on the candidates' order; a
  slope whose t statistic exceeds :data:`DRIFT_SIGMAS` and whose rise over them is at least
  :data:`DRIFT_RISE` of the range is a drift. A fault that grows a little from BIT to BIT
  passes every single-BIT test; its trend does not. When it drifts, learning stops for good
  (:attr:`InServiceLearning.frozen` says which mode and by how much):
  a unit whose baseline may be moving is re-commissioned by a person, not by the learner.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.reasoner.commissioning.calibrate import UnitCalibration, calibrate_unit
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary

__all__ = ["DRIFT_MIN", "DRIFT_RISE", "DRIFT_SIGMAS", "LEARN_QUANTILE", "SCHEDULE",
           "InServiceLearning"]

SCHEDULE = (5, 10, 20, 50, 100, 200)
"""Healthy BITs seen (commissioning's included) at which the unit is calibrated afresh."""
LEARN_QUANTILE = 0.9
"""A BIT is learned from only below this quantile of the unit's own leave-one-out scores."""
DRIFT_MIN = 10
"""Candidate BITs since the last calibration the drift guard needs before it judges a
trend."""
DRIFT_SIGMAS = 4.0
"""The t statistic of a mode's severity slope over the candidate BITs beyond which learning
stops (per mode; with six modes tested again at every BIT, 4 keeps a healthy unit learning
over hundreds of BITs)."""
DRIFT_RISE = 0.1
"""... and only when the fitted rise over those BITs is at least this fraction of the mode's
range (a significant but negligible slope over hundreds of BITs is not a fault)."""
SEVERITY_SD_FLOOR = 0.05
"""Least spread of a mode's severity reading, as a fraction of its range: a reading pinned at
its band's edge has none, and a few commissioning BITs understate a unit's scatter; a drift
of a few hundredths of a range is not worth stopping for (it is what the trend is for)."""


def _statistics(dec: classifier.Decision) -> dict[str, float]:
    """The decision's statistics under the names the unit calibration keeps them."""
    ev = dec.evidence
    out = {"score": dec.score, "null": float(ev.get("healthy_residual", math.nan))}
    matched = ev.get("matched")
    if isinstance(matched, dict) and matched.get("z") is not None:
        out["matched"] = float(matched["z"])
    return out


@dataclasses.dataclass
class InServiceLearning:
    """A commissioned unit that goes on learning from its healthy BITs (see the module doc).

    ``model`` is the dictionary before any unit calibration (the data sheet's or the
    identified model's); ``m`` and ``q`` the commissioning BITs' matrices and pressures.
    """

    model: Dictionary
    m: list[FloatArray]
    q: list[float]
    schedule: tuple[int, ...] = SCHEDULE
    guarded: bool = True
    """False learns from every BIT that raised no alarm (what the guard is measured against)."""
    current: Dictionary = dataclasses.field(init=False)
    report: UnitCalibration = dataclasses.field(init=False)
    refused: Counter[str] = dataclasses.field(default_factory=Counter)
    """Why BITs were not learned from (one count per BIT)."""
    frozen: str | None = None
    """Why learning stopped for good (a mode's severity drifting), or None."""
    refits: int = 0
    _kinds: list[str] = dataclasses.field(default_factory=list)
    _commissioned: int = 0
    _seen: list[int] = dataclasses.field(default_factory=list)
    _readings: list[FloatArray] = dataclasses.field(default_factory=list)

    def __post_init__(self) -> None:
        self._kinds = sorted({t.kind for t in self.model.templates if not t.switch})
        self._commissioned = len(self.m)
        self._calibrate()

    @property
    def bits(self) -> int:
        """Healthy BITs the unit's calibration rests on now or at its next refit."""
        return len(self.m)

    def _calibrate(self) -> None:
        self.current, self.report = calibrate_unit(self.model, np.stack(self.m),
                                                   np.asarray(self.q, dtype=np.float64))
        self.refits += 1
        # a new calibration reads every mode on its own level: the trend starts again
        self._seen.clear()
        self._readings.clear()

    def _severities(self, m: FloatArray, q: float) -> FloatArray:
        sev = classifier.kind_severities(self.current, m, q)
        return np.array([sev[k] for k in self._kinds])

    def _refusal(self, dec: classifier.Decision, m: FloatArray, q: float) -> str | None:
        """Why this BIT is not learned from, or None."""
        if self.frozen is not None:
            return "learning stopped"
        if dec.anomaly or dec.inconclusive:
            return "alarm" if dec.anomaly else "inconclusive"
        if not self.guarded:
            return None
        for name, value in _statistics(dec).items():
            loo = self.report.loo_scores.get(name)
            if loo and not value < float(np.quantile(loo, LEARN_QUANTILE)):
                return f"{name} in the unit's tail"
        self._seen.append(len(self._seen))
        self._readings.append(self._severities(m, q))
        if len(self._readings) >= DRIFT_MIN:
            x = np.asarray(self._seen, dtype=np.float64)
            y = np.asarray(self._readings)
            xc = x - x.mean()
            slope = xc @ (y - y.mean(axis=0)) / float(xc @ xc)
            resid = y - y.mean(axis=0) - np.outer(xc, slope)
            sd = np.maximum(resid.std(axis=0, ddof=2), SEVERITY_SD_FLOOR)
            t = slope * math.sqrt(float(xc @ xc)) / sd
            rise = slope * (x[-1] - x[0])
            k = int(np.argmax(np.where(rise >= DRIFT_RISE, t, -np.inf)))
            if rise[k] >= DRIFT_RISE and t[k] > DRIFT_SIGMAS:
                self.frozen = (f"{self._kinds[k]} drifting: its severity rose by "
                               f"{rise[k]:.2f} of its range over the last {len(x)} healthy-"
                               f"looking BITs (t = {t[k]:.1f})")
                return "learning stopped"
        return None

    def observe(self, m: FloatArray, q: float) -> classifier.Decision:
        """Decide one BIT with the unit's current dictionary; learn from it if it may be; at a
        count of the schedule, calibrate afresh. The decision is the one made before."""
        dec = classifier.decide(self.current, m, q)
        why = self._refusal(dec, m, q)
        if why is not None:
            self.refused[why] += 1
            return dec
        self.m.append(m)
        self.q.append(float(q))
        if len(self.m) in self.schedule:
            self._calibrate()
        return dec
