"""The plant's 25 us step, compiled: SMPS, inverter, windings, mechanics and the drive's loops.

Why compiled: each step depends on the one before (a switched plant: Hall sectors, diode
events, a saturating voltage loop), so time cannot be vectorised, and the step has ~220 float
operations. In CPython one actuator runs only a few times faster than real time,
and numpy across runs pays its per-call overhead ~200 times a step, cheap only in large
batches (docs/figures.md, "Costs behind the code"). Compiled
(:func:`drivers.jit.kernel`), Python is entered once per chunk of samples for all runs, and the
loop over runs, samples and steps runs as machine code.

Layout: a run's parameters are one row of a float matrix (:data:`PAR`, built by :func:`pack`
from :class:`~mapr_daemon.ema.batch.BatchArrays`), its state one row of another (:data:`STATE`).
:func:`integrate` advances every run over a chunk of samples and writes each sample's step
means (rows :data:`ACC`). Noise is drawn by the caller (numpy, one generator per run), so a
run's random numbers depend only on its seed.

All compiled code of the plant lives in this one file on purpose: numba's on-disk cache is
invalidated when the source file of a kernel changes, not when a kernel it calls in another
file does; one file keeps a changed equation from running stale machine code.

The equations (docs/ema-model.md has the model and its sources):

* SMPS: averaged synchronous buck, switch resistance ``D*Ron_high + (1-D)*Ron_low``, its
  L-C(ESR) state advanced exactly per step (2x2 matrix exponential by Sylvester's formula, as
  one affine map of the state, ``D*Vin`` and the bridge's current, recomputed only when the
  switch resistance or the shoot-through conductance change); voltage-mode PI(D) with input
  feed-forward, soft start, averaged cycle-by-cycle current limit, conditional integration.
  Sub-step ripple (inductor at ``f_sw``, inverter PWM current at ``f_pwm``) analytically
  through the capacitor bank's impedance.
* Inverter: six-step from Hall sectors, the driven leg PWM'd complementarily, the return leg's
  low side on, the idle leg's body diodes; legs averaged per PWM period with per-switch Ron. A
  shorted switch is forced on (shoot-through conductance on the DC link), an open one never on;
  such a bridge goes through the general per-switch legs (:func:`_legs`, :func:`_windings`).
* Windings: star, trapezoidal back-EMF, resistance implicit, the neutral voltage solved so the
  connected phases' currents sum to zero; a floating phase conducts through a diode when its
  terminal leaves the rails, and a diode current that would reverse is extinguished.
* Mechanics: rotor plus reflected surface inertia, viscous and smoothed Coulomb friction, gear
  efficiency by power-flow direction, hinge moment ``q*S*c*(ch0 + ch_delta*delta)``, stops.
* Drive: position PID with an integral clamp -> current command limited to ``i_lim`` ->
  current PI on the sector's torque current with back-EMF feed-forward -> duty over the
  measured DC-link voltage, limited to :data:`U_MAX`.
* Model form (:mod:`mapr_daemon.ema.form`, all off by default, the arithmetic then unchanged):
  stiction (Karnopp stick-slip with Stribeck decay, :func:`_stick_slip`), a voltage-mode
  position loop, discrete loop rates with zero-order hold (step counters in the state), a
  housekeeping load on the DC link, a Hall offset (commutation from the offset angle, every
  phase's back-EMF from the true one through the general legs).
* Once per sample: temperatures (exact first order), the aircraft bus (Ornstein-Uhlenbeck
  drift, ripple, clipped to the normal band), the winding resistance from the motor temperature.
* Switch temperatures: the SMPS's high and low side and the inverter's phase-A high side each
  a first-order node above the power stage's (the sink's) temperature, driven by the loss that
  switch carries in each step (the SMPS high side also takes the lumped switching loss); they
  only read the step's values, so every other output is the same with or without them.
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from drivers.jit import kernel
from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import BatchArrays

U_MAX = 0.98
"""Largest PWM duty the drive commands (bootstrap refresh)."""
COPPER_ALPHA = 0.00393
"""Temperature coefficient of copper resistance, 1/K."""

SCALARS = (
    "v_ref", "l_smps", "r_dcr", "c_total", "esr_eff", "ron_hi", "ron_lo", "f_sw", "d_max",
    "i_lim_smps", "soft_start", "kp_v", "ki_v", "kd_v", "tf_v", "p_sw", "v_diode", "r_diode",
    "r_w0", "l_w", "k_e", "pole_pairs", "j_eq", "b_visc", "t_coul", "w_coul", "ratio", "eta",
    "area_chord", "ch0", "ch_delta", "travel_rad", "kp_pos", "ki_pos", "kd_pos", "i_lim", "kp_i",
    "ki_i", "rth_m", "tau_m", "rth_s", "tau_s", "bus_nominal", "bus_drift_sd", "bus_tau",
    "bus_ripple", "bus_min", "bus_max", "r_source", "r_loop", "breakaway", "w_stribeck",
    "voltage_mode", "n_cur", "n_pos", "hk_w", "hk_var", "hk_period", "hall_offset",
    "rth_sw_smps", "tau_sw_smps", "rth_sw_inv", "tau_sw_inv")
"""BatchArrays fields of shape ``(n,)`` the step reads, in parameter-row order (ten before the
last four: the drive's loop resistance and the run's model form, :mod:`mapr_daemon.ema.form`;
the last four: the switch temperature nodes)."""
PHASED = ("r_high", "r_low", "short_high", "short_low", "open_high", "open_low")
"""BatchArrays fields of shape ``(3, n)``: three columns each (phases A, B, C)."""
EXTRA = ("z_sw", "z_pwm", "bus_offset")
"""Per-run values that are not BatchArrays fields: bank impedances, this flight's bus offset."""
PAR = SCALARS + tuple(f"{name}_{ph}" for name in PHASED for ph in "abc") + EXTRA
"""Columns of the parameter matrix."""
(V_REF, L_SMPS, R_DCR, C_TOTAL, ESR_EFF, RON_HI, RON_LO, F_SW, D_MAX, I_LIM_SMPS, SOFT_START,
 KP_V, KI_V, KD_V, TF_V, P_SW, V_DIODE, R_DIODE, R_W0, L_W, K_E, POLE_PAIRS, J_EQ, B_VISC,
 T_COUL, W_COUL, RATIO, ETA, AREA_CHORD, CH0, CH_DELTA, TRAVEL_RAD, KP_POS, KI_POS, KD_POS,
 I_LIM, KP_I, KI_I, RTH_M, TAU_M, RTH_S, TAU_S, BUS_NOMINAL, BUS_DRIFT_SD, BUS_TAU, BUS_RIPPLE,
 BUS_MIN, BUS_MAX, R_SOURCE, R_LOOP, BREAKAWAY, W_STRIBECK, VOLTAGE_MODE, N_CUR, N_POS, HK_W,
 HK_VAR, HK_PERIOD, HALL_OFFSET, RTH_SW_SMPS, TAU_SW_SMPS, RTH_SW_INV,
 TAU_SW_INV) = range(len(SCALARS))
