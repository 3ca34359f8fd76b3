"""Three-phase MOSFET bridge: six-step commutation, PWM-averaged legs, body diodes, faults.

Commutation (complementary PWM on the driven leg, low side on at the return leg): in each
Hall sector one phase's flat-top back-EMF is +1 and another's is -1. For positive torque the
"+" phase's leg is PWM'd (high side on for |u| of the period, its low side for the rest:
synchronous freewheeling) and the "-" phase's low-side switch is held on; for negative
torque the roles swap. The third phase is off. Phase A's high side therefore conducts in two
of the six sectors (for a given torque sign), which is what lets a per-sector resistance
separate its Ron from a winding change.

Each leg is averaged over a PWM period from its switches' on-fractions ``a_high``, ``a_low``
(a shorted switch is forced to 1, an open one to 0). The period splits into fractions where
only the high switch conducts, only the low one, both (shoot-through through a shorted
switch: the leg is a divider across the DC link and draws ``Vdc/(Rh+Rl)``), or neither (the
body diodes decide: positive phase current returns through the low diode, negative through
the high one, and a phase with no current floats). Every leg becomes a Thevenin source
``v_leg - r_leg*i`` seen by its winding, plus its share of the DC-link current.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import numpy.typing as npt

from mapr_daemon.ema.batch import BatchArrays, FloatArray


def trapezoid(theta_e: npt.NDArray[np.floating[Any]]) -> FloatArray:
    """Flat-top (120 degree) back-EMF shapes of phases A, B, C, shape ``(3, n)``, in [-1, 1]."""
    shifts = np.array([0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0])[:, None]
    phi = np.mod(theta_e[None, :] - shifts - math.pi / 2.0, 2.0 * math.pi)
    dist = np.minimum(phi, 2.0 * math.pi - phi)  # circular distance to the peak
    out: FloatArray = np.minimum(np.maximum(3.0 - dist * (6.0 / math.pi), -1.0), 1.0)
    return out


def sector(theta_e: FloatArray) -> npt.NDArray[np.int64]:
    """Hall sector 0..5; sector k spans electrical angles [pi/6 + k*pi/3, pi/6 + (k+1)*pi/3)."""
    out: npt.NDArray[np.int64] = (
        np.floor((theta_e - math.pi / 6.0) / (math.pi / 3.0)).astype(np.int64) % 6)
    return out


def _tables() -> tuple[FloatArray, FloatArray]:
    centres = math.pi / 3.0 + np.arange(6) * math.pi / 3.0
    f = trapezoid(centres)  # (3, 6)
    pos = (f > 0.99).astype(np.float64).T  # (6, 3) one-hot "+" phase per sector
    neg = (f < -0.99).astype(np.float64).T
    assert np.all(pos.sum(axis=1) == 1) and np.all(neg.sum(axis=1) == 1)
    return pos, neg


POSITIVE, NEGATIVE = _tables()
"""One-hot tables ``(6 sectors, 3 phases)``: which phase is "+" and which is "-" per sector."""


@dataclasses.dataclass
class Legs:
    """Averaged legs for one step, each array ``(3, n)``."""

    v_leg: FloatArray
    r_leg: FloatArray
    floating: npt.NDArray[np.bool_]
    f_high: FloatArray
    f_both: FloatArray
    f_none: FloatArray
    g_shoot: FloatArray
    """(n,) shoot-through conductance seen by the DC link."""


def on_fractions(p: BatchArrays, sec: npt.NDArray[np.int64],
                 u: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Commanded high/low on-fractions per leg for signed duty ``u``, faults applied."""
    pos = POSITIVE[sec].T  # (3, n)
    neg = NEGATIVE[sec].T
    forward = u >= 0.0
    hi_phase = np.where(forward, pos, neg)
    lo_phase = np.where(forward, neg, pos)
    a_high = hi_phase * np.abs(u)
    a_low = lo_phase + hi_phase * (1.0 - np.abs(u))
    a_high = np.maximum(a_high * (1.0 - p.open_high), p.short_high)
    a_low = np.maximum(a_low * (1.0 - p.open_low), p.short_low)
    return a_high, a_low


def legs(p: BatchArrays, a_high: FloatArray, a_low: FloatArray, vdc: FloatArray,
         i: FloatArray) -> Legs:
    """Thevenin equivalent of every leg for phase currents ``i`` (``(3, n)``).

    In a leg's fraction with both switches off, a positive (or zero) current returns through
    the low-side diode and a negative one through the high-side diode; a leg off for the whole
    period with no current floats (``floating``) and the winding solver decides whether a diode
    starts to conduct.
    """
    f_both = np.maximum(a_high + a_low - 1.0, 0.0)
    f_high = a_high - f_both
    f_low = a_low - f_both
    f_none = np.maximum(1.0 - f_high - f_low - f_both, 0.0)
    rh, rl = p.r_high, p.r_low
    r_sum = rh + rl
    vd = p.v_diode
    v_diode = np.where(i >= 0.0, -vd, vdc + vd)
    v_leg = f_high * vdc + f_both * vdc * (rl / r_sum) + f_none * v_diode
    r_leg = f_high * rh + f_low * rl + f_both * (rh * rl / r_sum) + f_none * p.r_diode
    floating = (f_none > 1.0 - 1e-9) & (i == 0.0)
    g_shoot = np.add.reduce(f_both / r_sum, axis=0)
    return Legs(v_leg, r_leg, floating, f_high, f_both, f_none, g_shoot)


def dc_link_current(p: BatchArrays, lg: Legs, i: FloatArray) -> FloatArray:
    """DC-link current drawn by the bridge, excluding the shoot-through ``g_shoot*Vdc`` term."""
    through_high = lg.f_high * i + lg.f_both * i * (p.r_low / (p.r_high + p.r_low))
    diode_back = lg.f_none * np.minimum(i, 0.0)
    out: FloatArray = np.add.reduce(through_high + diode_back, axis=0)
    return out


def conduction_loss(p: BatchArrays, lg: Legs, i: FloatArray, vdc: FloatArray) -> FloatArray:
    """Bridge conduction loss (W) per run: switch Ron, diodes and shoot-through."""
    i2 = i * i
    f_low = np.maximum(1.0 - lg.f_high - lg.f_both - lg.f_none, 0.0)
    sw = lg.f_high * p.r_high * i2 + f_low * p.r_low * i2
    sw += lg.f_both * (p.r_high * p.r_low / (p.r_high + p.r_low)) * i2
    diode = lg.f_none * (p.v_diode * np.abs(i) + p.r_diode * i2)
    out: FloatArray = np.add.reduce(sw + diode, axis=0) + lg.g_shoot * vdc * vdc
    return out
