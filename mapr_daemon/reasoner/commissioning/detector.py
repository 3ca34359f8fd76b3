"""The unit's own anomaly detector: the BIT's reading against its commissioned baseline,
thresholded where the unit's held-out healthy BITs put it.

A reading (:func:`~mapr_daemon.reasoner.commissioning.severity.read`) gives two numbers, both
mean squares of the residual in units of the unit's held-out healthy spread:

* ``no_fault`` — the "no fault" cost (``Reading.healthy_cost``): how far the BIT sits from the
  unit's healthy prediction. It catches a departure whatever causes it, one no fault
  hypothesis explains included;
* ``explained`` — the generalized likelihood ratio statistic: the "no fault" cost minus the
  best fault hypothesis's (``healthy_cost - least_cost``: the least squares' best, also when
  the phase currents named an open switch), how much of the departure one known fault
  takes away. It catches a small fault whose signature is a direction the healthy scatter
  does not go in, before the no-fault cost has grown out of the scatter.

**Calibration** (at commissioning, :func:`calibrate`). Each commissioning BIT is read against
a baseline that has not seen it: the discrepancy relearned without that BIT
(:func:`~mapr_daemon.reasoner.commissioning.discrepancy.held_out_discrepancies`, each signal's
choice kept), as the discrepancy's own held-out spread is measured. Per statistic, a scaled
chi-square ``g * chi2(nu)`` is fitted to the held-out values by their mean ``m`` and variance
``v`` (``g = v / 2m``, ``nu = 2m^2 / v``: a mean square of correlated Gaussian residuals is
such a variable, with ``nu`` the effective count of independent terms), and the threshold is
its upper ``ALPHA / 2`` quantile, never below the largest held-out value (a healthy BIT of the
unit's own already went there). The two thresholds together hold a healthy BIT's false-alarm
probability to at most :data:`ALPHA` (one in a thousand BITs) as far as the tail fit holds.
A statistic whose held-out values are all below the least positive drop
:data:`FLOOR_EXPLAINED` (no fault ever explained anything on a healthy BIT, or next to nothing)
is fitted as if the largest of them were that floor; a non-finite held-out value fits no tail
(:func:`calibrate` refuses: no detector).

**What a true single fault leaves on this unit** (:func:`single_allowance`, the
:class:`Allowance`). A fault hypothesis never fits a record exactly: it leaves the unit's
healthy scatter, plus its own model error, which grows with the fault's departure (our model's
departure is not the unit's). What it may leave and still be called "the" explanation
(:func:`~mapr_daemon.reasoner.commissioning.unit_decision.verdict`) is measured on the unit's
own data, not taken as a share of the departure:

* ``healthy`` — the leftover healthy scatter allows: the upper :data:`ALPHA_SINGLE` / 2
  point of the held-out "no fault" costs, fitted robustly (:func:`healthy_quantile`: a
  log-normal by median and median absolute deviation; the detector's moment fit floored at
  the largest value would make one held-out BIT at an unvisited condition, 10 times the
  others, the allowance of every BIT: on design seed 1001's first aileron unit 11.4 against
  2.1, and two faults leaving 6-12 would then pass as one);
* ``share`` — the model error per unit of explained departure. The held-out commissioning BITs
  get :data:`ADDED` departures added in all, each of a parametric fault drawn in turn at a
  severity uniform in :data:`SEVERITIES`, flown on the identified model with each uncertain
  parameter moved by a factor drawn log-uniform within :data:`PERTURB` of its data sheet
  tolerance band (:data:`~mapr_daemon.reasoner.commissioning.prior.DEFAULT_TOLERANCES`): the
  departure of a unit that is not exactly the identified model. The BIT is read back against
  the baseline that has not seen it; the best single leaves ``c`` of a departure ``D`` (no
  fault's cost minus ``c``) where the BIT alone left ``h``: the excess ``max(c - h, 0) / D``
  is that true single's model error per unit of departure. ``share`` is the upper
  :data:`ALPHA_SINGLE` / 2 quantile of the scaled chi-square fitted to the excesses (never
  below the largest), per fault mode (a mode with fewer than :data:`MIN_PER_MODE` counted
  takes the pooled one): how far our model's departure is from a slightly different unit's
  differs by mode. A pair is allowed the larger of its two modes' shares. Departures the
  reading cannot see (``D`` below :data:`MIN_DEPARTURE`, the low-side Ron mostly) are not
  counted.

A reading's hypothesis that explains ``D`` is within the unit's allowance when it leaves at
most ``healthy + share * D``: on the calibration, a true single fault is outside it with
probability at most :data:`ALPHA_SINGLE` (one in twenty; the two tails' union) as far as the
tail fits and the perturbation stand for the unit's real model error.

The thresholds, the fitted tails and the held-out values are kept in the commissioning record
(``detector``, :meth:`Detector.to_json`, the allowance under ``single_allowance``); a record
without them (written before) loads without a detector (or without an allowance: the
decision's older shares of the departure apply) and the dictionary keeps detecting alone.

Cost: one reading per commissioning BIT at commissioning (about 0.7-0.8 s CPU each at the
default grid), :data:`ADDED` more for the allowance (2 per BIT from 20), and one per BIT in service.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from mapr_daemon.ema.faults import PARAMETRIC, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import BitRecord
from mapr_daemon.reasoner.commissioning.discrepancy import Discrepancy, held_out_discrepancies
from mapr_daemon.reasoner.commissioning.flight import Flight, fly, recorded
from mapr_daemon.reasoner.commissioning.severity import Reading, read

ALPHA = 1e-3
"""False-alarm target: healthy BITs flagged by the detector, at most one in a thousand."""
STATISTICS = ("no_fault", "explained")
FLOOR_EXPLAINED = 1e-3
"""Stand-in for an all-zero column of held-out drops (healthy spreads squared)."""
MIN_HELD_OUT = 4
"""Fewer held-out readings than this fit no tail: no detector."""
ALPHA_SINGLE = 0.05
"""False rate of the single-fault allowance: a true single fault's leftover above it, at most
one BIT in twenty (module docstring)."""
ADDED = 40
"""Fault departures added for the allowance, in all: ``ceil(ADDED / BITs)`` to each held-out
commissioning BIT (2 each from 20 BITs)."""
SEVERITIES = (0.25, 1.0)
"""Range of the added faults' severities (fractions of the Table 1 range)."""
PERTURB = 0.5
"""Each uncertain parameter of the departure's model moves within this fraction of its
tolerance band (log-uniform), a unit that is not exactly the identified model."""
MIN_PER_MODE = 4
"""Counted added faults of one mode below which the mode takes the pooled share."""
MIN_DEPARTURE = 1.0
"""Least departure (healthy spreads squared) an added fault must give to count (the decision's
``MIN_EXPLAINED``)."""
SEED = 2026
"""The allowance's draws (modes' order, severities, perturbations): fixed, so commissioning
the same BITs twice gives the same record."""


