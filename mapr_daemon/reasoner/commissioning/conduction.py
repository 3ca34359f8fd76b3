"""An open inverter switch read off the recorded phase currents: the switch whose current
direction does not conduct.

Why apart from the model's least squares
(:func:`~mapr_daemon.reasoner.commissioning.severity.read`): an open switch is a gross change
of the bridge, and what it does to the *motion* depends on laws the identified model may not
carry (the friction law near standstill, the control law, the loop rates). On a unit that is
not the model's twin the surface can stall in the sectors the open switch should drive, or
drift through them, and the model stalls elsewhere or not at all; the position residual, tens
of degrees in units of a sensor noise of a thousandth of one, then outweighs every other
signal, and the hypothesis closest to "stuck" (a shorted switch, heavy friction) wins the cost
or nothing explains the BIT (the open switch, best by a hair, leaves 93-100 % of the "no
fault" cost).

What does not depend on those laws is the bridge itself: in a six-step drive a phase's
high-side switch is what drives positive current into its winding from the DC link, the low
side what drives it negative. Every BIT moves the surface both ways through many electrical
revolutions, so on a sound bridge each phase carries current both ways at a peak close to the
others'. With one switch open that direction only carries what the back-EMF pushes through
the leg's other switch or a diode: a small share of the driven peak. A rotor that stalls in
the sectors the open switch should drive can starve one more direction.

:func:`open_switch` measures, per phase and direction, the :data:`PEAK_QUANTILE` quantile of
the current in that direction over the BIT, as a share of the largest of the six, and names an
open switch when one or two directions (:data:`MAX_MISSING`) stay below :data:`OPEN_SHARE`
while the others reach :data:`CONDUCT_SHARE`, the largest well above the sensors' noise
(:data:`MIN_CURRENT_NOISE`): the lowest direction is named, the other low one (if any) kept as
a candidate. A shorted switch or a bridge that carries almost nothing (a rotor parked where the
open switch should drive, in voltage-mode control) leaves three or more directions low, or
every one under the noise: then nothing is said and the model's reading stands.

Thresholds chosen on design seeds of the mismatch harness (31: 3 aileron units read in full;
32 and 33: 10 aileron and 10 elevator units, the phase currents only; every unit 10-24 healthy
BITs, one BIT per parametric mode, an open on every switch, shorts on the high sides). On 320
healthy and parametric-fault BITs the weakest direction reached 0.44 of the largest or more
(1 % quantile 0.45, median 0.62-0.67); at :data:`OPEN_SHARE` 0.15 / 0.2 / 0.25 the opens named
were 32 / 35 / 41 of 60 (aileron) and 29 / 31 / 33 of 60 (elevator), none of the 60 shorts
and none of the healthy or parametric BITs; 0.2 keeps twice the margin below the weakest
healthy direction. An open low side is named nearly always (its direction 0.01-0.20); an
open high side about half the time (0.04-0.44: with complementary PWM the back-EMF drives
current through the leg's low switch); a stalled bridge (largest peak 0.1 A) never.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import SWITCHES
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.reasoner.commissioning.bits import PHASE_CHANNELS, channel_noise

PEAK_QUANTILE = 0.99
"""A direction's peak: the current exceeded for 1 % of the BIT (15 ms of a 1.46 s BIT), so a
single noise spike does not count as conduction."""
OPEN_SHARE = 0.2
"""A direction whose peak stays below this share of the largest does not conduct."""
CONDUCT_SHARE = 0.3
"""Every other direction must reach this share of the largest: one switch missing, not a
shorted bridge."""
MAX_MISSING = 2
"""At most this many directions below :data:`OPEN_SHARE`: the open switch's, and one a stall
in its sectors starved."""
MIN_CURRENT_NOISE = 10.0
"""The largest peak must exceed this many phase-current noise sd (else the BIT drew too little
current to say which switch carried it)."""


@dataclasses.dataclass(frozen=True)
class OpenSwitch:
    """The switch the phase currents say never conducted, and what says it."""

    switch: str
    """One of :data:`~mapr_daemon.ema.faults.SWITCHES`."""
    peaks: dict[str, float]
    """Each switch's direction peak as a share of the largest (the open one near 0)."""
    candidates: tuple[str, ...]
    """The switches whose direction stayed below :data:`OPEN_SHARE`, lowest first (the
    named one first)."""
    largest_a: float
    """The largest direction peak, amperes."""

    def to_json(self) -> dict[str, Any]:
        """The event's ``evidence.baseline.phase_currents``."""
        return {"open_switch": self.switch, "candidates": list(self.candidates),
                "largest_peak_a": round(self.largest_a, 4),
                "peak_share": {k: round(v, 3) for k, v in self.peaks.items()},
                "rule": f"at most {MAX_MISSING} switches' current directions stay below "
                        f"{OPEN_SHARE:g} of the largest, the others reach {CONDUCT_SHARE:g} "
                        f"of it; the lowest is named"}


def phase_noise(params: ActuatorParams) -> float:
    """The phase-current channels' per-sample noise sd (white noise and quantisation; the
    largest of the three)."""
    return max(channel_noise(params, k) for k in PHASE_CHANNELS)


def peaks(channels: Mapping[str, FloatArray]) -> dict[str, float]:
    """Per switch (:data:`SWITCHES` order: A high, A low, B high, ...), the
    :data:`PEAK_QUANTILE` quantile of its phase's current in the direction it drives: positive
    (into the winding) for a high side, negative for a low side; amperes."""
    out: dict[str, float] = {}
    for k, name in enumerate(PHASE_CHANNELS):
        i = np.asarray(channels[name], dtype=np.float64)
        out[SWITCHES[2 * k]] = float(np.quantile(np.maximum(i, 0.0), PEAK_QUANTILE))
        out[SWITCHES[2 * k + 1]] = float(np.quantile(np.maximum(-i, 0.0), PEAK_QUANTILE))
    return out


def open_switch(params: ActuatorParams, channels: Mapping[str, FloatArray]
                ) -> OpenSwitch | None:
    """The open switch the BIT's phase currents show (module docstring), or None: a sound
    bridge, or a record that cannot say (too little current, three or more directions
    missing, a phase channel absent)."""
    if any(k not in channels for k in PHASE_CHANNELS):
        return None
    p = peaks(channels)
    largest = max(p.values())
    if not math.isfinite(largest) or largest < MIN_CURRENT_NOISE * phase_noise(params):
        return None
    share = {k: v / largest for k, v in p.items()}
    low = sorted((k for k, v in share.items() if v < OPEN_SHARE), key=lambda k: share[k])
    if not 1 <= len(low) <= MAX_MISSING or any(
            v < CONDUCT_SHARE for k, v in share.items() if k not in low):
        return None
    return OpenSwitch(low[0], share, tuple(low), largest)
