"""Two faults at once, and runs no known fault explains: what a single-fault fit cannot say.

The single-fault fit (:func:`~mapr_daemon.reasoner.diagnosis.fault_models.fit_all`) always
names the template closest to the run, however far that is. Two questions are asked of it
here, on the same whitened coordinates ``y`` and with the same templates:

* **a pair**: two parametric faults in different replaceable parts (the seed paper's
  "compound damage modes"; two members of one part are one replacement and one diagnosis),
  modelled as the sum of their single signatures before the compression
  (:func:`~mapr_daemon.reasoner.diagnosis.fault_models.compress`): a fault's departure in the
  healthy model's whitened cells is close to additive while both are small, and where they
  interact (a heavier friction draws more current through a worse ESR) the pair leaves more
  unexplained, which :func:`pair_gain` then weighs like any misfit. The pair is fitted on a
  coarse grid of both severities (every :data:`COARSE` th severity of each member's smooth
  and grid curves) and refined member by member on the fine grid near the best cell.
* **an explanation at all**: what the best hypothesis leaves, against what a correct one is
  allowed to leave. A correct template leaves the noise (the healthy residual's threshold,
  ``null_threshold``) plus its own model error, which grows with the departure; so both
  statistics are in units of the *tolerance* ``null_threshold + TOLERANCE_SHARE * null``
  (``null`` the energy of the departure, :func:`fault_models.null_residual`).

Both thresholds come from the dictionary build's *fault calibration runs*: single faults at
random severities, pressures and conditions that fitted nothing (like the healthy
calibration runs for the anomaly threshold). :func:`pair_gain` of a single fault is what
adding a second member gains on model error alone; the largest over those runs times
:data:`PAIR_MARGIN` is the pair threshold. :func:`unexplained_ratio` of a single fault under its
best template is what a correct explanation leaves; the largest times :data:`MARGIN` is the
threshold beyond which the event says "not explained by any known fault mode". A dictionary
without them (built before) names no pairs and says unexplained only as before.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.reasoner.diagnosis.dictionary import Template
from mapr_daemon.reasoner.diagnosis.fault_models import SEVERITY_GRID, FaultModels, compress
from mapr_daemon.reasoner.diagnosis.healthy_model import Conditions
from mapr_daemon.reasoner.diagnosis.parts import PART_OF

__all__ = ["COARSE", "MARGIN", "PAIR_FLOOR", "PAIR_MARGIN", "TOLERANCE_SHARE", "PairFit",
           "fit_pairs", "pair_gain", "pairs_of", "tolerance", "unexplained_ratio"]

TOLERANCE_SHARE = 0.2
"""Share of a run's departure energy a correct template may leave through its own model
error. Chosen on design runs of our plant (seeds 501 and 777, 240 single faults and 520
pairs at 25-100 % of range over the envelope): with 0.1, 0.2, 0.3 and 0.5 the single faults'
largest ratio of residual to tolerance was 5.0, 3.1, 2.3 and 1.6 — the share sets the scale
of both statistics, the calibration runs their thresholds."""
MARGIN = 1.5
"""The unexplained threshold is the fault calibration runs' largest residual times this (a
few dozen runs do not show the tail a fleet's thousands of BITs will)."""
PAIR_MARGIN = 1.0
"""The pair threshold is their largest gain times this. Chosen on design runs (seed 777, 240
single faults and 360 pairs the bus can see, 25-100 % of range): at 1.5, 1.0, 0.75 and 0.5
the pairs named right were 203, 225, 242 and 264 of 360 and the single faults named as a pair
4, 8, 14 and 28 of 200; 1.0 names a second part on about one single fault in 25."""
PAIR_FLOOR = 0.05
"""The pair threshold is never below this many tolerances: a dictionary whose calibration runs
never gain from a second member (few kinds, no pair that shares a cell) must not name a pair on
any gain above zero."""
COARSE = 8
"""Stride of the pair fit's first grid on each member's severities (33 of the 257)."""
REFINE = 2
"""Member-by-member refinement passes on the fine grid."""