(R_HIGH_A, R_LOW_A, SHORT_HIGH_A, SHORT_LOW_A, OPEN_HIGH_A,
 OPEN_LOW_A) = range(len(SCALARS), len(SCALARS) + 3 * len(PHASED), 3)
"""First column (phase A) of each per-phase parameter; B and C follow."""
Z_SW, Z_PWM, BUS_OFFSET = range(len(PAR) - len(EXTRA), len(PAR))

STATE = ("i_l", "v_c", "v_out", "integ", "deriv", "prev_err", "duty",
         "pos_integ", "cur_integ", "i_cmd", "i_q", "i_a", "i_b", "i_c", "vn",
         "omega", "theta", "i_in", "motor_c", "stage_c", "bus_drift", "bus_v", "u",
         "cur_count", "pos_count", "hs_rise", "ls_rise", "ah_rise")
"""Columns of the state matrix: SMPS, loops, windings, mechanics, supply, temperatures, bus,
the drive's held duty and its steps left until the next current- and position-loop update,
then the three switch junctions' rises over the power stage (K)."""
ACC = ("i_dc", "i_a", "i_b", "i_c", "v_out", "delta", "v_in", "i_in", "v_out2", "ripple2",
       "p_motor", "p_stage", "torque", "omega", "hinge", "i_cmd", "i_q", "duty", "i_l", "u",
       "sector", "t_smps_high", "t_smps_low", "t_inv_a_high")
"""Rows of :func:`integrate`'s output: step means over each sample, except ``p_motor`` and
``p_stage`` (replaced by the motor and stage temperatures after the sample), ``sector``
(the Hall sector, 1-6, of the sample's last step) and the three switch temperatures after the
sample."""

PLUS = (0, 0, 1, 1, 2, 2)
"""The "+" phase (back-EMF flat top at +1) of each Hall sector 0-5 (inverter.POSITIVE)."""
MINUS = (1, 2, 2, 0, 0, 1)
"""The "-" phase of each Hall sector (inverter.NEGATIVE)."""
IDLE = (2, 1, 0, 2, 1, 0)
"""The phase on its back-EMF ramp in each sector."""
_TWO_PI = 2.0 * math.pi
_SLOPE = 6.0 / math.pi
_SECTOR_OFFSET = math.pi / 6.0
_SECTOR_WIDTH = math.pi / 3.0
_HALF_PI = math.pi / 2.0
_SHIFTS = (_HALF_PI, 2.0 * math.pi / 3.0 + _HALF_PI, 4.0 * math.pi / 3.0 + _HALF_PI)
"""Electrical angles of the phases' trapezoid peaks (inverter.trapezoid)."""
_FLOAT_ONE = 1.0 - 1e-9
"""A leg off for more than this share of the period is off for all of it (diode only)."""


