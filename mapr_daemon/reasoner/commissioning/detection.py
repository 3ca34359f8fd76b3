"""A commissioned unit's anomaly decision: the dictionary's alarm and the unit's own detector
on the baseline reading (:mod:`~mapr_daemon.reasoner.commissioning.detector`), combined.

Four rules (:data:`RULES`), all measured by ``bench/units.py --baseline``:

* ``dictionary`` — the dictionary alone detects (what a unit whose record has no detector
  gets: every BIT the dictionary calls nominal stays nominal);
* ``union`` — an anomaly when the dictionary or either statistic of the unit's detector fires;
* ``explained`` — an anomaly when the dictionary fires or the unit's detector's
  ``explained`` statistic (the GLRT: what the best known fault takes off the no-fault cost)
  is above its threshold;
* ``baseline`` — the unit's detector decides alone: a dictionary alarm on a BIT whose reading
  sits within the unit's healthy scatter (neither statistic above its threshold) is vetoed.

:data:`RULE` is the product's: ``explained``. On the design seeds (master seed 12345, 3
mismatched aileron units, 60 healthy and 48 faulted BITs; docs/commissioning.md, "The unit's
own detector") the ``no_fault`` statistic's thresholds did not hold on BITs outside the
commissioning (3 of 60 healthy BITs above, up to 1.84 times the threshold: a departure no
fault explains is also what an unvisited condition gives), while no healthy BIT's
``explained`` went above its threshold (largest 0.84 of it). The veto (``baseline``) lost every
inverter phase-A fault the dictionary caught (the reading's cost for that mode is flat within
the unit's scatter) and detected 64 % against the dictionary's 86 %; the union added 3
healthy alarms for one detection. ``explained`` keeps the dictionary's detections and adds the
faults only the reading's GLRT sees, without the no-fault statistic's false alarms.

An anomaly then goes through
:func:`~mapr_daemon.reasoner.commissioning.unit_decision.combine` (mode, part and severity from
the reading when it explains the BIT; "anomaly, not explained by any known fault mode"
otherwise). The event's ``evidence.detection`` says which detector fired: the dictionary's
alarm, each baseline statistic with its threshold, everything above its threshold
(``fired``), what the rule counted (``decided_by``: empty for a nominal BIT) and the rule. A
nominal BIT of a unit whose record measured what its BITs can see
(:mod:`~mapr_daemon.reasoner.commissioning.visibility`) names the modes it does not see from
a quarter of their range, with each one's floor (``evidence.not_seen_on_this_unit``): what
that "no anomaly" does not clear.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.commissioning.unit_decision import combine
from mapr_daemon.reasoner.diagnosis.classifier import Decision

RULES = ("dictionary", "union", "explained", "baseline")
RULE = "explained"
"""The product's rule (module docstring)."""
_SAYS = {
    "dictionary": "the dictionary detects alone",
    "union": "an anomaly when the dictionary or the unit's detector fires",
    "explained": "an anomaly when the dictionary fires or a known fault explains more of the "
                 "reading than the unit's healthy BITs allow (the detector's GLRT statistic)",
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
        return combine(dec, reading, baseline) if dec.anomaly else unseen(dec, baseline)
    fired = detector.fired(reading)
    everything = (["dictionary"] if dec.anomaly else []) + [f"baseline.{k}" for k in fired]
    counted = {"dictionary": ["dictionary"] if dec.anomaly else [], "union": everything,
               "explained": [k for k in everything if k != "baseline.no_fault"],
               "baseline": [k for k in everything if k != "dictionary"]}[rule]
    anomaly = bool(counted)
    detection: dict[str, Any] = {
        "dictionary": dec.anomaly, "baseline": detector.evidence(reading),
        "fired": everything, "decided_by": counted, "rule": _SAYS[rule]}
    if not anomaly:
        evidence = dict(dec.evidence)
        evidence.update(detection=detection, baseline=baseline.to_json(reading))
        confidence = dec.confidence
        if dec.anomaly:
            evidence["vetoed"] = {"fault": dec.fault, "confidence": round(dec.confidence, 4)}
            confidence = 1.0 - dec.confidence
        return unseen(dataclasses.replace(
            dec, anomaly=False, fault=None, switch=None, severity=None, value=None, unit=None,
            pair=None, kind_residuals={}, confidence=confidence, evidence=evidence), baseline)
    if not dec.anomaly:
        # the unit's detector alone: as sure as its fitted tail makes the departure rare; an
        # anomaly not explained until the reading explains it (combine then drops the words)
        said = {**dec.evidence, "unexplained": (
            "anomaly, not explained by any known fault mode: the unit's own detector flagged "
            "the BIT (" + ", ".join(counted) + ") and the dictionary did not")}
        dec = dataclasses.replace(dec, anomaly=True, fault=None, switch=None, severity=None,
                                  value=None, unit=None, pair=None, kind_residuals={},
                                  confidence=1.0 - min(fired[k.split(".")[1]]
                                                       for k in counted), evidence=said)
    out = combine(dec, reading, baseline)
    return dataclasses.replace(out, evidence={**out.evidence, "detection": detection})


def unseen(dec: Decision, baseline: Baseline) -> Decision:
    """A nominal decision with what this unit's BITs do not see (its record's visibility;
    also what :meth:`~mapr_daemon.reasoner.reasoner.Reasoner.diagnose` applies to a unit
    without a detector, whose nominal BITs are not read against the baseline):
    ``evidence.not_seen_on_this_unit`` maps each mode not seen from the least measured
    severity to its floor (a fraction of range; None: not within its range). Unchanged when
    the record has no visibility, or the unit sees every mode from there."""
    seen = baseline.visibility
    if seen is None or dec.anomaly or dec.inconclusive:
        return dec
    start = min(seen.severities)
    floors = {k: seen.floor(k) for k in seen.detected if not seen.sees(k, start)}
    if not floors:
        return dec
    return dataclasses.replace(dec, evidence={**dec.evidence, "not_seen_on_this_unit": {
        "floors": floors,
        "rule": f"each mode's floor (a fraction of range; null: not within its range) is the "
                f"least severity from which every larger one, added to this unit's "
                f"commissioning BITs, was detected on at least {seen.seen:.0%} of them by its "
                f"calibrated dictionary (mapr commission); a fault below it may go unseen"}})
