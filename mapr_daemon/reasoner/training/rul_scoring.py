"""RUL scored along run-to-failure trajectories (issue 5's aging paths with true end of life).

Each unit ages over flights; a BIT is flown every ``bit_every`` flights from flight 0 to its end
of life, each at its own dynamic pressure and seed. The kind's degradation estimator
(:mod:`~mapr_daemon.reasoner.prognosis.wear_estimators`, trained on BITs flown at known
degradations with seeds of
their own) reads each BIT as a degradation fraction; at every BIT from the first quarter of
the life on, :func:`trend.fit_rul` fits the kind's aging shape to the estimates so far and
gives a RUL with 5/50/95 % bounds.

What the trend is told, besides the unit's own estimates, and where it comes from:

* the estimate's scale error and noise (:class:`trend.Noise`): measured on calibration BITs
  flown at known degradations (0 to 5/4 of the failure threshold, finer below 0.3,
  ``calibration_reps`` each, seeds and pressures of their own, disjoint from the estimators'
  training BITs and from the scored units' BITs);
* optionally (``use_prior``) a fleet prior on the shape parameter (:class:`trend.ShapePrior`),
  learned from the true degradation paths of ``training_units`` (:data:`FLEET_UNITS`) other
  units of the kind (unit seeds 10,000 and up; the scored units use small seeds) — the
  accelerated-aging records a fleet has of a part, measured directly in the lab: the shape
  parameter jointly with the life, and the part's own flight-to-flight scatter.

All BITs (units, training and calibration) are simulated in one batch.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.degradation import Trajectory, trajectory
from mapr_daemon.ema.faults import Fault, FaultSet, nominal_value
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.prognosis import soh, trend, wear_estimators
from mapr_daemon.reasoner.training import rul_metrics
from mapr_daemon.reasoner.training.corpus import BitRuns
from mapr_daemon.reasoner.training.dictionary_build import stream_matrices

TRAINING_SEED = 10_000
"""First unit seed of the fleet-prior training units (disjoint from scored units' seeds)."""
FLEET_UNITS = 30
"""Run-to-failure units per kind behind the fleet prior."""
UNIT_BIT_SEED = 3_000_000
"""First simulation seed of the scored units' BITs and the calibration BITs."""
TRAINING_BIT_SEED = 7_000_000
"""First simulation seed of the estimators' training BITs (disjoint from the above)."""
TRAINING_BITS = 300
"""Training BITs per kind for its degradation estimator
(:mod:`~mapr_daemon.reasoner.prognosis.wear_estimators`)."""
CALIBRATION_LEVELS: tuple[float, ...] = (0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0, 1.25)
"""Degradations (fractions of the failure threshold) of the noise-calibration BITs."""
CALIBRATION_REPS = 6
"""Calibration BITs per level and kind."""


@dataclasses.dataclass(frozen=True)
class Scored:
    """One unit: its BIT flights, estimates, and the RUL predictions against the truth."""

    kind: str
    seed: int
    eol: float
    flights: FloatArray
    h_true: FloatArray
    h_est: FloatArray
    times: FloatArray
    true_rul: FloatArray
    est_rul: FloatArray
    lower: FloatArray
    upper: FloatArray
    alpha_lambda: dict[float, bool]
    relative_accuracy: dict[float, float]
    horizon: float
    noise: trend.Noise | None
    prior: trend.ShapePrior | None
    unobservable: str | None = None
    """Why no RUL was predicted (the per-BIT estimate does not follow the degradation)."""


def bit_flights(t: Trajectory, every: int) -> FloatArray:
    """Flights with a BIT: every ``every`` flights from flight 0 up to the end of life."""
    last = min(math.floor(t.eol_flight), t.values.size - 1)
    return np.arange(0, last + 1, max(int(every), 1), dtype=np.float64)


def _true_path(params: ActuatorParams, t: Trajectory) -> tuple[FloatArray, FloatArray]:
    last = min(math.floor(t.eol_flight), t.values.size - 1)
    n = np.arange(last + 1, dtype=np.float64)
    return n, np.array([soh.degradation(params, t.kind, float(v))
                        for v in t.values[: last + 1]])


def learn_prior(params: ActuatorParams, kind: str, units: int,
                mean_life: float = 200.0) -> trend.ShapePrior:
    """The fleet prior of a kind from ``units`` training units' true degradation paths (their
    life held as tightly as their own spread: what a fleet whose life is known gives; the
    product loosens it where no life is stated,
    :meth:`~mapr_daemon.reasoner.prognosis.prognostic_model.PrognosticModel
    .with_lives`)."""
    paths = [_true_path(params, trajectory(params, kind, int(mean_life * 2), TRAINING_SEED + i,
                                           mean_life)) for i in range(units)]
    return trend.ShapePrior.learn(kind, paths)


@dataclasses.dataclass(frozen=True)
class Observed:
    """One unit's BITs: flights, true and estimated degradation, the estimate's noise.

    ``noise`` is None (and ``unobservable`` says why) when the kind's per-BIT estimate does
    not follow the degradation on the calibration BITs: no trend can be fitted to it.
    """

    kind: str
    seed: int
    trajectory: Trajectory
    flights: FloatArray
    h_true: FloatArray
    h_est: FloatArray
    noise: trend.Noise | None
    unobservable: str | None


def observe_units(d: Dictionary, params: ActuatorParams, units: Sequence[tuple[str, int]],
                  bit_every: int = 4, mean_life: float = 200.0,
                  calibration_reps: int = CALIBRATION_REPS,
                  training_bits: int = TRAINING_BITS) -> list[Observed]:
    """Fly every unit's BITs, the estimators' training BITs and the calibration BITs (one
    batch, each with its own seeds); train the per-kind estimators, calibrate, estimate."""
    trajs = [trajectory(params, k, int(mean_life * 2), seed, mean_life) for k, seed in units]
    flights = [bit_flights(t, bit_every) for t in trajs]
    kinds = list(dict.fromkeys(k for k, _ in units))
    fs: list[FaultSet] = []
    for t, fl in zip(trajs, flights, strict=True):
        fs += [FaultSet.of([t.fault(int(f))]) if f > 0 else FaultSet() for f in fl]
    n_units = len(fs)

    def at(kind: str, h: float) -> FaultSet:
        lo = nominal_value(params, kind)
        return (FaultSet.of([Fault(kind, lo + h * (soh.failure_value(params, kind) - lo))])
                if h > 0 else FaultSet())

    cal: list[tuple[str, float]] = [(k, h) for k in sorted(kinds) for h in CALIBRATION_LEVELS
                                    for _ in range(calibration_reps)]
    fs += [at(k, h) for k, h in cal]
    rng = np.random.default_rng(4242)
    qs = [float(q) for q in rng.uniform(100.0, 2400.0, len(fs))]
    seeds = [UNIT_BIT_SEED + i for i in range(len(fs))]
    # the estimators' training BITs: degradations, pressures and seeds of their own
    trng = np.random.default_rng(TRAINING_BIT_SEED)
    train = [(k, float(h)) for k in kinds
             for h in trng.uniform(*wear_estimators.TRAINING_RANGE, training_bits)]
    fs += [at(k, h) for k, h in train]
    qs += [float(q) for q in trng.uniform(100.0, 2400.0, len(train))]
    seeds += [TRAINING_BIT_SEED + i for i in range(len(train))]
    m = stream_matrices(params, BitRuns.of(fs, qs, seeds), d.window_starts, d.window_samples,
                        d.signals)
    y, c = wear_estimators.observations(d, m, qs)
    n_cal = n_units + len(cal)
    models = wear_estimators.fit_kinds(kinds, y[n_cal:], c[n_cal:], np.array([h for _, h in train]),
                            [k for k, _ in train])

    def estimate(row: int, kind: str) -> float:
        return models[kind].estimate(y[row], c[row])

    noise: dict[str, trend.Noise | None] = {}
    why: dict[str, str | None] = {}
    for k in kinds:
        rows = [n_units + i for i, (kk, _) in enumerate(cal) if kk == k]
        try:
            noise[k], why[k] = trend.Noise.measure(
                np.array([cal[r - n_units][1] for r in rows]),
                np.array([estimate(r, k) for r in rows])), None
        except ConfigError as e:
            noise[k], why[k] = None, e.detail
    out = []
    row = 0
    for (kind, seed), t, fl in zip(units, trajs, flights, strict=True):
        h_est = np.array([estimate(row + j, kind) for j in range(fl.size)])
        row += fl.size
        h_true = np.array([soh.degradation(params, kind, float(t.values[int(f)]))
                           for f in fl])
        out.append(Observed(kind, seed, t, fl, h_true, h_est, noise[kind], why[kind]))
    return out


def score(observed: Sequence[Observed], params: ActuatorParams, use_prior: bool = True,
          lambdas: Sequence[float] = (0.5, 0.75), alpha: float = 0.2,
          training_units: int = FLEET_UNITS, mean_life: float = 200.0) -> list[Scored]:
    """RUL predictions of observed units against their truth."""
    kinds = sorted({o.kind for o in observed})
    priors = {k: learn_prior(params, k, training_units, mean_life) if use_prior else None
              for k in kinds}
    return [_score(o, lambdas, alpha, priors[o.kind]) for o in observed]


def score_units(d: Dictionary, params: ActuatorParams, units: Sequence[tuple[str, int]],
                bit_every: int = 4, use_prior: bool = True,
                lambdas: Sequence[float] = (0.5, 0.75), alpha: float = 0.2) -> list[Scored]:
    """Simulate and score every (kind, unit seed)."""
    return score(observe_units(d, params, units, bit_every), params, use_prior, lambdas, alpha)


def _score(o: Observed, lambdas: Sequence[float], alpha: float,
           prior: trend.ShapePrior | None) -> Scored:
    t, fl, kind = o.trajectory, o.flights, o.kind
    times, true_rul, est, lo, hi = [], [], [], [], []
    draws_at: dict[float, FloatArray] = {}
    for j in range(fl.size):
        now = float(fl[j])
        if o.noise is None or now < 0.25 * t.eol_flight or j < 3 or t.rul(int(now)) <= 0:
            continue
        r = trend.fit_rul(fl[: j + 1], o.h_est[: j + 1], now, kind, o.noise, prior, seed=j)
        times.append(now)
        true_rul.append(t.eol_flight - now)
        est.append(r.rul)
        lo.append(r.lower)
        hi.append(r.upper)
        draws_at[now] = r.draws
    tt, tr, er = np.array(times), np.array(true_rul), np.array(est)
    al: dict[float, bool] = {}
    ra: dict[float, float] = {}
    for lam in lambdas:
        if tt.size == 0:  # unobservable: every lambda fails
            al[lam], ra[lam] = False, math.nan
            continue
        k = int(np.argmin(np.abs(tt - lam * t.eol_flight)))
        al[lam] = rul_metrics.alpha_lambda_pass(float(tr[k]), draws_at[float(tt[k])], alpha)
        ra[lam] = rul_metrics.relative_accuracy(float(tr[k]), float(er[k]))
    ph = rul_metrics.prognostic_horizon(tt, tr, er, t.eol_flight, alpha) if tt.size else 0.0
    return Scored(kind, o.seed, t.eol_flight, fl, o.h_true, o.h_est, tt, tr, er, np.array(lo),
                  np.array(hi), al, ra, ph, o.noise, prior, o.unobservable)