def pack(p: BatchArrays, z_sw: FloatArray, z_pwm: FloatArray,
         bus_offset: FloatArray) -> FloatArray:
    """The parameter matrix ``(n_runs, len(PAR))`` of a batch."""
    cols = [getattr(p, name) for name in SCALARS]
    cols += [getattr(p, name)[ph] for name in PHASED for ph in range(3)]
    cols += [z_sw, z_pwm, bus_offset]
    out: FloatArray = np.ascontiguousarray(np.stack(cols, axis=1), dtype=np.float64)
    return out


@kernel
def integrate(par: FloatArray, state: FloatArray, cmd_rad: FloatArray, q: FloatArray,
              amb: FloatArray, z_drift: FloatArray, z_ripple: FloatArray, t0: float,
              t_on: float, h: float, spb: int, dt: float, means: FloatArray, bus: FloatArray,
              rw: FloatArray) -> float:
    """Advance every run ``n`` samples of ``spb`` steps of ``h`` from time ``t0``.

    ``par`` and ``state`` are ``(n_runs, len(PAR))`` and ``(n_runs, len(STATE))`` (the state is
    updated in place); the inputs ``cmd_rad`` (surface command), ``q`` (dynamic pressure),
    ``amb`` (ambient temperature) and the standard normal draws ``z_drift``, ``z_ripple`` are
    ``(n_runs, n)`` and held over each sample. ``t_on`` is when the SMPS was switched on (-inf
    when powered), ``dt`` the sample period. Writes ``means`` ``(len(ACC), n_runs, n)``, the
    aircraft bus voltage at each sample's start and the winding resistance of each sample
    (``bus``, ``rw``: ``(n_runs, n)``). Returns the time after the last sample.
    """
    t_end = t0
    scratch = np.empty((6, 3))
    for r in range(par.shape[0]):
        t_end = _run(par[r], state[r], cmd_rad[r], q[r], amb[r], z_drift[r], z_ripple[r], t0,
                     t_on, h, spb, dt, means[:, r, :], bus[r], rw[r], scratch)
    return t_end


