"""The prognostic model of an actuator type: what turns its BITs into a trend and a RUL.

A fault dictionary tells faults apart; trending one part's aging needs three more things,
all learned from the actuator's data sheet (no unit's own data) and kept in one file beside
the dictionary (``mapr dictionary build --prognosis FILE``, format :data:`FORMAT`):

* per aging kind a degradation estimator (:class:`~.wear.WearModel`), trained on BITs flown
  at known degradations over the flight envelope (pressures, ambient temperatures and
  aircraft-bus voltages drawn like the dictionary's, seeds of their own);
* per kind the estimate's measured scale error and scatter (:class:`~.estimate_noise.Noise`),
  from calibration BITs at known degradations with yet other seeds, half over the same
  envelope and half at the actuator's flight-to-flight spread (:attr:`BuildSpec.flight_share`),
  the scatter as a function of the degradation and the BIT's flight condition (the error
  of one estimate differs several-fold across the envelope); a kind whose estimate does not
  follow its degradation gets no noise model and the reason, and is never trended;
* per kind the fleet prior on its aging shape (:class:`~.trend.ShapePrior`), learned from the
  aging model's run-to-failure paths (:func:`~.trajectory.learn_prior`).

:meth:`PrognosticModel.estimates` reads one BIT's feature matrix as a degradation fraction
per kind and :meth:`PrognosticModel.bit_conditions` the flight condition it was flown at
(stored with it: the trend weighs each estimate by its noise at that condition);
:mod:`.health` fits the trend.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mapr_daemon.ema.faults import Fault, FaultSet, nominal_value
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner import healthy, prognosis, trend, wear
from mapr_daemon.reasoner.build import stream_matrices
from mapr_daemon.reasoner.corpus import BitRuns
from mapr_daemon.reasoner.dictionary import Dictionary
from mapr_daemon.reasoner.features import FloatArray
from mapr_daemon.reasoner.trajectory import CALIBRATION_LEVELS, TRAINING_BIT_SEED, learn_prior

FORMAT = "mapr-prognosis/2"
AGING_KINDS: tuple[str, ...] = tuple(sorted(trend.SHAPES))
"""The kinds the aging model ages and the trend can follow."""
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
    coordinate, :func:`~.wear.regressors`)."""
    calibration_reps: int = 30
    """Calibration BITs per level and kind (300 per kind: enough to fit the noise's
    dependence on the flight condition, :data:`~.estimate_noise.CONDITION_TERMS`)."""
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


