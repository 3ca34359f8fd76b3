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

**Two faults at once.** When the reading searched pairs
(:mod:`~mapr_daemon.reasoner.commissioning.pairs`), :func:`verdict` weighs the best pair
against the best single hypothesis before the rule above. A pair has one more free parameter
than a single fault (its second severity), so it always leaves a little less; it is
**named** (:func:`named_pair`) only when it gains more than that parameter can by chance, in
the unit's healthy scatter:

* the pair explains the BIT as a single fault must (takes at least :data:`MIN_EXPLAINED` off
  the "no fault" cost and leaves at most :data:`MAX_LEFT` of it);
* it leaves at least :data:`PAIR_GAIN` less than the best single: the likelihood ratio of
  pair over single (the costs are mean squares in healthy spreads, so their difference is a
  log-likelihood ratio per decimated sample) is more than a healthy BIT's whole residual, what
  one extra severity could at most fit of the scatter;
* it leaves at most :data:`PAIR_SHARE` of what the single left: the single's leftover holds
  its own model error on this unit, which grows with the departure and which a second fault
  can partly absorb; the pair must take most of it away, not a slice.

A BIT that departs clearly from the baseline but that neither the best single nor the best
pair explains, when pairs were searched — the best of them leaves more than
:data:`UNEXPLAINED_LEFT` healthy spreads squared, several times what healthy BITs leave —
is **unexplained** by the baseline: the
event says "anomaly, not explained by any known fault mode" (the best single and pair as the
closest, not a fit), rather than falling back on the dictionary's single fault, which on such
BITs is mostly one of two faults. Otherwise, as before, the dictionary's decision stands.
The constants were chosen on design seeds (docs/commissioning.md, "Two faults at once against
the baseline").
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mapr_daemon.ema.faults import PARAMETRIC, at_severity
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.severity import HEALTHY, TERMINAL, Reading
from mapr_daemon.reasoner.diagnosis import parts
from mapr_daemon.reasoner.diagnosis.classifier import Decision, Member

MIN_EXPLAINED = 1.0
"""Least drop of the cost, in healthy spreads squared, that a fault must explain."""
MAX_LEFT = 0.5
"""Largest share of the "no fault" cost the fault may leave unexplained."""
PAIR_GAIN = 1.0
"""Least drop from the best single to the best pair's cost (healthy spreads squared). On the
design seed (1001: 4 aileron units, 12 held-out healthy BITs) the best pair gained at most
0.01 over the best single on a healthy BIT; the same 1.0 as :data:`MIN_EXPLAINED`."""
PAIR_SHARE = 0.8
"""Largest share of the best single's cost the pair may leave. Chosen on the design seed
(104 pair and 72 single-fault BITs, 35-100 % and 25-100 % of range): at 0.6, 0.7, 0.8 and
0.9 the pairs the bus can see named right were 17, 18, 22 and 24 of 72 and the single faults
called a pair 0 at every share (at :data:`PAIR_GAIN` 0.1 and 0.95, 4 were); 0.8 is taken, one
step short of the plateau."""
UNEXPLAINED_LEFT = 3.0
"""Cost above which a BIT nothing explains is unexplained: healthy BITs cost about 1 (on the
design seed 12 held-out healthy BITs cost 0.4-2.6, one 10)."""
PAIR_RULE = (f"two faults in different parts are named when their best pair explains the BIT "
             f"and leaves at least {PAIR_GAIN:g} (healthy spreads squared) less than the best "
             f"single fault and at most {PAIR_SHARE:g} of what it leaves")
UNEXPLAINED_RULE = (f"neither a single fault nor a pair explains the BIT and the best leaves "
                    f"more than {UNEXPLAINED_LEFT:g} healthy spreads squared")
RULE = (f"the baseline reading decides mode, part and severity when its best hypothesis is a "
        f"fault that explains at least {MIN_EXPLAINED:g} (healthy spreads squared) and leaves at "
        f"most {MAX_LEFT:g} of the no-fault cost; otherwise the dictionary's decision stands")


def explains(reading: Reading | str) -> bool:
    """Whether the reading accounts for the BIT (module docstring)."""
    if isinstance(reading, str) or reading.mode == HEALTHY:
        return False
    drop = reading.healthy_cost - reading.cost
    return drop >= MIN_EXPLAINED and reading.cost <= MAX_LEFT * reading.healthy_cost


def named_pair(reading: Reading | str) -> bool:
    """Whether the reading's best pair is named (module docstring)."""
    if isinstance(reading, str) or reading.pair is None:
        return False
    c = reading.pair.cost
    return (reading.healthy_cost - c >= MIN_EXPLAINED and c <= MAX_LEFT * reading.healthy_cost
            and reading.cost - c >= PAIR_GAIN and c <= PAIR_SHARE * reading.cost)


def verdict(reading: Reading | str) -> str:
    """What the baseline reading says of a flagged BIT: ``pair``, ``single`` (it
    :func:`explains` it), ``unexplained``, or ``dictionary`` (too little to say: the
    dictionary's decision stands)."""
    if isinstance(reading, str):
        return "dictionary"
    if named_pair(reading):
        return "pair"
    if explains(reading):
        return "single"
    if reading.pair is None:  # pairs not searched: nothing to say beyond single faults
        return "dictionary"
    best = min(reading.cost, reading.pair.cost)
    return "unexplained" if best > UNEXPLAINED_LEFT else "dictionary"


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
    said = verdict(reading)
    taken = explains(reading)
    evidence["baseline"] = {**baseline.to_json(reading), "explains": taken, "rule": RULE,
                            "verdict": said, "pair_rule": PAIR_RULE,
                            "unexplained_rule": UNEXPLAINED_RULE}
    if said == "dictionary":
        evidence["reading"] = "dictionary"
        return dataclasses.replace(dec, evidence=evidence)
    assert isinstance(reading, Reading)
    if said == "pair":
        return _pair(dec, reading, baseline, evidence)
    if said == "unexplained":
        return _unexplained(dec, reading, evidence)
    mode = reading.mode
    if dec.fault is not None and parts.PART_OF.get(dec.fault) != parts.PART_OF[mode]:
        evidence["disagreement"] = {
            "dictionary_part": parts.PART_OF.get(dec.fault),
            "baseline_part": parts.PART_OF[mode],
            "rule": "the baseline reading is followed: it is measured against the unit's own "
                    "healthy behaviour"}
    evidence["reading"] = "baseline"
    _strip(evidence)   # the dictionary's "unexplained" no longer describes the event either
    if mode in TERMINAL:
        return dataclasses.replace(dec, fault=mode, switch=reading.switch, severity=None,
                                   value=None, unit=None, pair=None, kind_residuals={},
                                   evidence=evidence)
    s = min(max(reading.severity, 0.0), 1.0)
    value = at_severity(baseline.datasheet, mode, s).value
    return dataclasses.replace(dec, fault=mode, switch=None, severity=s, value=value,
                               unit=PARAMETRIC[mode].unit, pair=None, kind_residuals={},
                               evidence=evidence)


def _member(baseline: Baseline, mode: str, severity: float) -> Member:
    s = min(max(severity, 0.0), 1.0)
    return Member(mode, s, at_severity(baseline.datasheet, mode, s).value, PARAMETRIC[mode].unit)


def _strip(evidence: dict[str, Any]) -> None:
    """The dictionary's single-fault keys, which no longer describe the event's fault."""
    for key in ("switch", "nominal", "replace_at", "severity_fraction_of_range", "unexplained",
                "departures", "closest"):
        evidence.pop(key, None)


def _pair(dec: Decision, reading: Reading, baseline: Baseline,
          evidence: dict[str, Any]) -> Decision:
    """The decision naming the reading's pair, in the dictionary path's shape
    (:attr:`Decision.pair`, the more severe member first and as ``fault``)."""
    assert reading.pair is not None
    p = reading.pair
    a, b = _member(baseline, p.first, p.severity_first), _member(baseline, p.second,
                                                                   p.severity_second)
    first, second = (a, b) if a.severity >= b.severity else (b, a)
    named = {parts.PART_OF[p.first], parts.PART_OF[p.second]}
    if dec.fault is not None and parts.PART_OF.get(dec.fault) not in named:
        evidence["disagreement"] = {
            "dictionary_part": parts.PART_OF.get(dec.fault),
            "baseline_part": sorted(named),
            "rule": "the baseline reading is followed: it is measured against the unit's own "
                    "healthy behaviour"}
    evidence["reading"] = "baseline"
    _strip(evidence)
    return dataclasses.replace(dec, fault=first.fault, switch=None, severity=first.severity,
                               value=first.value, unit=first.unit, pair=(first, second),
                               kind_residuals={}, evidence=evidence)


def _unexplained(dec: Decision, reading: Reading, evidence: dict[str, Any]) -> Decision:
    """The decision "anomaly, not explained by any known fault mode": what the best single
    and the best pair leave, and the closest of them (not a fit)."""
    departures = evidence.get("departures")
    _strip(evidence)
    evidence["reading"] = "baseline"
    assert reading.pair is not None
    left = min(reading.cost, reading.pair.cost)
    evidence["unexplained"] = (
        "anomaly, not explained by any known fault mode: against the unit's baseline the best "
        f"single fault or pair leaves {left:.1f} healthy spreads squared of "
        f"{reading.healthy_cost:.1f}, a healthy BIT about 1")
    closest: dict[str, Any] = {"fault": reading.mode, "part": parts.PART_OF.get(reading.mode),
                               "note": "the nearest hypothesis, not a fit"}
    closest["pair"] = [reading.pair.first, reading.pair.second]
    evidence["closest"] = closest
    if departures is not None:
        evidence["departures"] = departures
    return dataclasses.replace(dec, fault=None, switch=None, severity=None, value=None,
                               unit=None, pair=None, kind_residuals={}, evidence=evidence)