@kernel
def _run(pr: FloatArray, x: FloatArray, cmd_rad: FloatArray, q: FloatArray, amb: FloatArray,
         z_drift: FloatArray, z_ripple: FloatArray, t: float, t_on: float, h: float, spb: int,
         dt: float, out: FloatArray, bus: FloatArray, rw: FloatArray,
         scratch: FloatArray) -> float:
    """:func:`integrate` for one run (``pr``, ``x``: its parameter and state rows)."""
    (i_l, v_c, v_out, integ, deriv, prev_err, duty, pos_integ, cur_integ, i_cmd, i_q,
     i0, i1, i2, vn, omega, theta, i_in, motor_c, stage_c, drift, bus_v, u, cur_count,
     pos_count) = (
        x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9], x[10], x[11], x[12],
        x[13], x[14], x[15], x[16], x[17], x[18], x[19], x[20], x[21], x[22], x[23], x[24])
    hs_rise, ls_rise, ah_rise = x[25], x[26], x[27]
    pp, k_e, r_source = pr[POLE_PAIRS], pr[K_E], pr[R_SOURCE]
    soft_start, v_ref, tf_v = max(pr[SOFT_START], 1e-12), pr[V_REF], pr[TF_V]
    kp_v, ki_v, kd_v = pr[KP_V], pr[KI_V], pr[KD_V]
    ron_hi, ron_lo, r_dcr, l_smps = pr[RON_HI], pr[RON_LO], pr[R_DCR], pr[L_SMPS]
    i_lim_smps, d_max, f_sw, p_sw = pr[I_LIM_SMPS], pr[D_MAX], pr[F_SW], pr[P_SW]
    esr, c_total = pr[ESR_EFF], pr[C_TOTAL]
    ratio, ki_pos, kp_pos, kd_pos = pr[RATIO], pr[KI_POS], pr[KP_POS], pr[KD_POS]
    i_lim, ki_i, kp_i = pr[I_LIM], pr[KI_I], pr[KP_I]
    vd, r_diode = pr[V_DIODE], pr[R_DIODE]
    h_l = h / pr[L_W]
    area_chord, ch0, ch_delta = pr[AREA_CHORD], pr[CH0], pr[CH_DELTA]
    eta, t_coul, w_coul, j_eq = pr[ETA], pr[T_COUL], pr[W_COUL], pr[J_EQ]
    limit = pr[TRAVEL_RAD] * ratio
    d_gain = h / (tf_v + h)
    inv_h = 1.0 / h
    # model form: loop rates (steps per update; 1 = every step, h * 1.0 == h exactly); the
    # other options are read from the row where used: hoisted into locals, their extra live
    # values measurably slowed the default path
    n_cur, n_pos = pr[N_CUR], pr[N_POS]
    ki_v_h, ki_pos_h, ki_i_h = ki_v * h, ki_pos * (h * n_pos), ki_i * (h * n_cur)
    p_hk = 0.0
    d_ron = ron_hi - ron_lo
    lim_term = l_smps / h
    ripple_l = 1.0 / (l_smps * f_sw)
    zsw2, zpwm2 = pr[Z_SW] * pr[Z_SW] / 12.0, pr[Z_PWM] * pr[Z_PWM]
    ke2 = 2.0 * k_e
    refl_pos, refl_neg = eta / ratio, (1.0 / eta) / ratio
    visc = 1.0 + h * pr[B_VISC] / j_eq
    h_j = h / j_eq
    faulted = False
    sh0 = sh1 = sh2 = 0.0
    for k in range(3):
        if (pr[OPEN_HIGH_A + k] != 0.0 or pr[OPEN_LOW_A + k] != 0.0
                or pr[SHORT_HIGH_A + k] != 0.0 or pr[SHORT_LOW_A + k] != 0.0):
            faulted = True
    if pr[HALL_OFFSET] != 0.0:
        # the drive commutates off the true angle: every phase's back-EMF from its trapezoid,
        # through the general legs and windings
        faulted = True
    key_r = key_g = -1.0
    m11 = m12 = m21 = m22 = p1 = p2 = q1 = q2 = kk = 0.0
    # once-per-sample constants (sensors): thermal and bus decays
    am = math.exp(-dt / pr[TAU_M])
    ast = math.exp(-dt / pr[TAU_S])
    a_sw, a_inv = math.exp(-dt / pr[TAU_SW_SMPS]), math.exp(-dt / pr[TAU_SW_INV])
    rth_sw, rth_inv = pr[RTH_SW_SMPS], pr[RTH_SW_INV]
    ab = math.exp(-dt / pr[BUS_TAU])
    drift_gain = pr[BUS_DRIFT_SD] * math.sqrt(1.0 - ab * ab)
    n_steps = float(spb)
    for s in range(cmd_rad.size):
        bus[s] = bus_v
        r_w = pr[R_W0] * (1.0 + COPPER_ALPHA * (motor_c - 25.0))
        rw[s] = r_w
        w_dio = 1.0 / (1.0 + h_l * (r_diode + r_w))
        hinge_k = q[s] * area_chord
        inv_ratio_cmd = cmd_rad[s] * ratio
        if pr[HK_W] != 0.0:
            p_hk = pr[HK_W] * (1.0 + pr[HK_VAR] * math.sin(_TWO_PI * t / pr[HK_PERIOD]))
        a_dc = a_a = a_b = a_c = a_v = a_d = a_vin = a_iin = a_v2 = a_r2 = 0.0
        a_pm = a_ps = a_tq = a_om = a_hg = a_ic = a_iq = a_du = a_il = a_u = 0.0
        a_phs = a_pls = a_pah = 0.0
        sec = 0
        for _ in range(spb):
            # Hall sector and the idle phase's back-EMF (the "+"/"-" phases on their flat tops)
            theta_e = pp * theta
            sec = math.floor((theta_e + pr[HALL_OFFSET] - _SECTOR_OFFSET) / _SECTOR_WIDTH) % 6
            kp_ph, km_ph, id_ph = PLUS[sec], MINUS[sec], IDLE[sec]
            phi = (theta_e - _SHIFTS[id_ph]) % _TWO_PI
            d = _TWO_PI - phi if phi > math.pi else phi
            s_id = 3.0 - d * _SLOPE
            s_id = 1.0 if s_id > 1.0 else (-1.0 if s_id < -1.0 else s_id)
            ke_w = k_e * omega
            e_id = ke_w * s_id
            vdc = v_out
            vin = bus_v - r_source * i_in
            # SMPS voltage loop
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
            # drive: position loop -> current command -> current loop -> signed duty u, each
            # loop at its own rate (held in between); voltage mode: the current command times
            # the loop resistance plus back-EMF is the voltage (the current only limited)
            pos_count -= 1.0
            if pos_count <= 0.0:
                pos_count = pr[N_POS]
                perr = inv_ratio_cmd - theta
                trial = pos_integ + ki_pos_h * perr
                trial = i_lim if trial > i_lim else (-i_lim if trial < -i_lim else trial)
                raw = kp_pos * perr + trial - kd_pos * omega
                i_cmd = i_lim if raw > i_lim else (-i_lim if raw < -i_lim else raw)
                if raw == i_cmd:
                    pos_integ = trial
            c_p = i0 if kp_ph == 0 else (i1 if kp_ph == 1 else i2)
            c_m = i0 if km_ph == 0 else (i1 if km_ph == 1 else i2)
            i_q = 0.5 * (c_p - c_m)
            cur_count -= 1.0
            if cur_count <= 0.0:
                cur_count = pr[N_CUR]
                if pr[VOLTAGE_MODE] != 0.0:
                    u_raw = (pr[R_LOOP] * i_cmd + ke2 * omega) / (vdc if vdc > 1.0 else 1.0)
                    u = U_MAX if u_raw > U_MAX else (-U_MAX if u_raw < -U_MAX else u_raw)
                else:
                    e_i = i_cmd - i_q
                    trial = cur_integ + ki_i_h * e_i
                    u_raw = (kp_i * e_i + trial + ke2 * omega) / (vdc if vdc > 1.0 else 1.0)
                    u = U_MAX if u_raw > U_MAX else (-U_MAX if u_raw < -U_MAX else u_raw)
                    if u == u_raw:
                        cur_integ = trial
            au = u if u >= 0.0 else -u
            hi_ph, lo_ph = (kp_ph, km_ph) if u >= 0.0 else (km_ph, kp_ph)
            i_hi = i0 if hi_ph == 0 else (i1 if hi_ph == 1 else i2)
            i_lo = i0 if lo_ph == 0 else (i1 if lo_ph == 1 else i2)
            i_id = i0 if id_ph == 0 else (i1 if id_ph == 1 else i2)
            rh, rl = pr[R_HIGH_A + hi_ph], pr[R_LOW_A + hi_ph]
            r_hi = au * rh + (1.0 - au) * rl
            v_hi = au * vdc
            if faulted:
                if pr[HALL_OFFSET] != 0.0:
                    sh0, sh1, sh2 = _trap(theta_e, 0), _trap(theta_e, 1), _trap(theta_e, 2)
                else:
                    sh0 = 1.0 if kp_ph == 0 else (-1.0 if km_ph == 0 else s_id)
                    sh1 = 1.0 if kp_ph == 1 else (-1.0 if km_ph == 1 else s_id)
                    sh2 = 1.0 if kp_ph == 2 else (-1.0 if km_ph == 2 else s_id)
                g_shoot, i_ext, p_inv, p_ah = _legs(pr, hi_ph, lo_ph, au, vdc, i0, i1, i2,
                                                    scratch)
            else:
                # intact bridge: the PWM'd leg (high side on for au of the period, low side
                # the rest), the return leg (low side on), the idle leg (its diodes decide)
                g_shoot = 0.0
                i_ext = au * i_hi + (i_id if i_id < 0.0 else 0.0)
                p_inv = (r_hi * i_hi * i_hi + pr[R_LOW_A + lo_ph] * i_lo * i_lo
                         + vd * abs(i_id) + r_diode * i_id * i_id)
                # phase A's high side: PWM'd (on for au), or the idle leg's high diode
                p_ah = (au * rh * i_hi * i_hi if hi_ph == 0 else
                        (vd * -i_id + r_diode * i_id * i_id if id_ph == 0 and i_id < 0.0
                         else 0.0))
            i_dc = i_ext + g_shoot * vdc
            # sub-step ripple (V^2) for the RMS detector
            dv = vin - v_out
            di_l = dv * duty * ripple_l if dv > 0.0 else 0.0
            i_ac = i_dc * i_dc * au * (1.0 - au)
            ripple2 = di_l * di_l * zsw2 + (i_ac * zpwm2 if i_ac > 0.0 else 0.0)
            if pr[HK_W] != 0.0:
                # housekeeping: constant power off the DC link, upstream of its current sensor
                i_hk = p_hk / (vdc if vdc > 1.0 else 1.0)
                i_ext += i_hk
                i_dc += i_hk
            i_l_prev = i_l
            r_sw = ron_lo + duty * d_ron
            p_smps = i_l * i_l * r_sw
            a_phs += duty * ron_hi * i_l * i_l
            a_pls += (1.0 - duty) * ron_lo * i_l * i_l
            a_pah += p_ah
            # SMPS power stage, exact for the step
            r_tot = r_sw + r_dcr
            if r_tot != key_r or g_shoot != key_g:
                key_r, key_g = r_tot, g_shoot
                m11, m12, m21, m22, p1, p2, q1, q2, kk = smps_step_matrix(
                    r_tot, g_shoot, esr, l_smps, c_total, h)
            dvin = duty * vin
            i_l, v_c = (m11 * i_l + m12 * v_c + p1 * dvin + q1 * i_ext,
                        m21 * i_l + m22 * v_c + p2 * dvin + q2 * i_ext)
            v_out = kk * (v_c + esr * (i_l - i_ext))
            i_in = duty * i_l
            # windings
            if faulted:
                i0, i1, i2, vn = _windings(i0, i1, i2, ke_w * sh0, ke_w * sh1, ke_w * sh2,
                                           scratch, r_w, h_l, vdc, vd, r_diode)
                torque = k_e * (sh0 * i0 + sh1 * i1 + sh2 * i2)
            else:
                # PWM'd and return legs always connected, the idle leg through a diode while
                # it carries current (or starts to)
                e_hi = ke_w if u >= 0.0 else -ke_w  # the return leg's EMF is -e_hi
                w_lo = 1.0 / (1.0 + h_l * (pr[R_LOW_A + lo_ph] + r_w))
                w_hi = (1.0 / (1.0 + h_l * (rl + r_w)) if rh == rl
                        else 1.0 / (1.0 + h_l * (r_hi + r_w)))
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
                i0 = n_hi if hi_ph == 0 else (n_lo if lo_ph == 0 else n_id)
                i1 = n_hi if hi_ph == 1 else (n_lo if lo_ph == 1 else n_id)
                i2 = n_hi if hi_ph == 2 else (n_lo if lo_ph == 2 else n_id)
            # mechanics, referred to the motor shaft
            delta = theta / ratio
            hinge = hinge_k * (ch0 + ch_delta * delta)
            if pr[BREAKAWAY] != 0.0:
                load = torque + hinge * (refl_pos if hinge * omega > 0.0 else refl_neg)
                omega = _stick_slip(omega, load, t_coul, pr[BREAKAWAY] * t_coul,
                                    pr[W_STRIBECK], h_j, visc)
            else:
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
        p_motor, p_stage = a_pm / n_steps, a_ps / n_steps + p_sw
        # temperatures (exact first order) and the aircraft bus, once per sample
        a = amb[s]
        motor_c = a + pr[RTH_M] * p_motor + (motor_c - a - pr[RTH_M] * p_motor) * am
        stage_c = a + pr[RTH_S] * p_stage + (stage_c - a - pr[RTH_S] * p_stage) * ast
        drift = drift * ab + drift_gain * z_drift[s]
        raw = pr[BUS_NOMINAL] + pr[BUS_OFFSET] + drift + pr[BUS_RIPPLE] * z_ripple[s]
        bus_v = min(max(raw, pr[BUS_MIN]), pr[BUS_MAX])
        acc = (a_dc, a_a, a_b, a_c, a_v, a_d, a_vin, a_iin, a_v2, a_r2, a_pm, a_ps, a_tq,
               a_om, a_hg, a_ic, a_iq, a_du, a_il, a_u)
        for k in range(20):
            out[k, s] = acc[k] / n_steps
        out[10, s] = motor_c
        out[11, s] = stage_c
        out[20, s] = sec + 1.0
        # switch junctions over the sink (the stage), exact first order like the others
        p_hs, p_ls, p_a = a_phs / n_steps + p_sw, a_pls / n_steps, a_pah / n_steps
        hs_rise = rth_sw * p_hs + (hs_rise - rth_sw * p_hs) * a_sw
        ls_rise = rth_sw * p_ls + (ls_rise - rth_sw * p_ls) * a_sw
        ah_rise = rth_inv * p_a + (ah_rise - rth_inv * p_a) * a_inv
        out[21, s] = stage_c + hs_rise
        out[22, s] = stage_c + ls_rise
        out[23, s] = stage_c + ah_rise
    state = (i_l, v_c, v_out, integ, deriv, prev_err, duty, pos_integ, cur_integ, i_cmd, i_q,
             i0, i1, i2, vn, omega, theta, i_in, motor_c, stage_c, drift, bus_v, u, cur_count,
             pos_count)
    for k in range(25):
        x[k] = state[k]
    x[25], x[26], x[27] = hs_rise, ls_rise, ah_rise
    return t


