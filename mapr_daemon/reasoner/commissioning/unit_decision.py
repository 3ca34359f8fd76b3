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
fault".

**Within what the unit allows** (a record whose detector has a single-fault allowance,
:class:`~mapr_daemon.reasoner.commissioning.detector.Allowance`; every record commissioned
since). A hypothesis (a single fault, or a pair) explains the BIT when it takes at least
:data:`MIN_EXPLAINED` off the "no fault" cost (more than a healthy BIT's scatter can give) and
leaves at most ``healthy + share * D`` of it, ``D`` what it takes off: ``healthy`` the
leftover the unit's healthy scatter allows, ``share`` the model error per unit of departure a
true single fault of that mode left on this unit's own commissioning BITs with faults added
and read back (a pair: the larger of its two modes').
On that calibration a true single fault is outside the allowance at most one BIT in twenty
(:data:`~mapr_daemon.reasoner.commissioning.detector.ALPHA_SINGLE`). Then (:func:`verdict`):

* the best single fault explains the BIT: **single** (its mode, part and severity);
* else the best pair of two faults in different parts explains it and leaves at least
  :data:`PAIR_GAIN` less than the best single (what a second severity can fit of a healthy
  BIT's scatter by chance is far less): **pair**, both severities;
* else, when the BIT departs beyond the healthy allowance (its "no fault" cost above
  ``healthy``): **unexplained** — "anomaly, not explained by any known fault mode", naming the
  signals and BIT stretches that carry most of the departure
  (:func:`~mapr_daemon.reasoner.commissioning.departures.departures`) and the part the best
  single fault points at, if it takes anything off (said to be no fit);
* else the dictionary's decision stands (the reading sees too little to say).

A single fault that leaves more than the unit allows is not called the explanation just
because it takes most of a large departure away: what it leaves, beyond the healthy scatter
and its own model error, is where a second fault hides. A short or an open is a gross change
the parametric calibration does not measure: it keeps the older share rule below.

**An open switch the phase currents show** (``Reading.open_seen``,
:mod:`~mapr_daemon.reasoner.commissioning.conduction`: one switch's current direction never
conducts while the other five do) explains the BIT under either rule, whatever the model's
cost leaves, and before any pair: the bridge itself says which switch is open, and what the
open did to the motion of a unit that is not the model's twin (a stall, or none) is not asked
of the model.

**Without an allowance** (a record written before it): the fault explains the BIT when it
takes at least :data:`MIN_EXPLAINED` off the "no fault" cost and leaves at most
:data:`MAX_LEFT` of it; a pair is named when it explains the BIT so, leaves at least
:data:`PAIR_GAIN` less than the best single and at most :data:`PAIR_SHARE` of what the single
left; a BIT that neither explains is unexplained when the best leaves more than
:data:`UNEXPLAINED_LEFT` (pairs searched), else the dictionary's decision stands.

When the reading and the dictionary name different parts the event says so
(``evidence.disagreement``) and follows the baseline reading: on mismatched units it named the
part right far more often than the dictionary did (docs/commissioning.md, "Reading a fault
against the unit's baseline"). The figures: docs/commissioning.md, "Two faults at once against
the baseline".
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mapr_daemon.ema.faults import PARAMETRIC, at_severity
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.detector import Allowance
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
ALLOWED_RULE = (f"a single fault, else a pair of faults in different parts gaining at least "
                f"{PAIR_GAIN:g} on it, explains the BIT when it takes at least "
                f"{MIN_EXPLAINED:g} off the no-fault cost and leaves at most what the unit's "
                f"calibration allows a true single fault (healthy + share x what it takes "
                f"off); neither, on a BIT beyond the healthy allowance: anomaly, not explained "
                f"by any known fault mode; otherwise the dictionary's decision stands")


def _within(cost: float, healthy_cost: float, allowance: Allowance,
            modes: tuple[str, ...]) -> bool:
    """Whether a hypothesis of ``modes`` leaving ``cost`` explains a reading whose "no fault"
    costs ``healthy_cost`` on this unit (module docstring)."""
    return (healthy_cost - cost >= MIN_EXPLAINED
            and allowance.holds(cost, healthy_cost, modes))


def explains(reading: Reading | str, allowance: Allowance | None = None) -> bool:
    """Whether the reading's best single hypothesis accounts for the BIT: within the unit's
    ``allowance`` when there is one (module docstring)."""
    if isinstance(reading, str) or reading.mode == HEALTHY:
        return False
    if reading.open_seen is not None:
        return True
    if allowance is not None and reading.mode not in TERMINAL:
        return _within(reading.cost, reading.healthy_cost, allowance, (reading.mode,))
    drop = reading.healthy_cost - reading.cost
    return drop >= MIN_EXPLAINED and reading.cost <= MAX_LEFT * reading.healthy_cost


def named_pair(reading: Reading | str, allowance: Allowance | None = None) -> bool:
    """Whether the reading's best pair explains the BIT and gains enough on the best single
    (module docstring; with an ``allowance`` :func:`verdict` asks it only when the single
    does not explain the BIT)."""
    if isinstance(reading, str) or reading.pair is None:
        return False
    c = reading.pair.cost
    if allowance is not None:
        return reading.cost - c >= PAIR_GAIN and _within(
            c, reading.healthy_cost, allowance, (reading.pair.first, reading.pair.second))
    return (reading.healthy_cost - c >= MIN_EXPLAINED and c <= MAX_LEFT * reading.healthy_cost
            and reading.cost - c >= PAIR_GAIN and c <= PAIR_SHARE * reading.cost)


def verdict(reading: Reading | str, allowance: Allowance | None = None) -> str:
    """What the baseline reading says of a flagged BIT: ``single`` (it :func:`explains` it),
    ``pair``, ``unexplained``, or ``dictionary`` (too little to say: the dictionary's
    decision stands); against the unit's ``allowance`` when there is one."""
    if isinstance(reading, str):
        return "dictionary"
    if reading.open_seen is not None:
        return "single"
    if allowance is not None:
        if explains(reading, allowance):
            return "single"
        if named_pair(reading, allowance):
            return "pair"
        return "unexplained" if reading.healthy_cost > allowance.healthy else "dictionary"
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
    allowance = None if baseline.detector is None else baseline.detector.allowance
    said = verdict(reading, allowance)
    taken = explains(reading, allowance)
    evidence["baseline"] = {**baseline.to_json(reading), "explains": taken, "verdict": said}
    if allowance is None:
        evidence["baseline"].update(rule=RULE, pair_rule=PAIR_RULE,
                                    unexplained_rule=UNEXPLAINED_RULE)
    else:
        modes = () if isinstance(reading, str) else (reading.mode,)
        evidence["baseline"].update(rule=ALLOWED_RULE, allowance={
            "healthy": round(allowance.healthy, 4),
            "share": round(allowance.share_of(modes), 4), "false_rate": allowance.alpha})
        if not isinstance(reading, str):
            evidence["baseline"]["allowed"] = round(
                allowance.left(reading.healthy_cost - reading.cost, modes), 4)
    if said == "dictionary":
        evidence["reading"] = "dictionary"
        return dataclasses.replace(dec, evidence=evidence)
    assert isinstance(reading, Reading)
    if said == "pair":
        return _pair(dec, reading, baseline, evidence)
    if said == "unexplained":
        return _unexplained(dec, reading, evidence, allowance)
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


def _unexplained(dec: Decision, reading: Reading, evidence: dict[str, Any],
                 allowance: Allowance | None) -> Decision:
    """The decision "anomaly, not explained by any known fault mode": what the best single
    and the best pair leave (against what the unit allows), where the BIT departs (the
    reading's own departures; the dictionary's when the reading has none) and the part the
    best single fault points at, if any (the closest hypothesis, not a fit)."""
    departures = reading.departures or evidence.get("departures")
    _strip(evidence)
    evidence["reading"] = "baseline"
    left = reading.cost if reading.pair is None else min(reading.cost, reading.pair.cost)
    allowed = ("" if allowance is None else
               f", the unit's calibration allows a true single fault "
               f"{allowance.left(reading.healthy_cost - reading.cost, (reading.mode,)):.1f}")
    evidence["unexplained"] = (
        "anomaly, not explained by any known fault mode: against the unit's baseline the best "
        f"single fault or pair leaves {left:.1f} healthy spreads squared of "
        f"{reading.healthy_cost:.1f}{allowed}, a healthy BIT about 1")
    points = (parts.PART_OF.get(reading.mode) if reading.mode != HEALTHY
              and reading.healthy_cost - reading.cost >= MIN_EXPLAINED else None)
    closest: dict[str, Any] = {"fault": None if reading.mode == HEALTHY else reading.mode,
                               "part": points, "note": "the nearest hypothesis, not a fit"}
    if reading.pair is not None:
        closest["pair"] = [reading.pair.first, reading.pair.second]
    evidence["closest"] = closest
    if departures is not None:
        evidence["departures"] = {**departures, "points_at": points}
    return dataclasses.replace(dec, fault=None, switch=None, severity=None, value=None,
                               unit=None, pair=None, kind_residuals={}, evidence=evidence)
