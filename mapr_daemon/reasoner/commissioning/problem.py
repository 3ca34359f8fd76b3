"""The least-squares problem behind :func:`~mapr_daemon.reasoner.commissioning.identify.identify`:
the
recorded BITs, the model flown through them in one batch, residuals, Jacobian, weights and
the posterior covariance. See :mod:`~mapr_daemon.reasoner.commissioning.identify` for the method."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import (
    FIT_SIGNALS,
    PHASE_SUM,
    BitRecord,
    condition,
    signal_noise,
)
from mapr_daemon.reasoner.commissioning.flight import (
    FRICTION,
    flown,
    noise_scale,
    recorded,
)
from mapr_daemon.reasoner.diagnosis.healthy_model import supply_floor_v

SUPPLY_CHANNELS = ("dc_bus_voltage_v", "ripple_rms_v", "smps_input_current_a")
"""Channels a BIT on a bus below the supply floor (:func:`build.supply_floor_v`) cannot be
fitted on: the converter sits at its duty limit and its output follows the bus's drift and
ripple within the BIT, which the model (flying each BIT at the bus's mean) does not have."""
UPPER = {"gear.efficiency": 1.0, "smps.max_duty": 0.999}
"""Physical upper limits of parameters a fit may reach."""
SEGMENT_S = 0.1
"""Stretch of a BIT's residual taken as independent of the next by the sandwich covariance."""


@dataclasses.dataclass(frozen=True)
class FitOptions:
    """How the fit runs; the defaults are what the bench measured (docs/commissioning.md)."""

    decimate: int = 10
    """Residuals are means over this many samples (5 ms at 2 kHz)."""
    step: float = 0.03
    """Forward-difference step in log parameters (3 %): the plant's response is rough on
    the scale of one integrator step (a commutation moves by a whole step), so a smaller step
    differentiates that roughness rather than the parameter's effect."""
    max_iterations: int = 12
    identifiable_ratio: float = 0.5
    outlier_factor: float = 4.0
    friction_sigmas: float = 4.0
    bound_sigmas: float = math.inf
    """A parameter stays within this many prior sds of its prior mean (inf: unbounded, as
    before; :data:`~.friction_law.CHOOSE_FRICTION_LAW` bounds at 4, twice the tolerance
    band's half-width beyond the centre). A value far outside the part-to-part band is not
    the unit's part: it is the fit compensating a law our plant does not have (on a design
    unit with a voltage-mode drive and stiction the winding resistance went to 4.5x, the
    model's drive then voltage-limited, and a friction fault moved its position where the
    unit's moved its current); bounded, what the parameters cannot express is left to the
    learned discrepancy."""
    chunk: int = 500


@dataclasses.dataclass
class Evaluation:
    """Residuals and Jacobian of one batched model call, per BIT."""

    x: FloatArray
    r: FloatArray
    """(n_bits, K, T) whitened residuals."""
    jac: FloatArray
    """(n_bits, p + 1, K, T): per parameter, then the BIT's own friction factor."""
    raw: FloatArray
    """(n_bits, K, T) model minus record in channel units."""
    cost: float




class Problem:
    def __init__(self, params: ActuatorParams, tol: Sequence[ip.Tolerance],
                 bits: Sequence[BitRecord], opt: FitOptions) -> None:
        self.params, self.tol, self.bits, self.opt = params, tuple(tol), tuple(bits), opt
        self.model = ip.quiet(params)
        self.paths = [t.path for t in self.tol]
        self.mu, self.s = ip.prior(self.tol)
        self.base = np.array([ip.get(params, p) for p in self.paths])
        self.conditions = [condition(params, b) for b in self.bits]
        self.s_nu = float(params.motor.friction_flight_sd)
        n = self.bits[0].n_samples
        self.t = n // opt.decimate
        self.data = recorded(self.bits, opt.decimate)
        self.phase_noise = signal_noise(params)[PHASE_SUM] / math.sqrt(3.0)
        self.scale = noise_scale(params, opt.decimate)
        self.floor = self.scale.copy()
        """A channel is never trusted beyond its sensor noise."""
        floor = supply_floor_v(params)
        self.mask = np.array([[0.0 if (bus < floor and k in SUPPLY_CHANNELS) else 1.0
                               for k in FIT_SIGNALS] for _, bus in self.conditions])
        """(n_bits, K): 0 where a channel says nothing of the unit (see SUPPLY_CHANNELS)."""
        physical = np.array([math.log(UPPER[p] / b) if p in UPPER else np.inf
                             for p, b in zip(self.paths, self.base, strict=True)])
        span = opt.bound_sigmas * self.s if math.isfinite(opt.bound_sigmas) \
            else np.full(self.s.shape, np.inf)
        self.upper = np.minimum(physical, self.mu + span)
        self.lower = self.mu - span
        """Bounds of the log parameters (:attr:`FitOptions.bound_sigmas`, and
        :data:`UPPER`)."""
        self.runs = 0

    @property
    def p(self) -> int:
        return len(self.paths)

    def _actuator(self, theta: FloatArray, nu: float) -> ActuatorParams:
        f = {p: math.exp(v) for p, v in zip(self.paths, theta, strict=True)}
        if self.s_nu > 0.0:
            for p in FRICTION:
                f[p] = f.get(p, 1.0) * math.exp(nu)
        return ip.scaled(self.model, f)

    @property
    def own_friction_run(self) -> bool:
        """Whether a BIT's friction factor needs a perturbed run of its own: not when both
        friction terms are fitted (its column is then exactly the sum of theirs, so the
        unit's friction and the flights' scatter are told apart by the prior alone)."""
        return not all(f in self.paths for f in FRICTION)

    def evaluate(self, x: FloatArray) -> Evaluation:
        """One batched plant call: every BIT's base run and its perturbed runs."""
        p, h, nb = self.p, self.opt.step, len(self.bits)
        per = p + 1 + int(self.own_friction_run)
        specs: list[RunSpec] = []
        for i, (amb, bus) in enumerate(self.conditions):
            theta, nu = x[:p], float(x[p + i])
            for j in range(per):
                th = theta.copy()
                if 0 < j <= p:
                    th[j - 1] += h
                specs.append(RunSpec(self._actuator(th, nu + (h if j == p + 1 else 0.0)),
                                     seed=i, ambient_c=amb, bus_v=bus))
        cmd = np.repeat(np.stack([b.command_deg for b in self.bits]), per, axis=0)
        q = np.repeat([b.dynamic_pressure_pa for b in self.bits], per)
        y = flown(specs, cmd, q, self.opt.decimate, self.phase_noise, self.opt.chunk)
        self.runs += len(specs)
        y = y.reshape(nb, per, len(FIT_SIGNALS), self.t)
        raw = y[:, 0] - self.data
        w = self.mask[:, :, None] / self.scale[None, :, None]
        r = raw * w
        jac = (y[:, 1:] - y[:, :1]) / h * w[:, None]
        if not self.own_friction_run:
            cols = [self.paths.index(f) for f in FRICTION]
            jac = np.concatenate([jac, jac[:, cols].sum(axis=1, keepdims=True)], axis=1)
        return Evaluation(x.copy(), r, jac, raw, self.cost(x, r))

    def cost(self, x: FloatArray, r: FloatArray) -> float:
        prior = np.sum(((x[: self.p] - self.mu) / self.s) ** 2)
        if self.s_nu > 0.0:
            prior += np.sum((x[self.p:] / self.s_nu) ** 2)
        return float(np.sum(r**2) + prior)

    def normal(self, e: Evaluation) -> tuple[FloatArray, FloatArray]:
        """Gauss-Newton normal matrix and gradient over [theta, one nu per BIT]."""
        p, nb = self.p, len(self.bits)
        a = np.zeros((p + nb, p + nb))
        g = np.zeros(p + nb)
        for i in range(nb):
            jm = e.jac[i].reshape(p + 1, -1)
            rv = e.r[i].ravel()
            idx = np.r_[np.arange(p), p + i]
            a[np.ix_(idx, idx)] += jm @ jm.T
            g[idx] += jm @ rv
        x = e.x
        a[:p, :p] += np.diag(1.0 / self.s**2)
        g[:p] += (x[:p] - self.mu) / self.s**2
        nu_var = self.s_nu**2 if self.s_nu > 0.0 else 1e-12
        a[p:, p:] += np.eye(nb) / nu_var
        g[p:] += x[p:] / nu_var
        return a, g

    def covariance(self, e: Evaluation) -> FloatArray:
        """Posterior covariance of theta: the Gauss-Newton one, widened per parameter where a
        sandwich estimate says the data tell less (the residual's stretches of
        :data:`SEGMENT_S` taken as independent: model error is smooth over milliseconds, so
        the white-noise covariance alone is too sure). Correlations are the Gauss-Newton's."""
        a, _ = self.normal(e)
        ainv = np.linalg.inv(a)
        p, nb = self.p, len(self.bits)
        seg = max(1, round(SEGMENT_S * self.bits[0].sample_rate_hz / self.opt.decimate))
        b = np.zeros_like(a)
        for i in range(nb):
            idx = np.r_[np.arange(p), p + i]
            for s0 in range(0, self.t, seg):
                g = np.einsum("jkt,kt->j", e.jac[i][:, :, s0:s0 + seg], e.r[i][:, s0:s0 + seg])
                b[np.ix_(idx, idx)] += np.outer(g, g)
        nu_var = self.s_nu**2 if self.s_nu > 0.0 else 1e-12
        b += np.diag(np.r_[1.0 / self.s**2, np.full(nb, 1.0 / nu_var)])
        gn = ainv[:p, :p]
        widen = np.sqrt(np.maximum(np.diag((ainv @ b @ ainv)[:p, :p]) / np.diag(gn), 1.0))
        out: FloatArray = gn * np.outer(widen, widen)
        return out

    def reweight(self, e: Evaluation) -> None:
        """Rescale each channel's noise by its residual variance and lag-one correlation."""
        for k in range(len(FIT_SIGNALS)):
            rk = e.r[self.mask[:, k] > 0, k, :]
            if rk.size == 0:
                continue
            var = float(np.mean(rk**2))
            rho = float(np.sum(rk[:, 1:] * rk[:, :-1]) / max(np.sum(rk**2), 1e-300))
            rho = min(max(rho, 0.0), 0.95)
            self.scale[k] *= math.sqrt(var * (1.0 + rho) / (1.0 - rho))
        self.scale = np.maximum(self.scale, self.floor)


