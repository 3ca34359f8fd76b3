"""Remaining useful life as the trend states it: a median and a 90 % interval in flights.

:class:`RulEstimate` comes from the aging-shape trend fit of
:mod:`~mapr_daemon.reasoner.prognosis.trend`; :func:`quantiles` reads the trend's draws.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray


@dataclasses.dataclass(frozen=True)
class RulEstimate:
    """RUL in flights: the median and the 5 % / 95 % bounds, plus the draws behind them.

    A value that lies beyond ``horizon`` (the longest RUL the trend was followed to) is
    ``math.inf``: the trend does not reach the threshold within the horizon. It is never
    ``nan``; :meth:`as_event` turns it into ``null`` with a note saying so.
    """

    rul: float
    lower: float
    upper: float
    draws: FloatArray
    horizon: float = math.inf

    def as_event(self) -> dict[str, Any]:
        """JSON-ready: ``rul``/``low``/``high`` in flights, ``null`` beyond the horizon."""
        out: dict[str, Any] = {"unit": "flights"}
        beyond = []
        for key, v in (("rul", self.rul), ("low", self.lower), ("high", self.upper)):
            out[key] = round(v, 3) if math.isfinite(v) else None
            if not math.isfinite(v):
                beyond.append(key)
        if beyond:
            out["note"] = (f"{', '.join(beyond)} beyond the {self.horizon:g}-flight horizon: "
                           "the trend does not reach the failure threshold by then")
        return out


def quantiles(draws: FloatArray, q: Sequence[float] = (5.0, 50.0, 95.0)) -> list[float]:
    """Percentiles of RUL draws as order statistics: a draw that never crosses (``inf``) gives
    ``inf`` where linear interpolation would give ``inf - inf = nan``."""
    return [float(v) for v in np.percentile(draws, list(q), method="inverted_cdf")]
