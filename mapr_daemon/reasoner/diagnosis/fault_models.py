"""Fault signatures in the healthy model's whitened fault subspace, and the fit of a run to them.

A parametric fault kind's signature ``y_k(s; q, V)`` (``s`` the severity as a fraction of its
Table 1 range) is a smooth least-squares model over all of the dictionary's runs of that kind:
piecewise linear in ``s`` (hat functions on a few knots, zero at ``s = 0``), each hat's
coefficient quadratic in dynamic pressure. Fitting many runs with few coefficients averages
their noise away, which one run per grid point could not.

A gross fault can change the actuator's regime (a heavy friction at a high air load runs into
the current limit), which a smooth model cannot follow; so each parametric kind also keeps its
runs' coordinates on the dictionary grid (mean per pressure and severity), interpolated
linearly in pressure and severity, and a run is fitted to whichever of the two curves is
closer. A switch fault (short or open, one per switch) is one point per dictionary pressure
(the mean of its runs), interpolated in pressure.

:func:`fit_all` gives each template's best severity and residual ``|y - y_k(s)|^2``; the
anomaly score is the generalised likelihood ratio ``|y|^2 - min residual`` (after
:func:`compress`, and against the best healthy explanation, see :func:`glr_score`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.reasoner.diagnosis.healthy_model import (
    PRESSURE_SCALE_PA,
    Conditions,
    condition_terms,
    pressure_weights,
)

SEVERITY_GRID = np.linspace(0.0, 1.0, 257)
"""Severities tried per parametric kind (1/256 of the range apart)."""
COMPRESS = 10.0
"""Where :func:`compress` turns from linear to logarithmic, in whitened units (a healthy
coordinate stays within about 4)."""


def compress(y: FloatArray) -> FloatArray:
    """``c*sign(y)*log1p(|y|/c)``: linear near the noise, logarithmic far outside it, so a gross
    fault is matched on the pattern of its coordinates' magnitudes rather than on the few
    largest, and a template's modelling error there does not decide the fit."""
    out: FloatArray = COMPRESS * np.sign(y) * np.log1p(np.abs(y) / COMPRESS)
    return out


@dataclasses.dataclass(frozen=True)
class Fit:
    """The best severity of one template beyond its healthy band, its residual
    ``|y - y_t(s)|^2`` there, and the best residual inside the band (the null hypothesis)."""

    template: int
    severity: float
    residual: float
    null_residual: float


def hat_basis(s: FloatArray, knots: FloatArray, c: Conditions,
              supply_nominal_v: float) -> FloatArray:
    """Regressors ``(len(s), 3 * (len(knots) - 1))`` of a parametric signature."""
    eye = np.eye(knots.size)
    hats = np.stack([np.interp(s, knots, eye[j]) for j in range(1, knots.size)], axis=1)
    q = c.pressure_pa / PRESSURE_SCALE_PA
    return np.concatenate([hats, hats * q, hats * q * q], axis=1)


@dataclasses.dataclass
class FaultModels:
    """Per template: a parametric model's coefficients, or a switch fault's points."""

    knots: FloatArray
    coef: list[FloatArray | None]
    """Per template ``(3 * (knots - 1), K)`` for parametric kinds, None for switch faults."""
    points: list[FloatArray | None]
    """Per template ``(n_pressures, K)`` for switch faults, None for parametric kinds."""
    pressures_pa: FloatArray
    supply_nominal_v: float
    bands: list[float] = dataclasses.field(default_factory=list)
    grid: list[FloatArray | None] = dataclasses.field(default_factory=list)
    """Per parametric template, its runs' mean coordinates ``(n_pressures, S, K)`` on the
    dictionary grid (severities :attr:`grid_severities`)."""
    grid_severities: FloatArray = dataclasses.field(
        default_factory=lambda: np.zeros(0, dtype=np.float64))
    severity_coef: list[FloatArray | None] = dataclasses.field(default_factory=list)
    output_v: float = 0.0
    """The SMPS's regulated output (the severity model's off-time share)."""
    """Per parametric template, ridge coefficients of its severity on ``[1, q, compress(y)]``
    (the inverse model: the severity read straight off the run, see :func:`severity`)."""
    """Per template, the severity up to which a healthy actuator may scatter with nothing
    measured to predict it (friction's flight-to-flight scatter); 0 elsewhere."""

    def band(self, i: int) -> float:
        return self.bands[i] if i < len(self.bands) else 0.0

    def curve(self, i: int, c: Conditions) -> FloatArray:
        """Template ``i``'s signature at the run's conditions: ``(len(SEVERITY_GRID), K)`` for a
        parametric kind (twice that with its grid curve after the smooth one), ``(1, K)`` for a
        switch fault."""
        coef = self.coef[i]
        w = pressure_weights(self.pressures_pa, c.pressure_pa)
        if coef is not None:
            out: FloatArray = hat_basis(SEVERITY_GRID, self.knots, c, self.supply_nominal_v) @ coef
            grid = self.grid[i] if i < len(self.grid) else None
            if grid is None:
                return out
            at_q = np.vstack([np.zeros((1, grid.shape[2])), np.tensordot(w, grid, axes=1)])
            sev = np.concatenate([[0.0], self.grid_severities])
            on_grid = np.stack([np.interp(SEVERITY_GRID, sev, at_q[:, j])
                                for j in range(at_q.shape[1])], axis=1)
            return np.vstack([out, on_grid])
        pts = self.points[i]
        assert pts is not None
        return np.tensordot(w, pts, axes=1)[None, :]

    def arrays(self) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {"fm_knots": self.knots,
                                      "fm_scalars": np.array([self.supply_nominal_v,
                                                              self.output_v]),
                                      "fm_bands": np.array(self.bands, dtype=np.float64)}
        for i, (c, p) in enumerate(zip(self.coef, self.points, strict=True)):
            if c is not None:
                out[f"fm_coef_{i}"] = c
            if p is not None:
                out[f"fm_points_{i}"] = p
        out["fm_grid_severities"] = self.grid_severities
        for i, g in enumerate(self.grid):
            if g is not None:
                out[f"fm_grid_{i}"] = g
        for i, sc in enumerate(self.severity_coef):
            if sc is not None:
                out[f"fm_sev_{i}"] = sc
        return out

    @classmethod
    def from_arrays(cls, a: dict[str, np.ndarray], n_templates: int,
                    pressures_pa: FloatArray) -> FaultModels:
        return cls(a["fm_knots"], [a.get(f"fm_coef_{i}") for i in range(n_templates)],
                   [a.get(f"fm_points_{i}") for i in range(n_templates)], pressures_pa,
                   float(a["fm_scalars"][0]), [float(b) for b in a["fm_bands"]],
                   [a.get(f"fm_grid_{i}") for i in range(n_templates)],
                   a["fm_grid_severities"], [a.get(f"fm_sev_{i}") for i in range(n_templates)],
                   float(a["fm_scalars"][1]))


