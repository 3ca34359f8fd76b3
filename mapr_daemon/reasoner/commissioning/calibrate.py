"""Commissioning's calibration step: the healthy model and thresholds made the unit's own.

A dictionary is built from a model of the actuator (the data sheet, or the model identified
from the unit's BITs, :mod:`~mapr_daemon.reasoner.commissioning.identify`). A real unit still
differs from
any model in ways a data sheet does not carry — its friction law, its controller's sampling,
loads nobody listed, a Hall sensor mounted a few degrees off — and each such difference moves
some of the healthy model's cells by a fixed amount, BIT after BIT. Left alone, every healthy
BIT of that unit alarms. The paper's answer is model adaptation; this module is that step for
the healthy model, from the unit's own healthy BITs:

* **offset**: per cell, the unit's departure from the prediction: a mean, slopes in air load,
  temperature and supply and a step for BITs on the ground
  (:func:`~mapr_daemon.reasoner.diagnosis.healthy_model.offset_basis`), plus a gain on the model's
  own
  predicted departure (a unit whose motor constant is 8 % off moves its load currents 8 % more
  or less), fitted by ridge regression on the unit's standardized residuals;
* **spread**: per cell, the unit's scatter about its offset over the model's, from the fit's
  leave-one-out residuals (a cell the unit holds differently from BIT to BIT, e.g. which side
  of the bridge holds the surface where friction decides it, gets its spread widened instead of
  alarming), pooled with a prior of :data:`PRIOR_DOF` BITs at the model's own spread, never
  narrower than the model's;
* **metric**: in the fault subspace, the directions in which the unit's healthy BITs still vary
  more than the model's (a housekeeping load that wanders from flight to flight moves every
  DC-link cell together) are scaled down to the model's variance, for the run and the
  templates alike;
* **thresholds**: each BIT is scored by a calibration fitted without it (leave one out); where
  the unit's healthy scores run higher than the fleet's calibration runs at the same quantile
  (its median, upper quartile and 90th percentile: not its largest, which one odd BIT would
  set), the likelihood-ratio and healthy-residual thresholds are raised by the largest of
  those ratios (the tail keeps the calibration's shape, scaled to the unit); the matched
  filter's output is close to normal, so its threshold is re-centred on the unit's
  leave-one-out mean and scaled by their spread (never lowered).

The faults' signatures stay the model's: a fault moves the cells of this unit as it moves the
model's (the dictionary built on the identified model is what makes that hold).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis import classifier, healthy_model
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.diagnosis.false_alarm import CALIBRATION_QUANTILES, stored_quantiles

MIN_BITS = 3
"""Fewest healthy BITs a unit calibration accepts."""
PRIOR_DOF = 5.0
"""Weight, in BITs, of the model's own spread in a cell's unit spread."""
OFFSET_RIDGE = 0.5
"""Ridge penalty (in BITs) on every offset regressor but the mean."""
STATISTICS = (("threshold", "score"), ("null_threshold", "null"),
              ("matched_threshold", "matched"))
"""Each threshold of the dictionary and the calibration quantiles stored for it."""


@dataclasses.dataclass(frozen=True)
class UnitCalibration:
    """What a unit calibration did, for the commissioning record."""

    bits: int
    offset_rms: float
    """RMS over cells of the unit's mean offset, in the model's healthy spreads."""
    largest_offsets: list[tuple[str, float]]
    """The cells the unit departs from most (column name, offset in spreads)."""
    widened_cells: int
    """Cells whose spread the unit widened by more than 2x."""
    thresholds: dict[str, tuple[float, float]]
    """Per statistic: (the dictionary's threshold, the unit's)."""
    loo_scores: dict[str, list[float]]
    """Per statistic: each healthy BIT's score with the calibration fitted without it."""

    def as_dict(self) -> dict[str, object]:
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class _UnitFit:
    coef: FloatArray
    gain: FloatArray
    factor: FloatArray
    reference: FloatArray
    metric: FloatArray


