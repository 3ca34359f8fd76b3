"""Three-phase bridge geometry: six-step commutation tables and the back-EMF trapezoids.

Commutation (complementary PWM on the driven leg, low side on at the return leg): in each
Hall sector one phase's flat-top back-EMF is +1 and another's is -1. For positive torque the
"+" phase's leg is PWM'd (high side on for |u| of the period, its low side for the rest:
synchronous freewheeling) and the "-" phase's low-side switch is held on; for negative
torque the roles swap. The third phase is off. Phase A's high side therefore conducts in two
of the six sectors (for a given torque sign), which is what lets a per-sector resistance
separate its Ron from a winding change.

The bridge itself (legs averaged per PWM period with per-switch Ron, body diodes, shorted and
open switches) is part of the plant's compiled step (:mod:`mapr_daemon.ema.step`, which
carries these tables as ``PLUS``/``MINUS``); this module keeps the geometry for analysis code
(the reasoner's sector-resolved resistance, the EKF's back-EMF shapes, the observability
bench).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray


def trapezoid(theta_e: npt.NDArray[np.floating[Any]]) -> FloatArray:
    """Flat-top (120 degree) back-EMF shapes of phases A, B, C, shape ``(3, n)``, in [-1, 1]."""
    shifts = np.array([0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0])[:, None]
    phi = np.mod(theta_e[None, :] - shifts - math.pi / 2.0, 2.0 * math.pi)
    dist = np.minimum(phi, 2.0 * math.pi - phi)  # circular distance to the peak
    out: FloatArray = np.minimum(np.maximum(3.0 - dist * (6.0 / math.pi), -1.0), 1.0)
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
