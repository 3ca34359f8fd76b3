"""The healthy actuator's model: what a healthy BIT looks like at a run's operating conditions.

Flight-to-flight variation is *removed*, not thresholded. A BIT record's cells (window means
and spreads of the currents, bus voltage, SMPS input current and conversion loss, ripple,
position and tracking error over the whole record; :func:`record_cells`) are predicted from the
run's operating conditions — dynamic pressure (from the air data on the bus), aircraft-bus
voltage and ambient temperature (both measured by the actuator: the SMPS input voltage and the
power stage's temperature at the start of a BIT) — by a polynomial least-squares fit over many
healthy runs. The residual is divided by its healthy spread and whitened with the healthy
residuals' covariance, shrunk towards the identity by the Ledoit-Wolf formula (there are more
cells than healthy runs, and what is left — friction scatter, sensor noise, bus drift — is
correlated across cells). In whitened units a healthy run is close to white noise, so a fault's
small but consistent pattern stands out.

Last, the whitened residual is projected on the *fault subspace*: the leading directions of the
fault dictionary's whitened signatures. The classifier works on these few coordinates, whose
healthy distribution is known (close to chi-square), instead of on thousands of noisy cells.

Ledoit & Wolf, "A well-conditioned estimator for large-dimensional covariance matrices",
J. Multivariate Analysis 88 (2004) 365-411: the shrinkage intensity of their Lemma 3.3/3.4.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema import temperature
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError

PAPER_ROWS = 32
"""M's first 32 rows are the paper's corner windows; the record rows follow."""
RECORD_MEANS: tuple[str, ...] = (
    "dc_link_current_a", "phase_a_current_a", "phase_b_current_a", "phase_c_current_a",
    "dc_bus_voltage_v", "position_deg", "smps_input_current_a", "ripple_rms_v",
    "tracking_error_deg", "smps_loss_w", "duty_a_high", "duty_other", "dc_link_a_high_a",
    "a_high_share", "smps_high_side_rise_k", "smps_low_side_rise_k", "inverter_a_high_rise_k")
"""Signals whose window mean over the record rows is a cell of the healthy model (the sector
and switch temperature signals only when the dictionary has them; the switch temperatures
only by their means: read at 100 Hz, their spread and spectra inside a window are noise)."""
RECORD_SPREADS: tuple[str, ...] = ("dc_link_current_a", "phase_a_current_a", "dc_bus_voltage_v",
                                   "ripple_rms_v")
"""... and whose window standard deviation is one too (the fast response inside a window)."""
RECORD_SCALARS: tuple[str, ...] = ("a_high_resistance_ohm",)
"""Signals that hold one value per record (a fit over the whole record): one cell each."""
SUPPLY = "mean:smps_input_voltage_v"
TEMPERATURE = "mean:stage_temperature_c"
PRESSURE_SCALE_PA = 2500.0
TEMPERATURE_REF_C = 25.0
TEMPERATURE_SCALE_K = 10.0
OFF_TIME_FLOOR = 0.05
"""Least off-time share of the SMPS (its duty limit, 0.95, leaves 5 %)."""
OFF_TIME_NOMINAL = 0.13
"""The off-time share at the nominal bus (1 - 24/27.5): the regressor's unit."""
GROUND_PA = 1.0
"""Below this dynamic pressure a BIT is flown on the ground: no air load at all, so the position
loop holds the surface against friction alone and the sector cells take another regime (which
side of the bridge holds is decided by friction, not by a hinge moment); a regressor of its own."""
PEAK_HEADROOM_V = 0.5
"""What the healthy converter drops across its switch, inductor and feeder resistances at the
BIT's current peaks (~0.4 V): the regulator saturates at its peaks below ``Vout/max_duty`` plus
this, all the time below ``Vout/max_duty``."""
SPREAD_CLIP = (0.25, 8.0)
"""Bounds of a cell's condition-dependent spread, relative to its typical spread."""
SPREAD_MIN_RUNS = 200
"""Healthy runs below which the spread is not made condition-dependent (fitted from single
residuals, its seven coefficients per cell would follow their noise)."""
"""Bounds of a cell's condition-dependent spread, relative to its typical spread."""
SD_FLOOR_COLUMN = 0.1
"""Least healthy spread of a cell, as a share of its column's median spread ..."""
SD_FLOOR_REL = 1e-3
"""... and as a share of the column's largest magnitude."""


