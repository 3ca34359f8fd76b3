"""Decisions from one run's M: anomaly or not, which fault, how severe, how sure.

Two classifiers read the same dictionary:

* :func:`decide` (ours) reads the run's record cells through the healthy model
  (:mod:`~mapr_daemon.reasoner.diagnosis.healthy_model`): their deviation from what a healthy
  actuator does at
  the run's dynamic pressure, supply voltage and temperature, whitened, on the fault subspace
  ``y``. Every template's signature is fitted
  (:mod:`~mapr_daemon.reasoner.diagnosis.fault_models`). The
  anomaly score is the generalised likelihood ratio ``|y|^2 - min_{t,s} |y - y_t(s)|^2`` — how
  much of the deviation a fault explains — against a threshold set for a stated false-alarm
  rate (:mod:`~mapr_daemon.reasoner.diagnosis.false_alarm`). The best template gives the fault mode
  and
  the severity; the margin to the best template of *another* mode gives the isolation
  confidence. A second statistic catches runs no template fits well: the residual that the
  best healthy explanation leaves, against its own threshold at the same rate. A third, the
  *matched filter* (:mod:`~mapr_daemon.reasoner.diagnosis.matched_filter`), projects the
  standardized cells on
  the direction of the weakest fault (the inverter's phase-A high-side Ron, mostly its
  sector-resolved loop resistance) against a one-sided normal threshold: over the 32
  coordinates and every template, that fault's few-spread shift drowns in the likelihood
  ratio's threshold. The three share the stated rate. A record flown
  below the SMPS's supply headroom is *inconclusive*: no anomaly,
  confidence 0, the reason in the evidence.
* :func:`paper_decide` (the paper, III.D) reads only each fault kind's chosen curve cell of
  the 32 x 32 M: N there against a per-kind threshold from healthy runs; the kind with the
  largest ratio wins; the severity comes from the curve by the variable-stride descent.

Confidence: the detection part is ``sigmoid(log(score/threshold) / s)`` (``s`` the spread of
the log score on healthy runs), for "no anomaly" its complement; an anomaly's confidence is
multiplied by ``tanh(margin / (2 * spread))``, the isolation margin in units of the healthy
score spread.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import PARAMETRIC
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis import (
    compound,
    detection_map,
    fault_models,
    healthy_model,
    matched_filter,
    parts,
)
from mapr_daemon.reasoner.diagnosis.compound import PairFit
from mapr_daemon.reasoner.diagnosis.curves import variable_stride_descent
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, Template, pressure_weights
from mapr_daemon.reasoner.diagnosis.fault_models import Fit

PAPER_COLUMNS = 32
TOP_CELLS = 5
MATCHED_KIND = matched_filter.KIND

__all__ = ["MATCHED_KIND", "PAPER_COLUMNS", "Decision", "Fit", "Member", "decide",
           "explanation_statistics", "kind_severities", "kind_severity", "matched_score",
           "paper_decide", "score_of"]


@dataclasses.dataclass(frozen=True)
class Member:
    """One fault of a compound decision."""

    fault: str
    severity: float
    """Fraction of the fault's Table 1 range."""
    value: float
    """The faulted parameter's value, in ``unit``."""
    unit: str


@dataclasses.dataclass(frozen=True)
class Decision:
    """What the reasoner concludes about one run."""

    anomaly: bool
    fault: str | None
    switch: str | None
    severity: float | None
    """Fraction of the fault's Table 1 range (0 nominal, 1 range end); None for short/open."""
    value: float | None
    """Severity in the fault's physical unit (the faulted parameter's value)."""
    unit: str | None
    confidence: float
    score: float
    threshold: float
    evidence: dict[str, Any]
    kind_residuals: dict[str, float] = dataclasses.field(default_factory=dict)
    """Each fault mode's best template residual among the templates the decision weighed
    (all of them; only the matched filter's mode when it alone raised the alarm); empty for
    the paper's classifier and an inconclusive record. What :mod:`~.parts` turns into member
    probabilities."""
    pair: tuple[Member, Member] | None = None
    """Two faults in different parts (:mod:`~mapr_daemon.reasoner.diagnosis.compound`), the
    more severe (as a fraction of range) first (the reasoner's event puts the member nearer its
    replace-at threshold first); ``fault``, ``severity`` and ``value`` are then
    the first's. None for a single fault or none."""
    tolerance: float = 1.0
    """How much wider than the healthy noise a correct template's residual may be on this
    run (its model error grows with the departure, :func:`compound.tolerance`); what the
    member probabilities' scale is widened by."""

    @property
    def inconclusive(self) -> bool:
        """True when the record could not be judged (see ``evidence["inconclusive"]``)."""
        return "inconclusive" in self.evidence