def statistics(reading: Reading) -> dict[str, float]:
    """The reading's two detection statistics (module docstring)."""
    return {"no_fault": float(reading.healthy_cost),
            "explained": float(max(reading.healthy_cost - reading.least_cost, 0.0))}


@dataclasses.dataclass(frozen=True)
class Tail:
    """A scaled chi-square ``scale * chi2(dof)`` fitted to one statistic's held-out values."""

    scale: float
    dof: float
    threshold: float
    largest: float
    """The largest held-out value."""

    @classmethod
    def fit(cls, values: Sequence[float], alpha: float) -> Tail:
        """The tail of ``values`` (>= 0) by moments and its upper-``alpha`` threshold."""
        x = np.asarray(values, dtype=np.float64)
        if x.size < 2 or not np.all(np.isfinite(x)):
            raise ValueError(f"held-out values {list(values)}: at least two, all finite")
        if not np.any(x >= FLOOR_EXPLAINED):
            # all zero, or nearly: fitted as if the largest were the floor (a tail fitted to
            # one tiny drop among zeros would put the threshold below the all-zero case's)
            x = np.r_[np.delete(x, int(np.argmax(x))), FLOOR_EXPLAINED]
        m, v = float(np.mean(x)), float(np.var(x, ddof=1))
        v = max(v, 1e-12 * m * m)
        scale, dof = v / (2.0 * m), 2.0 * m * m / v
        q = float(scale * stats.chi2.isf(alpha, dof))
        return cls(scale, dof, max(q, float(x.max())), float(x.max()))

    def exceedance(self, value: float) -> float:
        """The fitted probability that a healthy BIT's statistic is above ``value``."""
        return float(stats.chi2.sf(value / self.scale, self.dof))


