"""The EKF's model: bus-rate signals cut into blocks, the nonlinear mechanics and their Jacobians.

The estimator (:mod:`~mapr_daemon.reasoner.estimator`) steps once per *block* of ``n`` bus
samples (20 at 2 kHz: 10 ms), not once per sample: a filterpy step costs ~100 us in Python,
and a per-sample filter could not run 50x faster than real time. Within a block the
mechanics are still integrated sample by sample (:func:`propagate`), so nothing is averaged
away; only the covariance update happens once per block.

State (:data:`STATE`), all in the units of the reference model:

* ``theta`` motor-shaft angle (rad) and ``omega`` its speed (rad/s): the joint *state*;
* ``viscous`` and ``coulomb``: friction as ratios of the actuator file's nominal values (the
  friction fault multiplies both, :mod:`mapr_daemon.ema.faults`);
* ``r_other`` and ``r_a_high``: loop resistance (two windings + the switches in the current
  path, ohm) per commutation-sector group. In six-step commutation phase A's high side is
  the PWM'd switch only while phase A is the driven ("+") phase, two of six sectors, which is
  when ``i_a`` is the positive line current. ``r_a_high`` is estimated in those sectors and
  ``r_other`` in the other four, so a winding change moves both and a phase-A high-side Ron
  rise moves only ``r_a_high`` (weighted by the duty, so most visible in fast moves);
* ``bus0`` and ``bus1``: a DC-bus response proxy: the two taps of ``dV[k] = bus0*dI[k] +
  bus1*dI[k-1]`` (sample-to-sample steps of the DC-bus voltage and DC-link current). At the
  2 kHz bus rate the capacitor's ESR step and its C droop are not separately resolved, so
  these are proxies, not ohms and farads: an ESR rise and a capacitance loss move them in
  different directions (see tests), which is what a detector needs.

Measurements per block: the position at the block end (the joint state), the mean DC-link
power left after the back-EMF power (explained by the two sector-group resistances), and the
least-squares normal equations of the bus taps (measurement noise proportional to their Gram
matrix, so a block without current steps carries no information, as it should).

Coulomb friction acts with the sign of the *measured* speed: the plant smooths ``sgn`` with
``tanh(omega/0.5 rad/s)``, which is far stiffer than the 0.5 ms sample step and would make
an explicit model step unstable near rest.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from mapr_daemon.ema.inverter import trapezoid
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.features import FloatArray

STATE: tuple[str, ...] = ("theta", "omega", "viscous", "coulomb", "r_other", "r_a_high",
                          "bus0", "bus1")
"""Names of the state vector's entries, in order."""
PARAMETERS: tuple[str, ...] = STATE[2:]
"""The entries that are physical parameters (the rest is the motor's state)."""
BLOCK = 20
"""Bus samples per filter step (10 ms at 2 kHz)."""
NEEDED: tuple[str, ...] = ("phase_a_current_a", "phase_b_current_a", "phase_c_current_a",
                           "dc_link_current_a", "dc_bus_voltage_v", "position_deg")
"""Channels the estimator reads (a subset of what the daemon passes)."""


@dataclasses.dataclass(frozen=True)
class Plant:
    """The reference-model constants the filter needs, taken from one actuator file."""

    dt: float
    ratio: float
    pole_pairs: float
    k_e: float
    j_eq: float
    viscous_nom: float
    coulomb_nom: float
    eta: float
    area_chord: float
    ch0: float
    ch_delta: float
    r_loop_nom: float

    @classmethod
    def of(cls, p: ActuatorParams) -> Plant:
        n = p.gear.ratio
        return cls(
            dt=1.0 / p.sensors.sample_rate_hz, ratio=n, pole_pairs=p.motor.pole_pairs,
            k_e=p.motor.back_emf_v_s_per_rad,
            j_eq=p.motor.inertia_kg_m2 + p.surface.inertia_kg_m2 / (n * n),
            viscous_nom=p.motor.viscous_friction_nm_s, coulomb_nom=p.motor.coulomb_friction_nm,
            eta=p.gear.efficiency, area_chord=p.surface.area_m2 * p.surface.chord_m,
            ch0=p.surface.ch0, ch_delta=p.surface.ch_delta_per_rad,
            r_loop_nom=2.0 * p.motor.resistance_ohm + 2.0 * p.inverter.ron_ohm)