def _fit(hm: healthy_model.HealthyModel, z: FloatArray,
         conds: Sequence[healthy_model.Conditions]) -> _UnitFit:
    """Per cell, ridge regression of the unit's standardized residuals ``z (n, D)`` on the
    shared offset regressors and the cell's own predicted departure; then its spread factor."""
    a = np.stack([healthy_model.offset_basis(c, hm.supply_nominal_v) for c in conds])
    reference = np.mean([hm.predicted(c) for c in conds], axis=0)
    r = np.stack([(hm.predicted(c) - reference) / hm.spread(c) for c in conds])  # (n, D)
    n, u = a.shape
    x = np.concatenate([np.broadcast_to(a[None], (r.shape[1], n, u)), r.T[:, :, None]],
                       axis=2)  # (D, n, U + 1)
    pen = OFFSET_RIDGE * np.eye(u + 1)
    pen[0, 0] = 0.0
    gram = np.einsum("dnk,dnl->dkl", x, x) + pen
    rhs = np.einsum("dnk,nd->dk", x, z)
    sol = np.linalg.solve(gram, rhs[:, :, None])[:, :, 0]  # (D, U + 1)
    # leave-one-out residuals (exact for a linear smoother: e_i / (1 - h_ii)): what the unit's
    # next BIT will show, not what the fit leaves on the BITs it was fitted to
    lever = np.einsum("dnk,dkl,dnl->dn", x, np.linalg.inv(gram), x).T  # (n, D)
    resid = (z - np.einsum("dnk,dk->nd", x, sol)) / np.maximum(1.0 - lever, 0.05)
    var = ((resid**2).sum(axis=0) + PRIOR_DOF) / (n + PRIOR_DOF)
    factor = np.sqrt(np.maximum(var, 1.0))
    return _UnitFit(np.ascontiguousarray(sol[:, :u].T), np.ascontiguousarray(sol[:, u]),
                    factor, reference, _metric((resid / factor) @ hm.projection, n))


def _metric(y: FloatArray, dof: int) -> FloatArray:
    """``(K, K)``: the unit's residual coordinates ``y (n, K)`` have covariance ``C`` (pooled
    with :data:`PRIOR_DOF` BITs of the identity); its directions with variance above 1 are
    scaled down to 1, the others left as they are (a unit is never made more sensitive than
    the model)."""
    k = y.shape[1]
    cov = (y.T @ y + PRIOR_DOF * np.eye(k)) / (dof + PRIOR_DOF)
    ev, vec = np.linalg.eigh(cov)
    out: FloatArray = (vec / np.sqrt(np.maximum(ev, 1.0))) @ vec.T
    return out


def _with_unit(d: Dictionary, fit: _UnitFit) -> Dictionary:
    """A copy of ``d`` whose healthy model carries the unit's offset, gain and spread."""
    hm = d.healthy
    assert hm is not None
    out = copy.copy(d)
    out.calibration = dict(d.calibration)
    out.healthy = dataclasses.replace(hm, unit_coef=fit.coef, unit_factor=fit.factor,
                                      unit_gain=fit.gain, unit_reference=fit.reference,
                                      unit_metric=fit.metric)
    return out


def _scores(d: Dictionary, m: FloatArray, q: float) -> dict[str, float]:
    glr, null = classifier.score_of(d, m, q)
    matched = classifier.matched_score(d, m, q)
    out = {"score": glr, "null": null}
    if matched is not None:
        out["matched"] = matched
    return out


def without_each(d: Dictionary, m: FloatArray, q: FloatArray) -> list[Dictionary] | None:
    """``d`` calibrated to the unit without each of its BITs in turn (``m``, ``q`` as
    :func:`calibrate_unit` takes them): what is measured on BIT ``i`` with dictionary ``i`` is
    measured on a BIT that calibration never saw, as every BIT flown after commissioning is.
    None when leaving one out leaves fewer than :data:`MIN_BITS` (about 0.3 s of CPU each)."""
    n = m.shape[0]
    if n - 1 < MIN_BITS:
        return None
    return [calibrate_unit(d, m[np.arange(n) != i], q[np.arange(n) != i])[0] for i in range(n)]


