"""Averaged synchronous buck (aircraft bus -> 24 V DC link), its voltage loop and ripple.

Why averaged: the real converter switches at ``switching_frequency_hz`` (100 kHz); integrating
every edge would need sub-microsecond steps. Over one switching period the inductor sees
``D*Vin`` on average, and the switches add ``Req = D*Ron_high + (1-D)*Ron_low`` in series (the
high side conducts a fraction D of the time, the low side 1-D: at 24/28 the low side carries
the current only ~14 % of the time, which is why its Ron is hard to see).

State per run: inductor current ``i_l`` and capacitor voltage ``v_c``. The output is
``v_out = v_c + ESR*(i_l - i_out)``, where the inverter draws ``i_out = i_ext + g*v_out``
(``g`` is the shoot-through conductance of a shorted switch). For one step the system is
linear with constant inputs, so it is advanced *exactly* (matrix exponential of the 2x2 system
by Sylvester's formula, eigenvalues complex when the LC rings): stable for any capacitance
down to the ceramic floor and with no numerical damping, which would otherwise hide the loop
instability that a small capacitance causes.

Ripple below the step's resolution is estimated analytically (:func:`ripple_sq`) and feeds the
RMS detector channel: the inductor's triangular ripple at the switching frequency and the
inverter's pulsed current at its PWM frequency, each through the output capacitor bank's
impedance at that frequency (electrolytic with ESR in parallel with the ceramic). This is the
REFERENCE formula dV = dI*ESR + dI/(8 f C) with the two terms added in quadrature.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mapr_daemon.ema.batch import BatchArrays, FloatArray


@dataclasses.dataclass
class SmpsState:
    """Mutable SMPS state, one entry per run."""

    i_l: FloatArray
    v_c: FloatArray
    v_out: FloatArray
    integ: FloatArray
    deriv: FloatArray
    prev_err: FloatArray
    duty: FloatArray
    t_on: float = 0.0
    """Time the supply was switched on: its soft start ramps the reference from here."""

    @classmethod
    def cold(cls, n: int) -> SmpsState:
        """Unpowered: everything at zero (the soft start runs from t = 0)."""
        z = np.zeros(n)
        return cls(z.copy(), z.copy(), z.copy(), z.copy(), z.copy(), z.copy(), z.copy())

    @classmethod
    def powered(cls, p: BatchArrays, vin: FloatArray) -> SmpsState:
        """The regulated steady state with the bridge idle, at input voltage ``vin``.

        Switched on long ago (the soft start is over), output and capacitor at the reference,
        no load so no inductor or capacitor current, the PI integral at the value that holds
        the duty at ``Vref/Vin`` with zero error (``integ = D*Vin - Vref = R*i_l = 0``): the
        first step of a powered run changes nothing until the motor draws current. A shorted
        switch (shoot-through) has no regulated steady state; it loads this one from the first
        step, as it would a running supply at the moment of the fault.
        """
        s = cls.cold(p.n)
        s.v_c[:] = p.v_ref
        s.v_out[:] = p.v_ref
        s.duty[:] = p.v_ref / np.maximum(vin, 1.0)
        s.t_on = -np.inf
        return s


def voltage_loop(s: SmpsState, p: BatchArrays, t: float, vin: FloatArray) -> FloatArray:
    """Digital PI(D) with input-voltage feed-forward and soft start; returns the duty.

    The soft start ramps the reference from 0 at ``s.t_on`` to ``Vref`` ``soft_start`` later.
    """
    h = p.step_s
    ramp = np.minimum(1.0, (t - s.t_on) / np.maximum(p.soft_start, 1e-12))
    vref = p.v_ref * ramp
    err = vref - s.v_out
    s.deriv += (h / (p.tf_v + h)) * ((err - s.prev_err) / h - s.deriv)
    s.prev_err = err
    trial = s.integ + p.ki_v * err * h
    u = p.kp_v * err + trial + p.kd_v * s.deriv
    vin_safe = np.maximum(vin, 1.0)
    raw = (vref + u) / vin_safe
    # averaged cycle-by-cycle current limit: the duty that brings i_l to the limit in one step
    r_eq = raw * p.ron_hi + (1.0 - raw) * p.ron_lo + p.r_dcr
    d_cl = (s.v_out + r_eq * s.i_l + p.l_smps * (p.i_lim_smps - s.i_l) / h) / vin_safe
    duty = np.maximum(np.minimum(raw, np.minimum(p.d_max, d_cl)), 0.0)
    # conditional integration (anti-windup): keep the integral only while not saturated
    # or while the error pulls the duty back inside
    saturated = ((duty < raw) & (err > 0)) | ((duty > raw) & (err < 0))
    s.integ = np.where(saturated, s.integ, trial)
    s.duty = duty
    return duty


def _phi(lam: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """exp(lam*h) and its integral over [0, h], elementwise (complex)."""
    e = np.exp(lam * h)
    small = np.abs(lam * h) < 1e-8
    safe = np.where(small, 1.0, lam)
    return e, np.where(small, h, (e - 1.0) / safe)


def step(s: SmpsState, p: BatchArrays, vin: FloatArray, i_ext: FloatArray,
         g: FloatArray) -> None:
    """Advance the power stage by one step with the duty in ``s.duty`` (exact for the step)."""
    h = p.step_s
    d = s.duty
    r = d * p.ron_hi + (1.0 - d) * p.ron_lo + p.r_dcr
    esr = p.esr_eff
    k = 1.0 / (1.0 + esr * g)
    lc, cc = p.l_smps, p.c_total
    a11 = -(r + k * esr) / lc
    a12 = -k / lc
    a21 = k / cc
    a22 = -g * k / cc
    b1 = (d * vin + k * esr * i_ext) / lc
    b2 = -k * i_ext / cc
    half_tr = 0.5 * (a11 + a22)
    det = a11 * a22 - a12 * a21
    disc = np.sqrt((half_tr * half_tr - det).astype(np.complex128))
    tiny = 1e-7 * (np.abs(half_tr) + 1.0)
    disc = np.where(np.abs(disc) < tiny, tiny, disc)
    l1, l2 = half_tr + disc, half_tr - disc
    e1, f1 = _phi(l1, h)
    e2, f2 = _phi(l2, h)
    dl = l1 - l2
    ea = ((e1 - e2) / dl).real
    eb = ((l1 * e2 - l2 * e1) / dl).real
    fa = ((f1 - f2) / dl).real
    fb = ((l1 * f2 - l2 * f1) / dl).real
    x1, x2 = s.i_l, s.v_c
    # x' = (ea*A + eb*I) x + (fa*A + fb*I) b
    ab1 = a11 * b1 + a12 * b2
    ab2 = a21 * b1 + a22 * b2
    s.i_l = ea * (a11 * x1 + a12 * x2) + eb * x1 + fa * ab1 + fb * b1
    s.v_c = ea * (a21 * x1 + a22 * x2) + eb * x2 + fa * ab2 + fb * b2
    s.v_out = k * (s.v_c + esr * (s.i_l - i_ext))


def ripple_sq(s: SmpsState, p: BatchArrays, vin: FloatArray, i_dc_pulsed: FloatArray,
              inv_duty: FloatArray, z_sw: FloatArray, z_pwm: FloatArray) -> FloatArray:
    """Mean-square output ripple from sub-step switching (V^2), for the RMS detector.

    ``z_sw`` and ``z_pwm`` are :func:`bank_impedance` at the SMPS and inverter frequencies.
    """
    d = s.duty
    # inductor ripple, peak to peak, triangular: rms = pp/sqrt(12)
    di_l = np.maximum(vin - s.v_out, 0.0) * d / (p.l_smps * p.f_sw)
    # inverter PWM: the DC link carries i_dc_pulsed for a fraction inv_duty of each period
    i_inv_ac = np.abs(i_dc_pulsed) * np.sqrt(np.maximum(inv_duty * (1.0 - inv_duty), 0.0))
    out: FloatArray = (di_l * z_sw) ** 2 / 12.0 + (i_inv_ac * z_pwm) ** 2
    return out


def bank_impedance(p: BatchArrays, f: FloatArray) -> FloatArray:
    """|Z| of (ESR + electrolytic) in parallel with the ceramic, at frequency ``f``."""
    w = 2.0 * np.pi * f
    z_e = p.esr - 1j / (w * np.maximum(p.c_elec, 1e-15))
    z_c = -1j / (w * p.c_ceramic)
    out: FloatArray = np.abs(z_e * z_c / (z_e + z_c))
    return out
