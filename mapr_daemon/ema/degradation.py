"""Degradation trajectories over many flights, with the true end of life, for scoring RUL.

Shapes follow the published aging behaviour of each part (rates are drawn per unit, so two
units of the same kind age differently; a little flight-to-flight scatter rides on top):

* MOSFET Ron (SMPS high/low side, inverter phase-A high side) — thermal-overstress aging of
  power MOSFETs (NASA Ames IRF520N runs) shows die-attach degradation as an *exponentially*
  rising Ron: ``R(n) = R0 + a*(exp(b*n) - 1)``.
* Electrolytic output capacitor — electrolyte loss: capacitance falls and ESR rises, both
  accelerating; modelled as ``C(n) = C0*(1 - a*(exp(b*n) - 1))`` and ``1/ESR`` falling
  linearly (``ESR(n) = ESR0/(1 - k*n)``), the common empirical forms.
* Friction (bearing/gear wear) — a power law ``1 + a*n**1.5``.

End of life is the (fractional) flight at which the parameter crosses its failure threshold:
capacitance at 70 % of nominal, ESR at twice nominal (the capacitor criterion quoted in
REFERENCE.md), Ron at twice nominal (our choice; REFERENCE notes a 0.05 ohm rise is also
quoted, flagged uncertain), friction at three times nominal.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import Fault, nominal_value
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError

FAILURE: dict[str, float] = {
    "capacitance": 0.7, "esr": 2.0, "smps_ron_high": 2.0, "smps_ron_low": 2.0,
    "inverter_ron_a_high": 2.0, "friction": 3.0,
}
"""Failure threshold as a ratio of the nominal value."""


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """One unit's parameter over flights 0..n-1 and where it truly failed."""

    kind: str
    values: FloatArray
    nominal: float
    threshold: float
    eol_flight: float

    def fault(self, flight: int) -> Fault:
        """The seeded fault for one flight of this trajectory."""
        return Fault(self.kind, float(self.values[flight]))

    def rul(self, flight: int) -> float:
        """True remaining useful life, in flights, at the start of ``flight``."""
        return max(self.eol_flight - flight, 0.0)


def _shape(kind: str, n: FloatArray, life: float, rng: np.random.Generator) -> FloatArray:
    """Ratio to nominal over flights ``n`` for a unit whose nominal life is ``life`` flights."""
    target = FAILURE[kind]
    if kind == "esr":
        k = (1.0 - 1.0 / target) / life
        out: FloatArray = 1.0 / np.maximum(1.0 - k * n, 0.05)
        return out
    if kind == "friction":
        return 1.0 + (target - 1.0) * (n / life) ** 1.5
    b = rng.uniform(2.0, 4.0) / life  # curvature: a few e-foldings over the life
    a = abs(target - 1.0) / math.expm1(b * life)
    if kind == "capacitance":
        return np.maximum(1.0 - a * np.expm1(b * n), 0.0)
    return 1.0 + a * np.expm1(b * n)


def trajectory(params: ActuatorParams, kind: str, n_flights: int, seed: int,
               mean_life_flights: float = 200.0, scatter: float = 0.01) -> Trajectory:
    """A unit's aging path over ``n_flights``; the life is drawn around the mean (+/-30 %)."""
    if kind not in FAILURE:
        raise ConfigError(f"no aging model for {kind!r} (known: {', '.join(FAILURE)})",
                          field="kind")
    if n_flights < 2:
        raise ConfigError("need at least two flights", field="n_flights")
    rng = np.random.default_rng(seed)
    life = mean_life_flights * rng.uniform(0.7, 1.3)
    flights = np.arange(n_flights, dtype=np.float64)
    ratio = _shape(kind, flights, life, rng)
    ratio = ratio * (1.0 + scatter * rng.standard_normal(n_flights))
    ratio[0] = 1.0
    nominal = nominal_value(params, kind)
    fine = np.linspace(0.0, max(n_flights, life * 1.5), 20001)
    rng2 = np.random.default_rng(seed)
    rng2.uniform(0.7, 1.3)  # replay the draws above: the smooth curve is the same unit's
    smooth = _shape(kind, fine, life, rng2)
    target = FAILURE[kind]
    crossed = smooth <= target if kind == "capacitance" else smooth >= target
    eol = float(fine[np.argmax(crossed)]) if crossed.any() else math.inf
    return Trajectory(kind, np.maximum(ratio, 0.0) * nominal, nominal, target * nominal, eol)
