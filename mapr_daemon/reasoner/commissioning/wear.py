"""Each aging kind's wear read against the unit's own commissioned baseline, with a measured sd.

The prognostic model's per-BIT estimators
(:mod:`~mapr_daemon.reasoner.prognosis.wear_estimators`) are trained on the data sheet's twin;
on a unit that is not the twin they read its wear at a gain of 0.3-0.7 with scatter 1.5-10x
their stated sd (docs/reasoner-measured.md), and a trend cannot fit a gain. A commissioned unit
has a physical reading of its own: the identified model plus the learned discrepancy
(:mod:`~mapr_daemon.reasoner.commissioning.severity`). Here that reading is turned into the
trend's input:

* **Estimate** (:func:`read`): per aging kind, a one-dimensional least-squares fit of the BIT
  against "identified model with that kind's parameter at degradation ``h`` + the unit's
  discrepancy at the BIT's condition", ``h`` on :data:`GRID` (0 is the unit as commissioned,
  1 its failure threshold: the parameter at :data:`~mapr_daemon.ema.degradation.FAILURE` times
  the UNIT's identified healthy value, the ratio the prognosis counts in), the residual in the
  unit's held-out healthy spreads as the severity reading weighs it; the minimum refined by a
  parabola through the best grid point and its neighbours. One batched plant call per BIT for
  every kind (``1 + kinds x 9`` runs; about 0.4-0.6 s CPU on the aileron with the six aging
  kinds), read on EVERY BIT: the trend needs the early, healthy-looking ones.
* **Its sd, measured** (:func:`measure`, at commissioning): each commissioning BIT is read
  the same way against the discrepancy relearned without it
  (:func:`~mapr_daemon.reasoner.commissioning.discrepancy.held_out_discrepancies`), so the
  readings are what a healthy BIT the baseline has not seen gives: their median is the kind's
  **offset** at ``h = 0`` (subtracted before trending) and their scatter about it the kind's
  ``sd0`` (1.4826 times the median absolute deviation: a weakly seen kind's held-out reading
  can leave the grid, -0.5 or 2, and one such BIT made the plain sd of eight 0.87 where the
  in-service readings of the same unit scattered by 0.29, on a design seed). How the sd grows
  with ``h`` is taken from the same readings' cost curves: the sd of
  a least-squares estimate scales as one over the square root of the expected cost's
  curvature (the Fisher information of a Gaussian residual), so the mean held-out cost curve's
  second difference ``k(h)`` gives ``sd(h) = sd0 * sqrt(k(0) / k(h))`` on the grid over
  0..1.5, fitted as ``sd0 + sd1 * h`` (``sd1 >= 0``). **Criterion**: the held-out healthy
  scatter at ``h = 0``, scaled by the curvature ratio; the gain is taken as 1 (the fault's
  departure is our model's around the unit's identified operating point), which healthy BITs
  cannot check: a unit whose fault response differs from the model's reads at a gain the sd
  does not state (measured on built units in docs/reasoner-measured.md).

A kind is read against the baseline only where that reading **resolves** its wear: its sd at
the failure threshold (``sd0 + sd1``) at most
:data:`~mapr_daemon.reasoner.training.prognosis_build.RESOLVE_SD` (0.5 of the threshold),
the bar the prognostic model sets its own estimators (a single BIT must tell new from failed
at two sd). A kind whose fault barely moves the fit signals the reading compares (the
DC-link ESR's ripple is mostly averaged out of the decimated signals) fails it on a unit
with a large discrepancy, and keeps the prognostic model's estimator.

The measured noise is kept in the commissioning record (``wear``, :meth:`BaselineWear.to_json`)
and given to the trend as each kind's :class:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise`
(:meth:`BaselineWear.noise`), in place of the estimators' for that unit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.ema.faults import Fault, FaultSet, nominal_value
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning.bits import BitRecord
from mapr_daemon.reasoner.commissioning.discrepancy import (
    Discrepancy,
    correction_for,
    held_out_discrepancies,
)
from mapr_daemon.reasoner.commissioning.flight import Flight, fly, recorded
from mapr_daemon.reasoner.commissioning.pairs import vertex
from mapr_daemon.reasoner.commissioning.severity import weights
from mapr_daemon.reasoner.prognosis.wear_noise import Noise
from mapr_daemon.reasoner.training.prognosis_build import RESOLVE_SD

GRID: tuple[float, ...] = (-0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0)
"""Degradations tried for every kind (fractions of the failure threshold; 0 = as
commissioned, shared by all kinds)."""
KINDS: tuple[str, ...] = tuple(sorted(FAILURE))
"""The aging kinds read."""
CURVATURE_SPAN = (0.0, 1.5)
"""The degradations the sd's growth is fitted over (the grid's interior points in it)."""
MAD_SD = 1.4826
"""A normal variable's sd over its median absolute deviation."""
SD_FLOOR = 1e-3
"""The least scatter stated (a kind whose held-out readings all agree)."""
MIN_HELD_OUT = 4
"""Fewer held-out readings than this measure no scatter."""
RULE = ("per kind: the median of the commissioning BITs read held out is the offset at "
        "h = 0, 1.4826 x their median absolute deviation the scatter sd0; sd(h) = sd0 * "
        "sqrt(k(0) / k(h)) with k the mean held-out cost curve's second difference, fitted "
        "as sd0 + sd1*h over h 0-1.5; gain taken as 1; a kind is read against the baseline "
        "when sd0 + sd1 <= 0.5")


