"""The float path's general pieces: any bridge (shorted or open switches), the SMPS exact step.

Helpers of :mod:`mapr_daemon.ema.scalar`, each the one-run transcription of the vectorised
function named in its docstring; the intact-bridge case is written inline there for speed.
"""

from __future__ import annotations

import cmath
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mapr_daemon.ema.scalar import ScalarRun

_FLOAT_ONE = 1.0 - 1e-9
"""inverter/motor threshold for "off for the whole period"."""


def phi(lam: complex, h: float) -> tuple[complex, complex]:
    """smps._phi: exp(lam*h) and its integral over [0, h]."""
    e = cmath.exp(lam * h)
    if abs(lam * h) < 1e-8:
        return e, complex(h)
    return e, (e - 1.0) / lam


def legs(run: ScalarRun, hi_ph: int, lo_ph: int, au: float, vdc: float,
          cur: tuple[float, float, float]) -> tuple[list[float], list[float], list[bool],
                                                    list[bool], float, float, float]:
    """inverter.on_fractions, legs, dc_link_current and conduction_loss for one run."""
    oh, ol, sh, sl = (run.ph("open_high"), run.ph("open_low"), run.ph("short_high"),
                      run.ph("short_low"))
    rh3, rl3 = run.ph("r_high"), run.ph("r_low")
    vd, r_diode = run.f("v_diode"), run.f("r_diode")
    v_leg = [0.0, 0.0, 0.0]
    r_leg = [0.0, 0.0, 0.0]
    floating = [False, False, False]
    diode_only = [False, False, False]
    g_shoot = i_ext = p_inv = 0.0
    for k in range(3):
        a_h = au if k == hi_ph else 0.0
        a_lo = 1.0 if k == lo_ph else (1.0 - au if k == hi_ph else 0.0)
        a_h = max(a_h * (1.0 - oh[k]), sh[k])
        a_lo = max(a_lo * (1.0 - ol[k]), sl[k])
        f_both = max(a_h + a_lo - 1.0, 0.0)
        f_high = a_h - f_both
        f_low = a_lo - f_both
        f_none = max(1.0 - f_high - f_low - f_both, 0.0)
        rh, rl = rh3[k], rl3[k]
        r_sum = rh + rl
        ik = cur[k]
        v_dio = -vd if ik >= 0.0 else vdc + vd
        v_leg[k] = f_high * vdc + f_both * vdc * (rl / r_sum) + f_none * v_dio
        r_leg[k] = f_high * rh + f_low * rl + f_both * (rh * rl / r_sum) + f_none * r_diode
        diode_only[k] = f_none > _FLOAT_ONE
        floating[k] = diode_only[k] and ik == 0.0
        g_shoot += f_both / r_sum
        i_ext += f_high * ik + f_both * ik * (rl / r_sum) + f_none * min(ik, 0.0)
        i2 = ik * ik
        f_low2 = max(1.0 - f_high - f_both - f_none, 0.0)
        sw = f_high * rh * i2 + f_low2 * rl * i2
        sw += f_both * (rh * rl / r_sum) * i2
        p_inv += sw + f_none * (vd * abs(ik) + r_diode * i2)
    p_inv += g_shoot * vdc * vdc
    return v_leg, r_leg, floating, diode_only, g_shoot, i_ext, p_inv


def smps_coeffs(r: float, g: float, esr: float, lc: float, cc: float,
                 h: float) -> tuple[float, ...]:
    """smps.step's system matrix and exact-step coefficients for resistance r, conductance g.

    Returns ``(k, a11, a12, a21, a22, ea, eb, fa, fb)``: one step is
    ``x' = (ea*A + eb*I) x + (fa*A + fb*I) b``.
    """
    kk = 1.0 / (1.0 + esr * g)
    a11 = -(r + kk * esr) / lc
    a12 = -kk / lc
    a21 = kk / cc
    a22 = -g * kk / cc
    half_tr = 0.5 * (a11 + a22)
    det = a11 * a22 - a12 * a21
    disc = cmath.sqrt(complex(half_tr * half_tr - det))
    tiny = 1e-7 * (abs(half_tr) + 1.0)
    if abs(disc) < tiny:
        disc = complex(tiny)
    l1, l2 = half_tr + disc, half_tr - disc
    e1, f1 = phi(l1, h)
    e2, f2 = phi(l2, h)
    dl = l1 - l2
    return (kk, a11, a12, a21, a22, ((e1 - e2) / dl).real, ((l1 * e2 - l2 * e1) / dl).real,
            ((f1 - f2) / dl).real, ((l1 * f2 - l2 * f1) / dl).real)


