"""System identification of one actuator from its healthy BITs: the paper's model adaptation
done once, at commissioning, by fitting our plant to what the unit recorded.

Given the data sheet (:class:`~mapr_daemon.ema.params.ActuatorParams`), the parameters it
leaves uncertain with their tolerances (:mod:`~mapr_daemon.reasoner.commissioning.prior`) and a
few healthy BIT records (:mod:`~mapr_daemon.reasoner.commissioning.bits`), :func:`identify` finds
the maximum a-posteriori parameters: it flies our plant (:class:`~mapr_daemon.ema.plant.EmaBatch`,
the reasoner's model) through each recorded BIT — same command, same dynamic pressure, the
record's own ambient temperature and bus voltage — and minimises the residuals of the
recorded signals (:data:`~mapr_daemon.reasoner.commissioning.bits.FIT_SIGNALS`, time series
averaged over ``decimate`` samples, each scaled by its sensor noise) plus the prior's
penalty, in log parameters, by Levenberg-Marquardt.

* Each BIT has its own friction factor (log-normal, sd ``motor.friction_flight_sd``): the
  grease's flight-to-flight scatter is real and not the unit's; the unit's friction is what
  the BITs share. When both friction terms are fitted its Jacobian column is the sum of
  theirs; otherwise it costs one more perturbed run per BIT.
* One batched plant call per iteration: for every BIT the base run and one run per parameter
  perturbed by ``step`` in log space, all with the BIT's seed (common random numbers; the
  model is noise-free anyway, :func:`identify_prior.quiet`). The Jacobian is their forward
  differences.
* Weights: first the data sheet's sensor noise; after a fit each signal's noise is rescaled
  by its residual variance and by ``(1 + rho)/(1 - rho)`` for its residuals' lag-one
  correlation (model error is smooth, not white), and the fit continues from there until
  the scales settle.
* BITs flown on a bus below the supply floor
(:func:`~mapr_daemon.reasoner.diagnosis.healthy_model.supply_floor_v`)
  are fitted on the motor-side signals only (``identify_problem.SUPPLY_CHANNELS``).
* Uncertainty: the posterior covariance ``(J'WJ + prior precision)^-1`` at the optimum,
  widened per parameter by a sandwich estimate (``identify_problem.Problem.covariance``).
  A parameter is *identifiable* from these BITs when its posterior sd is below
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

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import FIT_SIGNALS, BitRecord, unusable
from mapr_daemon.reasoner.commissioning.problem import Evaluation, FitOptions, Problem

__all__ = ["Estimate", "FitOptions", "Identification", "UsedBit", "identify"]
REWEIGHT_ROUNDS = 3

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
    friction_law: dict[str, object] | None = None
    """The friction law chosen and every law's score
    (:meth:`~mapr_daemon.reasoner.commissioning.friction_law.LawChoice.to_json`); None when
    no choice was made (:func:`identify` alone; the choice is
    :func:`~mapr_daemon.reasoner.commissioning.friction_law.identify_with_law`)."""


def _solve(pr: Problem, e: Evaluation, progress: Callable[[str], None] | None
           ) -> tuple[Evaluation, int, bool]:
    """Levenberg-Marquardt from ``e``; stops on a small step, a stalled cost (the model's
    roughness allows no finer optimum) or three rejected steps in a row."""
    lam, rejected = 0.1, 0
    for it in range(1, pr.opt.max_iterations + 1):
        a, g = pr.normal(e)
        dx = np.linalg.solve(a + lam * np.diag(np.diag(a)), -g)
        x = e.x + dx
        x[: pr.p] = np.clip(x[: pr.p], pr.lower, pr.upper)
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




def _fit(pr: Problem, x0: FloatArray, progress: Callable[[str], None] | None
         ) -> tuple[Evaluation, Evaluation, int, bool]:
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


def _suspects(pr: Problem, e: Evaluation) -> dict[int, str]:
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
        pr = Problem(params, tolerances, good, opt)
        first, e, iterations, converged = _fit(pr, np.zeros(pr.p + len(good)), progress)
        runs += pr.runs
        bad = _suspects(pr, e)
        if not bad:
            break
        skipped += [(good[i].name(), why) for i, why in sorted(bad.items())]
        good = [b for i, b in enumerate(good) if i not in bad]
    return _result(pr, first, e, skipped, iterations, converged, runs,
                   time.monotonic() - start)


def _result(pr: Problem, first: Evaluation, e: Evaluation, skipped: list[tuple[str, str]],
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
