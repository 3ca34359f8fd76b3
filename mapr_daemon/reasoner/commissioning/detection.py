"""A commissioned unit's anomaly decision: the dictionary's alarm and the unit's own detector
on the baseline reading (:mod:`~mapr_daemon.reasoner.commissioning.detector`), combined.

Three rules (:data:`RULES`), all measured by ``bench/units.py --baseline``:

* ``dictionary`` — the dictionary alone detects (what a unit whose record has no detector
  gets: every BIT the dictionary calls nominal stays nominal);
* ``union`` — an anomaly when either detector fires;
* ``baseline`` — the unit's detector decides: a dictionary alarm on a BIT whose reading sits
  within the unit's healthy scatter (neither statistic above its threshold) is vetoed, and a
  BIT the dictionary calls nominal is an anomaly when the reading departs beyond it.

:data:`RULE` is the product's. It is ``baseline``: on the design seeds (docs/commissioning.md,
"The unit's own detector") the union kept every false alarm of the unit-calibrated dictionary
(its thresholds are set on the unit's 20 BITs, not to a stated false-alarm rate) and detected
no more than the baseline alone, whose thresholds are the unit's held-out tail.

An anomaly then goes through
:func:`~mapr_daemon.reasoner.commissioning.unit_decision.combine` (mode, part and severity from
the reading when it explains the BIT; "anomaly, not explained by any known fault mode"
otherwise). The event's ``evidence.detection`` says which detector fired: the dictionary's
alarm, each baseline statistic with its threshold, and the rule.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.commissioning.unit_decision import combine
from mapr_daemon.reasoner.diagnosis.classifier import Decision

RULES = ("dictionary", "union", "baseline")
RULE = "baseline"
"""The product's rule (module docstring)."""
_SAYS = {
    "dictionary": "the dictionary detects alone",
    "union": "an anomaly when the dictionary or the unit's detector fires",
    "baseline": "the unit's detector on the baseline reading decides; a dictionary alarm "
                "within the unit's healthy scatter is vetoed",
}


def decide(dec: Decision, reading: Reading | str, baseline: Baseline,
           rule: str = RULE) -> Decision:
    """The decision on a BIT the dictionary decided ``dec`` and the baseline read
    ``reading`` (a string: why it could not be read). Without a detector on the baseline, or
    without a reading, the dictionary detects alone (``rule`` ignored)."""
    if rule not in RULES:
        raise ValueError(f"unknown detection rule {rule!r}")
    detector = baseline.detector
    if dec.inconclusive:
        return dec
    if detector is None or isinstance(reading, str):
        return combine(dec, reading, baseline) if dec.anomaly else dec
    fired = detector.fired(reading)
    anomaly = {"dictionary": dec.anomaly, "union": dec.anomaly or bool(fired),
               "baseline": bool(fired)}[rule]
    detection: dict[str, Any] = {
        "dictionary": dec.anomaly, "baseline": detector.evidence(reading),
        "fired": (["dictionary"] if dec.anomaly else []) + [f"baseline.{k}" for k in fired],
        "rule": _SAYS[rule]}
    if not anomaly:
        evidence = dict(dec.evidence)
        evidence.update(detection=detection, baseline=baseline.to_json(reading))
        confidence = dec.confidence
        if dec.anomaly:
            evidence["vetoed"] = {"fault": dec.fault, "confidence": round(dec.confidence, 4)}
            confidence = 1.0 - dec.confidence
        return dataclasses.replace(dec, anomaly=False, fault=None, switch=None, severity=None,
                                   value=None, unit=None, pair=None, kind_residuals={},
                                   confidence=confidence, evidence=evidence)
    if not dec.anomaly:
        # the unit's detector alone: as sure as its fitted tail makes the departure rare
        dec = dataclasses.replace(dec, anomaly=True, fault=None, switch=None, severity=None,
                                  value=None, unit=None, pair=None, kind_residuals={},
                                  confidence=1.0 - min(fired.values()))
    out = combine(dec, reading, baseline)
    return dataclasses.replace(out, evidence={**out.evidence, "detection": detection})