@dataclasses.dataclass(frozen=True)
class Allowance:
    """What a hypothesis may leave of a reading and still explain it on this unit: at most
    ``healthy + share * explained``, ``share`` its fault mode's (module docstring)."""

    healthy: float
    """The leftover the unit's healthy scatter allows (healthy spreads squared)."""
    share: float
    """The model error allowed per unit of explained departure, all modes pooled."""
    shares: dict[str, float]
    """The same per fault mode, for the modes with at least :data:`MIN_PER_MODE` counted
    added faults (the others take :attr:`share`)."""
    alpha: float
    """The false rate: a true single fault outside the allowance."""
    excess: dict[str, tuple[float, ...]]
    """Per mode the calibration's excesses ``max(c - h, 0) / D``, one per counted added
    fault."""

    def share_of(self, modes: Sequence[str]) -> float:
        """The share a hypothesis of ``modes`` (one, or a pair's two) is allowed: the largest
        of theirs."""
        return max((self.shares.get(m, self.share) for m in modes), default=self.share)

    def left(self, explained: float, modes: Sequence[str] = ()) -> float:
        """The most a hypothesis of ``modes`` explaining ``explained`` may leave."""
        return self.healthy + self.share_of(modes) * max(explained, 0.0)

    def holds(self, cost: float, healthy_cost: float, modes: Sequence[str] = ()) -> bool:
        """Whether a hypothesis of ``modes`` leaving ``cost`` of a reading whose "no fault"
        costs ``healthy_cost`` is within the allowance."""
        return cost <= self.left(healthy_cost - cost, modes)

    def to_json(self) -> dict[str, Any]:
        return {"rule": ALLOWANCE_RULE, "alpha": self.alpha, "healthy": self.healthy,
                "share": self.share, "shares": dict(self.shares),
                "excess": {k: [round(v, 6) for v in x] for k, x in self.excess.items()}}

    @classmethod
    def from_json(cls, doc: Any) -> Allowance:
        """Parse :meth:`to_json`'s output (KeyError, TypeError, ValueError or AttributeError
        when malformed)."""
        out = cls(float(doc["healthy"]), float(doc["share"]),
                  {str(k): float(v) for k, v in doc["shares"].items()}, float(doc["alpha"]),
                  {str(k): tuple(float(v) for v in x) for k, x in doc["excess"].items()})
        shares = [out.share, *out.shares.values()]
        if not (out.healthy > 0.0 and math.isfinite(out.healthy) and 0.0 < out.alpha < 1.0
                and all(v >= 0.0 and math.isfinite(v) for v in shares)):
            raise ValueError(f"single allowance healthy {out.healthy}, shares {shares}, "
                             f"alpha {out.alpha} (positive, finite, alpha in (0, 1))")
        return out


