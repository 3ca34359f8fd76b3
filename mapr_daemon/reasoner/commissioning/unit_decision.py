"""The event's fault taken from the reading against the unit's commissioned baseline when that
reading explains the BIT; the dictionary's reading kept beside it.

Detection is decided before (the dictionary's alone, or combined with the unit's own
detector when the record has one: :mod:`~mapr_daemon.reasoner.commissioning.detection`). For
a BIT called an anomaly, :func:`combine` weighs the baseline reading
(:class:`~mapr_daemon.reasoner.commissioning.severity.Reading`) and, when it **explains** the
BIT, the decision's mode, part and severity become the baseline's.

"Explains" is measured in the unit's own healthy scatter. The reading's costs are mean squares
of the residual in units of the spread the identified model plus discrepancy left on the
commissioning's healthy BITs it was not learned on, so a healthy BIT costs about 1 under "no
fault" and a fault can take at most about that away from it (on the mismatch bench the
largest drop on held-out healthy BITs was 0.25). The reading explains the BIT when

* its best hypothesis is a fault, not "no fault";
* the fault takes at least :data:`MIN_EXPLAINED` (one healthy BIT's whole residual) off the
  "no fault" cost: more than any healthy BIT's scatter can give, so a healthy BIT read
  against its baseline is not called a fault;
* what remains is at most :data:`MAX_LEFT` of the "no fault" cost: the fault accounts for
  most of the departure, not a sliver of something else.

Otherwise the dictionary's decision stands (its fault, or its "anomaly, not explained by any
known fault mode"). When the two name different parts the event says so
(``evidence.disagreement``) and follows the baseline reading: on mismatched units it named the
part right far more often than the dictionary did (docs/commissioning.md, "Reading a fault
against the unit's baseline").
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mapr_daemon.ema.faults import PARAMETRIC, at_severity
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.severity import HEALTHY, TERMINAL, Reading
from mapr_daemon.reasoner.diagnosis import parts
from mapr_daemon.reasoner.diagnosis.classifier import Decision

MIN_EXPLAINED = 1.0
"""Least drop of the cost, in healthy spreads squared, that a fault must explain."""
MAX_LEFT = 0.5
"""Largest share of the "no fault" cost the fault may leave unexplained."""
RULE = (f"the baseline reading decides mode, part and severity when its best hypothesis is a "
        f"fault that explains at least {MIN_EXPLAINED:g} (healthy spreads squared) and leaves at "
        f"most {MAX_LEFT:g} of the no-fault cost; otherwise the dictionary's decision stands")


def explains(reading: Reading | str) -> bool:
    """Whether the reading accounts for the BIT (module docstring)."""
    if isinstance(reading, str) or reading.mode == HEALTHY:
        return False
    drop = reading.healthy_cost - reading.cost
    return drop >= MIN_EXPLAINED and reading.cost <= MAX_LEFT * reading.healthy_cost


def _dictionary_view(dec: Decision) -> dict[str, Any]:
    """The dictionary's reading as the event's ``evidence.dictionary``."""
    out: dict[str, Any] = {"fault": dec.fault, "switch": dec.switch,
                           "part": parts.PART_OF.get(dec.fault) if dec.fault else None}
    if dec.severity is not None:
        out["severity_fraction_of_range"] = round(dec.severity, 4)
    if dec.value is not None:
        out["severity"] = float(f"{dec.value:.6g}")
        out["unit"] = dec.unit
    if dec.pair is not None:
        out["compound"] = [m.fault for m in dec.pair]
    return out


def combine(dec: Decision, reading: Reading | str, baseline: Baseline) -> Decision:
    """``dec`` (the dictionary's decision on an anomalous BIT) with the baseline reading
    weighed in: mode, part and severity from the reading when it :func:`explains` the BIT,
    both readings in the evidence, and their disagreement on the part stated."""
    evidence = dict(dec.evidence)
    evidence["dictionary"] = _dictionary_view(dec)
    taken = explains(reading)
    evidence["baseline"] = {**baseline.to_json(reading), "explains": taken, "rule": RULE}
    if not taken:
        evidence["reading"] = "dictionary"
        return dataclasses.replace(dec, evidence=evidence)
    assert isinstance(reading, Reading)
    mode = reading.mode
    if dec.fault is not None and parts.PART_OF.get(dec.fault) != parts.PART_OF[mode]:
        evidence["disagreement"] = {
            "dictionary_part": parts.PART_OF.get(dec.fault),
            "baseline_part": parts.PART_OF[mode],
            "rule": "the baseline reading is followed: it is measured against the unit's own "
                    "healthy behaviour"}
    evidence["reading"] = "baseline"
    for key in ("switch", "nominal", "replace_at", "severity_fraction_of_range"):
        evidence.pop(key, None)
    if mode in TERMINAL:
        return dataclasses.replace(dec, fault=mode, switch=reading.switch, severity=None,
                                   value=None, unit=None, pair=None, kind_residuals={},
                                   evidence=evidence)
    s = min(max(reading.severity, 0.0), 1.0)
    value = at_severity(baseline.datasheet, mode, s).value
    return dataclasses.replace(dec, fault=mode, switch=None, severity=s, value=value,
                               unit=PARAMETRIC[mode].unit, pair=None, kind_residuals={},
                               evidence=evidence)