@dataclasses.dataclass(frozen=True)
class PairFit:
    """Two templates fitted together: their severities (fractions of range) and the residual."""

    first: int
    second: int
    severity_first: float
    severity_second: float
    residual: float
    row_first: int = 0
    """The row of :meth:`FaultModels.curve` of ``first`` the fit chose (its smooth curve's
    rows first, then its grid curve's)."""
    row_second: int = 0


def pairs_of(templates: Sequence[Template]) -> list[tuple[int, int]]:
    """Indices of the parametric templates that make a pair: one template per fault kind, two
    kinds of different replaceable parts."""
    kinds = {t.kind: i for i, t in enumerate(templates) if not t.switch and t.kind in PART_OF}
    return [(kinds[a], kinds[b]) for a, b in itertools.combinations(sorted(kinds), 2)
            if PART_OF[a] != PART_OF[b]]


def _candidates(models: FaultModels, i: int, c: Conditions,
                metric: FloatArray | None) -> tuple[FloatArray, FloatArray, npt.NDArray[np.intp]]:
    """Template ``i``'s signature points beyond its healthy band (raw, in the run's metric),
    their severities and their rows in :meth:`FaultModels.curve`."""
    raw = models.curve(i, c)
    if metric is not None:
        raw = raw @ metric
    sev = np.resize(SEVERITY_GRID, raw.shape[0])
    rows = np.flatnonzero(sev > models.band(i))
    return raw[rows], sev[rows], rows


def fit_pairs(models: FaultModels, templates: Sequence[Template], y: FloatArray,
              c: Conditions, metric: FloatArray | None = None) -> list[PairFit]:
    """Every pair's best fit to the run's coordinates ``y`` (already in ``metric``'s
    coordinates, as :func:`~mapr_daemon.reasoner.diagnosis.fault_models.fit_all` takes them)."""
    yc = compress(y)
    cands = {i: _candidates(models, i, c, metric) for pair in pairs_of(templates) for i in pair}
    out = []
    for a, b in pairs_of(templates):
        (ra, sa, rows_a), (rb, sb, rows_b) = cands[a], cands[b]
        if ra.shape[0] == 0 or rb.shape[0] == 0:
            continue
        ca, cb = np.arange(0, ra.shape[0], COARSE), np.arange(0, rb.shape[0], COARSE)
        grid = ((compress(ra[ca][:, None, :] + rb[cb][None, :, :]) - yc) ** 2).sum(axis=2)
        ia, ib = np.unravel_index(int(np.argmin(grid)), grid.shape)
        ja, jb = int(ca[ia]), int(cb[ib])
        res = float(grid[ia, ib])
        for _ in range(REFINE):
            wa = np.arange(max(0, ja - COARSE), min(ra.shape[0], ja + COARSE + 1))
            r = ((compress(ra[wa] + rb[jb]) - yc) ** 2).sum(axis=1)
            ja = int(wa[int(np.argmin(r))])
            wb = np.arange(max(0, jb - COARSE), min(rb.shape[0], jb + COARSE + 1))
            r = ((compress(ra[ja] + rb[wb]) - yc) ** 2).sum(axis=1)
            jb = int(wb[int(np.argmin(r))])
            res = float(r.min())
        out.append(PairFit(a, b, float(sa[ja]), float(sb[jb]), res, int(rows_a[ja]),
                           int(rows_b[jb])))
    return out


def tolerance(null: float, null_threshold: float) -> float:
    """What a correct explanation may leave of a run whose departure energy is ``null``."""
    return null_threshold + TOLERANCE_SHARE * max(null, 0.0)


def pair_gain(single: float, pair: float, null: float, null_threshold: float) -> float:
    """How much less the best pair leaves than the best single fault, in tolerances."""
    return (single - pair) / tolerance(null, null_threshold)


def unexplained_ratio(residual: float, null: float, null_threshold: float) -> float:
    """What the best explanation leaves, in tolerances."""
    return residual / tolerance(null, null_threshold)