def record_cells(columns: Sequence[str], n_rows: int, pool: int = 1) -> npt.NDArray[np.int64]:
    """Flat indices into M ``(n_rows, len(columns))`` of the healthy model's cells ``(D, pool)``:
    each cell is the mean of ``pool`` consecutive record rows of one column (fewer cells than
    healthy runs keeps the covariance estimable; the windows stay short for the spectra)."""
    wanted = [f"mean:{s}" for s in RECORD_MEANS] + [f"std:{s}" for s in RECORD_SPREADS]
    cols = np.asarray([columns.index(c) for c in wanted if c in columns], dtype=np.int64)
    n_groups = (n_rows - PAPER_ROWS) // max(pool, 1)
    if cols.size == 0 or n_groups < 1:
        raise ConfigError("the dictionary's M has no record rows or columns", field="signals")
    rows = PAPER_ROWS + np.arange(n_groups * pool, dtype=np.int64).reshape(n_groups, pool)
    flat: npt.NDArray[np.int64] = (rows[:, None, :] * len(columns)
                                   + cols[None, :, None]).reshape(-1, pool)
    scalars = [columns.index(f"mean:{s}") for s in RECORD_SCALARS if f"mean:{s}" in columns]
    if scalars:
        one = PAPER_ROWS * len(columns) + np.asarray(scalars, dtype=np.int64)
        flat = np.concatenate([flat, np.repeat(one[:, None], flat.shape[1], axis=1)])
    return flat


@dataclasses.dataclass(frozen=True)
class Conditions:
    """A run's operating conditions, as the healthy model reads them."""

    pressure_pa: float
    supply_v: float
    """Mean aircraft-bus (SMPS input) voltage over the record."""
    supply_min_v: float
    """Lowest window mean of it: below the SMPS's headroom a BIT says nothing about faults."""
    temperature_c: float


def conditions(m: FloatArray, columns: Sequence[str], pressure_pa: float) -> Conditions:
    """The operating conditions of one run from its M ``(W, C)`` and the air data."""
    vin = m[PAPER_ROWS:, columns.index(SUPPLY)]
    temp = m[PAPER_ROWS:, columns.index(TEMPERATURE)]
    return Conditions(float(pressure_pa), float(vin.mean()), float(vin.min()), float(temp.mean()))


def pressure_weights(grid: FloatArray, q: float) -> FloatArray:
    """Linear-interpolation weights over the pressure grid (clamped at its ends)."""
    w = np.zeros(grid.size)
    if q <= grid[0]:
        w[0] = 1.0
    elif q >= grid[-1]:
        w[-1] = 1.0
    else:
        j = int(np.searchsorted(grid, q)) - 1
        t = (q - grid[j]) / (grid[j + 1] - grid[j])
        w[j], w[j + 1] = 1.0 - t, t
    return w


def scaled(c: Conditions, supply_nominal_v: float) -> tuple[float, float, float]:
    """The flight condition as regressors take it: dynamic pressure in units of
    :data:`PRESSURE_SCALE_PA`, supply voltage above nominal (V), temperature from
    :data:`TEMPERATURE_REF_C` in units of :data:`TEMPERATURE_SCALE_K`."""
    return (c.pressure_pa / PRESSURE_SCALE_PA, c.supply_v - supply_nominal_v,
            (c.temperature_c - TEMPERATURE_REF_C) / TEMPERATURE_SCALE_K)


def condition_terms(c: Conditions, supply_nominal_v: float,
                    output_v: float) -> tuple[float, float, float, float, float]:
    """The flight condition as the physics takes it: air load ``q`` and temperature ``t`` and
    supply ``v`` (:func:`scaled`), the ESR law ``e = esr_factor(T) - 1``, and the SMPS's
    off-time share ``w = 1 - Vout/Vin`` (floored at its duty limit, in units of its nominal)."""
    q, v, t = scaled(c, supply_nominal_v)
    e = float(temperature.esr_factor(c.temperature_c)) - 1.0
    w = max(1.0 - output_v / max(c.supply_v, 1.0), OFF_TIME_FLOOR) / OFF_TIME_NOMINAL
    return q, t, v, e, w