def _sigmoid(x: float) -> float:
    return 1.0 / (1.0 + math.exp(-max(-50.0, min(50.0, x))))


def _models(d: Dictionary) -> tuple[healthy_model.HealthyModel, fault_models.FaultModels]:
    if d.healthy is None or d.models is None:
        raise ConfigError("the dictionary has no healthy model (rebuild it with "
                          "`mapr dictionary build`)", field="dictionary")
    return d.healthy, d.models


def _fits(d: Dictionary, m: FloatArray, q: float) -> tuple[healthy_model.Conditions, FloatArray,
                                                            list[Fit]]:
    """Conditions, coordinates and every template's fit; a parametric fit's severity is its
    inverse model's reading (the signature fit's point where there is none). The coordinates
    returned are in a commissioned unit's metric, when it has one (its own nuisance
    directions weighed down, :mod:`~mapr_daemon.reasoner.commissioning.calibrate`)."""
    hm, fm = _models(d)
    c = healthy_model.conditions(m, d.columns, q)
    y = hm.coordinates(m, c)
    metric = hm.unit_metric
    y_eff = y if metric is None else y @ metric
    fits = [f if (s := fault_models.severity(fm, f.template, y, c)) is None
            else dataclasses.replace(f, severity=s)
            for f in fault_models.fit_all(fm, y_eff, c, metric)]
    return c, y_eff, fits


def score_of(d: Dictionary, m: FloatArray, q: float) -> tuple[float, float]:
    """The two anomaly statistics of one run's M (what the thresholds are calibrated on): the
    likelihood ratio of the best fault, and the residual of the best healthy explanation."""
    _, y, fits = _fits(d, m, q)
    return fault_models.glr_score(y, fits), fault_models.null_residual(y, fits)


def _matched(d: Dictionary, z: FloatArray) -> float | None:
    """The matched filter's output for the run's standardized cells, in its healthy spreads
    (raw before calibration); None when the dictionary has no filter."""
    hm, _ = _models(d)
    if hm.matched is None:
        return None
    return matched_filter.statistic(hm.matched, z, d.calibration.get("matched_mean", 0.0),
                                    d.calibration.get("matched_sd", 1.0))


def matched_score(d: Dictionary, m: FloatArray, q: float) -> float | None:
    """The matched filter's output for one run's M (what its threshold is calibrated on)."""
    hm, _ = _models(d)
    return _matched(d, hm.standardized(m, healthy_model.conditions(m, d.columns, q)))


def explanation_statistics(d: Dictionary, m: FloatArray, q: float) -> tuple[float, float]:
    """What the build's fault calibration runs are measured on: the best pair's gain over the
    best single fault and what the best single fault leaves, both in tolerances
    (:mod:`~mapr_daemon.reasoner.diagnosis.compound`)."""
    hm, fm = _models(d)
    c, y, fits = _fits(d, m, q)
    null = fault_models.null_residual(y, fits)
    nt = d.calibration.get("null_threshold", math.inf)
    best = min(fits, key=lambda f: f.residual)
    if d.templates[best.template].switch:
        # decide holds only parametric explanations to these tests: not measured here either
        return math.nan, math.nan
    single = best.residual
    pairs = compound.fit_pairs(fm, d.templates, y, c, hm.unit_metric)
    pair = min((p.residual for p in pairs), default=single)
    return (compound.pair_gain(single, pair, null, nt),
            compound.unexplained_ratio(single, null, nt))


def _pair_severity(fm: fault_models.FaultModels, i: int, other: int, other_row: int,
                   y: FloatArray, c: healthy_model.Conditions) -> float | None:
    """A pair member's severity by its inverse model, read on the run's coordinates ``y``
    (the model's, not a unit's metric) less the other member's signature at the row of its
    curve the pair fit chose: the pair fit's own grid point is set by the few coordinates
    where the two signatures overlap, the inverse model weighs every coordinate by how well it
    predicts the member's severity. None where the template has no inverse model."""
    return fault_models.severity(fm, i, y - fm.curve(other, c)[other_row], c)


