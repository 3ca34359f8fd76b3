"""The unit keeps being learned in service: its first flights' healthy BITs refine its
calibration, guarded so that neither a fault nor a slowly developing one is learned as health.

Commissioning calibrates the dictionary to a unit on a few healthy BITs
(:func:`~mapr_daemon.reasoner.commissioning.calibrate.calibrate_unit`); the more BITs, the
better its offsets, spreads and thresholds. :class:`InServiceLearning` keeps deciding every
new BIT with the unit's current dictionary and keeps the BITs it may learn from; at each
count of :data:`SCHEDULE` it calibrates the model's dictionary afresh on the commissioning
BITs and those. A BIT is learned from only when:

* it raised no alarm and was conclusive, under the unit's current calibration and under its
  commissioning one (kept as it was: a fault that later calibrations absorbed a little at a
  time still shows against it);
* (no tighter test on a single BIT: learning only the BITs below, say, the 90th percentile of
  the unit's own scores truncates its healthy sample, and the calibration made on it then sets
  the unit's spread and thresholds too low: on 10 units of bench/in_service.py such a guard
  raised the held-out healthy alarms to 16-20 in 100);
* no fault mode's severity is drifting: per parametric mode the severity its inverse model
  reads on every candidate BIT (:func:`~mapr_daemon.reasoner.diagnosis.classifier.kind_severities`:
  out of sample, as the commissioning BITs' own readings are not) is regressed on the
  candidates' order, with a level of its own for each calibration's stretch (a recalibration
  moves every reading; the slope is what stays within the stretches), and so are the BIT's
  two anomaly statistics (:data:`EVIDENCE`); a
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

__all__ = ["DRIFT_MIN", "DRIFT_RISE", "DRIFT_SIGMAS", "SCHEDULE",
           "InServiceLearning"]

SCHEDULE = (5, 10, 20, 50, 100, 200)
"""Healthy BITs seen (commissioning's included) at which the unit is calibrated afresh."""
DRIFT_MIN = 10
"""Candidate BITs the drift guard needs before it judges a trend."""
DRIFT_SIGMAS = 4.0
"""The t statistic of a mode's severity slope over the candidate BITs beyond which learning
stops (per mode; with six modes tested again at every BIT, 4 keeps a healthy unit learning
over hundreds of BITs)."""
DRIFT_RISE = 0.1
"""... and only when the fitted rise over those BITs is at least this fraction of the mode's
range (a significant but negligible slope over hundreds of BITs is not a fault)."""
EVIDENCE = ("anomaly score", "healthy residual")
"""Besides every mode's severity, the drift guard follows the BIT's two anomaly statistics
(``log1p`` of their ratio to their thresholds): a fault the unit's form hides from the
severity models still raises them BIT after BIT."""
EVIDENCE_RISE = 0.3
"""... and calls a rise of at least this much (about 1.35x the statistic's ratio) a drift."""
SEVERITY_SD_FLOOR = 0.05
"""Least spread of a mode's severity reading, as a fraction of its range: a reading pinned at
its band's edge has none, and a few commissioning BITs understate a unit's scatter; a drift
of a few hundredths of a range is not worth stopping for (it is what the trend is for)."""


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
    commissioned: Dictionary = dataclasses.field(init=False)
    """The calibration made at commissioning, kept: a BIT it flags is never learned from."""
    report: UnitCalibration = dataclasses.field(init=False)
    refused: Counter[str] = dataclasses.field(default_factory=Counter)
    """Why BITs were not learned from (one count per BIT)."""
    frozen: str | None = None
    """Why learning stopped for good (a mode's severity drifting), or None."""
    refits: int = 0
    _kinds: list[str] = dataclasses.field(default_factory=list)
    _commissioned: int = 0
    _seen: list[int] = dataclasses.field(default_factory=list)
    _epoch: list[int] = dataclasses.field(default_factory=list)
    _order: int = 0
    _readings: list[FloatArray] = dataclasses.field(default_factory=list)

    def __post_init__(self) -> None:
        self.m, self.q = list(self.m), [float(v) for v in self.q]   # ours, not the caller's
        self._kinds = sorted({t.kind for t in self.model.templates if not t.switch})
        self._commissioned = len(self.m)
        self._calibrate()
        self.commissioned = self.current

    @property
    def bits(self) -> int:
        """Healthy BITs the unit's calibration rests on now or at its next refit."""
        return len(self.m)

    def _calibrate(self) -> None:
        self.current, self.report = calibrate_unit(self.model, np.stack(self.m),
                                                   np.asarray(self.q, dtype=np.float64))
        self.refits += 1

    def _severities(self, m: FloatArray, q: float) -> FloatArray:
        sev = classifier.kind_severities(self.current, m, q)
        return np.array([sev[k] for k in self._kinds])

    def _evidence(self, dec: classifier.Decision) -> FloatArray:
        """The decision's anomaly statistics as drift channels (:data:`EVIDENCE`)."""
        null = float(dec.evidence.get("healthy_residual", 0.0))
        null_threshold = self.current.calibration.get("null_threshold", math.inf)
        return np.array([math.log1p(max(dec.score, 0.0) / dec.threshold),
                         math.log1p(max(null, 0.0) / null_threshold)])

    def _refusal(self, dec: classifier.Decision, m: FloatArray, q: float) -> str | None:
        """Why this BIT is not learned from, or None."""
        if self.frozen is not None:
            return "learning stopped"
        if dec.anomaly or dec.inconclusive:
            return "alarm" if dec.anomaly else "inconclusive"
        if not self.guarded:
            return None
        if self.refits > 1 and classifier.decide(self.commissioned, m, q).anomaly:
            # what later calibrations absorbed, the commissioning one still sees
            return "alarm at commissioning's calibration"
        self._seen.append(self._order)
        self._epoch.append(self.refits)
        self._order += 1
        self._readings.append(np.concatenate([self._severities(m, q), self._evidence(dec)]))
        if len(self._readings) >= DRIFT_MIN:
            x = np.asarray(self._seen, dtype=np.float64)
            y = np.asarray(self._readings)
            epoch = np.asarray(self._epoch)
            # each calibration reads every mode on its own level: order and readings centred
            # within each calibration's stretch, one slope over all of them
            xc, yc = x.copy(), y.copy()
            for e in np.unique(epoch):
                at = epoch == e
                xc[at] -= x[at].mean()
                yc[at] -= y[at].mean(axis=0)
            sxx = float(xc @ xc)
            dof = len(x) - len(np.unique(epoch)) - 1
            if sxx > 0.0 and dof > 0:
                slope = xc @ yc / sxx
                resid = yc - np.outer(xc, slope)
                sd = np.maximum(np.sqrt((resid**2).sum(axis=0) / dof), SEVERITY_SD_FLOOR)
                t = slope * math.sqrt(sxx) / sd
                rise = slope * (x[-1] - x[0])
                names = [*self._kinds, *EVIDENCE]
                least = np.array([DRIFT_RISE] * len(self._kinds) + [EVIDENCE_RISE] * len(EVIDENCE))
                k = int(np.argmax(np.where(rise >= least, t, -np.inf)))
                if rise[k] >= least[k] and t[k] > DRIFT_SIGMAS:
                    what = (f"its severity rose by {rise[k]:.2f} of its range"
                            if k < len(self._kinds) else
                            f"it rose by {rise[k]:.2f} (log of 1 + its ratio to its threshold)")
                    self.frozen = (f"{names[k]} drifting: {what} over {len(x)} healthy-looking "
                                   f"BITs (t = {t[k]:.1f})")
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
