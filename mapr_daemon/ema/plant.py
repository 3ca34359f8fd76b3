"""The EMA plant: a batch of runs sharing one clock, stepped in chunks of sensor samples.

Integration is a fixed step (``sensors.step_s``, 25 us by default) compiled as one kernel
(:mod:`mapr_daemon.ema.step`) that loops over the runs, the samples of a chunk and the steps of
each sample; Python is entered once per :meth:`EmaBatch.advance`. Why a fixed step and not
scipy's adaptive solvers: the plant switches (six Hall sectors per electrical turn, PWM-averaged
legs, diodes that start and stop conducting, a saturating voltage loop), so an adaptive solver
would be cut at every event; a step at ~1/30 of the 0.83 ms winding time constant with the stiff
parts taken exactly (the SMPS 2x2 system) or implicitly (winding resistance) is stable. What
numpy does well stays here: the noise (one generator per run), the ADC, the output channels.

Example — a remote terminal pulling sensor blocks as simulated time goes on::

    plant = EmaBatch([RunSpec(params, FaultSet.of([Fault("esr", 0.5)]), seed=1)])
    while flying:
        block = plant.advance(20, command_deg=cmd, dynamic_pressure_pa=q)   # 10 ms at 2 kHz
        block.channels["dc_link_current_a"]      # shape (1, 20)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema import sensors, temperature
from mapr_daemon.ema.batch import BatchArrays, RunSpec, build
from mapr_daemon.ema.params import CHANNELS, CONTROLLER_CHANNELS, SWITCH_CHANNELS
from mapr_daemon.ema.step import ACC, STATE, integrate, pack
from mapr_daemon.errors import ConfigError

TRUTH: tuple[str, ...] = (
    "position_true_deg", "command_deg", "motor_speed_rad_s", "motor_torque_nm",
    "hinge_moment_nm", "current_command_a", "torque_current_a", "smps_duty",
    "inductor_current_a", "aircraft_bus_v", "dynamic_pressure_pa", "winding_resistance_ohm",
)
"""Noise-free signals recorded alongside the sensors (block means), for ground truth."""

_ROW = {name: k for k, name in enumerate(ACC)}


@dataclasses.dataclass(frozen=True)
class SensorBlock:
    """Sensor samples of a chunk: ``channels[name]`` and ``truth[name]`` are ``(n_runs, n)``."""

    time_s: FloatArray
    channels: dict[str, FloatArray]
    truth: dict[str, FloatArray]


def _per_run(value: float | npt.ArrayLike, n_runs: int, n: int, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    try:
        return np.broadcast_to(arr, (n_runs, n)) if arr.ndim != 1 or arr.shape[0] != n_runs \
            else np.broadcast_to(arr[:, None], (n_runs, n))
    except ValueError:
        raise ConfigError(f"shape {arr.shape} does not fit ({n_runs}, {n})", field=name) from None


def _flight_scatter(p: BatchArrays, rngs: list[np.random.Generator]) -> BatchArrays:
    """This flight's ambient temperature and friction (grease) scatter, from each run's seed.

    The ambient temperature moves what physically depends on it — winding resistance (via the
    motor temperature), MOSFET Ron, the capacitor's ESR and capacitance — so healthy flights
    differ as real ones do. Without this two healthy flights at one condition would differ only
    by bus voltage and sensor noise, and every fault would look visible from its first percent.
    """
    z = np.array([g.standard_normal(2) for g in rngs]).T
    friction = np.exp(p.friction_sd * z[1])
    t_amb = p.t_amb + p.t_amb_sd * z[0]
    ron = temperature.ron_factor(t_amb)
    esr = temperature.esr_factor(t_amb)
    cap = temperature.capacitance_factor(t_amb)
    return dataclasses.replace(
        p, t_amb=t_amb, b_visc=p.b_visc * friction, t_coul=p.t_coul * friction,
        ron_hi=p.ron_hi * ron, ron_lo=p.ron_lo * ron, r_high=p.r_high * ron,
        r_low=p.r_low * ron, esr=p.esr * esr, esr_eff=p.esr_eff * esr,
        c_elec=p.c_elec * cap, c_total=p.c_elec * cap + p.c_ceramic)


def bank_impedance(p: BatchArrays, f: FloatArray) -> FloatArray:
    """|Z| of the SMPS output bank, (ESR + electrolytic) parallel to the ceramic, at ``f``.

    The analytic sub-step ripple (inductor ripple at the switching frequency, the inverter's
    pulsed current at its PWM frequency) goes through this impedance: the REFERENCE formula
    dV = dI*ESR + dI/(8 f C), its two terms added in quadrature.
    """
    w = 2.0 * np.pi * f
    z_e = p.esr - 1j / (w * np.maximum(p.c_elec, 1e-15))
    z_c = -1j / (w * p.c_ceramic)
    out: FloatArray = np.abs(z_e * z_c / (z_e + z_c))
    return out


def _column(name: str) -> int:
    return STATE.index(name)


class EmaBatch:
    """A batch of EMA runs sharing one clock. ``advance`` returns the next sensor samples.

    Every run is integrated by the compiled step of :mod:`mapr_daemon.ema.step`, one run after
    the other; a run does not depend on the batch it shares (nor on how ``advance`` chunks it).
    """

    def __init__(self, runs: Sequence[RunSpec], *, powered: bool = True) -> None:
        """``powered=True`` starts in the powered steady state; ``powered=False`` starts with
        the SMPS off, so every run begins with its soft start (the capacitance observation
        needs it).

        The powered state: the supply switched on long ago (the soft start over), output and
        capacitor at the reference, no load so no inductor or capacitor current, the voltage
        loop's integral at the value that holds the duty at ``Vref/Vin`` with zero error
        (``integ = D*Vin - Vref = R*i_l = 0``): the first step changes nothing until the motor
        draws current. A shorted switch has no regulated steady state; it loads this one from
        the first step, as it would a running supply at the moment of the fault.
        """
        self.specs = tuple(runs)
        self.rngs = [np.random.default_rng(s.seed) for s in self.specs]
        self.switch_rngs = [np.random.default_rng(np.random.SeedSequence(s.seed).spawn(1)[0])
                            for s in self.specs]
        """The switch temperature channels' noise: a stream of its own per run (a child of the
        run's seed), so the other channels draw exactly what they drew before them."""
        self.switch_held = np.zeros((len(SWITCH_CHANNELS), len(self.specs)))
        """The switch sensors' last readings (held between readings, across chunks)."""
        self.switch_sum = np.zeros((len(SWITCH_CHANNELS), len(self.specs)))
        """... and the sum of their samples in the reading period under way."""
        self.p: BatchArrays = _flight_scatter(build(self.specs), self.rngs)
        p = self.p
        self.t = 0.0
        self.sample_index = 0
        slow = sensors.SlowState.start(p, self.rngs)
        self.state = np.zeros((p.n, len(STATE)))
        """Every run's state, columns :data:`~mapr_daemon.ema.step.STATE`."""
        for name, value in (("motor_c", slow.motor_c), ("stage_c", slow.stage_c),
                            ("bus_drift", slow.bus_drift), ("bus_v", slow.bus_v)):
            self.state[:, _column(name)] = value
        # the SMPS high side's junction starts settled over the sink on its switching loss
        self.state[:, _column("hs_rise")] = p.rth_sw_smps * p.p_sw
        self.t_on = 0.0
        """When the SMPS was switched on: its soft start ramps the reference from here."""
        if powered:
            for name in ("v_c", "v_out"):
                self.state[:, _column(name)] = p.v_ref
            self.state[:, _column("duty")] = p.v_ref / np.maximum(slow.bus_v, 1.0)
            self.t_on = -np.inf
        self.par = pack(p, bank_impedance(p, p.f_sw), bank_impedance(p, p.f_pwm),
                        slow.bus_offset)
        """Every run's parameters, columns :data:`~mapr_daemon.ema.step.PAR`."""

    @property
    def n_runs(self) -> int:
        return self.p.n

    @property
    def sample_period_s(self) -> float:
        return self.p.step_s * self.p.samples_per_block

    def advance(self, n_samples: int, command_deg: float | npt.ArrayLike = 0.0,
                dynamic_pressure_pa: float | npt.ArrayLike = 0.0,
                ambient_c: float | npt.ArrayLike | None = None) -> SensorBlock:
        """Simulate ``n_samples`` output samples; inputs are held over each sample period.

        Inputs are scalars, ``(n_samples,)`` (shared by all runs), ``(n_runs,)`` (constant per
        run) or ``(n_runs, n_samples)``. A 1-D input whose length is both is read as per run:
        a caller whose chunk can be as long as the batch passes ``(1, n_samples)`` or
        ``(n_runs, 1)``.
        """
        p = self.p
        n = int(n_samples)
        cmd = np.radians(_per_run(command_deg, p.n, n, "command_deg"))
        q = _per_run(dynamic_pressure_pa, p.n, n, "dynamic_pressure_pa")
        amb = (np.broadcast_to(p.t_amb[:, None], (p.n, n)) if ambient_c is None
               else _per_run(ambient_c, p.n, n, "ambient_c"))
        z = sensors.draw(self.rngs, n, len(CHANNELS))
        z_sw = sensors.draw(self.switch_rngs, n, len(SWITCH_CHANNELS), extra=0)
        means = np.empty((len(ACC), p.n, n))
        bus = np.empty((p.n, n))
        rw = np.empty((p.n, n))

        def c(a: FloatArray) -> FloatArray:
            # always a fresh writable C array: a read-only view (what broadcast_to gives for one
            # run or one sample) is another numba type, and would compile a second kernel
            return np.array(a, dtype=np.float64, order="C")

        self.t = integrate(self.par, self.state, c(cmd), c(q), c(amb), c(z[-2]), c(z[-1]),
                           self.t, self.t_on, p.step_s, p.samples_per_block,
                           self.sample_period_s, means, bus, rw)
        self.sample_index += n
        return self._block(means, z, z_sw, cmd, q, bus, rw, n)

    def _block(self, m: FloatArray, z: FloatArray, z_sw: FloatArray, cmd: FloatArray,
               q: FloatArray, bus: FloatArray, rw: FloatArray, n: int) -> SensorBlock:
        p = self.p
        r = _ROW
        var = np.maximum(m[r["v_out2"]] - m[r["v_out"]] ** 2, 0.0)
        clean = np.stack((
            m[r["i_dc"]], m[r["i_a"]], m[r["i_b"]], m[r["i_c"]], m[r["v_out"]],
            np.degrees(m[r["delta"]]), m[r["p_motor"]], m[r["v_in"]], m[r["i_in"]],
            m[r["p_stage"]], np.sqrt(var + m[r["ripple2"]])))
        noisy = sensors.adc(p, clean, z[: len(CHANNELS)])
        first = self.sample_index - n
        time_s = (np.arange(first, first + n, dtype=np.float64) + 1.0) * self.sample_period_s
        channels = {name: noisy[k] for k, name in enumerate(CHANNELS)}
        duty_lsb = p.duty_lsb[:, None]
        reported = (m[r["sector"]], np.round(m[r["u"]] / duty_lsb) * duty_lsb)
        channels.update(zip(CONTROLLER_CHANNELS, reported, strict=True))
        channels.update(zip(SWITCH_CHANNELS, self._switch_readings(m, z_sw, first, n),
                            strict=True))
        truth = dict(zip(TRUTH, (
            np.degrees(m[r["delta"]]), np.degrees(cmd), m[r["omega"]], m[r["torque"]],
            m[r["hinge"]], m[r["i_cmd"]], m[r["i_q"]], m[r["duty"]], m[r["i_l"]], bus,
            np.array(q), rw), strict=True))
        return SensorBlock(time_s=time_s, channels=channels, truth=truth)

    def _switch_readings(self, m: FloatArray, z: FloatArray, first: int,
                         n: int) -> FloatArray:
        """The switch temperature channels ``(3, n_runs, n)`` of samples ``first..first+n``.

        Their sensors are read as the stage temperature's (its noise per sample, its
        quantisation) by an integrating ADC at ``switches.sensor_rate_hz``: each reading is
        the mean over its ``sw_read_every`` samples, quantised, and is what the channel holds
        from the end of its period to the end of the next (the first period holds the first
        sample's value with a reading's noise). Partial periods carry across chunks, so a run
        reads the same however it is chunked.
        """
        p = self.p
        k = CHANNELS.index("stage_temperature_c")
        values = np.stack([m[_ROW[c]] for c in ("t_smps_high", "t_smps_low", "t_inv_a_high")])
        noisy = values + p.noise[k][None, :, None] * z
        every = int(p.sw_read_every[0])
        if first == 0 and n:
            start = values[:, :, 0] + p.noise[k][None, :] * z[:, :, 0] / np.sqrt(every)
            self.switch_held = sensors.quantise_as(p, "stage_temperature_c", start)
            self.switch_sum = np.zeros_like(self.switch_held)
        steps = np.arange(n)
        ends = steps[(first + steps + 1) % every == 0]          # last sample of each period
        cum = np.cumsum(noisy, axis=2)
        readings = np.empty((*noisy.shape[:2], ends.size))
        for i, j in enumerate(ends):
            lo = j - every + 1
            total = cum[:, :, j] - (cum[:, :, lo - 1] if lo > 0 else 0.0)
            readings[:, :, i] = total + (self.switch_sum if lo < 0 else 0.0)
        readings = sensors.quantise_as(p, "stage_temperature_c", readings / every)
        latest = np.searchsorted(ends, steps, side="left") - 1  # the last period ended before
        out: FloatArray = np.where(
            latest[None, None, :] >= 0, readings[:, :, np.maximum(latest, 0)] if ends.size
            else self.switch_held[:, :, None], self.switch_held[:, :, None])
        if ends.size:
            self.switch_held = readings[:, :, -1]
            tail = cum[:, :, -1] - cum[:, :, ends[-1]]
            self.switch_sum = tail
        elif n:
            self.switch_sum = self.switch_sum + cum[:, :, -1]
        return out