def basis(c: Conditions, supply_nominal_v: float, dropout_v: float,
          output_v: float) -> FloatArray:
    """The regressors of the healthy prediction, shaped by the physics of each condition.

    * air load: a cubic in dynamic pressure, and an indicator of a BIT on the ground;
    * aircraft bus: linear and quadratic above nominal, and two dropout knees: how far the
      record's lowest supply is below ``dropout_v`` (``Vout/max_duty`` plus the drops at the
      BIT's current peaks: there the regulator saturates at its peaks), linear, quadratic and
      times the air load; and how far the mean supply is below ``Vout/max_duty`` itself
      (``dropout_v - PEAK_HEADROOM_V``: there it saturates all the time and the DC link follows
      the input instead of its reference), linear and times the air load;
    * temperature: linear (copper, MOSFET Ron and capacitance are linear in it,
      :mod:`mapr_daemon.ema.temperature`) and quadratic, plus the electrolytic's ESR law
      ``esr_factor(T) - 1``, which is not (it grows ~3.7x from 25 to -40 C);
    * the products that carry one condition's effect through another (air load times supply,
      temperature and ESR; supply times temperature; the ground indicator times temperature);
    * the SMPS's off-time share ``w = 1 - Vout/Vin`` (floored at 5 %, in units of its nominal
      13 %), alone, times the ESR law, temperature and air load: the inductor's ripple current
      is proportional to it and the bank's ESR turns it into the output ripple, so the ripple
      cells follow ``ESR(T) * w``.
    """
    q, t, v, e, w = condition_terms(c, supply_nominal_v, output_v)
    g = 1.0 if c.pressure_pa < GROUND_PA else 0.0
    d = max(0.0, dropout_v - c.supply_min_v)
    d_steady = max(0.0, dropout_v - PEAK_HEADROOM_V - c.supply_v)
    return np.array([1.0, q, q * q, q**3, g, v, v * v, d, d * d, q * d, d_steady, q * d_steady,
                     t, t * t, e, q * v, q * t, q * e, v * t, g * t,
                     w, e * w, t * w, q * w, e * w * q])


def spread_basis(c: Conditions, supply_nominal_v: float, dropout_v: float) -> FloatArray:
    """Regressors of a cell's log healthy spread: a BIT on the ground, in dropout or in the cold
    is noisier in some cells than one in flight at room temperature (the sector cells on the
    ground swing with friction)."""
    q, _, t = scaled(c, supply_nominal_v)
    g = 1.0 if c.pressure_pa < GROUND_PA else 0.0
    d = max(0.0, dropout_v - c.supply_min_v)
    e = float(temperature.esr_factor(c.temperature_c)) - 1.0
    return np.array([1.0, q, q * q, g, d, t, e])


def offset_basis(c: Conditions, supply_nominal_v: float) -> FloatArray:
    """Regressors of a commissioned unit's offset from the model shared by every cell: a mean,
    slopes in air load, temperature and supply, and a step for BITs on the ground (what a few
    BITs of one unit can pin down; each cell also scales the model's own prediction,
    :attr:`HealthyModel.unit_gain`)."""
    q, v, t = scaled(c, supply_nominal_v)
    return np.array([1.0, q, 1.0 if c.pressure_pa < GROUND_PA else 0.0, t, v])


def ledoit_wolf(z: FloatArray, floor: float = 0.0) -> tuple[FloatArray, float]:
    """Shrunk covariance of the rows of ``z`` (zero-mean residuals) and the shrinkage intensity.

    ``S* = (1-a) S + a mu I`` with ``mu = tr(S)/p``; ``a = min(b2, d2)/d2``, ``d2`` the distance
    of S from ``mu I`` and ``b2`` the sampling noise of S, both per dimension (Frobenius);
    ``floor`` is a lower bound on ``a``.
    """
    n, p = z.shape
    s = z.T @ z / n
    mu = float(np.trace(s)) / p
    d2 = float(((s - mu * np.eye(p)) ** 2).sum()) / p
    b2 = (float(((z * z).sum(axis=1) ** 2).sum()) / n - float((s * s).sum())) / (n * p)
    a = 1.0 if d2 <= 0 else min(max(b2, 0.0), d2) / d2
    a = max(a, floor)
    return (1.0 - a) * s + a * mu * np.eye(p), a


