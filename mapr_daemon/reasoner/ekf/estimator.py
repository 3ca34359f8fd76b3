"""Joint state and parameter estimation (EKF) and the adaptable reference model (paper II).

The paper's premise: degradation moves physical parameters, so estimate them in normal
operation and measure their change from a healthy reference. :class:`ParameterEstimator`
runs filterpy's :class:`~filterpy.kalman.ExtendedKalmanFilter` over the bus-rate signals on
the model of :mod:`~mapr_daemon.reasoner.ekf.model` (motor angle and speed, friction,
loop resistance per commutation-sector group, a DC-bus response proxy).

filterpy 2.0.0's ``predict()`` propagates ``x`` with the linear ``F`` (filterpy issue #181), so
each step propagates the nonlinear model here, sets ``F`` to its Jacobian and lets filterpy
only propagate the covariance (its ``predict_x`` is replaced by a no-op on our instance).
Numerical health: filterpy's update is in Joseph form; after every step ``P`` is symmetrised,
and a parameter whose variance grew above its prior (long stretches without motion make
friction unobservable) is scaled back by a congruence, which keeps ``P`` positive definite
and bounded over hours. After every update viscous friction is projected into the band
the model's integration holds (:func:`~mapr_daemon.reasoner.ekf.model.project`), since an
estimate past that bound is pulled by the model itself to ``g = -1`` and beyond, where ``F``
and ``P`` overflow.

:class:`Reference` holds the reference model's parameters; :meth:`Reference.adapt` moves it to
confirmed estimates, so later detections measure change from the adapted model::

    est = ParameterEstimator(params)
    est.run(channels, dynamic_pressure_pa)
    ref = Reference.nominal(params)
    ref.changed(est.estimate())        # {"viscous": ...} when it moved
    ref.adapt(est.estimate())          # after the maintainer (or the classifier) confirms
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter

from drivers.jit import kernel
from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError, RecordError
from mapr_daemon.reasoner.ekf import model as em

UNITS: dict[str, str] = {"viscous": "x nominal", "coulomb": "x nominal", "r_other": "ohm",
                         "r_a_high": "ohm", "bus0": "V/A (proxy)", "bus1": "V/A (proxy)"}
PRIOR_SD: dict[str, float] = {"theta": 0.01, "omega": 2.0, "viscous": 1.0, "coulomb": 1.0,
                              "r_other": 0.3, "r_a_high": 0.3, "bus0": 0.3, "bus1": 0.3}
"""Initial standard deviations; also the cap on each parameter's standard deviation."""
DRIFT_SD: dict[str, float] = {"theta": 1e-4, "omega": 0.5, "viscous": 2e-3, "coulomb": 2e-3,
                              "r_other": 1e-3, "r_a_high": 1e-3, "bus0": 1e-3, "bus1": 1e-3}
"""Process noise per 10 ms block: speed absorbs torque error, parameters drift slowly."""


@dataclasses.dataclass(frozen=True)
class Estimate:
    """Parameter estimates with their standard deviations (``STATE[2:]`` names)."""

    value: dict[str, float]
    sd: dict[str, float]

    def as_event(self, reference: Reference | None = None) -> dict[str, dict[str, Any]]:
        """The event's ``parameters``: value, sd, unit (and the reference value if known)."""
        out: dict[str, dict[str, Any]] = {}
        for k, v in self.value.items():
            item: dict[str, Any] = {"value": float(f"{v:.6g}"), "sd": float(f"{self.sd[k]:.3g}"),
                                    "unit": UNITS[k]}
            if reference is not None and k in reference.value:
                item["reference"] = float(f"{reference.value[k]:.6g}")
            out[k] = item
        return out