@dataclasses.dataclass(frozen=True)
class Blocks:
    """A record cut into filter blocks. Per-sample lists (Python floats, for the sub-step loop)
    and per-block measurement arrays."""

    torque: list[float]
    """Electromagnetic torque from the measured currents, ``K*sum f_x(theta_e)*i_x``."""
    hinge: list[float]
    """Hinge moment reflected to the motor at the measured position (N m)."""
    coulomb_sign: list[float]
    theta_end: FloatArray
    """Measured motor angle at each block's last sample."""
    power: FloatArray
    """Mean DC-link power minus back-EMF power per block (W)."""
    i2_other: FloatArray
    i2_a_high: FloatArray
    """Mean squared line current per block in the two sector groups (A^2)."""
    mech_power: FloatArray
    gram: FloatArray
    """``(n_blocks, 2, 2)`` Gram matrix of the bus-tap regressors."""
    cross: FloatArray
    """``(n_blocks, 2)`` regressors times voltage steps."""
    theta0: float
    omega0: float

    @property
    def n(self) -> int:
        return int(self.theta_end.size)


def blocks(plant: Plant, channels: Mapping[str, FloatArray], dynamic_pressure_pa: float,
           block: int = BLOCK) -> Blocks:
    """Cut one actuator's record (1-D channels) into whole blocks (the tail is dropped)."""
    for name in NEEDED:
        if name not in channels:
            raise ConfigError("missing channel for the estimator", field=name)
    arr = {k: np.asarray(channels[k], dtype=np.float64).reshape(-1) for k in NEEDED}
    n = (arr["position_deg"].size - 1) // block * block
    if n < block:
        raise ConfigError(f"the estimator needs more than {block} samples", field="signals")
    s = slice(1, n + 1)  # sample 0 only seeds the state
    delta = np.radians(arr["position_deg"])
    theta = delta * plant.ratio
    omega = np.gradient(theta, plant.dt)
    i = np.stack([arr["phase_a_current_a"], arr["phase_b_current_a"],
                  arr["phase_c_current_a"]])
    shape = trapezoid(plant.pole_pairs * theta)
    torque = plant.k_e * np.add.reduce(shape * i, axis=0)
    h = dynamic_pressure_pa * plant.area_chord * (plant.ch0 + plant.ch_delta * delta)
    reflect = np.where(h * omega > 0.0, plant.eta, 1.0 / plant.eta) / plant.ratio
    line = np.add.reduce(np.abs(i), axis=0) / 2.0
    a_high = (i[0] > 0.5 * line) & (line > 0.2)
    i2 = line * line
    mech = omega * torque
    p_rest = arr["dc_bus_voltage_v"] * arr["dc_link_current_a"] - mech
    dv = np.diff(arr["dc_bus_voltage_v"], prepend=arr["dc_bus_voltage_v"][0])
    di = np.diff(arr["dc_link_current_a"], prepend=arr["dc_link_current_a"][0])
    di1 = np.concatenate(([0.0], di[:-1]))

    def per_block(x: FloatArray) -> FloatArray:
        out: FloatArray = x[s].reshape(-1, block).mean(axis=1)
        return out

    regs = np.stack([di, di1])[:, s].reshape(2, -1, block)       # (2, nb, block)
    gram = np.einsum("inb,jnb->nij", regs, regs)
    cross = np.einsum("inb,nb->ni", regs, dv[s].reshape(-1, block))
    return Blocks(
        torque=torque[s].tolist(), hinge=(h * reflect)[s].tolist(),
        coulomb_sign=np.sign(omega)[s].tolist(), theta_end=theta[s][block - 1::block].copy(),
        power=per_block(p_rest), i2_other=per_block(i2 * ~a_high),
        i2_a_high=per_block(i2 * a_high), mech_power=per_block(np.abs(mech)),
        gram=gram, cross=cross, theta0=float(theta[0]), omega0=float(omega[0]))


