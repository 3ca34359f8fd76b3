"""Phase A's high-side loop resistance, resolved by commutation sector, from the drive's channels.

An inverter phase-A high-side Ron fault adds its resistance only while that switch is the PWM'd
one: in Hall sectors 1-2 driving positive torque and 4-5 driving negative (the commutation
tables of :mod:`mapr_daemon.ema.inverter`). Per sample the drive applies ``v = duty * Vdc``
across the two conducting windings, and by the six-step circuit
``v = R_loop * i_q + k * omega + offset`` (``i_q`` the sector's torque current from the phase
sensors, ``omega`` the motor speed from the position's derivative). Fitting that line by least
squares once over the samples where phase A's high side is driven and once over the others,
and taking the difference of the two slopes ``R_loop``, leaves the fault's share: both fits
share one trajectory, winding, temperature and friction, so most flight-to-flight variation
cancels. What remains follows the air load (how long the BIT's ramps drive each sector), which
the healthy model predicts from the flight condition like any other cell.

The fit is batched: per run, the masked normal equations ``X'X`` (3 x 3) and ``X'v`` are sums
over samples, solved for all runs at once.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.inverter import NEGATIVE, POSITIVE

A_HIGH_SECTORS = {1: (1, 2), -1: (4, 5)}
"""Hall sectors (the drive's 1..6) where phase A's high side is PWM'd, by torque sign."""

CHANNELS = ("commutation_sector", "inverter_duty", "phase_a_current_a", "phase_b_current_a",
            "phase_c_current_a", "position_deg", "dc_bus_voltage_v")
RIDGE = 1e-9
"""Relative ridge on the normal equations (a run that never enters a sector stays finite)."""


def _slope(x: FloatArray, v: FloatArray, mask: FloatArray) -> FloatArray:
    """Per run, the first coefficient of the least-squares fit of ``v`` on ``x`` over
    ``mask``: ``x (n, S, 3)``, ``v (n, S)``, ``mask (n, S)`` -> ``(n,)``."""
    xw = x * mask[..., None]
    a = np.einsum("nsi,nsj->nij", xw, x)
    b = np.einsum("nsi,ns->ni", xw, v)
    scale = np.maximum(np.trace(a, axis1=1, axis2=2), 1e-30) / 3.0
    a = a + (RIDGE * scale)[:, None, None] * np.eye(3)[None]
    out: FloatArray = np.linalg.solve(a, b[..., None])[:, 0, 0]
    return out


def a_high_driven(sector: FloatArray, duty: FloatArray) -> npt.NDArray[np.bool_]:
    """Where phase A's high side is the PWM'd switch: the drive's Hall ``sector`` (1..6) and
    signed ``duty`` (its sign is the torque's), sample by sample."""
    pos, neg = A_HIGH_SECTORS[1], A_HIGH_SECTORS[-1]
    out: npt.NDArray[np.bool_] = ((duty > 0) & np.isin(sector, pos)) | \
        ((duty < 0) & np.isin(sector, neg))
    return out


def a_high_resistance(channels: Mapping[str, FloatArray]) -> FloatArray:
    """Loop resistance while phase A's high side is PWM'd minus elsewhere, per run (ohm).

    ``channels`` are ``(n_runs, samples)`` arrays carrying :data:`CHANNELS`.
    """
    sector = np.rint(np.asarray(channels["commutation_sector"], dtype=np.float64))
    sec = np.clip(sector.astype(np.int64) - 1, 0, 5)
    duty = np.asarray(channels["inverter_duty"], dtype=np.float64)
    cur = np.stack([np.asarray(channels[f"phase_{p}_current_a"], dtype=np.float64)
                    for p in "abc"])
    plus = POSITIVE.argmax(axis=1)[sec]
    minus = NEGATIVE.argmax(axis=1)[sec]
    i_q = 0.5 * (np.take_along_axis(cur, plus[None], 0)[0]
                 - np.take_along_axis(cur, minus[None], 0)[0])
    # speed in position units per sample: its scale only rescales the back-EMF coefficient
    omega = np.gradient(np.asarray(channels["position_deg"], dtype=np.float64), axis=-1)
    v = duty * np.asarray(channels["dc_bus_voltage_v"], dtype=np.float64)
    a_high = a_high_driven(sector, duty)
    x = np.stack([i_q, omega, np.ones_like(i_q)], axis=-1)
    m = a_high.astype(np.float64)
    out: FloatArray = _slope(x, v, m) - _slope(x, v, 1.0 - m)
    return out
