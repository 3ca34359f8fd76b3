"""The plant's step in plain Python floats, for one run at a time (a lone actuator, small batches).

Why: the vectorised step (:mod:`mapr_daemon.ema.plant` with :mod:`smps`, :mod:`inverter`,
:mod:`motor`, :mod:`control`) pays numpy's per-call overhead (~1 us per ufunc, some 200 calls
per step) whatever the number of runs: cheap per run in a 104-run batch, ruinous for one (0.1x
real time). The same equations on ``math`` floats, unrolled over the three phases, cost ~15 ns
per operation and allocate almost nothing: ~3-4 us per 25 us step, 6-8x real time.

Equivalence: the same formulas and the same fixed step as the vectorised functions named in
each comment, specialised where that is exact (a sector's "+" and "-" phases sit on their
flat tops; an intact bridge has one PWM'd, one return and one idle leg; the SMPS step's matrix
exponential depends only on the switch resistance and shoot-through conductance), so a run
agrees with the vectorised path to floating-point rounding: ``tests/ema/test_scalar_path.py``
shadows the vector path sample by sample (1e-9 relative) for every fault kind over the BIT
profile and a JSBSim segment, and compares free runs to one ADC LSB. A change to the physics
must be made in both places; that test fails if one is forgotten. Shorted or open switches go
through the general per-switch code of :mod:`scalar_bridge`.
"""

from __future__ import annotations

import math

from mapr_daemon.ema.batch import BatchArrays
from mapr_daemon.ema.control import U_MAX
from mapr_daemon.ema.inverter import NEGATIVE, POSITIVE
from mapr_daemon.ema.scalar_bridge import legs, smps_step_matrix, windings
from mapr_daemon.ema.sensors import COPPER_ALPHA

_PLUS = tuple(int(row.argmax()) for row in POSITIVE)
"""Index of the "+" phase of each Hall sector (inverter.POSITIVE as plain ints)."""
_MINUS = tuple(int(row.argmax()) for row in NEGATIVE)
_IDLE = tuple(3 - a - b for a, b in zip(_PLUS, _MINUS, strict=True))
"""The phase on its back-EMF ramp (neither "+" nor "-") in each sector."""
_TWO_PI = 2.0 * math.pi
_SLOPE = 6.0 / math.pi
_SECTOR_OFFSET = math.pi / 6.0
_SECTOR_WIDTH = math.pi / 3.0
_HALF_PI = math.pi / 2.0
_SHIFTS = (_HALF_PI, 2.0 * math.pi / 3.0 + _HALF_PI, 4.0 * math.pi / 3.0 + _HALF_PI)
"""Phase offsets of the trapezoids' peaks (inverter.trapezoid)."""
N_ACC = 21
"""Accumulator rows, in the order of ``plant._ACC``."""


