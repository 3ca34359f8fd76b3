"""System identification of one actuator from its healthy BITs: the paper's model adaptation
done once, at commissioning, by fitting our plant to what the unit recorded.

Given the data sheet (:class:`~mapr_daemon.ema.params.ActuatorParams`), the parameters it
leaves uncertain with their tolerances (:mod:`~mapr_daemon.reasoner.identify_prior`) and a
few healthy BIT records (:mod:`~mapr_daemon.reasoner.identify_bits`), :func:`identify` finds
the maximum a-posteriori parameters: it flies our plant (:class:`~mapr_daemon.ema.plant.EmaBatch`,
the reasoner's model) through each recorded BIT — same command, same dynamic pressure, the
record's own ambient temperature and bus voltage — and minimises the recorded channels'
residuals (:data:`~mapr_daemon.reasoner.identify_bits.FIT_CHANNELS`, time series averaged
over ``decimate`` samples, each scaled by its sensor noise) plus the prior's penalty, in log
parameters, by Levenberg-Marquardt.

* Each BIT has its own friction factor (log-normal, sd ``motor.friction_flight_sd``): the
  grease's flight-to-flight scatter is real and not the unit's; the unit's friction is what
  the BITs share. It costs no extra model runs' worth of bookkeeping: one more perturbed run
  per BIT.
* One batched plant call per iteration: for every BIT the base run and one run per parameter
  (and the friction factor) perturbed by ``step`` in log space, all with the BIT's seed
  (common random numbers; the model is noise-free anyway, :func:`identify_prior.quiet`).
  The Jacobian is their forward differences.
* Weights: first the data sheet's sensor noise; after a first fit each channel's weight is
  rescaled by its residual variance and by ``(1 + rho)/(1 - rho)`` for its residuals' lag-one
  correlation (model error is smooth, not white), and the fit continues from there, so the
  reported uncertainty counts the residual that is really there.
* Uncertainty: the posterior covariance ``(J'WJ + prior precision)^-1`` at the optimum. A
  parameter is *identifiable* from these BITs when its posterior sd is below
  ``identifiable_ratio`` of its prior sd; one that is not keeps its data sheet value.
* A BIT whose residual is far above the others' (``outlier_factor`` x their median) or whose
  friction factor is beyond ``friction_sigmas`` of the scatter looks faulty: it is dropped
  with its reason and the fit is repeated without it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner import identify_prior as ip
from mapr_daemon.reasoner.build import supply_floor_v
from mapr_daemon.reasoner.features import FloatArray
from mapr_daemon.reasoner.identify_bits import (
    FIT_CHANNELS,
    FIT_SIGNALS,
    PHASE_SUM,
    BitRecord,
    condition,
    fit_signals,
    signal_noise,
    unusable,
)

FRICTION = ("motor.viscous_friction_nm_s", "motor.coulomb_friction_nm")
SUPPLY_CHANNELS = ("dc_bus_voltage_v", "ripple_rms_v", "smps_input_current_a")
"""Channels a BIT on a bus below the supply floor (:func:`build.supply_floor_v`) cannot be
fitted on: the converter sits at its duty limit and its output follows the bus's drift and
ripple within the BIT, which the model (flying each BIT at the bus's mean) does not have."""
UPPER = {"gear.efficiency": 1.0, "smps.max_duty": 0.999}
"""Physical upper limits of parameters a fit may reach."""
REWEIGHT_ROUNDS = 3
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
    chunk: int = 500


@dataclasses.dataclass(frozen=True)
class Estimate:
    """One identified parameter. ``sd_rel`` is the posterior sd of ``log(value)``."""

    path: str
    datasheet: float
    value: float
    """What the identified actuator file says: the fit, or the data sheet if not identifiable."""
    fitted: float
    """The posterior mean, identifiable or not."""
    sd_rel: float
    prior_sd_rel: float
    identifiable: bool

    @property
    def sd(self) -> float:
        """Posterior sd in the parameter's unit (first order: ``fitted * sd_rel``)."""
        return self.fitted * self.sd_rel


@dataclasses.dataclass(frozen=True)
class UsedBit:
    """A BIT the fit used, its condition and how well the identified model explains it."""

    source: str
    index: int
    time: str | None
    label: str
    dynamic_pressure_pa: float
    ambient_c: float
    bus_v: float
    friction_factor: float
    """This flight's friction over the unit's (the grease's scatter)."""
    residual: float
    """RMS of its residuals over their noise after the fit (1 = as noisy as the sensors)."""


@dataclasses.dataclass(frozen=True)
class Identification:
    """What :func:`identify` found."""

    params: ActuatorParams
    estimates: tuple[Estimate, ...]
    residual_before: dict[str, float]
    """RMS of model minus record per channel (its unit), the data sheet's model."""
    residual_after: dict[str, float]
    bits: tuple[UsedBit, ...]
    skipped: tuple[tuple[str, str], ...]
    """(``source#index``, reason) of every record not used."""
    correlation: tuple[tuple[float, ...], ...]
    iterations: int
    converged: bool
    model_runs: int
    wall_s: float


@dataclasses.dataclass
class _Eval:
    """Residuals and Jacobian of one batched model call, per BIT."""

    x: FloatArray
    r: FloatArray
    """(n_bits, K, T) whitened residuals."""
    jac: FloatArray
    """(n_bits, p + 1, K, T): per parameter, then the BIT's own friction factor."""
    raw: FloatArray
    """(n_bits, K, T) model minus record in channel units."""
    cost: float


class _Problem:
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
        self.data = np.stack([[self._dec(v) for v in fit_signals(b.channels).values()]
                              for b in self.bits])
        noise = signal_noise(params)
        self.phase_noise = noise[PHASE_SUM] / math.sqrt(3.0)
        self.scale = np.array([noise[k] for k in FIT_SIGNALS]) / math.sqrt(opt.decimate)
        self.floor = self.scale.copy()
        """A channel is never trusted beyond its sensor noise."""
        floor = supply_floor_v(params)
        self.mask = np.array([[0.0 if (bus < floor and k in SUPPLY_CHANNELS) else 1.0
                               for k in FIT_SIGNALS] for _, bus in self.conditions])
        """(n_bits, K): 0 where a channel says nothing of the unit (see SUPPLY_CHANNELS)."""
        self.upper = np.array([math.log(UPPER[p] / b) if p in UPPER else np.inf
                               for p, b in zip(self.paths, self.base, strict=True)])
        self.runs = 0

    @property
    def p(self) -> int:
        return len(self.paths)

    def _dec(self, y: FloatArray) -> FloatArray:
        d = self.opt.decimate
        out: FloatArray = np.asarray(y[: self.t * d], dtype=np.float64).reshape(
            self.t, d).mean(axis=1)
        return out

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

    def evaluate(self, x: FloatArray) -> _Eval:
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
        q = np.repeat([b.dynamic_pressure_pa for b in self.bits], per)[:, None]
        plant = EmaBatch(specs)
        n = self.bits[0].n_samples
        parts: dict[str, list[FloatArray]] = {k: [] for k in FIT_CHANNELS}
        for start in range(0, n, self.opt.chunk):
            stop = min(n, start + self.opt.chunk)
            block = plant.advance(stop - start, np.ascontiguousarray(cmd[:, start:stop]), q)
            for k in FIT_CHANNELS:
                parts[k].append(block.channels[k])
        self.runs += len(specs)
        d = self.opt.decimate
        sig = fit_signals({k: np.concatenate(v, axis=1) for k, v in parts.items()},
                          self.phase_noise)
        y = np.stack([sig[k][:, : self.t * d].reshape(nb * per, self.t, d).mean(axis=2)
                      for k in FIT_SIGNALS], axis=1)
        y = y.reshape(nb, per, len(FIT_SIGNALS), self.t)
        raw = y[:, 0] - self.data
        w = self.mask[:, :, None] / self.scale[None, :, None]
        r = raw * w
        jac = (y[:, 1:] - y[:, :1]) / h * w[:, None]
        if not self.own_friction_run:
            cols = [self.paths.index(f) for f in FRICTION]
            jac = np.concatenate([jac, jac[:, cols].sum(axis=1, keepdims=True)], axis=1)
        return _Eval(x.copy(), r, jac, raw, self.cost(x, r))

    def cost(self, x: FloatArray, r: FloatArray) -> float:
        prior = np.sum(((x[: self.p] - self.mu) / self.s) ** 2)
        if self.s_nu > 0.0:
            prior += np.sum((x[self.p:] / self.s_nu) ** 2)
        return float(np.sum(r**2) + prior)

    def normal(self, e: _Eval) -> tuple[FloatArray, FloatArray]:
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

    def covariance(self, e: _Eval) -> FloatArray:
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

    def reweight(self, e: _Eval) -> None:
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


def _solve(pr: _Problem, e: _Eval, progress: Callable[[str], None] | None
           ) -> tuple[_Eval, int, bool]:
    """Levenberg-Marquardt from ``e``; stops on a small step, a stalled cost (the model's
    roughness allows no finer optimum) or three rejected steps in a row."""
    lam, rejected = 0.1, 0
    for it in range(1, pr.opt.max_iterations + 1):
        a, g = pr.normal(e)
        dx = np.linalg.solve(a + lam * np.diag(np.diag(a)), -g)
        x = e.x + dx
        x[: pr.p] = np.minimum(x[: pr.p], pr.upper)
        trial = pr.evaluate(x)
        if progress is not None:
            progress(f"iteration {it}: cost {trial.cost:.1f} (was {e.cost:.1f})")
        if trial.cost < e.cost:
            sd = np.sqrt(np.diag(np.linalg.inv(a)))
            small = float(np.max(np.abs(dx) / sd)) < 0.1
            stalled = (e.cost - trial.cost) < 1e-3 * e.cost
            e, lam, rejected = trial, max(lam / 3.0, 1e-6), 0
            if small or stalled:
                return e, it, True
        else:
            lam, rejected = lam * 10.0, rejected + 1
            if rejected == 3:
                return e, it, True
    return e, pr.opt.max_iterations, False




def _fit(pr: _Problem, x0: FloatArray, progress: Callable[[str], None] | None
         ) -> tuple[_Eval, _Eval, int, bool]:
    """Fit, rescale the channels' noise to the residuals, refit until the scales settle.
    Returns the data sheet's evaluation (for the residual before), the fit, iterations and
    whether the last round converged."""
    first = e = pr.evaluate(x0)
    total = 0
    converged = False
    for _ in range(REWEIGHT_ROUNDS):
        e, its, converged = _solve(pr, e, progress)
        total += its
        before = pr.scale.copy()
        pr.reweight(e)
        e = pr.evaluate(e.x)
        if float(np.max(np.abs(np.log(pr.scale / before)))) < math.log(1.2):
            break
    return first, e, total, converged


def _rms(raw: FloatArray) -> dict[str, float]:
    return {k: float(np.sqrt(np.mean(raw[:, j] ** 2))) for j, k in enumerate(FIT_SIGNALS)}


def _suspects(pr: _Problem, e: _Eval) -> dict[int, str]:
    per_bit = np.sqrt(np.mean(e.r**2, axis=(1, 2)))
    out: dict[int, str] = {}
    nb = len(pr.bits)
    for i in range(nb):
        others = np.delete(per_bit, i)
        if nb >= 3 and per_bit[i] > pr.opt.outlier_factor * float(np.median(others)):
            out[i] = (f"faulty-looking: residual {per_bit[i] / np.median(others):.1f}x the "
                      "median of the other BITs")
        nu = float(e.x[pr.p + i])
        if pr.s_nu > 0.0 and abs(nu) > pr.opt.friction_sigmas * pr.s_nu:
            out[i] = (f"faulty-looking: friction x{math.exp(nu):.2f} of the unit's, "
                      f"{abs(nu) / pr.s_nu:.1f} sd of the flight-to-flight scatter")
    return out


def identify(params: ActuatorParams, bits: Sequence[BitRecord],
             tolerances: Sequence[ip.Tolerance] = ip.DEFAULT_TOLERANCES,
             options: FitOptions | None = None,
             progress: Callable[[str], None] | None = None) -> Identification:
    """Fit ``tolerances``' parameters of ``params`` to the healthy ``bits``.

    Records that cannot be used are skipped with their reason (see ``Identification.skipped``);
    :class:`ConfigError` only if none is left or the tolerances name no parameter.
    """
    opt = options or FitOptions()
    if not tolerances:
        raise ConfigError("nothing to identify", field="tolerances")
    for t in tolerances:
        ip.get(params, t.path)
    start = time.monotonic()
    lengths = [b.n_samples for b in bits]
    common = max(set(lengths), key=lengths.count) if lengths else None
    skipped: list[tuple[str, str]] = []
    good: list[BitRecord] = []
    for b in bits:
        why = unusable(params, b, common)
        if why is None:
            good.append(b)
        else:
            skipped.append((b.name(), why))
    runs = 0
    while True:
        if not good:
            raise ConfigError("no usable BIT: " + "; ".join(f"{n}: {w}" for n, w in skipped),
                              field="bits")
        pr = _Problem(params, tolerances, good, opt)
        first, e, iterations, converged = _fit(pr, np.zeros(pr.p + len(good)), progress)
        runs += pr.runs
        bad = _suspects(pr, e)
        if not bad:
            break
        skipped += [(good[i].name(), why) for i, why in sorted(bad.items())]
        good = [b for i, b in enumerate(good) if i not in bad]
    return _result(pr, first, e, skipped, iterations, converged, runs,
                   time.monotonic() - start)


def _result(pr: _Problem, first: _Eval, e: _Eval, skipped: list[tuple[str, str]],
            iterations: int, converged: bool, runs: int, wall: float) -> Identification:
    cov = pr.covariance(e)
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd)
    estimates = []
    factors: dict[str, float] = {}
    for j, t in enumerate(pr.tol):
        fitted = float(pr.base[j] * math.exp(e.x[j]))
        ok = bool(sd[j] < pr.opt.identifiable_ratio * pr.s[j])
        value = fitted if ok else float(pr.base[j])
        if ok:
            factors[t.path] = math.exp(e.x[j])
        estimates.append(Estimate(t.path, float(pr.base[j]), value, fitted, float(sd[j]),
                                  float(pr.s[j]), ok))
    per_bit = np.sqrt(np.mean(e.r**2, axis=(1, 2)))
    used = tuple(UsedBit(b.source, b.index, b.time, b.label, b.dynamic_pressure_pa, amb, bus,
                         math.exp(float(e.x[pr.p + i])), float(per_bit[i]))
                 for i, (b, (amb, bus)) in enumerate(zip(pr.bits, pr.conditions, strict=True)))
    return Identification(
        params=ip.scaled(pr.params, factors), estimates=tuple(estimates),
        residual_before=_rms(first.raw), residual_after=_rms(e.raw), bits=used,
        skipped=tuple(skipped), correlation=tuple(tuple(float(v) for v in row) for row in corr),
        iterations=iterations, converged=converged, model_runs=runs, wall_s=wall)
