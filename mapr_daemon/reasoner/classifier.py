"""Decisions from one run's M: anomaly or not, which fault, how severe, how sure.

Two classifiers read the same dictionary:

* :func:`decide` (ours) scales the deviation from the nominal M (interpolated to the run's
  dynamic pressure) by the healthy spread, ``z = (M - M_nom(q)) / sd`` over all 32 x 72 cells,
  and fits every template's signature curve ``d_t(s)`` (piecewise linear in severity, exact
  projection per segment). The anomaly score is the generalised likelihood ratio
  ``|z|^2 - min_{t,s} |z - d_t(s)|^2`` — how much of the deviation a fault explains — compared
  with a threshold calibrated on healthy runs across pressures. The best template gives the
  fault mode and the severity; the margin to the best template of *another* mode gives the
  isolation confidence.
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

from mapr_daemon.ema.faults import PARAMETRIC
from mapr_daemon.reasoner.curves import variable_stride_descent
from mapr_daemon.reasoner.dictionary import Dictionary, pressure_weights
from mapr_daemon.reasoner.features import FloatArray

PAPER_COLUMNS = 32
COMPRESS = 3.0
"""Where :func:`compress` turns from linear to logarithmic, in healthy spreads."""


@dataclasses.dataclass(frozen=True)
class Fit:
    """The best severity of one template and its residual ``|z - d(s)|^2``."""

    template: int
    severity: float
    residual: float


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


def _sigmoid(x: float) -> float:
    return 1.0 / (1.0 + math.exp(-max(-50.0, min(50.0, x))))


def zscores(d: Dictionary, m: FloatArray, q: float) -> FloatArray:
    """The run's M as deviations from the nominal M at its pressure, in healthy spreads."""
    w = pressure_weights(d.pressures_pa, q)
    nom = np.tensordot(w, d.nominal_mean, axes=1)
    return compress(((m - nom) / d.nominal_sd).ravel())


def compress(z: FloatArray) -> FloatArray:
    """``c*sign(z)*log1p(|z|/c)``: linear within the noise, logarithmic far outside it, so a
    few cells a fault moves by thousands of spreads do not drown the pattern of the rest."""
    out: FloatArray = COMPRESS * np.sign(z) * np.log1p(np.abs(z) / COMPRESS)
    return out


def signatures(d: Dictionary, q: float) -> list[FloatArray]:
    """Per template, its signatures ``(S+1, W*C)`` in z units, severity 0 (zero) first."""
    w = pressure_weights(d.pressures_pa, q)
    nom = np.tensordot(w, d.nominal_mean, axes=1)
    out = []
    for m in d.template_m:
        sig = compress((np.tensordot(w, m, axes=1) - nom) / d.nominal_sd)  # (S, W, C)
        flat = sig.reshape(sig.shape[0], -1)
        out.append(np.vstack([np.zeros((1, flat.shape[1])), flat]))
    return out


def fit_templates(d: Dictionary, z: FloatArray, sigs: list[FloatArray]) -> list[Fit]:
    """Every template's best severity along its piecewise-linear signature curve."""
    fits = []
    for i, (t, sig) in enumerate(zip(d.templates, sigs, strict=True)):
        sev = np.array([0.0, *t.severities])
        a, delta = sig[:-1], np.diff(sig, axis=0)  # segment starts and directions
        dd = np.einsum("ij,ij->i", delta, delta)
        frac = np.clip(((z - a) * delta).sum(axis=1) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
        pts = a + frac[:, None] * delta
        res = ((z - pts) ** 2).sum(axis=1)
        if t.switch:  # on/off: only the faulted end counts, not the way there
            fits.append(Fit(i, 1.0, float(((z - sig[-1]) ** 2).sum())))
            continue
        k = int(np.argmin(res))
        fits.append(Fit(i, float(sev[k] + frac[k] * (sev[k + 1] - sev[k])), float(res[k])))
    return fits


def glr_score(z: FloatArray, fits: list[Fit]) -> float:
    """How much of ``|z|^2`` the best template explains."""
    return float(z @ z - min(f.residual for f in fits))


def decide(d: Dictionary, m: FloatArray, q: float) -> Decision:
    """Our decision for one run's M ``(W, C)`` flown at dynamic pressure ``q``."""
    z = zscores(d, m, q)
    fits = fit_templates(d, z, signatures(d, q))
    score = glr_score(z, fits)
    best = min(fits, key=lambda f: f.residual)
    t = d.templates[best.template]
    other = [f.residual for f in fits if d.templates[f.template].kind != t.kind]
    margin = (min(other) - best.residual) if other else float("inf")
    p_anom = _sigmoid(math.log(max(score, 1e-9) / d.threshold) / d.log_score_spread)
    anomaly = score > d.threshold
    cells = np.argsort(-np.abs(z))[:5]
    evidence: dict[str, Any] = {
        "template": t.name, "isolation_margin": round(margin, 3),
        "top_cells": [{"window": int(c // len(d.columns)) + 1,
                       "column": d.columns[int(c % len(d.columns))],
                       "z": round(float(z[c]), 2)} for c in cells],
        "fits": {d.templates[f.template].name: round(f.residual, 1)
                 for f in sorted(fits, key=lambda f: f.residual)[:4]},
    }
    if not anomaly:
        return Decision(False, None, None, None, None, None, 1.0 - p_anom, score, d.threshold,
                        evidence)
    conf = p_anom * math.tanh(margin / (2.0 * d.score_spread))
    if t.switch:
        return Decision(True, t.kind, t.switch, None, None, None, conf, score, d.threshold,
                        evidence)
    value = float(np.interp(best.severity, [0.0, *t.severities], [_nominal(t), *t.values]))
    return Decision(True, t.kind, None, best.severity, value, t.unit, conf, score, d.threshold,
                    evidence)


def _nominal(t: Any) -> float:
    """The healthy value of a parametric template (extrapolated from its first two points)."""
    s0, s1 = t.severities[0], t.severities[1]
    v0, v1 = t.values[0], t.values[1]
    return float(v0 - s0 * (v1 - v0) / (s1 - s0))


def kind_severity(d: Dictionary, m: FloatArray, q: float, kind: str) -> float:
    """The best severity of one parametric kind, whatever the anomaly decision (for trends)."""
    z = zscores(d, m, q)
    sigs = signatures(d, q)
    idx = [i for i, t in enumerate(d.templates) if t.kind == kind and not t.switch]
    fits = fit_templates(d, z, sigs)
    return min((fits[i] for i in idx), key=lambda f: f.residual).severity


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
        return Decision(False, None, None, None, None, None, 1.0 - _sigmoid(math.log(score)),
                        score, 1.0, evidence)
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
