"""Which path read a BIT's wear, and the noise each stored reading is weighed by.

A BIT's degradation reading of one aging kind comes from one of two paths
(docs/commissioning.md, "Wear against the baseline"):

* **estimator**: the prognostic model's twin-trained estimators
  (:mod:`~mapr_daemon.reasoner.prognosis.wear_estimators`), weighed by the model's measured
  noise at the BIT's flight condition and, for a kind that has one, the fleet's unit offset
  (:data:`~.trend.UNIT_OFFSET_MEAN`);
* **baseline**: the raw reading against the unit's commissioned baseline
  (:mod:`~mapr_daemon.reasoner.commissioning.wear`), weighed by that record's measured offset
  and ``sd0 + sd1 h`` with gain 1 and no fleet offset (the unit's own offset is measured and
  subtracted).

The two read the same unit at different offsets and scatters, so each reading must be weighed
by its own path's, whatever the asset's configuration is when the trend is rebuilt (an asset
commissioned after it had flown, a record replaced or removed). Each BIT's outcome says, per
kind, which path read it (:func:`estimator`, :func:`baseline`); the catalog keeps that beside
the wear (``bits.wear_source``). A baseline reading keeps its record's digest and the three
figures it is weighed by, so it stays weighable after its record is gone and a re-commissioned
unit's readings against its older baseline are told apart.

A reading whose source is not known (a BIT stored before the catalog kept it, or a malformed
entry) is taken as read by the path the asset has now: what the trend did before the source
was stored. :class:`PathNoise` is what the trend (:func:`~.trend.fit_rul`) and the evidence
test (:mod:`.assessment`) take: one kind's readings, each with its path's noise.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.reasoner.prognosis.wear_noise import Noise

ESTIMATOR = "estimator"
BASELINE = "baseline"
Source = Mapping[str, Any]
"""One kind's source as stored: ``{"path": "estimator"}`` or ``{"path": "baseline", "record":
digest, "offset": o, "sd0": s0, "sd1": s1}``."""


def estimator() -> dict[str, Any]:
    """The source of a reading by the prognostic model's estimators."""
    return {"path": ESTIMATOR}


def baseline(record: str, noise: Noise) -> dict[str, Any]:
    """The source of a raw reading against the baseline of the record ``record`` (its
    digest), whose measured noise is ``noise`` (``offset + h + e``, ``sd0 + sd1 h``)."""
    return {"path": BASELINE, "record": record, "offset": float(noise.offset),
            "sd0": float(noise.sd0), "sd1": float(noise.sd1)}


def _baseline_noise(source: Source | None) -> Noise | None:
    """The noise a baseline source states, or None (not a baseline source, or malformed)."""
    if not isinstance(source, Mapping) or source.get("path") != BASELINE:
        return None
    try:
        offset, sd0, sd1 = (float(source[k]) for k in ("offset", "sd0", "sd1"))
    except (KeyError, TypeError, ValueError):
        return None
    if not (sd0 > 0.0 and sd1 >= 0.0 and math.isfinite(offset + sd0 + sd1)):
        return None
    return Noise(sd0, sd1, offset, 1.0)