def windings(i: tuple[float, float, float], e: tuple[float, float, float],
              v_leg: list[float], r_leg: list[float], floating: list[bool],
              diode_only: list[bool], r_w: float, h_l: float, vdc: float, vd: float,
              r_diode: float) -> tuple[float, float, float, float]:
    """motor.solve_windings for one run: new phase currents and the neutral voltage."""
    conn = [not fl for fl in floating]
    w = [1.0 / (1.0 + h_l * (r_leg[k] + r_w)) for k in range(3)]
    vn = neutral(w, i, v_leg, e, h_l, conn)
    if floating[0] or floating[1] or floating[2]:
        clamp = False
        for k in range(3):
            if floating[k]:
                v_term = e[k] + vn
                if v_term > vdc + vd:
                    v_leg[k], r_leg[k], conn[k], clamp = vdc + vd, r_diode, True, True
                elif v_term < -vd:
                    v_leg[k], r_leg[k], conn[k], clamp = -vd, r_diode, True, True
        if clamp:
            w = [1.0 / (1.0 + h_l * (r_leg[k] + r_w)) for k in range(3)]
            vn = neutral(w, i, v_leg, e, h_l, conn)
    new = [w[k] * (i[k] + h_l * (v_leg[k] - e[k] - vn)) if conn[k] else 0.0 for k in range(3)]
    dead = [diode_only[k] and i[k] != 0.0 and new[k] * i[k] < 0.0 for k in range(3)]
    if dead[0] or dead[1] or dead[2]:
        new = [0.0 if dead[k] else new[k] for k in range(3)]
        alive = [conn[k] and not dead[k] and new[k] != 0.0 for k in range(3)]
        n_alive = alive[0] + alive[1] + alive[2]
        resid = (new[0] + new[1] + new[2]) / max(n_alive, 1)
        new = [new[k] - resid if alive[k] else new[k] for k in range(3)]
        if n_alive < 2:
            new = [0.0, 0.0, 0.0]
    return new[0], new[1], new[2], vn


def neutral(w: list[float], i: tuple[float, float, float], v_leg: list[float],
             e: tuple[float, float, float], h_l: float, conn: list[bool]) -> float:
    """motor._neutral for one run."""
    num = 0.0
    wsum = 0.0
    n_conn = 0
    for k in range(3):
        wc = w[k] if conn[k] else 0.0
        num += wc * (i[k] + h_l * (v_leg[k] - e[k]))
        wsum += wc
        n_conn += conn[k]
    if n_conn >= 2:
        return num / max(h_l * wsum, 1e-30)
    return (e[0] + e[1] + e[2]) / 3.0


def smps_step_matrix(r: float, g: float, esr: float, lc: float, cc: float,
                     h: float) -> tuple[float, ...]:
    """smps.step as one affine map: ``(m11, m12, m21, m22, p1, p2, q1, q2, k)`` with

    ``i_l' = m11 i_l + m12 v_c + p1 (D Vin) + q1 i_ext`` and likewise ``v_c'`` with row 2;
    ``M = ea A + eb I`` and ``N = fa A + fb I`` of :func:`smps_coeffs` applied to the input
    ``b = ((D Vin + k ESR i_ext)/L, -k i_ext/C)`` and regrouped by ``D Vin`` and ``i_ext``.
    """
    kk, a11, a12, a21, a22, ea, eb, fa, fb = smps_coeffs(r, g, esr, lc, cc, h)
    n11, n12, n21, n22 = fa * a11 + fb, fa * a12, fa * a21, fa * a22 + fb
    u1 = kk * esr / lc  # b1 per ampere of i_ext
    u2 = -kk / cc  # b2 per ampere of i_ext
    return (ea * a11 + eb, ea * a12, ea * a21, ea * a22 + eb, n11 / lc, n21 / lc,
            n11 * u1 + n12 * u2, n21 * u1 + n22 * u2, kk)