@kernel
def _trap(theta_e: float, phase: int) -> float:
    """Phase ``phase``'s flat-top back-EMF shape at electrical angle ``theta_e``, in [-1, 1]
    (inverter.trapezoid for one phase and one angle)."""
    phi = (theta_e - _SHIFTS[phase]) % _TWO_PI
    d = _TWO_PI - phi if phi > math.pi else phi
    f = 3.0 - d * _SLOPE
    return 1.0 if f > 1.0 else (-1.0 if f < -1.0 else f)


@kernel
def _stick_slip(omega: float, load: float, t_coul: float, t_break: float, w_s: float,
                h_j: float, visc: float) -> float:
    """The shaft speed after one step under stiction (Karnopp stick-slip, Stribeck decay).

    At rest the friction holds any applied ``load`` up to the breakaway torque ``t_break``;
    above it the shaft breaks away against ``t_break``. Sliding, the friction is
    ``Tc + (Ts - Tc) exp(-(w/w_s)^2)`` against the motion (viscous in ``visc``), and a speed
    that would cross zero within the step sticks at zero.
    """
    if omega == 0.0:
        if load <= t_break and load >= -t_break:
            return 0.0
        return h_j * (load - (t_break if load > 0.0 else -t_break)) / visc
    w = omega / w_s
    f = t_coul + (t_break - t_coul) * math.exp(-w * w)
    new = (omega + h_j * (load - (f if omega > 0.0 else -f))) / visc
    return 0.0 if new * omega < 0.0 else new