@dataclasses.dataclass
class HealthyModel:
    """Prediction, scaling and whitening of the record cells; the fault subspace."""

    cells: npt.NDArray[np.int64]
    """``(D, pool)`` flat indices into M; a cell is the mean of its ``pool`` entries."""
    coef: FloatArray
    """``(P, D)`` least-squares coefficients of the cells on :func:`basis`."""
    sd: FloatArray
    """``(D,)`` typical healthy residual spread per cell."""
    projection: FloatArray
    """``(D, K)``: whitening followed by the projection on the fault subspace."""
    supply_nominal_v: float
    supply_floor_v: float
    """Below this input voltage a BIT is inconclusive (outside the bus's normal band)."""
    shrinkage: float
    matched: FloatArray | None = None
    """``(D,)`` weights of the matched filter on the standardized cells
    (:mod:`~mapr_daemon.reasoner.diagnosis.matched_filter`); None when the dictionary has none."""
    dropout_v: float = 0.0
    """The SMPS's dropout knee (:func:`basis`)."""
    output_v: float = 0.0
    """The SMPS's regulated output (:func:`basis`)."""
    sd_coef: FloatArray | None = None
    """``(S, D)``: a cell's log spread relative to :attr:`sd` on :func:`spread_basis`."""
    sd_floor: FloatArray | None = None
    """``(D,)`` least spread of a cell, whatever the conditions."""
    unit_coef: FloatArray | None = None
    """``(U, D)``: a commissioned unit's own offset from the prediction, in healthy spreads, on
    :func:`offset_basis` (:mod:`~mapr_daemon.reasoner.commissioning.calibrate`); None before
    commissioning."""
    unit_factor: FloatArray | None = None
    """``(D,)``: the unit's spread over the model's (>= 1)."""
    unit_gain: FloatArray | None = None
    """``(D,)``: the unit's departure, per cell, as a share of the model's predicted departure
    from :attr:`unit_reference` (a unit whose motor constant is 8 % off moves its load currents
    8 % more or less than the model's, whatever the condition)."""
    unit_reference: FloatArray | None = None
    """``(D,)``: the model's prediction at the mean of the unit's commissioning conditions."""
    unit_metric: FloatArray | None = None
    """``(K, K)``: applied to the fault-subspace coordinates (and the templates) of a
    commissioned unit: the directions in which its healthy BITs vary more than the model's,
    scaled down to unit variance."""

    def unit_regressor(self, c: Conditions) -> FloatArray:
        """Per cell, the model's predicted departure from :attr:`unit_reference`, in spreads."""
        ref = self.unit_reference if self.unit_reference is not None else 0.0
        out: FloatArray = (self.predicted(c) - ref) / self.spread(c)
        return out

    def spread(self, c: Conditions) -> FloatArray:
        """Every cell's healthy spread at the run's conditions ``(D,)``."""
        if self.sd_coef is None:
            return self.sd
        rel = np.exp(spread_basis(c, self.supply_nominal_v, self.dropout_v) @ self.sd_coef)
        out: FloatArray = self.sd * np.clip(rel, *SPREAD_CLIP)
        return out if self.sd_floor is None else np.maximum(out, self.sd_floor)

    def predicted(self, c: Conditions) -> FloatArray:
        """The healthy actuator's cells at the run's conditions ``(D,)``."""
        out: FloatArray = basis(c, self.supply_nominal_v, self.dropout_v, self.output_v) @ self.coef
        return out

    def standardized(self, m: FloatArray, c: Conditions) -> FloatArray:
        """The cells' deviation from the healthy prediction, in healthy spreads ``(D,)`` (of the
        commissioned unit, when there is one)."""
        x = m.ravel()[self.cells].mean(axis=1)
        out: FloatArray = (x - self.predicted(c)) / self.spread(c)
        if self.unit_coef is not None:
            out = out - offset_basis(c, self.supply_nominal_v) @ self.unit_coef
        if self.unit_gain is not None:
            out = out - self.unit_gain * self.unit_regressor(c)
        if self.unit_factor is not None:
            out = out / self.unit_factor
        return out

    def coordinates(self, m: FloatArray, c: Conditions) -> FloatArray:
        """The run's whitened deviation on the fault subspace ``(K,)``."""
        out: FloatArray = self.standardized(m, c) @ self.projection
        return out

    def arrays(self) -> dict[str, np.ndarray]:
        """What :meth:`Dictionary.save` stores."""
        out = {"healthy_cells": self.cells, "healthy_coef": self.coef, "healthy_sd": self.sd,
               "healthy_projection": self.projection,
               "healthy_scalars": np.array([self.supply_nominal_v, self.supply_floor_v,
                                            self.shrinkage, self.dropout_v, self.output_v])}
        for key, value in (("healthy_matched", self.matched), ("healthy_sd_coef", self.sd_coef),
                           ("healthy_sd_floor", self.sd_floor),
                           ("healthy_unit_coef", self.unit_coef),
                           ("healthy_unit_factor", self.unit_factor),
                           ("healthy_unit_gain", self.unit_gain),
                           ("healthy_unit_reference", self.unit_reference),
                           ("healthy_unit_metric", self.unit_metric)):
            if value is not None:
                out[key] = value
        return out

    @classmethod
    def from_arrays(cls, a: dict[str, np.ndarray]) -> HealthyModel:
        sc = a["healthy_scalars"]
        return cls(a["healthy_cells"].astype(np.int64), a["healthy_coef"], a["healthy_sd"],
                   a["healthy_projection"], float(sc[0]), float(sc[1]), float(sc[2]),
                   a.get("healthy_matched"), float(sc[3]), float(sc[4]), a.get("healthy_sd_coef"),
                   a.get("healthy_sd_floor"), a.get("healthy_unit_coef"),
                   a.get("healthy_unit_factor"), a.get("healthy_unit_gain"),
                   a.get("healthy_unit_reference"), a.get("healthy_unit_metric"))