@dataclasses.dataclass(frozen=True)
class Detector:
    """The unit's thresholds on :func:`statistics`, from its held-out commissioning BITs."""

    alpha: float
    tails: dict[str, Tail]
    held_out: dict[str, tuple[float, ...]]
    """Per statistic the held-out commissioning BITs' values, in the order of the record."""
    allowance: Allowance | None = None
    """What a true single fault leaves on this unit; None in a record written before."""

    def fired(self, reading: Reading) -> dict[str, float]:
        """The statistics above their threshold, each with its fitted healthy exceedance
        probability (empty: the BIT sits within the unit's healthy scatter)."""
        s = statistics(reading)
        return {k: self.tails[k].exceedance(s[k]) for k in STATISTICS
                if s[k] > self.tails[k].threshold}

    def evidence(self, reading: Reading) -> dict[str, Any]:
        """What the event says of the detector: each statistic, its threshold and whether
        it fired."""
        s = statistics(reading)
        return {k: {"value": round(s[k], 4), "threshold": round(self.tails[k].threshold, 4),
                    "fired": s[k] > self.tails[k].threshold} for k in STATISTICS}

    def to_json(self) -> dict[str, Any]:
        out = {"rule": RULE, "alpha": self.alpha,
               "statistics": {k: {"scale": t.scale, "dof": t.dof, "threshold": t.threshold,
                                  "largest_held_out": t.largest,
                                  "held_out": [round(v, 6) for v in self.held_out[k]]}
                              for k, t in self.tails.items()}}
        if self.allowance is not None:
            out["single_allowance"] = self.allowance.to_json()
        return out

    @classmethod
    def from_json(cls, doc: Any, path: str = "<record>") -> Detector:
        """Parse :meth:`to_json`'s output; :class:`ConfigError` naming what is wrong."""
        try:
            st = doc["statistics"]
            tails = {k: Tail(float(st[k]["scale"]), float(st[k]["dof"]),
                             float(st[k]["threshold"]), float(st[k]["largest_held_out"]))
                     for k in STATISTICS}
            held = {k: tuple(float(v) for v in st[k]["held_out"]) for k in STATISTICS}
            alpha = float(doc["alpha"])
            for k, t in tails.items():
                if not (t.scale > 0.0 and t.dof > 0.0 and math.isfinite(t.scale)
                        and math.isfinite(t.dof) and math.isfinite(t.threshold)):
                    raise ValueError(f"{k}: scale {t.scale}, dof {t.dof}, threshold "
                                     f"{t.threshold} (positive and finite)")
            if not 0.0 < alpha < 1.0:
                raise ValueError(f"alpha {alpha} (between 0 and 1)")
            allowance = (Allowance.from_json(doc["single_allowance"])
                         if doc.get("single_allowance") is not None else None)
            return cls(alpha, tails, held, allowance)
        except (KeyError, TypeError, ValueError, AttributeError) as error:
            raise ConfigError(f"malformed detector ({type(error).__name__}: {error})",
                              path=path, field="detector") from None


RULE = ("per statistic (no-fault cost; no-fault minus best fault cost), a scaled chi-square "
        "fitted by moments to the commissioning BITs read held out; threshold its upper "
        "alpha/2 quantile, at least the largest held-out value")


ALLOWANCE_RULE = ("a hypothesis explains a reading when it leaves at most healthy + share x "
                  "the departure it explains: healthy the upper alpha/2 quantile of the "
                  "held-out no-fault costs' scaled chi-square; share that of the excess "
                  "leftover per unit of departure of faults added to the held-out BITs from a "
                  "perturbed identified model and read back")


def held_out_readings(params: ActuatorParams, datasheet: ActuatorParams, disc: Discrepancy,
                      bits: Sequence[BitRecord],
                      discs: Sequence[Discrepancy] | None = None) -> list[Reading]:
    """Each of ``bits`` (those ``disc`` was learned on) read against the baseline learned
    without it (``discs``: those baselines' discrepancies, when already made)."""
    if discs is None:
        discs = held_out_discrepancies(disc, params, bits)
    return [read(params, datasheet, d, b, disc.decimate)
            for d, b in zip(discs, bits, strict=True)]


def healthy_quantile(costs: Sequence[float], alpha: float) -> float:
    """The upper ``alpha`` point of the held-out "no fault" costs, robustly: a log-normal whose
    median and spread are the logs' median and scaled median absolute deviation. One held-out
    BIT at a condition the commissioning never flew (a cost of 10 among costs of 1) is then
    one BIT in twenty above the allowance, as it is, not the allowance itself (the moment fit
    of :class:`Tail`, floored at the largest value, would put it there)."""
    x = np.log(np.maximum(np.asarray(costs, dtype=np.float64), 1e-9))
    if x.size < 2 or not np.all(np.isfinite(x)):
        raise ValueError(f"held-out costs {list(costs)}: at least two, all finite")
    med = float(np.median(x))
    spread = 1.4826 * float(np.median(np.abs(x - med)))
    return float(np.exp(med + stats.norm.isf(alpha) * spread))