@dataclasses.dataclass(frozen=True)
class PrognosticModel:
    """Estimators, their measured noise and the fleet priors, per aging kind."""

    actuator: str
    estimators: dict[str, wear.WearModel]
    noise: dict[str, trend.Noise]
    """Only the kinds whose estimate follows the degradation."""
    unobservable: dict[str, str]
    """The kinds that cannot be trended, and why (measured on the calibration BITs)."""
    priors: dict[str, trend.ShapePrior]
    supply_nominal_v: float = math.nan
    """The healthy model's nominal aircraft-bus voltage (what conditions are scaled by)."""

    @property
    def kinds(self) -> tuple[str, ...]:
        """The kinds the trend follows."""
        return tuple(k for k in AGING_KINDS if k in self.noise)

    def estimates(self, dictionary: Dictionary, m: FloatArray,
                  dynamic_pressure_pa: float) -> dict[str, float]:
        """One BIT's degradation fraction per trended kind (0 healthy, 1 at the failure
        threshold), from its feature matrix ``m (W, C)``."""
        y, c = wear.observations(dictionary, m[None], [dynamic_pressure_pa])
        return {k: round(self.estimators[k].estimate(y[0], c[0]), 5) for k in self.kinds}

    @staticmethod
    def bit_conditions(dictionary: Dictionary, m: FloatArray,
                       dynamic_pressure_pa: float) -> dict[str, float]:
        """The flight condition one BIT was flown at, as the estimators read it from its
        feature matrix: dynamic pressure (Pa), mean aircraft-bus voltage (V), ambient
        temperature (deg C); empty if any is not finite (a damaged record)."""
        c = healthy.conditions(m, dictionary.columns, dynamic_pressure_pa)
        out = {"dynamic_pressure_pa": round(c.pressure_pa, 1), "supply_v": round(c.supply_v, 3),
               "ambient_c": round(c.temperature_c, 2)}
        return out if all(math.isfinite(v) for v in out.values()) else {}

    def scaled(self, condition: Mapping[str, float] | None) -> tuple[float, float, float] | None:
        """A stored :meth:`bit_conditions` as the noise model takes it; None if unknown."""
        if condition is None or not math.isfinite(self.supply_nominal_v):
            return None
        try:
            c = healthy.Conditions(float(condition["dynamic_pressure_pa"]),
                                   float(condition["supply_v"]), math.nan,
                                   float(condition["ambient_c"]))
        except (TypeError, KeyError, ValueError):
            return None
        return healthy.scaled(c, self.supply_nominal_v)

    def with_lives(self, lives: Mapping[str, float] | None = None) -> PrognosticModel:
        """This model with each kind's fleet prior set for the fleet it trends: where
        ``lives[kind]`` states the parts' expected life in flights (the user's reliability
        figure), the prior's life is centred there with the training units' own spread (the
        aging model's part-to-part scatter); where it does not, the life stays the aging
        model's assumption and is held loosely (:data:`~.trend.LIFE_SD`)."""
        lives = lives or {}
        unknown = sorted(set(lives) - set(self.priors))
        if unknown:
            raise ConfigError(f"no fleet prior for {', '.join(unknown)} (aging kinds: "
                              f"{', '.join(sorted(self.priors))})", field="expected_life_flights")
        longest = float(trend.LIVES[-1]) / 2.0
        beyond = sorted(k for k, v in lives.items() if v > longest)
        if beyond:
            raise ConfigError(f"an expected life beyond {longest:g} flights for "
                              f"{', '.join(beyond)}: the trend follows lives up to "
                              f"{float(trend.LIVES[-1]):g}", field="expected_life_flights")
        priors = {k: p.with_life(k, 0.0, lives[k]) if k in lives else
                  p.with_life(k, trend.LIFE_SD) for k, p in self.priors.items()}
        return dataclasses.replace(self, priors=priors)

    # --- persistence -----------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        arrays: dict[str, np.ndarray] = {}
        meta: dict[str, Any] = {"format": FORMAT, "actuator": self.actuator,
                                "supply_nominal_v": self.supply_nominal_v, "kinds": {}}
        for k, est in self.estimators.items():
            arrays[f"{k}_coef"], arrays[f"{k}_precision"] = est.coef, est.precision
            meta["kinds"][k] = {
                "shrinkage": est.shrinkage, "runs": est.runs,
                "noise": _noise_json(self.noise[k]) if k in self.noise else None,
                "unobservable": self.unobservable.get(k),
                "prior": dataclasses.asdict(self.priors[k]) if k in self.priors else None}
        arrays["meta_json"] = np.array(json.dumps(meta))
        np.savez_compressed(Path(path), **arrays)  # type: ignore[arg-type]

    @classmethod
    def load(cls, path: str | Path) -> PrognosticModel:
        """Read a model; ConfigError naming the file if it is missing, corrupt or another
        format."""
        p = Path(path)
        try:
            with np.load(p, allow_pickle=False) as data:
                a = {k: data[k] for k in data.files}
            meta = json.loads(str(a["meta_json"]))
        except (OSError, ValueError, KeyError) as error:
            raise ConfigError(f"cannot read the prognostic model: {error}", path=str(p)) from None
        if meta.get("format") != FORMAT:
            raise ConfigError(f"prognostic model format {meta.get('format')!r}, expected "
                              f"{FORMAT!r} (rebuild it with `mapr dictionary build "
                              "--prognosis`)", path=str(p))
        estimators, noise, why, priors = {}, {}, {}, {}
        for k, km in meta["kinds"].items():
            estimators[k] = wear.WearModel(k, a[f"{k}_coef"], a[f"{k}_precision"],
                                           float(km["shrinkage"]), int(km["runs"]))
            if km["noise"] is not None:
                noise[k] = trend.Noise(**{**km["noise"], **{
                    f: tuple(km["noise"].get(f, ())) for f in TUPLE_FIELDS}})
            if km["unobservable"] is not None:
                why[k] = str(km["unobservable"])
            if km["prior"] is not None:
                priors[k] = trend.ShapePrior(**km["prior"])
        return cls(str(meta["actuator"]), estimators, noise, why, priors,
                   float(meta.get("supply_nominal_v", math.nan)))


TUPLE_FIELDS = ("log_sd", "offset_c", "gain_c", "c_low", "c_high")
"""The :class:`~.estimate_noise.Noise` fields stored as JSON lists, read back as tuples."""


def _noise_json(noise: trend.Noise) -> dict[str, Any]:
    out = dataclasses.asdict(noise)
    for f in TUPLE_FIELDS:
        out[f] = list(getattr(noise, f))
    return out


def fault_at(params: ActuatorParams, kind: str, h: float) -> FaultSet:
    """The fault set of ``kind`` at degradation ``h`` (healthy at ``h <= 0``)."""
    lo = nominal_value(params, kind)
    value = lo + h * (prognosis.failure_value(params, kind) - lo)
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
                           workers: int | None = None) -> PrognosticModel:
    """Fly the training and calibration BITs (one batch), fit the estimators, measure their
    noise, learn the priors."""
    rng = np.random.default_rng(TRAINING_SEED)
    train = [(k, float(h)) for k in kinds for h in rng.uniform(*wear.TRAINING_RANGE,
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
    m = stream_matrices(params, runs, d.window_starts, d.window_samples, workers=workers)
    y, c = wear.observations(d, m, q)
    n = len(train)
    estimators = wear.fit_kinds(kinds, y[:n], c[:n], np.array([h for _, h in train]),
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