def fit(m: FloatArray, conds: Sequence[Conditions], cells: npt.NDArray[np.int64],
        supply_nominal_v: float, supply_floor_v: float, dropout_v: float, output_v: float,
        shrinkage_floor: float = 0.0) -> tuple[HealthyModel, FloatArray]:
    """Fit the prediction, the condition-dependent spread and the shrunk whitening on healthy
    runs ``m (n, W, C)``.

    Returns the model with an identity projection (``(D, D)`` whitening, no subspace yet) and
    the whitening matrix; :func:`with_subspace` then keeps the fault directions.
    """
    x = m.reshape(m.shape[0], -1)[:, cells].mean(axis=2)
    b = np.stack([basis(c, supply_nominal_v, dropout_v, output_v) for c in conds])
    n_live = int(_live(b)[1].sum())
    if x.shape[0] < 2 * n_live:
        raise ConfigError(f"need >= {2 * n_live} healthy runs for the healthy model",
                          field="healthy_runs")
    coef = _least_squares(b, x)
    resid = x - b @ coef
    dof = max(x.shape[0] - b.shape[1], 1)
    raw_sd = np.sqrt((resid**2).sum(axis=0) / dof)
    # a cell that barely moves in healthy runs (a parked position, quantised to the same count
    # every time; a sector share while parked) gets a floor: a tenth of its column's median
    # spread over the record, and a thousandth of the column's largest magnitude, so a
    # one-count change there does not count as thousands of spreads
    col = cells[:, 0] % m.shape[2]
    floor = np.zeros_like(raw_sd)
    scale = np.abs(x).max(axis=0)
    for c in np.unique(col):
        own = col == c
        floor[own] = max(SD_FLOOR_COLUMN * float(np.median(raw_sd[own])),
                         SD_FLOOR_REL * float(scale[own].max()))
    floor = np.maximum(floor, 1e-9)
    sd = np.maximum(raw_sd, floor)
    sd_coef = None if x.shape[0] < SPREAD_MIN_RUNS else _spread_fit(
        resid / sd, [spread_basis(c, supply_nominal_v, dropout_v) for c in conds])
    model = HealthyModel(cells, coef, sd, np.eye(cells.shape[0]), supply_nominal_v,
                         supply_floor_v, 0.0, None, dropout_v, output_v, sd_coef, floor)
    z = resid / np.stack([model.spread(c) for c in conds])
    cov, a = ledoit_wolf(z, shrinkage_floor)
    ev, vec = np.linalg.eigh(cov)
    whiten = vec / np.sqrt(np.maximum(ev, 1e-12 * float(ev.max())))
    model = dataclasses.replace(model, projection=whiten, shrinkage=a)
    return model, whiten