def _perturbed(params: ActuatorParams, rng: np.random.Generator) -> ActuatorParams:
    """``params`` with each uncertain parameter moved log-uniformly within :data:`PERTURB`
    of its tolerance band."""
    factors = {}
    for t in ip.DEFAULT_TOLERANCES:
        lo, hi = math.log1p(-t.minus_pct / 100.0), math.log1p(t.plus_pct / 100.0)
        factors[t.path] = math.exp(PERTURB * float(rng.uniform(lo, hi)))
    return ip.scaled(params, factors)


def single_allowance(params: ActuatorParams, datasheet: ActuatorParams,
                     discs: Sequence[Discrepancy], bits: Sequence[BitRecord],
                     healthy: Sequence[Reading], alpha: float = ALPHA_SINGLE,
                     kinds: Sequence[str] = tuple(PARAMETRIC),
                     per_bit: int | None = None) -> Allowance:
    """The unit's :class:`Allowance` (module docstring): ``bits`` each read against its
    held-out baseline (``discs``), ``healthy`` their readings as recorded, ``per_bit`` faults
    of ``kinds`` added to each (None: ``ceil(ADDED / len(bits))``); ``ValueError`` when fewer
    than two added faults could be counted."""
    if per_bit is None:
        per_bit = math.ceil(ADDED / len(bits))
    rng = np.random.default_rng(SEED)
    decimate = discs[0].decimate
    order = [kinds[int(j)] for j in rng.permutation(len(kinds))]
    excess: dict[str, list[float]] = {}
    n = 0
    for d, b, h in zip(discs, bits, healthy, strict=True):
        data = recorded([b], decimate)[0]
        for _ in range(per_bit):
            mode = order[n % len(order)]
            n += 1
            fault = at_severity(datasheet, mode, float(rng.uniform(*SEVERITIES)))
            y = fly(_perturbed(params, rng), [Flight(b, FaultSet.of([fault])), Flight(b)],
                    decimate)
            r = read(params, datasheet, d, b, decimate, data=data + y[0] - y[1])
            explained = r.healthy_cost - r.cost
            if explained < MIN_DEPARTURE:
                continue
            excess.setdefault(mode, []).append(max(r.cost - h.healthy_cost, 0.0) / explained)
    pooled = [v for x in excess.values() for v in x]
    if len(pooled) < 2:
        raise ValueError(f"{len(pooled)} added faults seen by the reading (at least two)")
    shares = {k: Tail.fit(x, alpha / 2.0).threshold for k, x in excess.items()
              if len(x) >= MIN_PER_MODE}
    left = healthy_quantile([r.healthy_cost for r in healthy], alpha / 2.0)
    return Allowance(left, Tail.fit(pooled, alpha / 2.0).threshold, shares, alpha,
                     {k: tuple(x) for k, x in excess.items()})


def calibrate(params: ActuatorParams, datasheet: ActuatorParams, disc: Discrepancy,
              bits: Sequence[BitRecord], alpha: float = ALPHA,
              allowance: bool = True, held_out: Sequence[Discrepancy] | None = None
              ) -> Detector:
    """The unit's detector from its commissioning ``bits`` (module docstring), with its
    single-fault allowance unless ``allowance`` is False; :class:`ConfigError` with fewer
    than :data:`MIN_HELD_OUT` + 0 usable BITs. ``held_out``: ``disc`` relearned without each
    BIT (:func:`~.discrepancy.held_out_discrepancies`), when the caller has made them
    already (the wear reading's scatter is measured on the same ones)."""
    if len(bits) < MIN_HELD_OUT:
        raise ConfigError(f"{len(bits)} BITs: the detector's tail needs at least "
                          f"{MIN_HELD_OUT}", field="bits")
    discs = held_out_discrepancies(disc, params, bits) if held_out is None else held_out
    readings = held_out_readings(params, datasheet, disc, bits, discs)
    values = {k: tuple(statistics(r)[k] for r in readings) for k in STATISTICS}
    try:
        tails = {k: Tail.fit(values[k], alpha / len(STATISTICS)) for k in STATISTICS}
    except ValueError as error:
        raise ConfigError(f"the detector's tail cannot be fitted ({error})",
                          field="detector") from None
    allowed = None
    if allowance:
        try:
            allowed = single_allowance(params, datasheet, discs, bits, readings)
        except ValueError:
            allowed = None  # no added fault seen: the decision's shares of the departure
    return Detector(alpha, tails, values, allowed)
