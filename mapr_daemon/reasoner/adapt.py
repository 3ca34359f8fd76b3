"""Commissioning's calibration step: the healthy model and thresholds made the unit's own.

A dictionary is built from a model of the actuator (the data sheet, or the model identified
from the unit's BITs, :mod:`~mapr_daemon.reasoner.identify`). A real unit still differs from
any model in ways a data sheet does not carry — its friction law, its controller's sampling,
loads nobody listed, a Hall sensor mounted a few degrees off — and each such difference moves
some of the healthy model's cells by a fixed amount, BIT after BIT. Left alone, every healthy
BIT of that unit alarms. The paper's answer is model adaptation; this module is that step for
the healthy model, from the unit's own healthy BITs:

* **offset**: per cell, the unit's mean departure from the prediction, linear in the air load
  and with a step for BITs on the ground (:func:`~mapr_daemon.reasoner.healthy.offset_basis`),
  fitted by ridge regression on the unit's standardized residuals;
* **spread**: per cell, the unit's scatter about its offset over the model's (a cell the unit
  holds differently from BIT to BIT, e.g. which side of the bridge holds the surface where
  friction decides it, gets its spread widened instead of alarming), pooled with a prior of
  :data:`PRIOR_DOF` BITs at the model's own spread, never narrower than the model's;
* **thresholds**: each BIT is scored by a calibration fitted without it (leave one out); where
  the unit's healthy scores run higher than the fleet's calibration runs at the same quantile,
  the threshold is raised by the same ratio (the tail keeps the calibration's shape, scaled to
  the unit): ``threshold' = max(threshold, threshold * q_unit / q_cal)``, ``q_unit`` the unit's
  largest leave-one-out score, ``q_cal`` the calibration runs' score at the same rank.

The faults' signatures stay the model's: a fault moves the cells of this unit as it moves the
model's (the dictionary built on the identified model is what makes that hold).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner import classifier, healthy
from mapr_daemon.reasoner.dictionary import Dictionary
from mapr_daemon.reasoner.features import FloatArray

MIN_BITS = 3
"""Fewest healthy BITs a unit calibration accepts."""
PRIOR_DOF = 5.0
"""Weight, in BITs, of the model's own spread in a cell's unit spread."""
OFFSET_RIDGE = 0.5
"""Ridge penalty (in BITs) on the offset's slope and ground step (not on its mean)."""
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


def _fit(z: FloatArray, conds: Sequence[healthy.Conditions]) -> tuple[FloatArray, FloatArray]:
    """Offset coefficients ``(U, D)`` in healthy spreads and the spread factor ``(D,)``."""
    a = np.stack([healthy.offset_basis(c) for c in conds])
    n, u = a.shape
    pen = OFFSET_RIDGE * np.eye(u)
    pen[0, 0] = 0.0
    coef = np.asarray(np.linalg.solve(a.T @ a + pen, a.T @ z), dtype=np.float64)
    resid = z - a @ coef
    dof = max(n - u, 1)
    var = ((resid**2).sum(axis=0) + PRIOR_DOF) / (dof + PRIOR_DOF)
    return coef, np.sqrt(np.maximum(var, 1.0))


def _with_unit(d: Dictionary, coef: FloatArray, factor: FloatArray) -> Dictionary:
    """A copy of ``d`` whose healthy model carries the unit's offset and spread."""
    hm = d.healthy
    assert hm is not None
    out = copy.copy(d)
    out.calibration = dict(d.calibration)
    out.healthy = dataclasses.replace(hm, unit_coef=coef, unit_factor=factor)
    return out


def _scores(d: Dictionary, m: FloatArray, q: float) -> dict[str, float]:
    glr, null = classifier.score_of(d, m, q)
    matched = classifier.matched_score(d, m, q)
    out = {"score": glr, "null": null}
    if matched is not None:
        out["matched"] = matched
    return out


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
    conds = [healthy.conditions(m[i], d.columns, float(q[i])) for i in range(n)]
    z = np.stack([hm.standardized(m[i], conds[i]) for i in range(n)])
    loo: dict[str, list[float]] = {}
    for i in range(n):
        keep = np.arange(n) != i
        coef, factor = _fit(z[keep], [conds[k] for k in np.flatnonzero(keep)])
        for name, value in _scores(_with_unit(d, coef, factor), m[i], float(q[i])).items():
            loo.setdefault(name, []).append(value)
    coef, factor = _fit(z, conds)
    out = _with_unit(d, coef, factor)
    thresholds: dict[str, tuple[float, float]] = {}
    rank = 1.0 - 1.0 / (n + 1)  # the expected quantile of the largest of n scores
    for key, name in STATISTICS:
        old = d.threshold if key == "threshold" else d.calibration.get(key)
        q_cal = stored_quantiles(d.calibration, name)
        if old is None or not math.isfinite(old) or name not in loo:
            continue
        new = old
        if q_cal is not None:
            ref = float(np.interp(rank, CALIBRATION_QUANTILES, q_cal))
            worst = max(loo[name])
            if ref > 0 and worst > ref:
                new = old * worst / ref
        thresholds[name] = (float(old), float(new))
        if key == "threshold":
            out.threshold = float(new)
        else:
            out.calibration[key] = float(new)
    offsets = coef[0]
    ncol = len(d.columns)
    top = np.argsort(-np.abs(offsets))[:5]
    report = UnitCalibration(
        bits=n, offset_rms=float(np.sqrt(np.mean(offsets**2))),
        largest_offsets=[(d.columns[int(hm.cells[k, 0] % ncol)], round(float(offsets[k]), 2))
                         for k in top],
        widened_cells=int((factor > 2.0).sum()), thresholds=thresholds,
        loo_scores={k: [round(float(v), 3) for v in vals] for k, vals in loo.items()})
    out.calibration["unit_bits"] = float(n)
    return out, report


CALIBRATION_QUANTILES = (0.5, 0.75, 0.9, 0.95, 0.975, 0.99)
"""Quantiles of the calibration runs' scores a dictionary keeps for unit calibrations."""


def quantile_entries(name: str, scores: FloatArray) -> dict[str, float]:
    """Calibration entries holding the calibration runs' ``name`` scores at
    :data:`CALIBRATION_QUANTILES` (what :func:`calibrate_unit` compares a unit's with)."""
    values = np.quantile(scores, CALIBRATION_QUANTILES)
    return {f"{name}_quantile_{k}": float(v) for k, v in enumerate(values)}


def stored_quantiles(calibration: dict[str, float], name: str) -> FloatArray | None:
    """The quantiles :func:`quantile_entries` stored, or None (a dictionary built before)."""
    keys = [f"{name}_quantile_{k}" for k in range(len(CALIBRATION_QUANTILES))]
    if not all(k in calibration for k in keys):
        return None
    return np.array([calibration[k] for k in keys])