@kernel
def _legs(pr: FloatArray, hi_ph: int, lo_ph: int, au: float, vdc: float, i0: float, i1: float,
          i2: float, scratch: FloatArray) -> tuple[float, float, float, float]:
    """Every leg of a bridge with shorted or open switches, averaged over a PWM period.

    Each leg's period splits into fractions with only the high switch on, only the low, both
    (shoot-through: a divider across the DC link) or neither (the body diodes: positive current
    returns through the low diode, negative through the high). Fills ``scratch`` rows 0-3 with
    each leg's Thevenin voltage and resistance, whether it floats and whether it is diode-only;
    returns the shoot-through conductance, the DC-link current without the shoot-through term,
    the bridge's conduction loss and phase A's high-side switch's share of it (its channel,
    the leg current while it alone is on, the shoot-through current while both are, its body
    diode's when the leg floats on negative current).
    """
    vd, r_diode = pr[V_DIODE], pr[R_DIODE]
    g_shoot = i_ext = p_inv = p_ah = 0.0
    for k in range(3):
        ik = i0 if k == 0 else (i1 if k == 1 else i2)
        a_h = au if k == hi_ph else 0.0
        a_lo = 1.0 if k == lo_ph else (1.0 - au if k == hi_ph else 0.0)
        a_h = max(a_h * (1.0 - pr[OPEN_HIGH_A + k]), pr[SHORT_HIGH_A + k])
        a_lo = max(a_lo * (1.0 - pr[OPEN_LOW_A + k]), pr[SHORT_LOW_A + k])
        f_both = max(a_h + a_lo - 1.0, 0.0)
        f_high = a_h - f_both
        f_low = a_lo - f_both
        f_none = max(1.0 - f_high - f_low - f_both, 0.0)
        rh, rl = pr[R_HIGH_A + k], pr[R_LOW_A + k]
        r_sum = rh + rl
        v_dio = -vd if ik >= 0.0 else vdc + vd
        scratch[0, k] = f_high * vdc + f_both * vdc * (rl / r_sum) + f_none * v_dio
        scratch[1, k] = f_high * rh + f_low * rl + f_both * (rh * rl / r_sum) + f_none * r_diode
        diode_only = f_none > _FLOAT_ONE
        scratch[2, k] = 1.0 if diode_only and ik == 0.0 else 0.0
        scratch[3, k] = 1.0 if diode_only else 0.0
        g_shoot += f_both / r_sum
        i_ext += f_high * ik + f_both * ik * (rl / r_sum) + f_none * min(ik, 0.0)
        sq = ik * ik
        f_low2 = max(1.0 - f_high - f_both - f_none, 0.0)
        sw = f_high * rh * sq + f_low2 * rl * sq
        sw += f_both * (rh * rl / r_sum) * sq
        p_inv += sw + f_none * (vd * abs(ik) + r_diode * sq)
        if k == 0:
            i_st = vdc / r_sum
            p_ah = (f_high * rh * sq + f_both * rh * i_st * i_st
                    + (f_none * (vd * -ik + r_diode * sq) if ik < 0.0 else 0.0))
    p_inv += g_shoot * vdc * vdc
    return g_shoot, i_ext, p_inv, p_ah


