"""The EMA plant: a batch of runs integrated together, stepped in chunks of sensor samples.

Integration is a fixed step (``sensors.step_s``, 25 us by default) with numpy vectorised
*across runs*: every state is an array with one entry per run, so a 416-run fault dictionary
costs one Python loop over time whose every operation handles all runs at once. Why this and
not scipy's compiled integrators: the plant switches (six Hall sectors per electrical turn,
PWM-averaged legs, diodes that start and stop conducting, a saturating voltage loop), so an
adaptive solver would be cut at every event and still call back into Python for each
right-hand side; a fixed step at ~1/30 of the 0.83 ms winding time constant with the stiff
parts taken exactly (the SMPS 2x2 system) or implicitly (winding resistance) is stable and
lets the per-step Python overhead be shared by the whole batch. A *single* run would pay that
overhead (~200 numpy calls a step) alone, so small batches take the float path of
:mod:`mapr_daemon.ema.scalar` instead: the same equations and step run by run on plain floats,
equal to rounding (see ``path`` and ``bench/plant.py``).

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

from mapr_daemon.ema import inverter as inv
from mapr_daemon.ema import motor, sensors, smps
from mapr_daemon.ema.batch import BatchArrays, FloatArray, RunSpec, build
from mapr_daemon.ema.control import ControlState, control
from mapr_daemon.ema.multirate import MultiRateRun
from mapr_daemon.ema.params import CHANNELS, CONTROLLER_CHANNELS
from mapr_daemon.ema.scalar import ScalarRun
from mapr_daemon.errors import ConfigError

TRUTH: tuple[str, ...] = (
    "position_true_deg", "command_deg", "motor_speed_rad_s", "motor_torque_nm",
    "hinge_moment_nm", "current_command_a", "torque_current_a", "smps_duty",
    "inductor_current_a", "aircraft_bus_v", "dynamic_pressure_pa", "winding_resistance_ohm",
)
"""Noise-free signals recorded alongside the sensors (block means), for ground truth."""

# rows of the per-step accumulator; the last ("sector") is not a mean but the sector of the
# sample period's last step (1-6)
_ACC = ("i_dc", "i_a", "i_b", "i_c", "v_out", "delta", "v_in", "i_in", "v_out2", "ripple2",
        "p_motor", "p_stage", "torque", "omega", "hinge", "i_cmd", "i_q", "duty", "i_l", "u",
        "sector")
_ROW = {name: k for k, name in enumerate(_ACC)}


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


RON_TEMPCO = 0.006
"""MOSFET Ron rise per kelvin (datasheet normalised-Ron curves: ~1.6x from 25 to 125 C)."""
ESR_TEMPCO = 0.02
"""Electrolytic ESR: exp(-0.02*(T-25)), about doubling from 25 to -10 C."""
CAP_TEMPCO = 0.002
"""Electrolytic capacitance change per kelvin."""


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
    dt = t_amb - 25.0
    ron = 1.0 + RON_TEMPCO * dt
    esr = np.exp(-ESR_TEMPCO * dt)
    return dataclasses.replace(
        p, t_amb=t_amb, b_visc=p.b_visc * friction, t_coul=p.t_coul * friction,
        ron_hi=p.ron_hi * ron, ron_lo=p.ron_lo * ron, r_high=p.r_high * ron,
        r_low=p.r_low * ron, esr=p.esr * esr, esr_eff=p.esr_eff * esr,
        c_elec=p.c_elec * (1.0 + CAP_TEMPCO * dt),
        c_total=p.c_elec * (1.0 + CAP_TEMPCO * dt) + p.c_ceramic)


SCALAR_MAX_RUNS = 64
"""Batches up to this size step run by run in floats (:mod:`scalar`), larger ones in numpy.

