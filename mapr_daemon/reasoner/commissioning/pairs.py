"""Two parametric faults at once, read against the unit's commissioned baseline.

The single-fault reading (:func:`~mapr_daemon.reasoner.commissioning.severity.read`) names the
hypothesis closest to the record however the record came about; a BIT with two faults in
different replaceable parts (the seed paper's "compound damage modes") is then read as one of
them, or as a third. Here the pair is a hypothesis of its own: both faults seeded together on
the identified model and flown, plus the unit's discrepancy — the same prediction a single
fault gets, so the faults' interaction (a heavier friction drawing more current through a
worse ESR) is in the model, not assumed additive.

Which pairs: those of the :data:`TOP` parametric modes the single reading ranked best, two
modes of different parts (:data:`~mapr_daemon.reasoner.diagnosis.parts.PART_OF`; two members
of one part are one replacement). A pair's members each explain part of the record on their
own, so they rank among the best singles. Each pair's two severities are found by a 2-D
search: a coarse grid (:data:`COARSE`, one batched plant call for every pair), then
:data:`REFINE` rounds of the 3 x 3 neighbourhood of the best cell of the :data:`KEEP` best
pairs at half the previous step (one call each), and a parabola along each axis through the
last neighbourhood's costs. About 100 model runs per BIT.

Whether the pair is named, or the BIT is left unexplained, is decided by
:mod:`~mapr_daemon.reasoner.commissioning.unit_decision` on the costs carried here.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.reasoner.diagnosis.parts import PART_OF

TOP = 3
"""The best single parametric modes whose pairs are searched."""
COARSE: tuple[float, ...] = (0.1, 0.3, 0.5, 0.7, 0.9)
"""Severities of the first grid on each member (fractions of the Table 1 range)."""
KEEP = 2
"""Pairs refined after the coarse grid."""
REFINE = 2
"""Refinement rounds (steps 0.1 then 0.05)."""
LOW = 0.01
"""Least severity the search tries (0 would be the single fault)."""


@dataclasses.dataclass(frozen=True)
class PairReading:
    """The best pair of two parametric faults in different parts, and what it leaves."""

    first: str
    second: str
    severity_first: float
    """Fraction of the data sheet's range."""
    severity_second: float
    cost: float
    """Mean square of the residual, in healthy spreads (as :class:`Reading.cost`)."""


Costs = Callable[[list[FaultSet]], FloatArray]
"""The reading's cost of each hypothesis (one batched plant call)."""


def candidates(mode_costs: Mapping[str, float], kinds: Sequence[str],
               top: int = TOP) -> list[tuple[str, str]]:
    """Pairs (in different parts) among the ``top`` best of ``kinds`` by their single cost."""
    ranked = sorted((k for k in kinds if k in mode_costs and k in PART_OF),
                    key=lambda k: mode_costs[k])[:top]
    return [(a, b) for a, b in itertools.combinations(ranked, 2) if PART_OF[a] != PART_OF[b]]


def _fault_set(datasheet: ActuatorParams, a: str, sa: float, b: str, sb: float) -> FaultSet:
    return FaultSet.of([at_severity(datasheet, a, sa), at_severity(datasheet, b, sb)])


def vertex(x: FloatArray, c: FloatArray) -> float:
    """The minimum of the parabola through three points ``(x, c)``, kept inside them (the
    lowest point itself when they do not bracket a minimum): how a severity search refines its
    grid (here along each pair axis, :mod:`.severity`, :mod:`.wear`)."""
    a = np.polyfit(x, c, 2)
    if a[0] <= 0.0:
        return float(x[int(np.argmin(c))])
    return float(np.clip(-a[1] / (2.0 * a[0]), x.min(), x.max()))


def search(costs: Costs, datasheet: ActuatorParams, mode_costs: Mapping[str, float],
           kinds: Sequence[str], top: int = TOP) -> PairReading | None:
    """The best pair among :func:`candidates`, its severities by the 2-D search of the module
    docstring; None when no two of the best modes are in different parts."""
    pairs = candidates(mode_costs, kinds, top)
    if not pairs:
        return None
    cells = [(p, sa, sb) for p in pairs for sa in COARSE for sb in COARSE]
    c = costs([_fault_set(datasheet, a, sa, b, sb) for (a, b), sa, sb in cells])
    tried: dict[tuple[tuple[str, str], float, float], float] = {
        (p, round(sa, 6), round(sb, 6)): float(v) for (p, sa, sb), v in zip(cells, c,
                                                                            strict=True)}
    best_of = {p: min((k for k in tried if k[0] == p), key=lambda k: tried[k]) for p in pairs}
    kept = sorted(pairs, key=lambda p: tried[best_of[p]])[:KEEP]
    step = (COARSE[1] - COARSE[0]) / 2.0
    for round_ in range(REFINE):
        new = []
        for p in kept:
            _, sa, sb = best_of[p]
            for da, db in itertools.product((-step, 0.0, step), repeat=2):
                key = (p, round(float(np.clip(sa + da, LOW, 1.0)), 6),
                       round(float(np.clip(sb + db, LOW, 1.0)), 6))
                if key not in tried and key not in new:
                    new.append(key)
        if new:
            c = costs([_fault_set(datasheet, p[0], sa, p[1], sb) for p, sa, sb in new])
            tried.update({k: float(v) for k, v in zip(new, c, strict=True)})
        for p in kept:
            best_of[p] = min((k for k in tried if k[0] == p), key=lambda k: tried[k])
        if round_ < REFINE - 1:
            step /= 2.0
    p = min(kept, key=lambda q: tried[best_of[q]])
    _, sa, sb = best_of[p]
    sev = [sa, sb]
    for axis in (0, 1):
        pts = []
        for d in (-step, 0.0, step):
            s = [sa, sb]
            s[axis] = round(float(np.clip(s[axis] + d, LOW, 1.0)), 6)
            k = (p, s[0], s[1])
            if k in tried:
                pts.append((s[axis], tried[k]))
        if len({x for x, _ in pts}) == 3:
            sev[axis] = vertex(np.array([x for x, _ in pts]), np.array([v for _, v in pts]))
    return PairReading(p[0], p[1], float(sev[0]), float(sev[1]), tried[best_of[p]])