class ParameterEstimator:
    """One actuator's EKF; :meth:`run` may be called on successive records (flights)."""

    def __init__(self, params: ActuatorParams, reference: Reference | None = None,
                 block: int = em.BLOCK, drift_sd: Mapping[str, float] | None = None) -> None:
        """``drift_sd`` overrides :data:`DRIFT_SD` per state (the in-flight tracker's
        parameters drift less: within one flight they are nearly constant)."""
        self.plant = em.Plant.of(params)
        self.block = block
        self.reference = reference if reference is not None else Reference.nominal(params)
        n = len(em.STATE)
        self.kf = ExtendedKalmanFilter(dim_x=n, dim_z=4)
        # our propagation is nonlinear: filterpy must only propagate P (issue #181)
        self.kf.predict_x = lambda u=0: None
        drift = {**DRIFT_SD, **(drift_sd or {})}
        self.kf.Q = np.diag([drift[k] ** 2 for k in em.STATE])
        self.p_cap = np.array([PRIOR_SD[k] ** 2 for k in em.STATE])
        self.steps = 0
        self.reset()

    def reset(self) -> None:
        """Back to the reference model with the prior covariance."""
        x = np.zeros(len(em.STATE))
        for k, name in enumerate(em.STATE):
            x[k] = self.reference.value.get(name, 0.0)
        em.project(self.plant, x)
        self.kf.x = x.reshape(-1, 1)
        self.kf.P = np.diag(self.p_cap.copy())

    def run(self, channels: Mapping[str, FloatArray], dynamic_pressure_pa: float) -> Estimate:
        """Filter one record of one actuator (1-D channels at the bus rate)."""
        b = em.blocks(self.plant, channels, float(dynamic_pressure_pa), self.block)
        kf = self.kf
        x = kf.x.reshape(-1).copy()
        x[0], x[1] = b.theta0, b.omega0  # the motor state restarts with each record
        kf.P[0:2, :] = 0.0
        kf.P[:, 0:2] = 0.0
        kf.P[0, 0], kf.P[1, 1] = self.p_cap[0], self.p_cap[1]
        for k in range(b.n):
            x, f = em.propagate(self.plant, x, b, k)
            kf.x = x.reshape(-1, 1)
            kf.F = f
            try:
                kf.predict()
                z, hx, hj = em.measure(x, b, k)
                kf.update(z.reshape(-1, 1), lambda _x, h=hj: h,
                          lambda _x, v=hx: v.reshape(-1, 1), R=b.r[k])
            except (ValueError, ArithmeticError) as error:  # the linear algebra gave up
                raise RecordError(f"numerical failure at block {k} of {b.n}: {error}",
                                  field="estimator") from error
            self._health()
            x = kf.x.reshape(-1).copy()
            em.project(self.plant, x)
            kf.x = x.reshape(-1, 1)
            self.steps += 1
        return self.estimate()

    def _health(self) -> None:
        """Symmetrise P and cap each variance at its prior (a congruence keeps P > 0)."""
        p = np.array(self.kf.P, dtype=np.float64)
        if not _symmetrise_and_cap(p, self.p_cap):
            raise RecordError("covariance diverged (a non-finite entry or a variance far below "
                              "zero)", field="estimator")
        self.kf.P = p

    @property
    def covariance(self) -> FloatArray:
        out: FloatArray = np.array(self.kf.P, dtype=np.float64)
        return out

    def estimate(self) -> Estimate:
        """The current parameter estimates and standard deviations."""
        x = self.kf.x.reshape(-1)
        d = np.diag(self.kf.P)
        idx = {name: k for k, name in enumerate(em.STATE)}
        return Estimate({n: float(x[idx[n]]) for n in em.PARAMETERS},
                        {n: float(np.sqrt(d[idx[n]])) for n in em.PARAMETERS})


@dataclasses.dataclass
class Reference:
    """The reference model's parameters (the adapted model after confirmed degradations).

    ``tolerance`` is each parameter's allowed model error (flight-to-flight scatter and the
    filter's bias): a change is reported when it exceeds ``k_sd`` standard deviations *and*
    the tolerance.
    """

    value: dict[str, float]
    tolerance: dict[str, float]
    k_sd: float = 3.0
    history: list[dict[str, float]] = dataclasses.field(default_factory=list)

    @classmethod
    def nominal(cls, params: ActuatorParams) -> Reference:
        """From the actuator file: friction ratios 1, loop resistance ``2R + 2Ron``.

        The bus proxies have no value in the file: they start at 0 with no detection until a
        healthy record calibrates them (:meth:`adapt` with the healthy estimate).
        """
        r = 2.0 * params.motor.resistance_ohm + 2.0 * params.inverter.ron_ohm
        return cls({"viscous": 1.0, "coulomb": 1.0, "r_other": r, "r_a_high": r,
                    "bus0": 0.0, "bus1": 0.0},
                   {"viscous": 0.3, "coulomb": 0.3, "r_other": 0.15 * r, "r_a_high": 0.2 * r,
                    "bus0": 0.05, "bus1": 0.05})

    def changed(self, est: Estimate, names: Iterable[str] | None = None) -> dict[str, float]:
        """Parameters that moved from the reference: name -> change (estimate - reference)."""
        out: dict[str, float] = {}
        for k in names if names is not None else est.value:
            if k not in self.value:
                continue
            delta = est.value[k] - self.value[k]
            if abs(delta) > max(self.k_sd * est.sd[k], self.tolerance[k]):
                out[k] = delta
        return out

    def adapt(self, confirmed_estimates: Estimate | Mapping[str, float]) -> None:
        """Move the reference to confirmed estimates (only the parameters given).

        Later :meth:`changed` calls then measure change from the adapted model, so a
        confirmed degradation is not reported again and a further one is.
        """
        vals = (confirmed_estimates.value if isinstance(confirmed_estimates, Estimate)
                else dict(confirmed_estimates))
        for k, v in vals.items():
            if k not in self.value:
                raise ConfigError("not an estimated parameter", field=k)
            self.value[k] = float(v)
        self.history.append(dict(self.value))