Measured on the 2-core reference machine (``bench/plant.py``): the float path gives 6-8
actuator-seconds per wall second whatever the batch size, the numpy path 0.1 for one run, 4.4
for 64 and 7.6 for 104; the two cross near 90-100 runs."""
PATHS = ("auto", "scalar", "vector", "multirate")


class EmaBatch:
    """A batch of EMA runs sharing one clock. ``advance`` returns the next sensor samples.

    ``path`` chooses how a step is computed: ``"vector"`` numpy across the runs (cheap per run
    in a large batch), ``"scalar"`` plain floats run by run (no per-call overhead: a lone
    actuator runs many times faster), ``"auto"`` scalar up to :data:`SCALAR_MAX_RUNS` runs.
    These compute the same equations with the same step and agree to rounding.
    ``"multirate"`` (:mod:`mapr_daemon.ema.multirate`) is floats too, with the drive updated
    once per PWM period: faster, and equal to the others only within the tolerances of
    ``tests/ema/test_multirate_path.py``.
    """

    def __init__(self, runs: Sequence[RunSpec], *, powered: bool = True,
                 path: str = "auto") -> None:
        """``powered=True`` starts in the powered steady state (DC bus regulated, the SMPS idle
        and settled: see :meth:`SmpsState.powered`); ``powered=False`` starts with the SMPS
        off, so every run begins with its soft start (the capacitance observation needs it)."""
        if path not in PATHS:
            raise ConfigError(f"unknown path {path!r} (known: {', '.join(PATHS)})", field="path")
        self.specs = tuple(runs)
        self.rngs = [np.random.default_rng(s.seed) for s in self.specs]
        self.p: BatchArrays = _flight_scatter(build(self.specs), self.rngs)
        p = self.p
        self.t = 0.0
        self.sample_index = 0
        self.ctl = ControlState.zero(p.n)
        self.slow = sensors.SlowState.start(p, self.rngs)
        self.smps = (smps.SmpsState.powered(p, self.slow.bus_v) if powered
                     else smps.SmpsState.cold(p.n))
        self.i = np.zeros((3, p.n))
        self.vn = np.zeros(p.n)
        self.omega = np.zeros(p.n)
        self.theta = np.zeros(p.n)
        self.i_in = np.zeros(p.n)
        self.z_sw = smps.bank_impedance(p, p.f_sw)
        self.z_pwm = smps.bank_impedance(p, p.f_pwm)
        scalar = path == "scalar" or (path == "auto" and p.n <= SCALAR_MAX_RUNS)
        self.path = "multirate" if path == "multirate" else "scalar" if scalar else "vector"
        self.scalar_runs: list[ScalarRun] = []
        if self.path != "vector":
            run_class = MultiRateRun if self.path == "multirate" else ScalarRun
            self.scalar_runs = [run_class(p, r, t_on=self.smps.t_on) for r in range(p.n)]
            self._to_scalar()

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
        run) or ``(n_runs, n_samples)``.
        """
        p = self.p
        n = int(n_samples)
        cmd = np.radians(_per_run(command_deg, p.n, n, "command_deg"))
        q = _per_run(dynamic_pressure_pa, p.n, n, "dynamic_pressure_pa")
        amb = (np.broadcast_to(p.t_amb[:, None], (p.n, n)) if ambient_c is None
               else _per_run(ambient_c, p.n, n, "ambient_c"))
        z = sensors.draw(self.rngs, n, len(CHANNELS))
        if self.scalar_runs:
            return self._advance_scalar(n, cmd, q, amb, z)
        means = np.empty((len(_ACC), p.n, n))
        bus = np.empty((p.n, n))
        rw = np.empty((p.n, n))
        for k in range(n):
            r_w = sensors.winding_resistance(p, self.slow)
            means[:, :, k] = self._sample(cmd[:, k], q[:, k], r_w)
            bus[:, k] = self.slow.bus_v
            rw[:, k] = r_w
            sensors.advance_slow(self.slow, p, self.sample_period_s,
                                 means[_ROW["p_motor"], :, k], means[_ROW["p_stage"], :, k],
                                 amb[:, k], z[-2, :, k], z[-1, :, k])
            means[_ROW["p_motor"], :, k] = self.slow.motor_c  # reuse rows for temperatures
            means[_ROW["p_stage"], :, k] = self.slow.stage_c
        return self._block(means, z, cmd, q, bus, rw, n)

    def _sample(self, cmd: FloatArray, q: FloatArray, r_w: FloatArray) -> FloatArray:
        """Integrate one sample period; returns the step means of the accumulator rows."""
        p = self.p
        acc = np.zeros((len(_ACC) - 1, p.n))
        h = p.step_s
        sec = inv.sector(p.pole_pairs * self.theta)
        for _ in range(p.samples_per_block):
            theta_e = p.pole_pairs * self.theta
            sec = inv.sector(theta_e)
            shape = inv.trapezoid(theta_e)
            e = p.k_e * self.omega * shape
            vdc = self.smps.v_out
            vin = self.slow.bus_v - p.r_source * self.i_in
            duty = smps.voltage_loop(self.smps, p, self.t, vin)
            u = control(self.ctl, p, cmd, self.theta, self.omega, self.i, sec, vdc)
            a_high, a_low = inv.on_fractions(p, sec, u)
            lg = inv.legs(p, a_high, a_low, vdc, self.i)
            i_ext = inv.dc_link_current(p, lg, self.i)
            p_inv = inv.conduction_loss(p, lg, self.i, vdc)
            i_dc = i_ext + lg.g_shoot * vdc
            ripple2 = smps.ripple_sq(self.smps, p, vin, i_dc, np.abs(u), self.z_sw, self.z_pwm)
            i_l = self.smps.i_l
            p_smps = i_l * i_l * (duty * p.ron_hi + (1.0 - duty) * p.ron_lo) + p.p_sw
            smps.step(self.smps, p, vin, i_ext, lg.g_shoot)
            self.i_in = duty * self.smps.i_l
            self.i, self.vn = motor.solve_windings(p, lg, self.i, e, r_w, vdc)
            torque = p.k_e * np.add.reduce(shape * self.i, axis=0)
            delta = self.theta / p.ratio
            hinge = motor.hinge_moment(p, q, delta)
            self.omega, self.theta = motor.mechanics(p, self.omega, self.theta, torque, hinge)
            v_out = self.smps.v_out
            acc += np.stack((
                i_dc, self.i[0], self.i[1], self.i[2], v_out, delta, vin, self.i_in,
                v_out * v_out, ripple2, r_w * np.add.reduce(self.i * self.i, axis=0),
                p_smps + p_inv,
                torque, self.omega, hinge, self.ctl.i_cmd, self.ctl.i_q, duty, i_l, u))
            self.t += h
        self.sample_index += 1
        out: FloatArray = np.concatenate((acc / p.samples_per_block, sec[None, :] + 1.0))
        return out

    def _advance_scalar(self, n: int, cmd: FloatArray, q: FloatArray, amb: FloatArray,
                        z: FloatArray) -> SensorBlock:
        """``advance`` with every run stepped in floats by :class:`ScalarRun`."""
        p = self.p
        dt = self.sample_period_s
        means = np.empty((len(_ACC), p.n, n))
        bus = np.empty((p.n, n))
        rw = np.empty((p.n, n))
        t_end = self.t
        row_m, row_s = _ROW["p_motor"], _ROW["p_stage"]
        for r, run in enumerate(self.scalar_runs):
            cmd_r, q_r, amb_r = cmd[r].tolist(), q[r].tolist(), amb[r].tolist()
            z_drift, z_ripple = z[-2, r].tolist(), z[-1, r].tolist()
            z_sw, z_pwm = float(self.z_sw[r]), float(self.z_pwm[r])
            offset = float(self.slow.bus_offset[r])
            out = [0.0] * len(_ACC)
            rows: list[list[float]] = []
            bus_r: list[float] = []
            rw_r: list[float] = []
            t = self.t
            for k in range(n):
                bus_r.append(run.x[21])
                t = run.sample(t, cmd_r[k], q_r[k], z_sw, z_pwm, out)
                rw_r.append(run.r_w)
                run.advance_slow(dt, out[row_m], out[row_s], amb_r[k], z_drift[k],
                                 z_ripple[k], offset)
                out[row_m], out[row_s] = run.x[18], run.x[19]
                rows.append(out.copy())
            means[:, r, :] = np.array(rows).T
            bus[r], rw[r] = bus_r, rw_r
            t_end = t
        self.t = t_end
        self.sample_index += n
        self._from_scalar()
        return self._block(means, z, cmd, q, bus, rw, n)

    def _state_arrays(self) -> list[tuple[object, str, int | None]]:
        """(holder, attribute, phase) of every state array, in ``ScalarRun.STATE`` order."""
        sm, c, sl = self.smps, self.ctl, self.slow
        return [(sm, "i_l", None), (sm, "v_c", None), (sm, "v_out", None), (sm, "integ", None),
                (sm, "deriv", None), (sm, "prev_err", None), (sm, "duty", None),
                (c, "pos_integ", None), (c, "cur_integ", None), (c, "i_cmd", None),
                (c, "i_q", None), (self, "i", 0), (self, "i", 1), (self, "i", 2),
                (self, "vn", None), (self, "omega", None), (self, "theta", None),
                (self, "i_in", None), (sl, "motor_c", None), (sl, "stage_c", None),
                (sl, "bus_drift", None), (sl, "bus_v", None)]

    def _to_scalar(self) -> None:
        """Load every run's state from the arrays into its :class:`ScalarRun`."""
        for k, (holder, name, phase) in enumerate(self._state_arrays()):
            arr = getattr(holder, name)
            col = arr[phase] if phase is not None else arr
            for r, run in enumerate(self.scalar_runs):
                run.x[k] = float(col[r])

    def _from_scalar(self) -> None:
        """Write the runs' float state back to the arrays (so both views stay true)."""
        for k, (holder, name, phase) in enumerate(self._state_arrays()):
            values = np.array([run.x[k] for run in self.scalar_runs])
            if phase is None:
                setattr(holder, name, values)
            else:
                getattr(holder, name)[phase] = values

    def _block(self, m: FloatArray, z: FloatArray, cmd: FloatArray, q: FloatArray,
               bus: FloatArray, rw: FloatArray, n: int) -> SensorBlock:
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
        truth = dict(zip(TRUTH, (
            np.degrees(m[r["delta"]]), np.degrees(cmd), m[r["omega"]], m[r["torque"]],
            m[r["hinge"]], m[r["i_cmd"]], m[r["i_q"]], m[r["duty"]], m[r["i_l"]], bus,
            np.array(q), rw), strict=True))
        return SensorBlock(time_s=time_s, channels=channels, truth=truth)
