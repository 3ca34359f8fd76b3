"""A multi-rate float path (``path="multirate"``): the drive at its PWM period, the SMPS at 25 us.

Why: the float path (:mod:`mapr_daemon.ema.scalar`) runs every part of the plant at the
integrator step (25 us), ~3-4 us of CPython per step. A real servo drive updates its current
loop and commutation once per PWM period (50 us at 20 kHz), and the motor's electrical
(L/R = 0.83 ms) and mechanical dynamics are slow beside the SMPS's LC resonance (1.37 kHz)
and its 25 us voltage loop. So here the drive side (Hall sector, position and current loops,
bridge, windings, mechanics) advances once every ``motor_every`` steps with that longer step
(windings implicit, mechanics semi-implicit as in the reference), and the SMPS with its
voltage loop keeps the 25 us step, fed with the bridge's DC-link current interpolated
linearly across the drive step. Sample means of the drive's signals are accumulated from the
same linear interpolation (closed form, no per-step work); the analytic sub-step ripple and
the SMPS conduction loss (slow, it only heats the stage) are taken once per drive step, and a
voltage loop without a D term skips its filter.

What it is not: bit-equal to the reference. It is validated against the 25 us reference in
``tests/ema/test_multirate_path.py`` with tolerances in units of each channel's noise: every
channel within 2.5 units except the ripple RMS detector (up to ~35 units: the DC bus's
within-sample ringing follows commutation, now timed to 50 us), and shorted or open switches
only by whole-run statistics. The measured speed (~1.6x the float path, not the 20x target)
and why it stops there are in docs/ema-model.md.
"""

from __future__ import annotations

import math

from mapr_daemon.ema.batch import BatchArrays
from mapr_daemon.ema.control import U_MAX
from mapr_daemon.ema.scalar import (
    _IDLE,
    _MINUS,
    _PLUS,
    _SECTOR_OFFSET,
    _SECTOR_WIDTH,
    _SHIFTS,
    _SLOPE,
    _TWO_PI,
    ScalarRun,
)
from mapr_daemon.ema.scalar_bridge import legs, smps_step_matrix, windings
from mapr_daemon.ema.sensors import COPPER_ALPHA

MOTOR_EVERY = 2
"""Integrator steps per drive update: 2 x 25 us = the 50 us PWM period."""


