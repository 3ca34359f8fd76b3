"""Per-run parameters of a batch as numpy arrays, so many runs integrate in one array pass.

A :class:`RunSpec` is one actuator file plus its seeded faults and noise seed. :func:`build`
turns a sequence of them into :class:`BatchArrays`: every scalar parameter becomes an array of
shape ``(n_runs,)`` and every per-switch value an array of shape ``(3, n_runs)`` (phase A, B, C),
after the faults of :mod:`mapr_daemon.ema.faults` have been applied. Runs of one batch must
share the integrator step and the output sample rate; everything else may differ.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema import faults as fl
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import CHANNELS, ActuatorParams
from mapr_daemon.errors import ConfigError

BoolArray = npt.NDArray[np.bool_]


@dataclasses.dataclass(frozen=True)
class RunSpec:
    """One simulated run: actuator parameters, seeded faults, the noise seed and, optionally,
    this flight's condition.

    ``ambient_c`` (ambient temperature, C) and ``bus_v`` (the aircraft bus's mean over the
    flight, V) fix what the plant otherwise draws from the actuator file's flight-to-flight
    spread (``thermal.ambient_c`` +- ``ambient_flight_sd_k``, ``bus.nominal_v`` +-
    ``flight_mean_sd_v``). The run's random draws are the same either way (a fixed value
    replaces the draw, it does not skip it), so the sensor noise of a seed does not depend on
    whether its condition was given. The bus still drifts and ripples within the flight.

    ``form`` is the run's model form (:class:`~mapr_daemon.ema.form.ModelForm`: friction law,
    control law and rates, housekeeping load, Hall offset, sensor gain and offset errors);
    the default is the plant as the actuator file describes it.
    """

    params: ActuatorParams
    faults: fl.FaultSet = dataclasses.field(default_factory=fl.FaultSet)
    seed: int = 0
    ambient_c: float | None = None
    bus_v: float | None = None
    form: ModelForm = dataclasses.field(default_factory=ModelForm)


def _arr(values: Sequence[float]) -> FloatArray:
    return np.asarray(values, dtype=np.float64)


@dataclasses.dataclass(frozen=True)
class BatchArrays:
    """Every parameter the integrator reads, one entry (or column) per run."""

    n: int
    step_s: float
    samples_per_block: int
    # SMPS
    v_ref: FloatArray
    l_smps: FloatArray
    r_dcr: FloatArray
    c_total: FloatArray
    esr_eff: FloatArray
    c_elec: FloatArray
    esr: FloatArray
    c_ceramic: FloatArray
    ron_hi: FloatArray
    ron_lo: FloatArray
    f_sw: FloatArray
    d_max: FloatArray
    i_lim_smps: FloatArray
    soft_start: FloatArray
    kp_v: FloatArray
    ki_v: FloatArray
    kd_v: FloatArray
    tf_v: FloatArray
    p_sw: FloatArray
    # inverter, (3, n): per phase
    r_high: FloatArray
    r_low: FloatArray
    short_high: FloatArray
    short_low: FloatArray
    open_high: FloatArray
    open_low: FloatArray
    v_diode: FloatArray
    r_diode: FloatArray
    f_pwm: FloatArray
    duty_lsb: FloatArray
    """Resolution of the reported duty: one timer count over the PWM periods of a sample."""
    # motor and mechanics
    r_w0: FloatArray
    l_w: FloatArray
    k_e: FloatArray
    pole_pairs: FloatArray
    j_eq: FloatArray
    b_visc: FloatArray
    t_coul: FloatArray
    w_coul: FloatArray
    ratio: FloatArray
    eta: FloatArray
    area_chord: FloatArray
    ch0: FloatArray
    ch_delta: FloatArray
    travel_rad: FloatArray
    # control
    kp_pos: FloatArray
    ki_pos: FloatArray
    kd_pos: FloatArray
    i_lim: FloatArray
    kp_i: FloatArray
    ki_i: FloatArray
    r_loop: FloatArray
    """The drive's loop resistance ``2 (R + Ron)`` from the file (the voltage-mode law's)."""
    # model form (ema/form.py), one value per run
    breakaway: FloatArray
    w_stribeck: FloatArray
    voltage_mode: FloatArray
    n_cur: FloatArray
    n_pos: FloatArray
    hk_w: FloatArray
    hk_var: FloatArray
    hk_period: FloatArray
    hall_offset: FloatArray
    """Hall sensor mounting error, electrical radians."""
    # thermal
    t_amb: FloatArray
    t_amb_sd: FloatArray
    friction_sd: FloatArray
    rth_m: FloatArray
    tau_m: FloatArray
    rth_s: FloatArray
    tau_s: FloatArray
    rth_sw_smps: FloatArray
    """Per-switch junction-to-sink nodes (:class:`~mapr_daemon.ema.params.SwitchThermalParams`)."""
    tau_sw_smps: FloatArray
    rth_sw_inv: FloatArray
    tau_sw_inv: FloatArray
    sw_read_every: FloatArray
    """Output samples per switch temperature reading (each held until the next)."""
    # aircraft bus
    bus_nominal: FloatArray
    bus_mean_sd: FloatArray
    bus_drift_sd: FloatArray
    bus_tau: FloatArray
    bus_ripple: FloatArray
    bus_min: FloatArray
    bus_max: FloatArray
    r_source: FloatArray
    # sensors, (n_channels, n)
    full_scale: FloatArray
    lsb: FloatArray
    noise: FloatArray
    sensor_gain: FloatArray
    sensor_offset: FloatArray


def _switch_masks(specs: Sequence[RunSpec], kind: str) -> tuple[FloatArray, FloatArray]:
    high = np.zeros((3, len(specs)))
    low = np.zeros((3, len(specs)))
    for r, spec in enumerate(specs):
        for name in spec.faults.switches(kind):
            phase = "ABC".index(name[0])
            (high if name.endswith("high") else low)[phase, r] = 1.0
    return high, low


def _given(specs: Sequence[RunSpec], name: str, default: FloatArray) -> FloatArray:
    """A condition's centre per run: the spec's value where it gives one, else ``default``."""
    given = [getattr(s, name) for s in specs]
    return _arr([default[k] if v is None else float(v) for k, v in enumerate(given)])


def _spread(specs: Sequence[RunSpec], name: str, default: FloatArray) -> FloatArray:
    """A condition's flight-to-flight spread per run: 0 where the spec fixes the condition."""
    return _arr([default[k] if getattr(s, name) is None else 0.0 for k, s in enumerate(specs)])


