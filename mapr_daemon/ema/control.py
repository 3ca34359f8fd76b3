"""Servo drive controller: position PID -> current command (limited) -> current PI -> duty.

Gains come from physical parameters (see :mod:`mapr_daemon.ema.batch`): the position loop
places a second-order pole pair at ``position_bandwidth_hz`` with ``position_damping`` on the
rigid inertia ``J_eq`` and torque constant ``Kt = 2K``, plus a slow integral that removes the
steady hinge-moment error; the current loop cancels the line-to-line ``2R + 2Ron, 2L`` pole and
crosses over at ``current_bandwidth_hz``. The controlled current is the sector's torque
current ``i_q = (i_plus - i_minus)/2`` as a drive measures it from its phase sensors; the
output is normalised by the measured DC-link voltage (a drive divides by its bus voltage),
with back-EMF feed-forward.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from mapr_daemon.ema.batch import BatchArrays, FloatArray
from mapr_daemon.ema.inverter import NEGATIVE, POSITIVE

U_MAX = 0.98
"""Largest PWM duty the drive commands (bootstrap refresh)."""


@dataclasses.dataclass
class ControlState:
    """Integrators of the two loops, one entry per run."""

    pos_integ: FloatArray
    cur_integ: FloatArray
    i_cmd: FloatArray
    i_q: FloatArray

    @classmethod
    def zero(cls, n: int) -> ControlState:
        z = np.zeros(n)
        return cls(z.copy(), z.copy(), z.copy(), z.copy())


def control(c: ControlState, p: BatchArrays, cmd_rad: FloatArray, theta: FloatArray,
            omega: FloatArray, i: FloatArray, sec: npt.NDArray[np.int64],
            vdc: FloatArray) -> FloatArray:
    """One controller step; returns the signed duty ``u`` in [-U_MAX, U_MAX]."""
    h = p.step_s
    err = cmd_rad * p.ratio - theta  # motor-side radians
    trial = np.minimum(np.maximum(c.pos_integ + p.ki_pos * err * h, -p.i_lim), p.i_lim)
    raw = p.kp_pos * err + trial - p.kd_pos * omega
    i_cmd = np.minimum(np.maximum(raw, -p.i_lim), p.i_lim)
    c.pos_integ = np.where(raw == i_cmd, trial, c.pos_integ)
    c.i_cmd = i_cmd
    pos = POSITIVE[sec].T
    neg = NEGATIVE[sec].T
    i_q = 0.5 * np.add.reduce((pos - neg) * i, axis=0)
    c.i_q = i_q
    e_i = i_cmd - i_q
    trial_i = c.cur_integ + p.ki_i * e_i * h
    v_cmd = p.kp_i * e_i + trial_i + 2.0 * p.k_e * omega
    vdc_safe = np.maximum(vdc, 1.0)
    u_raw = v_cmd / vdc_safe
    u = np.minimum(np.maximum(u_raw, -U_MAX), U_MAX)
    c.cur_integ = np.where(u == u_raw, trial_i, c.cur_integ)
    out: FloatArray = u
    return out