def fault_at(params: ActuatorParams, kind: str, h: float) -> FaultSet:
    """``kind`` at degradation ``h`` of the unit ``params``: its own healthy value moved
    ``h`` of the way to :data:`FAILURE` times it (no fault at ``h = 0``)."""
    if h == 0.0:
        return FaultSet()
    value = nominal_value(params, kind) * (1.0 + h * (FAILURE[kind] - 1.0))
    return FaultSet.of([Fault(kind, max(value, 0.0))])


def cost_grid(params: ActuatorParams, disc: Discrepancy, bit: BitRecord,
              kinds: Sequence[str] = KINDS) -> FloatArray:
    """``(len(kinds), len(GRID))``: the mean square residual, in healthy spreads, of ``bit``
    against the baseline with each kind at each :data:`GRID` degradation (one plant call)."""
    decimate = disc.decimate
    data = recorded([bit], decimate)[0]
    corr = correction_for(disc, params, [bit])[0]
    w = weights(params, disc, decimate)
    nonzero = [h for h in GRID if h != 0.0]
    flights = [Flight(bit)] + [Flight(bit, fault_at(params, k, h)) for k in kinds
                               for h in nonzero]
    y = fly(params, flights, decimate)
    c = np.mean(((data - y - corr) / w) ** 2, axis=(1, 2))
    out = np.empty((len(kinds), len(GRID)))
    zero = GRID.index(0.0)
    for i in range(len(kinds)):
        row = c[1 + i * len(nonzero): 1 + (i + 1) * len(nonzero)]
        out[i] = np.insert(row, zero, c[0])
    return out


def minimum(costs: FloatArray) -> float:
    """The degradation of least cost on :data:`GRID`, refined by the parabola through the
    best point and its two neighbours (kept between them; the grid point at an edge)."""
    g = np.asarray(GRID)
    i = int(np.argmin(costs))
    if i == 0 or i == g.size - 1:
        return float(g[i])
    return vertex(g[i - 1: i + 2], costs[i - 1: i + 2])


def read(params: ActuatorParams, disc: Discrepancy, bit: BitRecord,
         kinds: Sequence[str] = KINDS) -> dict[str, float]:
    """``bit``'s degradation per kind read against the baseline (raw: before the offset)."""
    grid = cost_grid(params, disc, bit, kinds)
    return {k: minimum(grid[i]) for i, k in enumerate(kinds)}


@dataclasses.dataclass(frozen=True)
class KindNoise:
    """One kind's baseline reading measured on the unit's held-out healthy BITs."""

    offset: float
    """Median held-out reading (the reading's bias at ``h = 0``)."""
    sd0: float
    """Scatter of the held-out readings (1.4826 x their median absolute deviation)."""
    sd1: float
    """Growth of the sd with ``h`` (from the cost's curvature)."""
    held_out: tuple[float, ...]

    def noise(self) -> Noise:
        """As the trend takes it: ``estimate = offset + h + e``, ``sd(e) = sd0 + sd1*h``."""
        return Noise(self.sd0, self.sd1, self.offset, 1.0)

    @property
    def resolves(self) -> bool:
        """Whether one BIT's reading at the failure threshold scatters by at most
        :data:`RESOLVE_SD` (else the kind keeps the prognostic model's estimator)."""
        return self.sd0 + self.sd1 <= RESOLVE_SD