def calibrate_unit(d: Dictionary, m: FloatArray, q: FloatArray) -> tuple[Dictionary,
                                                                          UnitCalibration]:
    """The dictionary made the unit's own from its healthy BITs' matrices ``m (n, W, C)`` flown
    at dynamic pressures ``q``; raises :class:`ConfigError` with fewer than :data:`MIN_BITS`."""
    hm = d.healthy
    if hm is None:
        raise ConfigError("the dictionary has no healthy model (rebuild it)", field="dictionary")
    if hm.unit_coef is not None:
        raise ConfigError("the dictionary is already calibrated to a unit", field="dictionary")
    n = m.shape[0]
    if n < MIN_BITS:
        raise ConfigError(f"{n} healthy BITs: a unit calibration needs at least {MIN_BITS}",
                          field="bits")
    conds = [healthy_model.conditions(m[i], d.columns, float(q[i])) for i in range(n)]
    z = np.stack([hm.standardized(m[i], conds[i]) for i in range(n)])
    loo: dict[str, list[float]] = {}
    for i in range(n):
        keep = np.arange(n) != i
        part = _fit(hm, z[keep], [conds[k] for k in np.flatnonzero(keep)])
        for name, value in _scores(_with_unit(d, part), m[i], float(q[i])).items():
            loo.setdefault(name, []).append(value)
    fit = _fit(hm, z, conds)
    out = _with_unit(d, fit)
    thresholds: dict[str, tuple[float, float]] = {}
    for key, name in STATISTICS:
        old = d.threshold if key == "threshold" else d.calibration.get(key)
        q_cal = stored_quantiles(d.calibration, name)
        if old is None or not math.isfinite(old) or name not in loo:
            continue
        new = old
        if name == "matched":
            new = max(old, _normal_threshold(np.asarray(loo[name]), old))
        elif q_cal is not None:
            ratio = max(_ratio(np.asarray(loo[name]), q_cal, r) for r in MATCHED_RANKS)
            new = old * max(ratio, 1.0)
        thresholds[name] = (float(old), float(new))
        if key == "threshold":
            out.threshold = float(new)
        else:
            out.calibration[key] = float(new)
    offsets = fit.coef[0]
    ncol = len(d.columns)
    top = np.argsort(-np.abs(offsets))[:5]
    report = UnitCalibration(
        bits=n, offset_rms=float(np.sqrt(np.mean(offsets**2))),
        largest_offsets=[(d.columns[int(hm.cells[k, 0] % ncol)], round(float(offsets[k]), 2))
                         for k in top],
        widened_cells=int((fit.factor > 2.0).sum()), thresholds=thresholds,
        loo_scores={k: [round(float(v), 3) for v in vals] for k, vals in loo.items()})
    out.calibration["unit_bits"] = float(n)
    return out, report





MATCHED_RANKS = (0.5, 0.75, 0.9)
"""Quantiles at which a unit's leave-one-out scores are held against the calibration runs'
(not its largest: one odd BIT of twenty would set the unit's threshold)."""


def _ratio(unit: FloatArray, calibration: FloatArray, rank: float) -> float:
    """The unit's score over the calibration runs' at quantile ``rank`` (for the likelihood
    ratio and the healthy residual, both never negative; the matched filter's near-normal
    output is re-centred instead, :func:`_normal_threshold`)."""
    ref = float(np.interp(rank, CALIBRATION_QUANTILES, calibration))
    own = float(np.quantile(unit, rank))
    return own / ref if ref > 1e-9 else 1.0


def _normal_threshold(unit: FloatArray, threshold: float) -> float:
    """The matched filter's threshold for the unit: its output is close to normal (mean 0, sd
    1 on the calibration runs; the threshold is ``threshold`` sd), so the unit's is re-centred
    on its leave-one-out mean and scaled by their sd (pooled with :data:`PRIOR_DOF` BITs of
    the calibration's 1)."""
    n = unit.size
    var = (float(np.var(unit, ddof=1)) * (n - 1) + PRIOR_DOF) / (n - 1 + PRIOR_DOF)
    return float(unit.mean()) + threshold * math.sqrt(var)
