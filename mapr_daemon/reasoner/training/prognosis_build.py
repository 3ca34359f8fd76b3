"""Learning an actuator type's prognostic model from simulated BITs (``--prognosis FILE``).

Flies the training and calibration BITs of :func:`build_prognostic_model` in one batch at known
degradations over the flight envelope, fits one degradation estimator per aging kind, measures
each estimate's noise against the truth, and learns the fleet prior on the aging shape from the
aging model's run-to-failure paths; what it returns is the
:class:`~mapr_daemon.reasoner.prognosis.soh.PrognosticModel` the daemon loads.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from mapr_daemon.ema.faults import Fault, FaultSet, nominal_value
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.prognosis import soh, trend, wear_estimators
from mapr_daemon.reasoner.prognosis.prognostic_model import AGING_KINDS, PrognosticModel
from mapr_daemon.reasoner.training.corpus import BitRuns
from mapr_daemon.reasoner.training.dictionary_build import stream_matrices
from mapr_daemon.reasoner.training.rul_scoring import (
    CALIBRATION_LEVELS,
    TRAINING_BIT_SEED,
    learn_prior,
)

TRAINING_SEED = TRAINING_BIT_SEED
"""First simulation seed of the estimators' training BITs (as the RUL bench's)."""
CALIBRATION_SEED = 8_000_000
"""First simulation seed of the noise-calibration BITs (disjoint from training)."""
RESOLVE_SD = 0.5
"""A kind is trended only if one BIT's estimate at the failure threshold scatters by less than
this (sd, in units of the threshold; median over the calibration BITs' conditions): at 0.5 a
single BIT cannot tell new from failed at two sd. The aileron's SMPS low-side Ron (sd ~1.4-2.3)
and inverter phase-A Ron (~0.8) fail it; with them trended, healthy units over the envelope
showed a wearing mode at 16 of 480 BITs, almost all of it the low side's scatter."""



@dataclasses.dataclass(frozen=True)
class BuildSpec:
    """How many BITs and units the model is learned from."""

    training_bits: int = 800
    """Training BITs per kind for its estimator (its forward model has 25 terms per
    coordinate, :func:`~mapr_daemon.reasoner.prognosis.wear_estimators.regressors`)."""
    calibration_reps: int = 30
    """Calibration BITs per level and kind (300 per kind: enough to fit the noise's
    dependence on the flight condition,
    :data:`~mapr_daemon.reasoner.prognosis.wear_noise.CONDITION_TERMS`)."""
    fleet_units: int = 30
    """Run-to-failure units per kind behind the fleet prior."""
    envelope: bool = True
    """Draw ambient temperature and aircraft-bus voltage over the actuator's envelope (else
    nominal); pressures uniform up to the envelope's maximum, a fifth of the BITs on the
    ground."""
    flight_share: float = 0.5
    """Share of each level's calibration BITs flown at the actuator's own flight-to-flight
    spread of ambient temperature and bus voltage (the data sheet's ``thermal.ambient_c`` +-
    ``ambient_flight_sd_k``, ``bus.nominal_v`` +- ``flight_mean_sd_v``: what a flight's BIT
    sees) instead of uniformly over the envelope; the pressures are drawn alike. With every
    calibration BIT over the envelope, the least squares of the calibration at a condition
    is set by the envelope's edges (where one estimate scatters 2-10 times more) and reads
    BITs flown at usual conditions with a bias and a sd off by up to 2x (docs/reasoner.md,
    "Why the product's estimates differ from the calibration's")."""



def fault_at(params: ActuatorParams, kind: str, h: float) -> FaultSet:
    """The fault set of ``kind`` at degradation ``h`` (healthy at ``h <= 0``)."""
    lo = nominal_value(params, kind)
    value = lo + h * (soh.failure_value(params, kind) - lo)
    return FaultSet.of([Fault(kind, value)]) if h > 0 else FaultSet()


def conditions(params: ActuatorParams, n: int, rng: np.random.Generator, envelope: bool
               ) -> tuple[list[float], list[float | None], list[float | None]]:
    """Flight conditions of ``n`` BITs: pressures (a fifth on the ground) and, over the
    envelope, ambient temperature and aircraft-bus voltage."""
    q = rng.uniform(0.0, params.envelope.max_dynamic_pressure_pa, n)
    q[rng.random(n) < 0.2] = 0.0
    if not envelope:
        return [float(v) for v in q], [None] * n, [None] * n
    amb = rng.uniform(params.envelope.ambient_min_c, params.envelope.ambient_max_c, n)
    bus = rng.uniform(params.bus.min_v, params.bus.max_v, n)
    return [float(v) for v in q], [float(v) for v in amb], [float(v) for v in bus]


def flight_spread(n_train: int, blocks: int, reps: int, share: float) -> list[bool]:
    """Which BITs of the build's batch (``n_train`` training BITs, then ``blocks`` calibration
    levels of ``reps`` BITs each) are flown at the plant's own flight-to-flight draw of ambient
    and bus: the last ``round(share * reps)`` of every level (the training BITs never, so the
    estimators do not depend on ``share``)."""
    k = min(max(round(share * reps), 0), reps)
    return [False] * n_train + [r >= reps - k for _ in range(blocks) for r in range(reps)]


def build_prognostic_model(d: Dictionary, params: ActuatorParams, spec: BuildSpec = BuildSpec(),
                           *, kinds: tuple[str, ...] = AGING_KINDS,
                           workers: int | None = None,
                           progress: Callable[[float], None] | None = None) -> PrognosticModel:
    """Fly the training and calibration BITs (one batch), fit the estimators, measure their
    noise, learn the priors. ``progress(fraction)`` is told the share of BITs flown (the
    bulk of the time)."""
    rng = np.random.default_rng(TRAINING_SEED)
    train = [(k, float(h)) for k in kinds for h in rng.uniform(*wear_estimators.TRAINING_RANGE,
                                                               spec.training_bits)]
    cal = [(k, h) for k in kinds for h in CALIBRATION_LEVELS
           for _ in range(spec.calibration_reps)]
    todo = train + cal
    q, amb, bus = conditions(params, len(todo), rng, spec.envelope)
    flown = flight_spread(len(train), len(kinds) * len(CALIBRATION_LEVELS),
                          spec.calibration_reps, spec.flight_share)
    amb = [None if f else a for a, f in zip(amb, flown, strict=True)]
    bus = [None if f else b for b, f in zip(bus, flown, strict=True)]
    seeds = [TRAINING_SEED + i for i in range(len(train))] + \
        [CALIBRATION_SEED + i for i in range(len(cal))]
    runs = BitRuns.of([fault_at(params, k, h) for k, h in todo], q, seeds, amb, bus)
    m = stream_matrices(params, runs, d.window_starts, d.window_samples, d.signals,
                        progress=progress, workers=workers)
    y, c = wear_estimators.observations(d, m, q)
    n = len(train)
    estimators = wear_estimators.fit_kinds(kinds, y[:n], c[:n], np.array([h for _, h in train]),
                                [k for k, _ in train])
    noise: dict[str, trend.Noise] = {}
    why: dict[str, str] = {}
    for k in kinds:
        rows = [n + i for i, (kk, _) in enumerate(cal) if kk == k]
        truth = np.array([todo[r][1] for r in rows])
        est = np.array([estimators[k].estimate(y[r], c[r]) for r in rows])
        try:
            measured = trend.Noise.measure(truth, est, c[rows])
        except ConfigError as error:
            why[k] = error.detail
            continue
        spread = [r for r in rows if not flown[r]] or rows   # the gate's median: the envelope
        at_threshold = float(np.median(measured.h_sd(np.ones(len(spread)), c[spread])))
        if at_threshold > RESOLVE_SD:
            why[k] = (f"one BIT's estimate scatters by sd {at_threshold:.2f} of the failure "
                      f"threshold at the threshold (median over the envelope), above "
                      f"{RESOLVE_SD}: a trend cannot place the crossing and its evidence of wear "
                      "would be noise")
            continue
        noise[k] = measured
    priors = {k: learn_prior(params, k, spec.fleet_units) for k in kinds}
    supply = d.healthy.supply_nominal_v if d.healthy is not None else math.nan
    return PrognosticModel(params.name, estimators, noise, why, priors, supply)
