"""State of health, remaining useful life from the trend across flights, and RUL metrics.

SoH of a component is ``1 - (p - p_nom) / (p_fail - p_nom)`` clipped to [0, 1]: 1 healthy, 0 at
its failure threshold. The thresholds are those of the degradation model
(:data:`mapr_daemon.ema.degradation.FAILURE`): capacitance at 70 % of nominal and ESR doubled
(the usual electrolytic end-of-life criterion, REFERENCE.md), MOSFET Ron doubled (our choice;
REFERENCE.md also quotes a 0.05 ohm rise, flagged uncertain), friction tripled (our choice).
A shorted or open switch is SoH 0 of the inverter bridge.

RUL: :class:`RulEstimate` (median and 5/95 % bounds in flights) comes from the aging-shape trend
fit of :mod:`~mapr_daemon.reasoner.trend`.

Metrics (Saxena et al.): relative accuracy on RUL ``1 - |r* - r|/r*`` (on RUL, not on the
time of the event, which would flatter late predictions); alpha-lambda: at
``t_lambda = t0 + lambda*(EoL - t0)`` at least ``beta`` of the RUL distribution within
``(1 +/- alpha) r*``; prognostic horizon: EoL minus the first time from which every prediction
stays within the alpha bounds.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.ema.faults import PARAMETRIC, nominal_value, range_end
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.features import FloatArray


def failure_value(params: ActuatorParams, kind: str) -> float:
    """The parameter value at which the component counts as failed."""
    if kind not in FAILURE:
        raise ConfigError("no failure threshold for this kind", field=kind)
    return FAILURE[kind] * nominal_value(params, kind)


def failure_severity(params: ActuatorParams, kind: str) -> float:
    """The failure threshold as a fraction of the Table 1 range."""
    lo, hi = nominal_value(params, kind), range_end(params, kind)
    return (failure_value(params, kind) - lo) / (hi - lo)


def degradation(params: ActuatorParams, kind: str, value: float) -> float:
    """``h``: 0 at nominal, 1 at the failure threshold (may exceed 1)."""
    lo = nominal_value(params, kind)
    return (value - lo) / (failure_value(params, kind) - lo)


def soh(params: ActuatorParams, kind: str, value: float | None) -> float:
    """State of health of the kind's component, 1 healthy to 0 failed."""
    if kind in ("short", "open"):
        return 0.0
    if kind not in PARAMETRIC or value is None:
        raise ConfigError("unknown fault kind", field=kind)
    return float(min(1.0, max(0.0, 1.0 - degradation(params, kind, value))))


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


def relative_accuracy(true_rul: float, est_rul: float) -> float:
    """RA on RUL: ``1 - |r* - r| / r*``."""
    if true_rul <= 0:
        raise ConfigError("true RUL must be > 0", field="rul")
    return 1.0 - abs(true_rul - est_rul) / true_rul


def alpha_lambda_pass(true_rul: float, draws: FloatArray, alpha: float = 0.2,
                      beta: float = 0.5) -> bool:
    """Whether at least ``beta`` of the RUL draws lie within ``(1 +/- alpha) r*``."""
    inside = (draws >= (1 - alpha) * true_rul) & (draws <= (1 + alpha) * true_rul)
    return bool(inside.mean() >= beta)


def prognostic_horizon(times: FloatArray, true_ruls: FloatArray, est_ruls: FloatArray,
                       eol: float, alpha: float = 0.2) -> float:
    """EoL minus the first time from which every point estimate stays within alpha bounds."""
    ok = np.abs(est_ruls - true_ruls) <= alpha * true_ruls
    for i in range(ok.size):
        if ok[i:].all():
            return float(eol - times[i])
    return 0.0