@dataclasses.dataclass
class Confirmation:
    """When a parameter change counts as a confirmed degradation (and the reference adapts).

    Rule: the same parameter is reported changed by :meth:`Reference.changed` (beyond
    ``k_sd`` sd and its tolerance) in the same direction on ``consecutive`` successive
    records that carried an estimate. A record on which it is not changed, or changed the
    other way, restarts its count. The confirmed value is the mean of those records'
    estimates (one record's estimate carries that flight's scatter).
    """

    consecutive: int = 3
    _runs: dict[str, list[float]] = dataclasses.field(default_factory=dict)
    _sign: dict[str, float] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.consecutive < 1:
            raise ConfigError("need at least one record to confirm", field="consecutive")

    def observe(self, changes: Mapping[str, float], est: Estimate) -> dict[str, float]:
        """Count one record's changes; the parameters confirmed now -> value to adapt to."""
        confirmed: dict[str, float] = {}
        for name in list(self._runs):
            if name not in changes:
                del self._runs[name], self._sign[name]
        for name, delta in changes.items():
            sign = 1.0 if delta > 0 else -1.0
            if self._sign.get(name) != sign:
                self._runs[name], self._sign[name] = [], sign
            self._runs[name].append(est.value[name])
            if len(self._runs[name]) >= self.consecutive:
                confirmed[name] = float(np.mean(self._runs[name]))
                del self._runs[name], self._sign[name]
        return confirmed

    def pending(self) -> dict[str, int]:
        """Parameters on their way to confirmation -> records seen so far."""
        return {k: len(v) for k, v in self._runs.items()}


def severity_check(fault: str | None, value: float | None,
                   est: Estimate) -> dict[str, Any] | None:
    """Cross-check the classifier's severity with the EKF where the fault moves an estimate.

    Only friction is checked in the fault's own unit: its factor scales both friction terms,
    so the EKF's value is the mean of the two ratios. The other parametric faults move no
    estimated parameter in their unit (the SMPS faults are upstream of the DC link; the
    phase-A Ron enters ``r_a_high`` weighted by the duty), so they get no check.
    """
    if fault != "friction" or value is None:
        return None
    v = 0.5 * (est.value["viscous"] + est.value["coulomb"])
    sd = 0.5 * float(np.hypot(est.sd["viscous"], est.sd["coulomb"]))
    agrees = abs(v - value) <= max(3.0 * sd, 0.3 * max(value, 1.0))
    return {"parameter": "friction factor", "ekf": round(v, 4), "ekf_sd": round(sd, 4),
            "classifier": round(float(value), 4), "agrees": bool(agrees)}


VARIANCE_FLOOR = 1e-12
"""Least variance of a state, as a share of its prior (cap): below it rounding, not
information, sets the value."""
ROUNDING = 1e-9
"""A variance below zero by less than this share of its prior is rounding (restored to the
floor); by more, the update diverged (an overflowing record) and the record fails."""


@kernel
def _symmetrise_and_cap(p: FloatArray, cap: FloatArray) -> bool:
    """In place: ``P = (P + P')/2``; a variance that rounding drove to zero or below (a state
    the measurements pin down, whose Joseph-form update subtracts two nearly equal numbers)
    set back to :data:`VARIANCE_FLOOR` of its cap with its covariances cleared; then each
    variance above ``cap`` scaled back to it by the congruence ``S P S`` with
    ``S = diag(sqrt(min(1, cap/d)))``, which keeps P positive definite. False (P left
    symmetrised) when P has a non-finite entry or a variance far below zero (more than
    :data:`ROUNDING` of its cap: a diverged update, not rounding)."""
    n = p.shape[0]
    for i in range(n):
        for j in range(n):
            if not np.isfinite(p[i, j]):
                return False
    for i in range(n):
        for j in range(i + 1, n):
            m = 0.5 * (p[i, j] + p[j, i])
            p[i, j] = m
            p[j, i] = m
    for i in range(n):
        floor = VARIANCE_FLOOR * cap[i]
        if p[i, i] < -ROUNDING * cap[i]:
            return False   # far below zero: the update diverged, not a rounding
        if p[i, i] < floor:
            for j in range(n):
                p[i, j] = 0.0
                p[j, i] = 0.0
            p[i, i] = floor
    scale = np.ones(n)
    capped = False
    for i in range(n):
        if p[i, i] > cap[i]:
            scale[i] = np.sqrt(cap[i] / p[i, i])
            capped = True
    if capped:
        for i in range(n):
            for j in range(n):
                p[i, j] *= scale[i] * scale[j]
    return True