@dataclasses.dataclass(frozen=True)
class PathNoise:
    """One kind's readings, each with the noise of the path that read it.

    ``noises[index[i]]`` weighs reading ``i``; ``own[j]``: path ``j``'s offset is the unit's
    own, measured and subtracted (no fleet unit offset). Its methods are
    :class:`~.wear_noise.Noise`'s, row by row.
    """

    noises: tuple[Noise, ...]
    own: tuple[bool, ...]
    index: npt.NDArray[np.intp]

    @classmethod
    def one(cls, noise: Noise, n: int, own: bool = False) -> PathNoise:
        """``n`` readings all of one path."""
        return cls((noise,), (own,), np.zeros(n, dtype=np.intp))

    @property
    def size(self) -> int:
        return int(self.index.size)

    def take(self, which: Any) -> PathNoise:
        """The readings selected by ``which`` (a mask, indices or a slice)."""
        return dataclasses.replace(self, index=np.asarray(self.index[which], dtype=np.intp))

    @property
    def fleet_offset(self) -> FloatArray:
        """1.0 where the reading takes the fleet's unit offset, 0.0 where its path's offset
        is the unit's own."""
        out: FloatArray = np.where(np.asarray(self.own)[self.index], 0.0, 1.0)
        return out

    @property
    def has_floor(self) -> bool:
        """Whether any reading's path has a dead zone (:attr:`~.wear_noise.Noise.floor`)."""
        return any(self.noises[j].floor is not None for j in np.unique(self.index))

    def _rows(self, f: Callable[[Noise, Any], npt.NDArray[Any]], dtype: Any = np.float64
              ) -> npt.NDArray[Any]:
        """``f(noise, rows)`` per path, put back in the readings' order."""
        if len(self.noises) == 1:
            return np.asarray(f(self.noises[0], slice(None)), dtype=dtype)
        out = np.empty(self.size, dtype=dtype)
        for j, noise in enumerate(self.noises):
            rows = np.nonzero(self.index == j)[0]
            if rows.size:
                out[rows] = f(noise, rows)
        return out

    def calibrate(self, h_est: FloatArray, conditions: FloatArray | None = None) -> FloatArray:
        """Each reading in units of the threshold, by its path (:meth:`Noise.calibrate`)."""
        y = np.asarray(h_est, dtype=np.float64)
        out: FloatArray = self._rows(lambda n, r: n.calibrate(
            y[r], None if conditions is None else np.asarray(conditions)[r]))
        return out

    def h_sd(self, h: FloatArray, conditions: FloatArray | None = None) -> FloatArray:
        """Each reading's sd at degradation ``h``, by its path (:meth:`Noise.h_sd`)."""
        hh = np.asarray(h, dtype=np.float64)
        out: FloatArray = self._rows(lambda n, r: n.h_sd(
            hh[r], None if conditions is None else np.asarray(conditions)[r]))
        return out

    def censored(self, h_est: FloatArray) -> npt.NDArray[np.bool_]:
        """Which readings sit at their path's floor (:meth:`Noise.censored`)."""
        y = np.asarray(h_est, dtype=np.float64)
        out: npt.NDArray[np.bool_] = self._rows(lambda n, r: n.censored(y[r]), bool)
        return out

    def detection(self) -> tuple[FloatArray, FloatArray]:
        """Each reading's path's :attr:`~.wear_noise.Noise.detection` and its sd."""
        det = np.array([n.detection for n in self.noises])[self.index]
        sd = np.array([n.detection_sd for n in self.noises])[self.index]
        return det, sd


def for_kind(kind: str, sources: Sequence[Mapping[str, Source] | None], estimators: Noise,
             now: Noise, now_own: bool) -> PathNoise:
    """The readings of ``kind`` on BITs whose stored sources are ``sources`` (one per BIT, its
    ``{kind: source}``; None where none was stored), each weighed by its path: the
    estimators' noise ``estimators``, the baseline's it states, or, unknown, the path the
    asset has now (``now``; ``now_own``: its offset is the unit's own). What
    :meth:`~.prognostic_model.PrognosticModel.path_noise` asks with the model's."""
    current = (now, now_own)
    paths: dict[tuple[Noise, bool], int] = {}
    index = np.empty(len(sources), dtype=np.intp)
    for i, per_kind in enumerate(sources):
        source = per_kind.get(kind) if isinstance(per_kind, Mapping) else None
        own_noise = _baseline_noise(source)
        if own_noise is not None:
            path = (own_noise, True)
        elif isinstance(source, Mapping) and source.get("path") == ESTIMATOR:
            path = (estimators, False)
        else:
            path = current
        index[i] = paths.setdefault(path, len(paths))
    if not paths:
        return PathNoise.one(current[0], 0, current[1])
    keys = sorted(paths, key=paths.__getitem__)
    return PathNoise(tuple(k[0] for k in keys), tuple(k[1] for k in keys), index)
