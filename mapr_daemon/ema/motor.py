"""BLDC windings, rotor mechanics, gear train and the surface's hinge moment.

Windings (star, no neutral wire): ``L di_x/dt = v_leg_x - (r_leg_x + R) i_x - e_x - v_n`` with
``e_x = K*omega*f_x(theta_e)`` and ``sum(i_x) = 0``. The resistive term is taken implicitly
(backward Euler), which keeps a shorted leg's small resistance stable, and the neutral voltage
``v_n`` is solved in closed form so that the connected phases' currents sum to zero exactly.
A phase whose leg is off and whose current is zero floats; it starts conducting through a body
diode when its terminal voltage ``e_x + v_n`` would leave ``[-Vd, Vdc + Vd]`` (regeneration),
and a diode current that would reverse is extinguished instead.

Mechanics (referred to the motor shaft, rigid gear of ratio N and efficiency eta):
``J_eq domega/dt = T_e - B omega - Tc tanh(omega/omega_s) + H_m``, with the hinge moment
``H = q S c (ch0 + ch_delta*delta)`` reflected as ``H/(N eta)`` when the motor works against it
and ``H*eta/N`` when the air drives the surface. The surface stops at +/- travel.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mapr_daemon.ema.batch import BatchArrays, FloatArray
from mapr_daemon.ema.inverter import Legs


def solve_windings(p: BatchArrays, lg: Legs, i: FloatArray, e: FloatArray, r_w: FloatArray,
                   vdc: FloatArray) -> tuple[FloatArray, FloatArray]:
    """One implicit step of the phase currents; returns (new currents, neutral voltage)."""
    h_l = p.step_s / p.l_w
    v_leg = lg.v_leg
    r_leg = lg.r_leg
    conn = ~lg.floating
    w = 1.0 / (1.0 + h_l * (r_leg + r_w))
    vn = _neutral(w, i, v_leg, e, h_l, conn)
    # floating phases whose terminal voltage leaves the diode window start conducting
    v_term = e + vn
    hi = lg.floating & (v_term > vdc + p.v_diode)
    lo = lg.floating & (v_term < -p.v_diode)
    clamp = hi | lo
    if clamp.any():
        v_leg = np.where(hi, vdc + p.v_diode, np.where(lo, -p.v_diode, v_leg))
        r_leg = np.where(clamp, p.r_diode, r_leg)
        conn = conn | clamp
        w = 1.0 / (1.0 + h_l * (r_leg + r_w))
        vn = _neutral(w, i, v_leg, e, h_l, conn)
    new = np.where(conn, w * (i + h_l * (v_leg - e - vn)), 0.0)
    # a diode-only phase whose current would reverse is extinguished
    diode_only = (lg.f_none > 1.0 - 1e-9) & (i != 0.0)
    dead = diode_only & (new * i < 0.0)
    if dead.any():
        # only runs with an extinguished phase are corrected: the others must not even see
        # the rounding of the re-balancing (a run does not depend on its batch neighbours)
        fixed = np.where(dead, 0.0, new)
        alive = conn & ~dead & (fixed != 0.0)
        n_alive = np.add.reduce(alive, axis=0)
        resid = np.add.reduce(fixed, axis=0) / np.maximum(n_alive, 1)
        fixed = np.where(alive, fixed - resid, fixed)
        fixed = np.where(n_alive >= 2, fixed, 0.0)
        new = np.where(np.logical_or.reduce(dead, axis=0), fixed, new)
    return new, vn


def _neutral(w: FloatArray, i: FloatArray, v_leg: FloatArray, e: FloatArray, h_l: FloatArray,
             conn: npt.NDArray[np.bool_]) -> FloatArray:
    """Neutral voltage making the connected phases' new currents sum to zero."""
    wc = np.where(conn, w, 0.0)
    num = np.add.reduce(wc * (i + h_l * (v_leg - e)), axis=0)
    den = h_l * np.add.reduce(wc, axis=0)
    n_conn = np.add.reduce(conn, axis=0)
    # with fewer than two connected phases no current can flow; take the mean EMF
    out: FloatArray = np.where(n_conn >= 2, num / np.maximum(den, 1e-30), np.mean(e, axis=0))
    return out


def hinge_moment(p: BatchArrays, q: FloatArray, delta: FloatArray) -> FloatArray:
    """Aerodynamic hinge moment on the surface (N m), positive in the +delta sense."""
    out: FloatArray = q * p.area_chord * (p.ch0 + p.ch_delta * delta)
    return out


def mechanics(p: BatchArrays, omega: FloatArray, theta: FloatArray, torque: FloatArray,
              hinge: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Advance rotor speed and angle (motor side) by one step, semi-implicitly."""
    h = p.step_s
    reflect = np.where(hinge * omega > 0.0, p.eta, 1.0 / p.eta) / p.ratio
    coul = p.t_coul * np.tanh(omega / p.w_coul)
    drive = torque - coul + hinge * reflect
    omega_new = (omega + h * drive / p.j_eq) / (1.0 + h * p.b_visc / p.j_eq)
    theta_new = theta + h * omega_new
    limit = p.travel_rad * p.ratio
    over = np.abs(theta_new) > limit
    if over.any():
        theta_new = np.clip(theta_new, -limit, limit)
        outward = over & (omega_new * theta_new > 0.0)
        omega_new = np.where(outward, 0.0, omega_new)
    return omega_new, theta_new