@dataclasses.dataclass(frozen=True)
class BaselineWear:
    """Per kind, what the unit's baseline reading of wear is worth (:func:`measure`)."""

    kinds: dict[str, KindNoise]
    """Every kind measured (those that do not resolve their wear included)."""

    @property
    def read_kinds(self) -> tuple[str, ...]:
        """The kinds read against the baseline: those whose reading resolves their wear."""
        return tuple(k for k, v in self.kinds.items() if v.resolves)

    def noise(self) -> dict[str, Noise]:
        """The noise of each kind read against the baseline, as the trend takes it."""
        return {k: self.kinds[k].noise() for k in self.read_kinds}

    def to_json(self) -> dict[str, Any]:
        return {"rule": RULE, "grid": list(GRID), "kinds": {
            k: {"offset": round(v.offset, 6), "sd0": round(v.sd0, 6), "sd1": round(v.sd1, 6),
                "resolves": v.resolves, "held_out": [round(x, 6) for x in v.held_out]}
            for k, v in self.kinds.items()}}

    @classmethod
    def from_json(cls, doc: Any, path: str = "<record>") -> BaselineWear:
        """Parse :meth:`to_json`'s output; :class:`ConfigError` naming what is wrong."""
        try:
            kinds = {str(k): KindNoise(float(v["offset"]), float(v["sd0"]), float(v["sd1"]),
                                       tuple(float(x) for x in v["held_out"]))
                     for k, v in doc["kinds"].items()}
            for k, v in kinds.items():
                if k not in FAILURE:
                    raise ValueError(f"unknown aging kind {k!r}")
                if not (v.sd0 > 0.0 and v.sd1 >= 0.0 and math.isfinite(v.offset + v.sd0
                                                                       + v.sd1)):
                    raise ValueError(f"{k}: sd0 {v.sd0}, sd1 {v.sd1}, offset {v.offset}")
        except (KeyError, TypeError, ValueError, AttributeError) as error:
            raise ConfigError(f"malformed baseline wear noise ({type(error).__name__}: "
                              f"{error})", path=path, field="wear") from None
        return cls(kinds)


def growth(curves: FloatArray, sd0: float) -> float:
    """``sd1`` of one kind from its held-out cost curves ``(n, len(GRID))``: the mean curve's
    second difference ``k`` at each interior grid point, ``sd0 * sqrt(k(0) / k(h))`` fitted as
    ``sd0 + sd1*h`` over :data:`CURVATURE_SPAN` (least squares through ``sd0`` at 0, floored
    at 0); 0 when the curvature at 0 is not positive."""
    g = np.asarray(GRID)
    mean = curves.mean(axis=0)
    k = {}
    for i in range(1, g.size - 1):
        h0, h1, h2 = g[i - 1], g[i], g[i + 1]
        # second derivative of the parabola through three unevenly spaced points
        k[float(h1)] = 2.0 * ((mean[i + 1] - mean[i]) / (h2 - h1)
                              - (mean[i] - mean[i - 1]) / (h1 - h0)) / (h2 - h0)
    k0 = k.get(0.0, 0.0)
    if not k0 > 0.0:
        return 0.0
    lo, hi = CURVATURE_SPAN
    hs = np.array([h for h, v in k.items() if lo < h <= hi and v > 0.0])
    if hs.size == 0:
        return 0.0
    excess = np.array([sd0 * (math.sqrt(k0 / k[float(h)]) - 1.0) for h in hs])
    return max(float(np.sum(hs * excess) / np.sum(hs * hs)), 0.0)


def measure(params: ActuatorParams, disc: Discrepancy, bits: Sequence[BitRecord],
            kinds: Sequence[str] = KINDS, held_out: Sequence[Discrepancy] | None = None
            ) -> BaselineWear:
    """Each kind's offset and sd from ``bits`` (those ``disc`` was learned on), each read
    against the discrepancy learned without it (``held_out``, when the caller has made them
    already: the detector is calibrated on the same ones); :class:`ConfigError` with fewer
    than :data:`MIN_HELD_OUT` BITs."""
    if len(bits) < MIN_HELD_OUT:
        raise ConfigError(f"{len(bits)} BITs: measuring the wear reading's scatter needs at "
                          f"least {MIN_HELD_OUT}", field="bits")
    discs = held_out_discrepancies(disc, params, bits) if held_out is None else held_out
    curves = np.stack([cost_grid(params, d, b, kinds) for d, b in zip(discs, bits,
                                                                     strict=True)])
    out = {}
    for i, k in enumerate(kinds):
        values = np.array([minimum(c) for c in curves[:, i]])
        offset = float(np.median(values))
        sd0 = max(MAD_SD * float(np.median(np.abs(values - offset))), SD_FLOOR)
        out[k] = KindNoise(offset, sd0, growth(curves[:, i], sd0),
                           tuple(float(v) for v in values))
    return BaselineWear(out)


def baseline_estimates(params: ActuatorParams, disc: Discrepancy, bit: BitRecord,
                       wear: BaselineWear, kinds: Sequence[str]) -> dict[str, float]:
    """The raw readings of ``kinds`` that ``wear`` reads (:attr:`BaselineWear.read_kinds`;
    what the catalog stores as the BIT's wear; the trend subtracts the offset through
    :meth:`BaselineWear.noise`)."""
    mine = [k for k in kinds if k in wear.read_kinds]
    return {k: round(v, 5) for k, v in read(params, disc, bit, mine).items()} if mine else {}