def fit_parametric(y: FloatArray, severities: FloatArray, conds: Sequence[Conditions],
                   knots: FloatArray, supply_nominal_v: float) -> FloatArray:
    """Least-squares coefficients of one kind's signature model from its runs ``y (n, K)``."""
    b = np.concatenate([hat_basis(np.array([s]), knots, c, supply_nominal_v)
                        for s, c in zip(severities, conds, strict=True)])
    coef, *_ = np.linalg.lstsq(b, y, rcond=None)
    out: FloatArray = coef
    return out


SEVERITY_RIDGE = 1.0
"""Ridge penalty of the inverse severity model (on coordinates of order 1-100)."""


def _severity_regressors(y: FloatArray, c: Conditions, supply_nominal_v: float,
                         output_v: float) -> FloatArray:
    """The run's coordinates and its condition (air load, temperature, supply, the ESR law and
    the SMPS's off-time share: a fault's signature grows or shrinks with them, e.g. a low-side
    Ron's with the off-time it conducts in)."""
    return np.concatenate([[1.0, *condition_terms(c, supply_nominal_v, output_v)],
                           compress(y)])


def fit_severity(y: FloatArray, severities: FloatArray, conds: Sequence[Conditions],
                 supply_nominal_v: float, output_v: float) -> FloatArray:
    """Ridge regression of one kind's severity on its runs' coordinates ``y (n, K)``.

    Why beside the signature model: the forward model is fitted for the likelihood ratio
    (which kind explains the run), and a few badly modelled coordinates move its best point;
    the inverse model weighs the coordinates by how well they predict the severity.
    """
    x = np.stack([_severity_regressors(yi, c, supply_nominal_v, output_v)
                  for yi, c in zip(y, conds, strict=True)])
    pen = SEVERITY_RIDGE * np.eye(x.shape[1])
    pen[0, 0] = 0.0
    out: FloatArray = np.asarray(np.linalg.solve(x.T @ x + pen, x.T @ severities),
                                 dtype=np.float64)
    return out


def severity(models: FaultModels, i: int, y: FloatArray, c: Conditions) -> float | None:
    """Template ``i``'s severity by its inverse model, within [its band, 1]; None without one."""
    coef = models.severity_coef[i] if i < len(models.severity_coef) else None
    if coef is None:
        return None
    x = _severity_regressors(y, c, models.supply_nominal_v, models.output_v)
    return float(np.clip(x @ coef, models.band(i), 1.0))


def fit_all(models: FaultModels, y: FloatArray, c: Conditions,
            metric: FloatArray | None = None) -> list[Fit]:
    """Every template's best severity beyond its band (1.0 for a switch fault) and residual,
    both compared after :func:`compress`. ``y`` is already in ``metric``'s coordinates when a
    commissioned unit's metric is given (:attr:`HealthyModel.unit_metric`); the templates are
    taken into them here."""
    fits = []
    yc = compress(y)
    energy = float(yc @ yc)
    for i in range(len(models.coef)):
        raw = models.curve(i, c)
        curve = compress(raw if metric is None else raw @ metric)
        res = ((yc[None, :] - curve) ** 2).sum(axis=1)
        if models.coef[i] is None:
            fits.append(Fit(i, 1.0, float(res[0]), energy))
            continue
        sev = np.resize(SEVERITY_GRID, res.size)  # the smooth curve, then the grid curve
        inside = models.band(i) >= sev
        k = int(np.argmin(np.where(inside, np.inf, res)))
        fits.append(Fit(i, float(sev[k]), float(res[k]), float(res[inside].min())))
    return fits


def null_residual(y: FloatArray, fits: list[Fit]) -> float:
    """What the best healthy explanation (nothing, or a parameter within its healthy band)
    leaves unexplained: about chi-square with K degrees of freedom for a healthy run; far more
    for a run that no healthy actuator produces, whether a template fits it well or not."""
    yc = compress(y)
    return min([float(yc @ yc), *(f.null_residual for f in fits)])


def glr_score(y: FloatArray, fits: list[Fit]) -> float:
    """The generalised likelihood ratio of "a fault beyond its band" against "healthy": how much
    less the best fault leaves unexplained than the best healthy explanation (nothing, or a
    parameter within its healthy band). Never negative."""
    return max(0.0, null_residual(y, fits) - min(f.residual for f in fits))