def _member(t: Template, severity: float) -> Member:
    value = float(np.interp(severity, [0.0, *t.severities], [_nominal(t), *t.values]))
    return Member(t.kind, severity, value, t.unit)


def _departures(d: Dictionary, hm: healthy_model.HealthyModel, z: FloatArray
                ) -> dict[str, Any]:
    """Where an unexplained run departs most: the signals (column names' signal part) and the
    BIT phases (from the first to the last record row a cell pools, in ms from the BIT's
    start; a whole-record value, stored on every row alike, is its own phase), by squared
    standardized departure, largest first."""
    ncol = len(d.columns)
    energy = z**2
    by_signal: dict[str, float] = {}
    by_phase: dict[tuple[int, int], float] = {}
    for e, cell in zip(energy, hm.cells, strict=True):
        name = d.columns[int(cell[0] % ncol)].split(":", 1)[-1]
        by_signal[name] = by_signal.get(name, 0.0) + float(e)
        rows = sorted({int(r) // ncol for r in cell})
        span = (-1, -1) if len(cell) > 1 and len(rows) == 1 else (rows[0], rows[-1])
        by_phase[span] = by_phase.get(span, 0.0) + float(e)
    total = max(float(energy.sum()), 1e-12)
    ms = 1000.0 / d.sample_rate_hz
    phases = []
    for (r0, r1), v in sorted(by_phase.items(), key=lambda kv: -kv[1])[:3]:
        if r0 < 0:
            phases.append({"whole_record": True, "share": round(v / total, 3)})
        else:
            phases.append({"from": round(float(d.window_starts[r0]) * ms, 1),
                           "to": round((float(d.window_starts[r1]) + d.window_samples) * ms,
                                       1),
                           "share": round(v / total, 3)})
    return {
        "signals": [{"signal": k, "share": round(v / total, 3)} for k, v in
                    sorted(by_signal.items(), key=lambda kv: -kv[1])[:3]],
        "phases_ms": phases,
    }


def decide(d: Dictionary, m: FloatArray, q: float) -> Decision:
    """Our decision for one run's M ``(W, C)`` flown at dynamic pressure ``q``."""
    hm, _ = _models(d)
    c, y, fits = _fits(d, m, q)
    if c.supply_min_v < hm.supply_floor_v:
        reason = (f"aircraft-bus voltage fell to {c.supply_min_v:.2f} V, below the "
                  f"{hm.supply_floor_v:.2f} V the SMPS needs to regulate at the BIT's peaks")
        return Decision(False, None, None, None, None, None, 0.0, 0.0, d.threshold,
                        {"inconclusive": reason})
    score = fault_models.glr_score(y, fits)
    null = fault_models.null_residual(y, fits)
    null_threshold = d.calibration.get("null_threshold", math.inf)
    z = hm.standardized(m, c)
    matched = _matched(d, z)
    matched_threshold = d.calibration.get("matched_threshold", math.inf)
    matched_alarm = matched is not None and matched > matched_threshold
    broad = score > d.threshold or null > null_threshold
    # an alarm raised by the matched test alone names the fault it is matched to
    named = [f for f in fits if d.templates[f.template].kind == MATCHED_KIND]
    matched_only = matched_alarm and not broad
    best = min(named if matched_only and named else fits, key=lambda f: f.residual)
    t = d.templates[best.template]
    other = [f.residual for f in fits if d.templates[f.template].kind != t.kind]
    margin = (min(other) - best.residual) if other else float("inf")
    p_anom = _sigmoid(math.log(max(score, 1e-9) / d.threshold) / d.log_score_spread)
    anomaly = broad or matched_alarm
    if null > null_threshold:  # nothing healthy explains the run, whatever the best fault
        p_anom = max(p_anom, 0.5 + 0.5 * (1.0 - null_threshold / null))
    if matched is not None and math.isfinite(matched_threshold):
        p_anom = max(p_anom, _sigmoid(matched - matched_threshold))
    cells = np.argsort(-np.abs(z))[:TOP_CELLS]
    ncol = len(d.columns)
    evidence: dict[str, Any] = {
        "template": t.name, "isolation_margin": round(margin, 3),
        "healthy_residual": round(null, 1), "healthy_residual_threshold": round(null_threshold, 1),
        "top_cells": [{"window": int(hm.cells[i, 0] // ncol) + 1,
                       "column": d.columns[int(hm.cells[i, 0] % ncol)],
                       "z": round(float(z[i]), 2)} for i in cells],
        "matched": None if matched is None else {
            "fault": MATCHED_KIND, "z": round(matched, 2),
            "threshold": round(matched_threshold, 2) if math.isfinite(matched_threshold)
            else None, "alarm": matched_alarm},
        "fits": {d.templates[f.template].name: round(f.residual, 1)
                 for f in sorted(fits, key=lambda f: f.residual)[:4]},
        "conditions": {"dynamic_pressure_pa": round(c.pressure_pa, 1),
                       "supply_v": round(c.supply_v, 2),
                       "temperature_c": round(c.temperature_c, 1)},
    }
    if d.detection is not None:
        blind = d.detection.blind(c.supply_v, c.temperature_c)
        if blind:
            evidence["not_observable_here"] = {
                "faults": blind,
                "rule": f"detected in under {detection_map.BLIND_BELOW:.0%} of the "
                        "dictionary's runs at this bus voltage and ambient temperature: no "
                        "anomaly says nothing about them"}
    kinds: dict[str, float] = {}
    for f in named if matched_only and named else fits:
        k = d.templates[f.template].kind
        kinds[k] = min(kinds.get(k, math.inf), f.residual)
    if not anomaly:
        return Decision(False, None, None, None, None, None, 1.0 - p_anom, score, d.threshold,
                        evidence, kinds)
    if (score <= 0.0 and broad) or (matched_only and not named):
        # nothing healthy explains it, and no fault explains it better (or the dictionary
        # lacks the fault the matched test is made for)
        evidence["unexplained"] = ("anomaly, not explained by any known fault mode: no "
                                   "dictionary fault explains this record better than health")
        evidence["departures"] = _departures(d, hm, z)
        return Decision(True, None, None, None, None, None, p_anom, score, d.threshold,
                        evidence, kinds)
    conf = p_anom * math.tanh(max(margin, 0.0) / (2.0 * d.score_spread))
    nt = null_threshold
    tol = compound.tolerance(null, nt) / nt if math.isfinite(nt) and nt > 0 else 1.0
    pair: PairFit | None = None
    explained = best.residual
    pair_threshold = d.calibration.get("pair_threshold", math.inf)
    if not matched_only and not t.switch and math.isfinite(pair_threshold):
        _, fm = _models(d)
        fitted = compound.fit_pairs(fm, d.templates, y, c, hm.unit_metric)
        if fitted:
            bp = min(fitted, key=lambda p: p.residual)
            gain = compound.pair_gain(best.residual, bp.residual, null, nt)
            evidence["pair"] = {
                "templates": [d.templates[bp.first].name, d.templates[bp.second].name],
                "gain": round(gain, 3), "threshold": round(pair_threshold, 3)}
            if gain > pair_threshold:
                pair, explained = bp, bp.residual
    unexplained_threshold = d.calibration.get("unexplained_threshold", math.inf)
    # the threshold is what parametric faults leave (the build's fault calibration runs); a
    # short or an open is a gross change its one-point template meets only roughly, and has no
    # such measure: it is not held to it
    if not matched_only and not t.switch and math.isfinite(unexplained_threshold):
        ratio = compound.unexplained_ratio(explained, null, nt)
        evidence["explanation"] = {"left": round(ratio, 3),
                                   "threshold": round(unexplained_threshold, 3)}
        if ratio > unexplained_threshold:
            evidence["unexplained"] = ("anomaly, not explained by any known fault mode: the "
                                       f"best explanation leaves {ratio:.1f} tolerances, a "
                                       f"correct one at most {unexplained_threshold:.1f}")
            evidence["departures"] = _departures(d, hm, z)
            evidence["closest"] = {"fault": t.kind, "part": parts.PART_OF.get(t.kind),
                                   "note": "the nearest template, not a fit"}
            return Decision(True, None, None, None, None, None, p_anom, score, d.threshold,
                            evidence, kinds, tolerance=tol)
    if t.switch:
        return Decision(True, t.kind, t.switch, None, None, None, conf, score, d.threshold,
                        evidence, kinds, tolerance=tol)
    if pair is not None:
        raw = hm.coordinates(m, c)
        _, fm = _models(d)
        sa = _pair_severity(fm, pair.first, pair.second, pair.row_second, raw, c)
        sb = _pair_severity(fm, pair.second, pair.first, pair.row_first, raw, c)
        a = _member(d.templates[pair.first], pair.severity_first if sa is None else sa)
        b = _member(d.templates[pair.second], pair.severity_second if sb is None else sb)
        first, second = (a, b) if a.severity >= b.severity else (b, a)
        return Decision(True, first.fault, None, first.severity, first.value, first.unit,
                        p_anom, score, d.threshold, evidence, kinds, (first, second), tol)
    value = float(np.interp(best.severity, [0.0, *t.severities], [_nominal(t), *t.values]))
    return Decision(True, t.kind, None, best.severity, value, t.unit, conf, score, d.threshold,
                    evidence, kinds, tolerance=tol)


def _nominal(t: Template) -> float:
    """The healthy value of a parametric template (extrapolated from its first two points)."""
    s0, s1 = t.severities[0], t.severities[1]
    v0, v1 = t.values[0], t.values[1]
    return float(v0 - s0 * (v1 - v0) / (s1 - s0))


def kind_severity(d: Dictionary, m: FloatArray, q: float, kind: str) -> float:
    """The best severity of one parametric kind, whatever the anomaly decision (for trends)."""
    return kind_severities(d, m, q)[kind]


def kind_severities(d: Dictionary, m: FloatArray, q: float) -> dict[str, float]:
    """Every parametric kind's best severity on one run (one fit for all of them)."""
    _, _, fits = _fits(d, m, q)
    out: dict[str, float] = {}
    for kind in {t.kind for t in d.templates if not t.switch}:
        idx = [i for i, t in enumerate(d.templates) if t.kind == kind and not t.switch]
        out[kind] = min((fits[i] for i in idx), key=lambda f: f.residual).severity
    return out


def paper_decide(d: Dictionary, m: FloatArray, q: float) -> Decision:
    """The paper's classifier: each kind's chosen-curve cell of the 32 x 32 M."""
    w = pressure_weights(d.pressures_pa, q)
    nom = np.tensordot(w, d.nominal_mean, axes=1)
    ratios: dict[str, float] = {}
    values: dict[str, float] = {}
    for kind, c in d.paper.items():
        n = abs(float(m[c.row, c.col] - nom[c.row, c.col]))
        values[kind] = n
        ratios[kind] = n / c.threshold
    kind = max(ratios, key=lambda k: ratios[k])
    score = ratios[kind]
    evidence: dict[str, Any] = {"curves": {k: {"reference": d.paper[k].reference,
                                               "N": round(values[k], 6),
                                               "ratio": round(ratios[k], 3)} for k in ratios}}
    if score <= 1.0:
        # a cell can sit exactly on its nominal (a quantised value that never moved): N = 0
        confidence = 1.0 - _sigmoid(math.log(max(score, 1e-12)))
        return Decision(False, None, None, None, None, None, confidence, score, 1.0, evidence)
    c = d.paper[kind]
    t = next(t for t in d.templates if t.kind == kind and not t.switch)
    sev = np.array([0.0, *t.severities])
    curve = np.tensordot(w, c.curve, axes=1)
    target = values[kind]

    def objective(x: FloatArray) -> float:
        return float((np.interp(x[0], sev, curve) - target) ** 2)

    start = np.array([sev[int(np.argmin(np.abs(curve - target)))]])
    res = variable_stride_descent(objective, start, 0.125, 1e-3, np.array([0.0]),
                                  np.array([1.0]))
    s = float(res.x[0])
    value = float(np.interp(s, sev, [_nominal(t), *t.values]))
    return Decision(True, kind, None, s, value, PARAMETRIC[kind].unit,
                    _sigmoid(math.log(score)), score, 1.0, evidence)
