"""The prognostic model of an actuator type: what turns its BITs into a trend and a RUL.

A fault dictionary tells faults apart; trending one part's aging needs three more things,
all learned from the actuator's data sheet (no unit's own data) and kept in one file beside
the dictionary (``mapr dictionary build --prognosis FILE``, format :data:`FORMAT`):

* per aging kind a degradation estimator
(:class:`~mapr_daemon.reasoner.prognosis.wear_estimators.WearModel`), trained on BITs flown
  at known degradations over the flight envelope (pressures, ambient temperatures and
  aircraft-bus voltages drawn like the dictionary's, seeds of their own);
* per kind the estimate's measured scale error and scatter
(:class:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise`),
  from calibration BITs at known degradations with yet other seeds, half over the same
  envelope and half at the actuator's flight-to-flight spread (:attr:`BuildSpec.flight_share`),
  the scatter as a function of the degradation and the BIT's flight condition (the error
  of one estimate differs several-fold across the envelope); a kind whose estimate does not
  follow its degradation gets no noise model and the reason, and is never trended;
* per kind the fleet prior on its aging shape (:class:`~.trend.ShapePrior`), learned from the
  aging model's run-to-failure paths
  (:func:`~mapr_daemon.reasoner.training.rul_scoring.learn_prior`).

:meth:`PrognosticModel.estimates` reads one BIT's feature matrix as a degradation fraction
per kind and :meth:`PrognosticModel.bit_conditions` the flight condition it was flown at
(stored with it: the trend weighs each estimate by its noise at that condition);
:mod:`~mapr_daemon.reasoner.prognosis.assessment` fits the trend.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis import healthy_model
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.prognosis import trend, wear_estimators, wear_noise, wear_paths

FORMAT = "mapr-prognosis/2"
AGING_KINDS: tuple[str, ...] = tuple(sorted(trend.SHAPES))
"""The kinds the aging model ages and the trend can follow."""

@dataclasses.dataclass(frozen=True)
class PrognosticModel:
    """Estimators, their measured noise and the fleet priors, per aging kind."""

    actuator: str
    estimators: dict[str, wear_estimators.WearModel]
    noise: dict[str, trend.Noise]
    """Only the kinds whose estimate follows the degradation."""
    unobservable: dict[str, str]
    """The kinds that cannot be trended, and why (measured on the calibration BITs)."""
    priors: dict[str, trend.ShapePrior]
    supply_nominal_v: float = math.nan
    """The healthy model's nominal aircraft-bus voltage (what conditions are scaled by)."""
    assumed_lives: frozenset[str] = frozenset()
    """The kinds whose life nobody stated (:meth:`with_lives`): their prior holds the aging
    model's assumed life loosely, and the headline RUL is withheld while a unit's readings
    have not narrowed it (:data:`~.trend.LEANS`). A stated life is the user's reliability
    figure, and a RUL that leans on it is what was asked for."""
    own_offset: frozenset[str] = frozenset()
    """The kinds read against the unit's own baseline (:meth:`against_baseline`): their
    offset is the unit's, measured and subtracted, so the trend puts no fleet unit offset
    on them (:data:`~.trend.UNIT_OFFSET_MEAN` and :data:`~.trend.UNIT_OFFSET_SD` are the
    estimators')."""
    estimators_noise: dict[str, trend.Noise] = dataclasses.field(default_factory=dict)
    """The estimators' own noise of each kind :attr:`noise` holds the baseline's for
    (:meth:`against_baseline`): what a reading of that kind by the estimators is weighed by
    (a BIT flown before the unit was commissioned, :mod:`.wear_paths`)."""

    @property
    def kinds(self) -> tuple[str, ...]:
        """The kinds the trend follows."""
        return tuple(k for k in AGING_KINDS if k in self.noise)

    def estimates(self, dictionary: Dictionary, m: FloatArray,
                  dynamic_pressure_pa: float) -> dict[str, float]:
        """One BIT's degradation fraction per trended kind (0 healthy, 1 at the failure
        threshold), from its feature matrix ``m (W, C)``."""
        y, c = wear_estimators.observations(dictionary, m[None], [dynamic_pressure_pa])
        return {k: round(self.estimators[k].estimate(y[0], c[0]), 5) for k in self.kinds}

    @staticmethod
    def bit_conditions(dictionary: Dictionary, m: FloatArray,
                       dynamic_pressure_pa: float) -> dict[str, float]:
        """The flight condition one BIT was flown at, as the estimators read it from its
        feature matrix: dynamic pressure (Pa), mean aircraft-bus voltage (V), ambient
        temperature (deg C); empty if any is not finite (a damaged record)."""
        c = healthy_model.conditions(m, dictionary.columns, dynamic_pressure_pa)
        out = {"dynamic_pressure_pa": round(c.pressure_pa, 1), "supply_v": round(c.supply_v, 3),
               "ambient_c": round(c.temperature_c, 2)}
        return out if all(math.isfinite(v) for v in out.values()) else {}

    def scaled(self, condition: Mapping[str, float] | None) -> tuple[float, float, float] | None:
        """A stored :meth:`bit_conditions` as the noise model takes it; None if unknown."""
        if condition is None or not math.isfinite(self.supply_nominal_v):
            return None
        try:
            c = healthy_model.Conditions(float(condition["dynamic_pressure_pa"]),
                                   float(condition["supply_v"]), math.nan,
                                   float(condition["ambient_c"]))
        except (TypeError, KeyError, ValueError):
            return None
        return healthy_model.scaled(c, self.supply_nominal_v)

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
        return dataclasses.replace(self, priors=priors,
                                   assumed_lives=frozenset(set(self.priors) - set(lives)))

    def against_baseline(self, noise: Mapping[str, wear_noise.Noise]) -> PrognosticModel:
        """This model for a commissioned unit whose wear of the kinds in ``noise`` is read
        against its own baseline
        (:meth:`~mapr_daemon.reasoner.commissioning.baseline.Baseline.wear_estimates`): those
        kinds' readings are weighed by ``noise`` (measured on the unit's held-out healthy
        BITs), the others by the estimators' own, and those kinds take no fleet unit offset
        (:attr:`own_offset`). The fleet priors are unchanged."""
        mine = {k: n for k, n in noise.items() if k in self.noise}
        return dataclasses.replace(self, noise={**self.noise, **mine},
                                   own_offset=self.own_offset | frozenset(mine),
                                   estimators_noise={**{k: self.noise[k] for k in mine},
                                                     **self.estimators_noise})

    def estimator_noise(self, kind: str) -> trend.Noise:
        """The noise a reading of ``kind`` by the estimators is weighed by (the estimators'
        own, also where this unit's readings are the baseline's)."""
        return self.estimators_noise.get(kind, self.noise[kind])

    def path_noise(self, kind: str, sources: Sequence[Mapping[str, wear_paths.Source] | None]
                   ) -> wear_paths.PathNoise:
        """Each BIT's reading of ``kind`` with the noise of the path that read it, from the
        BITs' stored ``sources`` (:func:`~.wear_paths.for_kind`): the estimators', a
        baseline's, or (unknown) this model's path now."""
        return wear_paths.for_kind(kind, sources, self.estimator_noise(kind), self.noise[kind],
                                   kind in self.own_offset)

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
            estimators[k] = wear_estimators.WearModel(k, a[f"{k}_coef"], a[f"{k}_precision"],
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
"""The :class:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise` fields stored as JSON lists,
read back as tuples."""


def _noise_json(noise: trend.Noise) -> dict[str, Any]:
    out = dataclasses.asdict(noise)
    for f in TUPLE_FIELDS:
        out[f] = list(getattr(noise, f))
    return out