class MultiRateRun(ScalarRun):
    """A :class:`ScalarRun` whose :meth:`sample` updates the drive side every few steps."""

    def __init__(self, p: BatchArrays, r: int, t_on: float = 0.0,
                 motor_every: int = MOTOR_EVERY) -> None:
        """As :class:`ScalarRun`; ``motor_every`` must divide the steps of a sample."""
        super().__init__(p, r, t_on)
        if self.spb % motor_every:
            raise ValueError(f"motor_every {motor_every} does not divide {self.spb} steps")
        self.m = motor_every
        self.torque = 0.0
        """Electromagnetic torque after the last drive update (for interpolation)."""

    def sample(self, t: float, cmd_rad: float, q: float, z_sw: float, z_pwm: float,
               out: list[float]) -> float:
        """Integrate one sample period from ``t`` (see the module docstring); returns t."""
        fp, p3, x = self.fp, self.p3, self.x
        h, m = self.h, self.m
        hm = h * m
        (i_l, v_c, v_out, integ, deriv, prev_err, duty, pos_integ, cur_integ, i_cmd, i_q,
         i0, i1, i2, vn, omega, theta, i_in, motor_c, _stage, _drift, bus_v) = x
        pp, k_e, r_source = fp["pole_pairs"], fp["k_e"], fp["r_source"]
        soft_start, v_ref, tf_v = max(fp["soft_start"], 1e-12), fp["v_ref"], fp["tf_v"]
        kp_v, ki_v, kd_v = fp["kp_v"], fp["ki_v"], fp["kd_v"]
        ron_hi, ron_lo, r_dcr, l_smps = fp["ron_hi"], fp["ron_lo"], fp["r_dcr"], fp["l_smps"]
        i_lim_smps, d_max, f_sw, p_sw = fp["i_lim_smps"], fp["d_max"], fp["f_sw"], fp["p_sw"]
        esr, c_total = fp["esr_eff"], fp["c_total"]
        ratio, ki_pos, kp_pos, kd_pos = fp["ratio"], fp["ki_pos"], fp["kp_pos"], fp["kd_pos"]
        i_lim, ki_i, kp_i = fp["i_lim"], fp["ki_i"], fp["kp_i"]
        rh3, rl3 = p3["r_high"], p3["r_low"]
        vd, r_diode = fp["v_diode"], fp["r_diode"]
        h_l = hm / fp["l_w"]
        area_chord, ch0, ch_delta = fp["area_chord"], fp["ch0"], fp["ch_delta"]
        eta, t_coul, w_coul, j_eq, b_visc = (fp["eta"], fp["t_coul"], fp["w_coul"], fp["j_eq"],
                                             fp["b_visc"])
        limit = fp["travel_rad"] * ratio
        r_w = fp["r_w0"] * (1.0 + COPPER_ALPHA * (motor_c - 25.0))
        self.r_w = r_w
        d_gain = h / (tf_v + h)
        inv_h = 1.0 / h
        ki_v_h, ki_pos_h, ki_i_h = ki_v * h, ki_pos * hm, ki_i * hm
        d_ron = ron_hi - ron_lo
        w_lo3 = tuple(1.0 / (1.0 + h_l * (r + r_w)) for r in rl3)
        w_dio = 1.0 / (1.0 + h_l * (r_diode + r_w))
        lim_term = l_smps / h
        ripple_l = 1.0 / (l_smps * f_sw)
        zsw2, zpwm2 = z_sw * z_sw / 12.0, z_pwm * z_pwm
        ke2 = 2.0 * k_e
        refl_pos, refl_neg = eta / ratio, (1.0 / eta) / ratio
        visc = 1.0 + hm * b_visc / j_eq
        h_j = hm / j_eq
        hinge_k = q * area_chord
        inv_ratio_cmd = cmd_rad * ratio
        faulted = self.faulted
        t_on = self.t_on
        torque = self.torque
        w_new = 0.5 * (m + 1)  # weight of the new end in the sum of a linear interpolation
        w_old_theta = 0.5 * (m - 1)
        (key_r, key_g), coeffs = self.smps_cache
        if not coeffs:
            key_r = ron_lo + r_dcr  # any valid key: the first drive step checks it anyway
            coeffs = smps_step_matrix(key_r, key_g, esr, l_smps, c_total, h)
        m11, m12, m21, m22, p1, p2, q1, q2, kk = coeffs
        a_dc = a_a = a_b = a_c = a_v = a_d = a_vin = a_iin = a_v2 = a_r2 = 0.0
        a_pm = a_ps = a_tq = a_om = a_hg = a_ic = a_iq = a_du = a_il = a_u = 0.0
        sec = 0
        i_ext = slope = g_shoot = au = 0.0
        ramping = t - t_on < soft_start  # the soft start is under way at this sample's start
        r_varies = d_ron != 0.0  # the switch resistance follows the duty
        vref = v_ref
        with_d = kd_v != 0.0  # without a D term its filter state is left as it is
        i_in_start = i_in
        for k in range(self.spb):
            vdc = v_out
            vin = bus_v - r_source * i_in
            # smps.voltage_loop, every step
            if ramping:
                t_up = t - t_on
                vref = v_ref * (t_up / soft_start) if t_up < soft_start else v_ref
            err = vref - v_out
            trial = integ + ki_v_h * err
            inv_vin = 1.0 / vin if vin > 1.0 else 1.0
            if with_d:
                deriv += d_gain * ((err - prev_err) * inv_h - deriv)
                raw = (vref + kp_v * err + trial + kd_v * deriv) * inv_vin
            else:
                raw = (vref + kp_v * err + trial) * inv_vin
            prev_err = err
            d_cl = (v_out + (ron_lo + r_dcr + raw * d_ron) * i_l
                    + lim_term * (i_lim_smps - i_l)) * inv_vin
            duty = d_max if d_max < raw else raw
            if d_cl < duty:
                duty = d_cl
            if duty < 0.0:
                duty = 0.0
            if not ((duty < raw and err > 0.0) or (duty > raw and err < 0.0)):
                integ = trial
            if k % m == 0:
                # ---- the drive: sector, loops, bridge, windings, mechanics over m steps ----
                theta_e = pp * theta
                sec = math.floor((theta_e - _SECTOR_OFFSET) / _SECTOR_WIDTH) % 6
                kp_ph, km_ph, id_ph = _PLUS[sec], _MINUS[sec], _IDLE[sec]
                phi = (theta_e - _SHIFTS[id_ph]) % _TWO_PI
                dist = _TWO_PI - phi if phi > math.pi else phi
                s_id = 3.0 - dist * _SLOPE
                s_id = 1.0 if s_id > 1.0 else (-1.0 if s_id < -1.0 else s_id)
                ke_w = k_e * omega
                e_id = ke_w * s_id
                cur = (i0, i1, i2)
                perr = inv_ratio_cmd - theta
                trial = pos_integ + ki_pos_h * perr
                trial = i_lim if trial > i_lim else (-i_lim if trial < -i_lim else trial)
                raw = kp_pos * perr + trial - kd_pos * omega
                i_cmd = i_lim if raw > i_lim else (-i_lim if raw < -i_lim else raw)
                if raw == i_cmd:
                    pos_integ = trial
                i_q = 0.5 * (cur[kp_ph] - cur[km_ph])
                e_i = i_cmd - i_q
                trial = cur_integ + ki_i_h * e_i
                u_raw = (kp_i * e_i + trial + ke2 * omega) / (vdc if vdc > 1.0 else 1.0)
                u = U_MAX if u_raw > U_MAX else (-U_MAX if u_raw < -U_MAX else u_raw)
                if u == u_raw:
                    cur_integ = trial
                au = u if u >= 0.0 else -u
                hi_ph, lo_ph = (kp_ph, km_ph) if u >= 0.0 else (km_ph, kp_ph)
                theta_old, omega_old, torque_old = theta, omega, torque
                if faulted:
                    shape = [0.0, 0.0, 0.0]
                    shape[kp_ph], shape[km_ph], shape[id_ph] = 1.0, -1.0, s_id
                    e = (ke_w * shape[0], ke_w * shape[1], ke_w * shape[2])
                    v_leg, r_leg, floating, diode_only, g_shoot, i_ext, p_inv = legs(
                        self, hi_ph, lo_ph, au, vdc, cur)
                    n0, n1, n2, vn = windings(cur, e, v_leg, r_leg, floating, diode_only, r_w,
                                              h_l, vdc, vd, r_diode)
                    torque = k_e * (shape[0] * n0 + shape[1] * n1 + shape[2] * n2)
                    i_ext_end = legs(self, hi_ph, lo_ph, au, vdc, (n0, n1, n2))[5]
                else:
                    rh, rl = rh3[hi_ph], rl3[hi_ph]
                    r_hi = au * rh + (1.0 - au) * rl
                    r_lo = rl3[lo_ph]
                    i_hi, i_lo, i_id = cur[hi_ph], cur[lo_ph], cur[id_ph]
                    v_hi = au * vdc
                    g_shoot = 0.0
                    i_ext = au * i_hi + (i_id if i_id < 0.0 else 0.0)
                    p_inv = (r_hi * i_hi * i_hi + r_lo * i_lo * i_lo
                             + vd * abs(i_id) + r_diode * i_id * i_id)
                    e_hi = ke_w if u >= 0.0 else -ke_w
                    w_hi = w_lo3[hi_ph] if rh == rl else 1.0 / (1.0 + h_l * (r_hi + r_w))
                    w_lo = w_lo3[lo_ph]
                    y = w_hi * (i_hi + h_l * (v_hi - e_hi)) + w_lo * (i_lo + h_l * e_hi)
                    w_id = v_id = 0.0
                    if i_id == 0.0:
                        vn = y / (h_l * (w_hi + w_lo))
                        v_term = e_id + vn
                        if v_term > vdc + vd or v_term < -vd:
                            v_id = vdc + vd if v_term > vdc + vd else -vd
                            w_id = w_dio
                    else:
                        v_id = -vd if i_id >= 0.0 else vdc + vd
                        w_id = w_dio
                    if w_id != 0.0:
                        vn = ((y + w_id * (i_id + h_l * (v_id - e_id)))
                              / (h_l * (w_hi + w_lo + w_id)))
                    n_id = w_id * (i_id + h_l * (v_id - e_id - vn)) if w_id != 0.0 else 0.0
                    n_hi = w_hi * (i_hi + h_l * (v_hi - e_hi - vn))
                    n_lo = w_lo * (i_lo + h_l * (e_hi - vn))
                    if i_id != 0.0 and n_id * i_id < 0.0:
                        n_id = 0.0
                        n_alive = (n_hi != 0.0) + (n_lo != 0.0)
                        resid = (n_hi + n_lo) / max(n_alive, 1)
                        if n_alive < 2:
                            n_hi = n_lo = 0.0
                        else:
                            n_hi -= resid
                            n_lo -= resid
                    torque = k_e * ((n_hi - n_lo if u >= 0.0 else n_lo - n_hi) + s_id * n_id)
                    new = [0.0, 0.0, 0.0]
                    new[hi_ph], new[lo_ph], new[id_ph] = n_hi, n_lo, n_id
                    n0, n1, n2 = new
                    i_ext_end = au * n_hi + (n_id if n_id < 0.0 else 0.0)
                slope = (i_ext_end - i_ext) / m
                delta = theta / ratio
                hinge = hinge_k * (ch0 + ch_delta * delta)
                drive = (torque - t_coul * math.tanh(omega / w_coul)
                         + hinge * (refl_pos if hinge * omega > 0.0 else refl_neg))
                omega = (omega + h_j * drive) / visc
                theta_new = theta + hm * omega
                if theta_new > limit or theta_new < -limit:
                    theta_new = limit if theta_new > limit else -limit
                    if omega * theta_new > 0.0:
                        omega = 0.0
                theta = theta_new
                # sums over the m steps of the linear interpolation between old and new
                a_a += m * i0 + w_new * (n0 - i0)
                a_b += m * i1 + w_new * (n1 - i1)
                a_c += m * i2 + w_new * (n2 - i2)
                i0, i1, i2 = n0, n1, n2
                a_tq += m * torque_old + w_new * (torque - torque_old)
                a_om += m * omega_old + w_new * (omega - omega_old)
                sum_delta = (m * theta_old + w_old_theta * (theta - theta_old)) / ratio
                a_d += sum_delta
                a_hg += hinge_k * (m * ch0 + ch_delta * sum_delta)
                a_pm += m * r_w * (i0 * i0 + i1 * i1 + i2 * i2)
                a_ps += m * p_inv
                a_ic += m * i_cmd
                a_iq += m * i_q
                a_u += m * u
                # the analytic sub-step ripple and the SMPS conduction loss change slowly:
                # taken once per drive step (the loss only heats the stage)
                i_dc = i_ext + g_shoot * vdc
                dv = vin - v_out
                di_l = dv * duty * ripple_l if dv > 0.0 else 0.0
                i_ac = i_dc * i_dc * au * (1.0 - au)
                ripple2 = di_l * di_l * zsw2 + (i_ac * zpwm2 if i_ac > 0.0 else 0.0)
                a_r2 += m * ripple2
                a_ps += m * i_l * i_l * (ron_lo + duty * d_ron)
                r = ron_lo + duty * d_ron + r_dcr
                if r != key_r or g_shoot != key_g:
                    key_r, key_g = r, g_shoot
                    coeffs = smps_step_matrix(r, g_shoot, esr, l_smps, c_total, h)
                    m11, m12, m21, m22, p1, p2, q1, q2, kk = coeffs
            else:
                i_ext += slope
                i_dc = i_ext + g_shoot * vdc
                if r_varies:
                    r = ron_lo + duty * d_ron + r_dcr
                    if r != key_r:
                        key_r = r
                        coeffs = smps_step_matrix(r, g_shoot, esr, l_smps, c_total, h)
                        m11, m12, m21, m22, p1, p2, q1, q2, kk = coeffs
            i_l_prev = i_l
            dvin = duty * vin
            i_l, v_c = (m11 * i_l + m12 * v_c + p1 * dvin + q1 * i_ext,
                        m21 * i_l + m22 * v_c + p2 * dvin + q2 * i_ext)
            v_out = kk * (v_c + esr * (i_l - i_ext))
            i_in = duty * i_l
            a_dc += i_dc
            a_v += v_out
            a_iin += i_in
            a_v2 += v_out * v_out
            a_du += duty
            a_il += i_l_prev
            if ramping:
                t += h
        self.smps_cache = ((key_r, key_g), coeffs)
        self.torque = torque
        x[:] = (i_l, v_c, v_out, integ, deriv, prev_err, duty, pos_integ, cur_integ, i_cmd,
                i_q, i0, i1, i2, vn, omega, theta, i_in, motor_c, _stage, _drift, bus_v)
        n = float(self.spb)
        if not ramping:
            t += n * h
        # the supply voltage of step k sags by the input current of step k-1
        a_vin = n * bus_v - r_source * (i_in_start + a_iin - i_in)
        out[:] = (a_dc / n, a_a / n, a_b / n, a_c / n, a_v / n, a_d / n, a_vin / n, a_iin / n,
                  a_v2 / n, a_r2 / n, a_pm / n, a_ps / n, a_tq / n, a_om / n, a_hg / n,
                  a_ic / n, a_iq / n, a_du / n, a_il / n, a_u / n, sec + 1.0)
        out[11] += p_sw
        return t