BASIS_RCOND = 1e-3
"""Directions of the standardized regressors weaker than this share of the strongest are left
out of the healthy fit: over a narrow spread of conditions the physical regressors are nearly
collinear (ESR's law and a quadratic in temperature over +-10 K), and fitting them would
follow the runs' noise; over the whole envelope none is cut."""


MIN_SUPPORT = 20
"""Least number of healthy runs in which a regressor must differ from its median to be fitted."""


def _live(b: FloatArray) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """Each regressor's spread over the runs, and whether it is fitted: it must vary, and a
    regressor that is zero but in a few runs (the ground indicator, the dropout knees) needs
    :data:`MIN_SUPPORT` of them (fitted on a handful it would memorise their noise)."""
    scale = b.std(axis=0)
    scale[0] = 1.0  # the intercept
    support = (np.abs(b - np.median(b, axis=0)) > 1e-12).sum(axis=0)
    live = (scale > 1e-12) & ((support >= MIN_SUPPORT) | (np.arange(b.shape[1]) == 0))
    return scale, live


def _least_squares(b: FloatArray, x: FloatArray) -> FloatArray:
    """Coefficients of ``x ~ b @ coef``, the regressors standardized and weak directions cut
    (:data:`BASIS_RCOND`); a regressor that never varies in these runs gets 0."""
    scale, live = _live(b)
    coef = np.zeros((b.shape[1], x.shape[1]))
    sol = np.linalg.lstsq(b[:, live] / scale[live], x, rcond=BASIS_RCOND)[0]
    coef[live] = sol / scale[live][:, None]
    return coef


LOG_CHI2_1_MEAN = -1.2704
"""E[log chi2(1)]: half of it is the bias of log|z| as an estimate of log sd."""


def _spread_fit(z: FloatArray, sb: Sequence[FloatArray]) -> FloatArray:
    """Per cell, log spread of the residuals ``z (n, D)`` (already in typical spreads) as a
    linear function of :func:`spread_basis`: least squares on ``log|z|`` corrected for its bias,
    lightly ridged (a cell's spread is estimated from single residuals)."""
    a = np.stack(sb)
    target = np.log(np.abs(z) + 1e-6) - 0.5 * LOG_CHI2_1_MEAN
    ridge = 1.0 * np.eye(a.shape[1])
    ridge[0, 0] = 0.0
    out: FloatArray = np.asarray(np.linalg.solve(a.T @ a + ridge, a.T @ target), np.float64)
    return out


def with_subspace(model: HealthyModel, signatures: FloatArray, dims: int) -> HealthyModel:
    """Keep the ``dims`` leading directions of the whitened fault signatures ``(n, D)``.

    Each signature is scaled to unit length first, so a dead capacitor does not outweigh a
    slightly worn MOSFET in choosing the directions.
    """
    norms = np.linalg.norm(signatures, axis=1, keepdims=True)
    unit = signatures[norms[:, 0] > 0] / norms[norms[:, 0] > 0]
    _, _, vt = np.linalg.svd(unit, full_matrices=False)
    k = min(dims, vt.shape[0])
    return dataclasses.replace(model, projection=model.projection @ vt[:k].T)


SUPPLY_HEADROOM_V = PEAK_HEADROOM_V
"""Input-voltage margin above ``Vout/max_duty`` that the BIT's current peaks need."""


def supply_floor_v(params: ActuatorParams) -> float:
    """The SMPS's dropout knee: below this aircraft-bus voltage its duty saturates at the BIT's
    current peaks and the DC link follows the input instead of its reference."""
    return params.smps.output_voltage_v / params.smps.max_duty + SUPPLY_HEADROOM_V