def propagate(plant: Plant, x: FloatArray, b: Blocks, k: int,
              block: int = BLOCK) -> tuple[FloatArray, FloatArray]:
    """Integrate block ``k`` sample by sample from state ``x``: the new state and ``F``.

    ``J domega/dt = T_e + H_m - B_nom*viscous*omega - Tc_nom*coulomb*sgn(omega)``,
    explicit in the forces (torque and hinge moment are inputs from the measured currents and
    position), then ``theta += dt*omega`` (semi-implicit Euler). ``F`` is the
    product of the per-sample Jacobians, carried as the sensitivities of (theta, omega) to
    (theta0, omega0, viscous, coulomb); the parameters are random walks (identity rows).
    """
    dt_j = plant.dt / plant.j_eq
    dt = plant.dt
    bn, cn = plant.viscous_nom, plant.coulomb_nom
    th, om, vr, cr = float(x[0]), float(x[1]), float(x[2]), float(x[3])
    # sensitivities d(theta), d(omega) / d(theta0, omega0, viscous, coulomb)
    t0, t1, t2, t3 = 1.0, 0.0, 0.0, 0.0
    w0, w1, w2, w3 = 0.0, 1.0, 0.0, 0.0
    start = k * block
    for j in range(start, start + block):
        sgn = b.coulomb_sign[j]
        om_new = om + dt_j * (b.torque[j] + b.hinge[j] - bn * vr * om - cn * cr * sgn)
        g = 1.0 - dt_j * bn * vr
        w0, w1, w2, w3 = g * w0, g * w1, g * w2 - dt_j * bn * om, g * w3 - dt_j * cn * sgn
        om = om_new
        th = th + dt * om
        t0, t1, t2, t3 = t0 + dt * w0, t1 + dt * w1, t2 + dt * w2, t3 + dt * w3
    out = x.copy()
    out[0], out[1] = th, om
    f = np.eye(x.shape[0])
    f[0, :4] = (t0, t1, t2, t3)
    f[1, :4] = (w0, w1, w2, w3)
    return out, f


def measure(x: FloatArray, b: Blocks, k: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Block ``k``'s measurement vector, its model value ``h(x)`` and the Jacobian ``H``.

    Rows: motor angle; the power balance; the two bus-tap normal equations.
    """
    z = np.array([b.theta_end[k], b.power[k], b.cross[k, 0], b.cross[k, 1]])
    hj = np.zeros((4, x.shape[0]))
    hj[0, 0] = 1.0
    hj[1, 4], hj[1, 5] = b.i2_other[k], b.i2_a_high[k]
    hj[2:, 6:8] = b.gram[k]
    hx = hj @ x.reshape(-1)
    return z, hx, hj


def noise(b: Blocks, k: int, theta_sd: float = 0.01, tap_sd: float = 0.03) -> FloatArray:
    """Measurement covariance of block ``k`` (model error dominates the sensor noise).

    The power row's error grows with the mechanical power it subtracts (a few per cent of
    torque error); the taps' normal equations have covariance ``sigma^2*Gram``.
    """
    r = np.zeros((4, 4))
    r[0, 0] = theta_sd * theta_sd
    p_sd = 0.3 + 0.05 * float(b.mech_power[k])
    r[1, 1] = p_sd * p_sd
    r[2:, 2:] = tap_sd * tap_sd * b.gram[k] + 1e-9 * np.eye(2)
    return r