@kernel
def _windings(i0: float, i1: float, i2: float, e0: float, e1: float, e2: float,
              scratch: FloatArray, r_w: float, h_l: float, vdc: float, vd: float,
              r_diode: float) -> tuple[float, float, float, float]:
    """One implicit step of the phase currents for the legs in ``scratch`` (:func:`_legs`).

    Returns the new currents and the neutral voltage. Uses ``scratch`` rows 4 (connected) and
    5 (winding weights) as work space.
    """
    v_leg, r_leg, floating, diode_only = scratch[0], scratch[1], scratch[2], scratch[3]
    conn, w = scratch[4], scratch[5]
    cur = (i0, i1, i2)
    e = (e0, e1, e2)
    for k in range(3):
        conn[k] = 1.0 - floating[k]
        w[k] = 1.0 / (1.0 + h_l * (r_leg[k] + r_w))
    vn = _neutral(w, cur, v_leg, e, h_l, conn)
    if floating[0] != 0.0 or floating[1] != 0.0 or floating[2] != 0.0:
        clamp = False
        for k in range(3):
            if floating[k] != 0.0:
                v_term = e[k] + vn
                if v_term > vdc + vd:
                    v_leg[k], r_leg[k], conn[k], clamp = vdc + vd, r_diode, 1.0, True
                elif v_term < -vd:
                    v_leg[k], r_leg[k], conn[k], clamp = -vd, r_diode, 1.0, True
        if clamp:
            for k in range(3):
                w[k] = 1.0 / (1.0 + h_l * (r_leg[k] + r_w))
            vn = _neutral(w, cur, v_leg, e, h_l, conn)
    new = [w[k] * (cur[k] + h_l * (v_leg[k] - e[k] - vn)) if conn[k] != 0.0 else 0.0
           for k in range(3)]
    n0, n1, n2 = new[0], new[1], new[2]
    d0 = diode_only[0] != 0.0 and i0 != 0.0 and n0 * i0 < 0.0
    d1 = diode_only[1] != 0.0 and i1 != 0.0 and n1 * i1 < 0.0
    d2 = diode_only[2] != 0.0 and i2 != 0.0 and n2 * i2 < 0.0
    if d0 or d1 or d2:
        # a diode-only phase whose current would reverse is extinguished; the others are
        # re-balanced to sum to zero (with fewer than two left, nothing flows)
        n0, n1, n2 = (0.0 if d0 else n0), (0.0 if d1 else n1), (0.0 if d2 else n2)
        al0 = conn[0] != 0.0 and not d0 and n0 != 0.0
        al1 = conn[1] != 0.0 and not d1 and n1 != 0.0
        al2 = conn[2] != 0.0 and not d2 and n2 != 0.0
        n_alive = al0 + al1 + al2
        resid = (n0 + n1 + n2) / max(n_alive, 1)
        n0, n1, n2 = (n0 - resid if al0 else n0), (n1 - resid if al1 else n1), (
            n2 - resid if al2 else n2)
        if n_alive < 2:
            n0 = n1 = n2 = 0.0
    return n0, n1, n2, vn


