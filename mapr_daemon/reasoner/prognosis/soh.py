"""State of health: how far a component has gone from nominal towards its failure threshold.

SoH of a component is ``1 - (p - p_nom) / (p_fail - p_nom)`` clipped to [0, 1]: 1 healthy, 0 at
its failure threshold. The thresholds are those of the degradation model
(:data:`mapr_daemon.ema.degradation.FAILURE`): capacitance at 70 % of nominal and ESR doubled
(the usual electrolytic end-of-life criterion, REFERENCE.md), MOSFET Ron doubled (our choice;
REFERENCE.md also quotes a 0.05 ohm rise, flagged uncertain), friction tripled (our choice).
A shorted or open switch is SoH 0 of the inverter bridge.
"""

from __future__ import annotations

from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.ema.faults import PARAMETRIC, nominal_value, range_end
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError


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
