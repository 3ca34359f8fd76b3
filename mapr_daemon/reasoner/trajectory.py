"""RUL scored along run-to-failure trajectories (issue 5's aging paths with true end of life).

Each unit ages over flights; a BIT is flown on a subset of its flights (evenly spaced from
flight 0 to its end of life, each at its own dynamic pressure and seed). The reasoner's
estimate of the unit's parameter on each BIT (:func:`classifier.kind_severity`, the best fit
of that component's template whatever the anomaly decision) becomes a degradation fraction;
at every BIT from the first quarter of the life on, the trend so far gives a RUL with bounds.
All BITs of all units are simulated in one batch.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mapr_daemon.ema.degradation import Trajectory, trajectory
from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.reasoner import classifier, prognosis
from mapr_daemon.reasoner.build import run_matrices
from mapr_daemon.reasoner.corpus import simulate_bit
from mapr_daemon.reasoner.dictionary import Dictionary
from mapr_daemon.reasoner.features import FloatArray


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


def bit_flights(t: Trajectory, n_points: int) -> FloatArray:
    """Flights with a BIT: evenly spaced over the unit's life (integers, flight 0 first)."""
    last = min(math.floor(t.eol_flight), t.values.size - 1)
    return np.unique(np.linspace(0, last, n_points).round())


def score_units(d: Dictionary, params: ActuatorParams, units: Sequence[tuple[str, int]],
                n_points: int = 24, lambdas: Sequence[float] = (0.5, 0.75),
                alpha: float = 0.2, mean_life: float = 200.0) -> list[Scored]:
    """Simulate and score every (kind, unit seed)."""
    trajs = [trajectory(params, k, int(mean_life * 2), seed, mean_life) for k, seed in units]
    flights = [bit_flights(t, n_points) for t in trajs]
    fs: list[FaultSet] = []
    qs: list[float] = []
    seeds: list[int] = []
    rng = np.random.default_rng(4242)
    for u, (t, fl) in enumerate(zip(trajs, flights, strict=True)):
        for f in fl:
            fs.append(FaultSet.of([t.fault(int(f))]) if f > 0 else FaultSet())
            qs.append(float(rng.uniform(100.0, 2400.0)))
            seeds.append(3_000_000 + 1000 * u + int(f))
    runs = simulate_bit(params, fs, qs, seeds)
    m = run_matrices(runs, d.window_starts, d.window_samples)
    out = []
    row = 0
    for (kind, seed), t, fl in zip(units, trajs, flights, strict=True):
        h_est = np.empty(fl.size)
        for j in range(fl.size):
            s = classifier.kind_severity(d, m[row], qs[row], kind)
            value = at_severity(params, kind, min(max(s, 0.0), 1.0)).value
            h_est[j] = prognosis.degradation(params, kind, value)
            row += 1
        h_true = np.array([prognosis.degradation(params, kind, float(t.values[int(f)]))
                           for f in fl])
        out.append(_score(kind, seed, t, fl, h_true, h_est, lambdas, alpha))
    return out


def _score(kind: str, seed: int, t: Trajectory, fl: FloatArray, h_true: FloatArray,
           h_est: FloatArray, lambdas: Sequence[float], alpha: float) -> Scored:
    times, true_rul, est, lo, hi = [], [], [], [], []
    draws_at: dict[float, FloatArray] = {}
    for j in range(fl.size):
        now = float(fl[j])
        if now < 0.25 * t.eol_flight or j < 3 or t.rul(int(now)) <= 0:
            continue
        r = prognosis.rul_from_trend(fl[: j + 1], h_est[: j + 1], now, seed=j)
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
        t_lam = lam * t.eol_flight
        k = int(np.argmin(np.abs(tt - t_lam)))
        al[lam] = prognosis.alpha_lambda_pass(float(tr[k]), draws_at[float(tt[k])], alpha)
        ra[lam] = prognosis.relative_accuracy(float(tr[k]), float(er[k]))
    ph = prognosis.prognostic_horizon(tt, tr, er, t.eol_flight, alpha)
    return Scored(kind, seed, t.eol_flight, fl, h_true, h_est, tt, tr, er, np.array(lo),
                  np.array(hi), al, ra, ph)