@kernel
def _neutral(w: FloatArray, i: tuple[float, float, float], v_leg: FloatArray,
             e: tuple[float, float, float], h_l: float, conn: FloatArray) -> float:
    """Neutral voltage making the connected phases' new currents sum to zero."""
    num = 0.0
    wsum = 0.0
    n_conn = 0
    for k in range(3):
        wc = w[k] if conn[k] != 0.0 else 0.0
        num += wc * (i[k] + h_l * (v_leg[k] - e[k]))
        wsum += wc
        n_conn += conn[k] != 0.0
    if n_conn >= 2:
        return num / max(h_l * wsum, 1e-30)
    # with fewer than two connected phases no current can flow: the mean EMF
    return (e[0] + e[1] + e[2]) / 3.0


@kernel
def _phi(lam: complex, h: float) -> tuple[complex, complex]:
    """exp(lam*h) and its integral over [0, h]."""
    e = cmath.exp(lam * h)
    if abs(lam * h) < 1e-8:
        return e, complex(h, 0.0)
    return e, (e - 1.0) / lam


@kernel
def smps_step_matrix(r: float, g: float, esr: float, lc: float, cc: float,
                     h: float) -> tuple[float, float, float, float, float, float, float, float,
                                        float]:
    """The SMPS power stage's exact step as one affine map ``(m11, m12, m21, m22, p1, p2, q1,
    q2, k)``: ``i_l' = m11 i_l + m12 v_c + p1 (D Vin) + q1 i_ext``, ``v_c'`` likewise with
    row 2, ``v_out = k (v_c + ESR (i_l - i_ext))``.

    The state ``x = (i_l, v_c)`` obeys ``x' = A x + b`` for the step (series resistance ``r``,
    shoot-through conductance ``g`` loading the output, ``k = 1/(1 + ESR g)``); the exact step
    ``x(h) = (ea A + eb I) x + (fa A + fb I) b`` comes from Sylvester's formula over A's two
    eigenvalues (complex while the LC rings), regrouped by ``D Vin`` and ``i_ext``.
    """
    kk = 1.0 / (1.0 + esr * g)
    a11 = -(r + kk * esr) / lc
    a12 = -kk / lc
    a21 = kk / cc
    a22 = -g * kk / cc
    half_tr = 0.5 * (a11 + a22)
    det = a11 * a22 - a12 * a21
    disc = cmath.sqrt(complex(half_tr * half_tr - det, 0.0))
    tiny = 1e-7 * (abs(half_tr) + 1.0)
    if abs(disc) < tiny:
        disc = complex(tiny, 0.0)
    l1, l2 = half_tr + disc, half_tr - disc
    e1, f1 = _phi(l1, h)
    e2, f2 = _phi(l2, h)
    dl = l1 - l2
    ea, eb = ((e1 - e2) / dl).real, ((l1 * e2 - l2 * e1) / dl).real
    fa, fb = ((f1 - f2) / dl).real, ((l1 * f2 - l2 * f1) / dl).real
    n11, n12, n21, n22 = fa * a11 + fb, fa * a12, fa * a21, fa * a22 + fb
    u1 = kk * esr / lc  # b1 per ampere of i_ext
    u2 = -kk / cc  # b2 per ampere of i_ext
    return (ea * a11 + eb, ea * a12, ea * a21, ea * a22 + eb, n11 / lc, n21 / lc,
            n11 * u1 + n12 * u2, n21 * u1 + n22 * u2, kk)