class ScalarRun:
    """One run's parameters and state as floats; :meth:`sample` integrates one sample period.

    Built from column ``r`` of a :class:`BatchArrays` and the run's starting state, and read back
    with :meth:`state` — the plant hands a run over between the two paths this way.
    """

    def __init__(self, p: BatchArrays, r: int, t_on: float = 0.0) -> None:
        """Copy run ``r``'s parameters; the state starts at zero (the plant loads it).

        ``t_on`` is when the SMPS was switched on (``SmpsState.t_on``; -inf when powered).
        """
        self.h = p.step_s
        self.t_on = t_on
        self.spb = p.samples_per_block
        names = [f.name for f in p.__dataclass_fields__.values() if f.name not in
                 ("n", "step_s", "samples_per_block", "full_scale", "lsb", "noise")]
        self.fp: dict[str, float] = {}
        """Scalar parameters by BatchArrays field name."""
        self.p3: dict[str, tuple[float, float, float]] = {}
        """Per-phase parameters (A, B, C) by BatchArrays field name."""
        for name in names:
            arr = getattr(p, name)
            if arr.ndim == 2:
                self.p3[name] = (float(arr[0, r]), float(arr[1, r]), float(arr[2, r]))
            else:
                self.fp[name] = float(arr[r])
        # state: SMPS (i_l, v_c, v_out, integ, deriv, prev_err, duty), control
        # (pos_integ, cur_integ, i_cmd, i_q), windings, mechanics, supply, slow
        self.x: list[float] = [0.0] * 22
        self.r_w = 0.0
        self.faulted = any(v != 0.0 for name in ("open_high", "open_low", "short_high",
                                                  "short_low") for v in self.ph(name))
        """A switch is shorted or open: the bridge takes the general per-switch path."""
        self.smps_cache: tuple[tuple[float, float], tuple[float, ...]] = ((-1.0, -1.0), ())
        """Winding resistance used by the last sample."""

    STATE = ("i_l", "v_c", "v_out", "integ", "deriv", "prev_err", "duty",
             "pos_integ", "cur_integ", "i_cmd", "i_q", "i_a", "i_b", "i_c", "vn",
             "omega", "theta", "i_in", "motor_c", "stage_c", "bus_drift", "bus_v")
    """Names of the entries of ``x``."""

    def f(self, name: str) -> float:
        return self.fp[name]

    def ph(self, name: str) -> tuple[float, float, float]:
        return self.p3[name]

    def sample(self, t: float, cmd_rad: float, q: float, z_sw: float, z_pwm: float,
               out: list[float]) -> float:
        """Integrate one sample period from time ``t``; step means go to ``out``; returns t.

        The body is the vectorised ``EmaBatch._sample`` spelled out for one run (the function
        of the vectorised path is named in each comment). Two shortcuts keep its arithmetic
        (to rounding): the SMPS step's matrix exponential, folded into one affine map of the
        state, the buck's input voltage and the load current, is reused while the switch
        resistance and the shoot-through conductance are unchanged (always, for equal high- and
        low-side Ron); and the bridge of a run without a shorted or open switch is written for
        its three roles (PWM'd leg, return leg, idle leg) instead of per-switch fractions.
        """
        fp, p3, x = self.fp, self.p3, self.x
        h = self.h
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
        h_l = h / fp["l_w"]
        area_chord, ch0, ch_delta = fp["area_chord"], fp["ch0"], fp["ch_delta"]
        eta, t_coul, w_coul, j_eq, b_visc = (fp["eta"], fp["t_coul"], fp["w_coul"], fp["j_eq"],
                                             fp["b_visc"])
        limit = fp["travel_rad"] * ratio
        r_w = fp["r_w0"] * (1.0 + COPPER_ALPHA * (motor_c - 25.0))  # sensors.winding_resistance
        self.r_w = r_w
        d_gain = h / (tf_v + h)
        inv_h = 1.0 / h
        ki_v_h, ki_pos_h, ki_i_h = ki_v * h, ki_pos * h, ki_i * h
        d_ron = ron_hi - ron_lo
        w_lo3 = tuple(1.0 / (1.0 + h_l * (r + r_w)) for r in rl3)
        w_dio = 1.0 / (1.0 + h_l * (r_diode + r_w))
        lim_term = l_smps / h
        ripple_l = 1.0 / (l_smps * f_sw)
        zsw2, zpwm2 = z_sw * z_sw / 12.0, z_pwm * z_pwm
        ke2 = 2.0 * k_e
        refl_pos, refl_neg = eta / ratio, (1.0 / eta) / ratio
        visc = 1.0 + h * b_visc / j_eq
        h_j = h / j_eq
        hinge_k = q * area_chord
        inv_ratio_cmd = cmd_rad * ratio
        faulted = self.faulted
        t_on = self.t_on
        (key_r, key_g), coeffs = self.smps_cache
        a_dc = a_a = a_b = a_c = a_v = a_d = a_vin = a_iin = a_v2 = a_r2 = 0.0
        a_pm = a_ps = a_tq = a_om = a_hg = a_ic = a_iq = a_du = a_il = a_u = 0.0
        sec = 0
        for _ in range(self.spb):
            theta_e = pp * theta
            sec = math.floor((theta_e - _SECTOR_OFFSET) / _SECTOR_WIDTH) % 6
            kp_ph, km_ph, id_ph = _PLUS[sec], _MINUS[sec], _IDLE[sec]
            # inverter.trapezoid: in a sector the "+" and "-" phases are on their flat tops
            # (+1, -1) and only the idle phase ramps
            phi = (theta_e - _SHIFTS[id_ph]) % _TWO_PI
            d = _TWO_PI - phi if phi > math.pi else phi
            s_id = 3.0 - d * _SLOPE
            s_id = 1.0 if s_id > 1.0 else (-1.0 if s_id < -1.0 else s_id)
            ke_w = k_e * omega
            e_id = ke_w * s_id
            cur = (i0, i1, i2)
            vdc = v_out
            vin = bus_v - r_source * i_in
            # smps.voltage_loop
            t_up = t - t_on
            vref = v_ref * (t_up / soft_start) if t_up < soft_start else v_ref
            err = vref - v_out
            deriv += d_gain * ((err - prev_err) * inv_h - deriv)
            prev_err = err
            trial = integ + ki_v_h * err
            inv_vin = 1.0 / vin if vin > 1.0 else 1.0
            raw = (vref + kp_v * err + trial + kd_v * deriv) * inv_vin
            d_cl = (v_out + (ron_lo + r_dcr + raw * d_ron) * i_l
                    + lim_term * (i_lim_smps - i_l)) * inv_vin
            duty = d_max if d_max < raw else raw
            if d_cl < duty:
                duty = d_cl
            if duty < 0.0:
                duty = 0.0
            if not ((duty < raw and err > 0.0) or (duty > raw and err < 0.0)):
                integ = trial
            # control.control
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
            if faulted:
                shape = [0.0, 0.0, 0.0]
                shape[kp_ph], shape[km_ph], shape[id_ph] = 1.0, -1.0, s_id
                e = (ke_w * shape[0], ke_w * shape[1], ke_w * shape[2])
                v_leg, r_leg, floating, diode_only, g_shoot, i_ext, p_inv = legs(
                    self, hi_ph, lo_ph, au, vdc, cur)
            else:
                # inverter.legs etc. for an intact bridge: the PWM'd leg (high side on for
                # au of the period, low side the rest), the return leg (low side on) and the
                # idle leg (both off: its body diodes decide)
                rh, rl = rh3[hi_ph], rl3[hi_ph]
                r_hi = au * rh + (1.0 - au) * rl
                r_lo = rl3[lo_ph]
                i_hi, i_lo, i_id = cur[hi_ph], cur[lo_ph], cur[id_ph]
                v_hi = au * vdc
                g_shoot = 0.0
                i_ext = au * i_hi + (i_id if i_id < 0.0 else 0.0)
                p_inv = (r_hi * i_hi * i_hi + r_lo * i_lo * i_lo
                         + vd * abs(i_id) + r_diode * i_id * i_id)
            i_dc = i_ext + g_shoot * vdc
            # smps.ripple_sq
            dv = vin - v_out
            di_l = dv * duty * ripple_l if dv > 0.0 else 0.0
            i_ac = i_dc * i_dc * au * (1.0 - au)
            ripple2 = di_l * di_l * zsw2 + (i_ac * zpwm2 if i_ac > 0.0 else 0.0)
            i_l_prev = i_l
            r_sw = ron_lo + duty * d_ron
            p_smps = i_l * i_l * r_sw
            # smps.step, its matrix exponential reused while (r, g) is unchanged
            r = r_sw + r_dcr
            if r != key_r or g_shoot != key_g:
                key_r, key_g = r, g_shoot
                coeffs = smps_step_matrix(r, g_shoot, esr, l_smps, c_total, h)
            m11, m12, m21, m22, p1, p2, q1, q2, kk = coeffs
            dvin = duty * vin
            i_l, v_c = (m11 * i_l + m12 * v_c + p1 * dvin + q1 * i_ext,
                        m21 * i_l + m22 * v_c + p2 * dvin + q2 * i_ext)
            v_out = kk * (v_c + esr * (i_l - i_ext))
            i_in = duty * i_l
            # motor.solve_windings
            if faulted:
                i0, i1, i2, vn = windings(cur, e, v_leg, r_leg, floating, diode_only, r_w,
                                           h_l, vdc, vd, r_diode)
                torque = k_e * (shape[0] * i0 + shape[1] * i1 + shape[2] * i2)
            else:
                # the same for an intact bridge: PWM'd and return legs always connected, the
                # idle leg through a diode while it carries current (or starts to)
                e_hi = ke_w if u >= 0.0 else -ke_w  # the return leg's EMF is -e_hi
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
                    # the idle leg's diode current would reverse: extinguished
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
                i0, i1, i2 = new
            delta = theta / ratio
            hinge = hinge_k * (ch0 + ch_delta * delta)  # motor.hinge_moment
            # motor.mechanics
            drive = (torque - t_coul * math.tanh(omega / w_coul)
                     + hinge * (refl_pos if hinge * omega > 0.0 else refl_neg))
            omega = (omega + h_j * drive) / visc
            theta_new = theta + h * omega
            if theta_new > limit or theta_new < -limit:
                theta_new = limit if theta_new > limit else -limit
                if omega * theta_new > 0.0:
                    omega = 0.0
            theta = theta_new
            a_dc += i_dc
            a_a += i0
            a_b += i1
            a_c += i2
            a_v += v_out
            a_d += delta
            a_vin += vin
            a_iin += i_in
            a_v2 += v_out * v_out
            a_r2 += ripple2
            a_pm += r_w * (i0 * i0 + i1 * i1 + i2 * i2)
            a_ps += p_smps + p_inv  # + p_sw, added once below
            a_tq += torque
            a_om += omega
            a_hg += hinge
            a_ic += i_cmd
            a_iq += i_q
            a_du += duty
            a_il += i_l_prev
            a_u += u
            t += h
        self.smps_cache = ((key_r, key_g), coeffs)
        x[:] = (i_l, v_c, v_out, integ, deriv, prev_err, duty, pos_integ, cur_integ, i_cmd,
                i_q, i0, i1, i2, vn, omega, theta, i_in, motor_c, _stage, _drift, bus_v)
        n = float(self.spb)
        out[:] = (a_dc / n, a_a / n, a_b / n, a_c / n, a_v / n, a_d / n, a_vin / n, a_iin / n,
                  a_v2 / n, a_r2 / n, a_pm / n, a_ps / n, a_tq / n, a_om / n, a_hg / n,
                  a_ic / n, a_iq / n, a_du / n, a_il / n, a_u / n, sec + 1.0)
        out[11] += p_sw
        return t

    def advance_slow(self, dt: float, motor_loss_w: float, stage_loss_w: float,
                     ambient_c: float, z_drift: float, z_ripple: float, bus_offset: float) -> None:
        """sensors.advance_slow for this run."""
        f, x = self.f, self.x
        motor_c, stage_c, drift = x[18], x[19], x[20]
        am = math.exp(-dt / f("tau_m"))
        ss = ambient_c + f("rth_m") * motor_loss_w
        x[18] = ss + (motor_c - ambient_c - f("rth_m") * motor_loss_w) * am
        ast = math.exp(-dt / f("tau_s"))
        ss = ambient_c + f("rth_s") * stage_loss_w
        x[19] = ss + (stage_c - ambient_c - f("rth_s") * stage_loss_w) * ast
        ab = math.exp(-dt / f("bus_tau"))
        drift = drift * ab + f("bus_drift_sd") * math.sqrt(1.0 - ab * ab) * z_drift
        x[20] = drift
        raw = f("bus_nominal") + bus_offset + drift + f("bus_ripple") * z_ripple
        x[21] = min(max(raw, f("bus_min")), f("bus_max"))