def build(specs: Sequence[RunSpec]) -> BatchArrays:
    """Arrays for a batch of runs; raises ConfigError if the runs cannot share one integrator."""
    if not specs:
        raise ConfigError("a batch needs at least one run", field="runs")
    step = specs[0].params.sensors.step_s
    rate = specs[0].params.sensors.sample_rate_hz
    for s in specs:
        if s.params.sensors.step_s != step or s.params.sensors.sample_rate_hz != rate:
            raise ConfigError("runs of one batch must share step_s and sample_rate_hz",
                              field="sensors")
        if s.params.switches.sensor_rate_hz != specs[0].params.switches.sensor_rate_hz:
            raise ConfigError("runs of one batch must share switches.sensor_rate_hz",
                              field="switches")
    ps = [fl.apply(s.params, s.faults) for s in specs]

    def col(get: object) -> FloatArray:
        return _arr([get(p) for p in ps])  # type: ignore[operator]

    sm = [p.smps for p in ps]
    c_elec = _arr([s.capacitance_f for s in sm])
    c_cer = _arr([s.ceramic_capacitance_f for s in sm])
    esr = _arr([s.esr_ohm for s in sm])
    short_h, short_l = _switch_masks(specs, "short")
    open_h, open_l = _switch_masks(specs, "open")
    r_high = np.tile(col(lambda p: p.inverter.ron_ohm), (3, 1))
    r_high[0] = col(lambda p: p.inverter.ron_a_high_ohm)
    r_low = np.tile(col(lambda p: p.inverter.ron_ohm), (3, 1))
    r_short = col(lambda p: p.inverter.short_resistance_ohm)
    r_high = np.where(short_h > 0, r_short, r_high)
    r_low = np.where(short_l > 0, r_short, r_low)

    ratio = col(lambda p: p.gear.ratio)
    j_eq = col(lambda p: p.motor.inertia_kg_m2) + col(lambda p: p.surface.inertia_kg_m2) / ratio**2
    kt = 2.0 * col(lambda p: p.motor.back_emf_v_s_per_rad)
    wn = 2 * math.pi * col(lambda p: p.control.position_bandwidth_hz)
    zeta = col(lambda p: p.control.position_damping)
    kp_pos = j_eq * wn**2 / kt
    wc = 2 * math.pi * col(lambda p: p.control.current_bandwidth_hz)
    r_loop = 2.0 * (col(lambda p: p.motor.resistance_ohm) + col(lambda p: p.inverter.ron_ohm))
    l_loop = 2.0 * col(lambda p: p.motor.inductance_h)

    chans = [[p.sensors.channels[c] for c in CHANNELS] for p in ps]
    fs = np.array([[c.full_scale for c in row] for row in chans]).T
    bits = np.array([[c.bits for c in row] for row in chans]).T
    per_block = round(1.0 / (rate * step))
    forms = [s.form for s in specs]
    loops = np.array([f.loop_steps(step) for f in forms], dtype=np.float64).reshape(-1, 2)

    def form(name: str) -> FloatArray:
        return _arr([float(getattr(f, name)) for f in forms])

    return BatchArrays(
        n=len(specs), step_s=step, samples_per_block=per_block,
        v_ref=_arr([s.output_voltage_v for s in sm]),
        l_smps=_arr([s.inductance_h for s in sm]),
        r_dcr=_arr([s.inductor_resistance_ohm for s in sm]),
        c_total=c_elec + c_cer, esr_eff=esr * c_elec / (c_elec + c_cer),
        c_elec=c_elec, esr=esr, c_ceramic=c_cer,
        ron_hi=_arr([s.ron_high_ohm for s in sm]), ron_lo=_arr([s.ron_low_ohm for s in sm]),
        f_sw=_arr([s.switching_frequency_hz for s in sm]), d_max=_arr([s.max_duty for s in sm]),
        i_lim_smps=_arr([s.current_limit_a for s in sm]),
        soft_start=_arr([s.soft_start_s for s in sm]),
        kp_v=_arr([s.loop_kp for s in sm]), ki_v=_arr([s.loop_ki for s in sm]),
        kd_v=_arr([s.loop_kd for s in sm]), tf_v=_arr([s.loop_derivative_filter_s for s in sm]),
        p_sw=_arr([s.switching_loss_w for s in sm]),
        r_high=r_high, r_low=r_low, short_high=short_h, short_low=short_l,
        open_high=open_h * (1 - short_h), open_low=open_l * (1 - short_l),
        v_diode=col(lambda p: p.inverter.diode_drop_v),
        r_diode=col(lambda p: p.inverter.diode_resistance_ohm),
        f_pwm=col(lambda p: p.inverter.pwm_frequency_hz),
        duty_lsb=rate / (col(lambda p: p.inverter.pwm_counter_period)
                         * col(lambda p: p.inverter.pwm_frequency_hz)),
        r_w0=col(lambda p: p.motor.resistance_ohm), l_w=col(lambda p: p.motor.inductance_h),
        k_e=col(lambda p: p.motor.back_emf_v_s_per_rad),
        pole_pairs=col(lambda p: p.motor.pole_pairs), j_eq=j_eq,
        b_visc=col(lambda p: p.motor.viscous_friction_nm_s),
        t_coul=col(lambda p: p.motor.coulomb_friction_nm),
        w_coul=col(lambda p: p.motor.coulomb_speed_rad_s),
        ratio=ratio, eta=col(lambda p: p.gear.efficiency),
        area_chord=col(lambda p: p.surface.area_m2 * p.surface.chord_m),
        ch0=col(lambda p: p.surface.ch0), ch_delta=col(lambda p: p.surface.ch_delta_per_rad),
        travel_rad=np.radians(col(lambda p: p.surface.travel_deg)),
        kp_pos=kp_pos, kd_pos=2.0 * zeta * wn * j_eq / kt,
        ki_pos=kp_pos * 2 * math.pi * col(lambda p: p.control.position_integral_hz),
        i_lim=col(lambda p: p.control.current_limit_a),
        kp_i=l_loop * wc, ki_i=r_loop * wc, r_loop=r_loop,
        breakaway=np.where(form("breakaway_ratio") > 0.0, form("breakaway_ratio"),
                           col(lambda p: p.motor.breakaway_ratio)),
        w_stribeck=np.where(form("breakaway_ratio") > 0.0, form("stribeck_speed_rad_s"),
                            col(lambda p: p.motor.stribeck_speed_rad_s)),
        voltage_mode=form("voltage_mode"), n_cur=loops[:, 0], n_pos=loops[:, 1],
        hk_w=form("housekeeping_w"), hk_var=form("housekeeping_variation"),
        hk_period=form("housekeeping_period_s"),
        hall_offset=np.radians(form("hall_offset_deg")),
        t_amb=_given(specs, "ambient_c", col(lambda p: p.thermal.ambient_c)),
        t_amb_sd=_spread(specs, "ambient_c", col(lambda p: p.thermal.ambient_flight_sd_k)),
        friction_sd=col(lambda p: p.motor.friction_flight_sd),
        rth_m=col(lambda p: p.thermal.motor_thermal_resistance_k_per_w),
        tau_m=col(lambda p: p.thermal.motor_time_constant_s),
        rth_s=col(lambda p: p.thermal.stage_thermal_resistance_k_per_w),
        tau_s=col(lambda p: p.thermal.stage_time_constant_s),
        rth_sw_smps=col(lambda p: p.switches.smps_thermal_resistance_k_per_w),
        tau_sw_smps=col(lambda p: p.switches.smps_time_constant_s),
        rth_sw_inv=col(lambda p: p.switches.inverter_thermal_resistance_k_per_w),
        tau_sw_inv=col(lambda p: p.switches.inverter_time_constant_s),
        sw_read_every=np.maximum(1.0, np.round(rate / col(lambda p: p.switches.sensor_rate_hz))),
        bus_nominal=_given(specs, "bus_v", col(lambda p: p.bus.nominal_v)),
        bus_mean_sd=_spread(specs, "bus_v", col(lambda p: p.bus.flight_mean_sd_v)),
        bus_drift_sd=col(lambda p: p.bus.drift_sd_v),
        bus_tau=col(lambda p: p.bus.drift_time_constant_s),
        bus_ripple=col(lambda p: p.bus.ripple_rms_v),
        bus_min=col(lambda p: p.bus.min_v), bus_max=col(lambda p: p.bus.max_v),
        r_source=col(lambda p: p.bus.source_resistance_ohm),
        full_scale=fs, lsb=2.0 * fs / 2.0**bits,
        noise=np.array([[c.noise_rms for c in row] for row in chans]).T,
        sensor_gain=np.array([f.gains() for f in forms]).T,
        sensor_offset=np.array([f.offsets() for f in forms]).T,
    )
