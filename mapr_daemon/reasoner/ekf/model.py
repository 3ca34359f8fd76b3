"""The EKF's model: bus-rate signals cut into blocks, the nonlinear mechanics and their Jacobians.

The estimator (:mod:`~mapr_daemon.reasoner.ekf.estimator`) steps once per *block* of ``n`` bus
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
  these are proxies, not ohms and farads. They need steps in the DC-link current (the BIT
  profile's ramps): there an ESR rise moves them clearly (see tests), a capacitance loss
  barely (the ripple RMS channel, not read here, sees both).

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
import functools
from collections.abc import Mapping

import numpy as np

from drivers.jit import kernel
from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.inverter import trapezoid
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError, RecordError

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

    @property
    def viscous_max(self) -> float:
        """The largest viscous ratio the model's integration holds: the per-sample decay
        ``g = 1 - dt/J*B_nom*viscous`` must stay in [0, 1]. Beyond it the explicit step
        overshoots (``g < 0``: the speed flips sign each sample), and past ``g = -1`` it grows
        without bound, so ``F`` and then ``P`` overflow. Physically it is friction that stops
        the motor within one 0.5 ms sample, far beyond any unit."""
        return self.j_eq / (self.dt * self.viscous_nom)


@dataclasses.dataclass(frozen=True)
class Blocks:
    """A record cut into filter blocks: per-sample inputs ``(n_blocks, block)`` for the
    propagation and, per block, the measurement, its Jacobian and its noise, all computed in
    one numpy pass so the filter's per-block Python is only the recursion itself."""

    drive: FloatArray
    """``dt/J*(T_e + H_m)`` per sample: electromagnetic torque from the measured currents
    (``K*sum f_x(theta_e)*i_x``) plus the hinge moment reflected to the motor."""
    coulomb_sign: FloatArray
    """Sign of the measured speed per sample (Coulomb friction's direction)."""
    z: FloatArray
    """``(n_blocks, 4)`` measurements: motor angle at the block's last sample, mean DC-link
    power minus back-EMF power (W), the two bus-tap cross terms."""
    h: FloatArray
    """``(n_blocks, 4, n_state)`` measurement Jacobians (the measurement is linear in x)."""
    r: FloatArray
    """``(n_blocks, 4, 4)`` measurement covariances (:func:`noise`)."""
    theta0: float
    omega0: float

    @property
    def n(self) -> int:
        return int(self.z.shape[0])


def blocks(plant: Plant, channels: Mapping[str, FloatArray], dynamic_pressure_pa: float,
           block: int = BLOCK) -> Blocks:
    """Cut one actuator's record (1-D channels) into whole blocks (the tail is dropped)."""
    for name in NEEDED:
        if name not in channels:
            raise ConfigError("missing channel for the estimator", field=name)
    arr = {k: np.asarray(channels[k], dtype=np.float64).reshape(-1) for k in NEEDED}
    n = (arr["position_deg"].size - 1) // block * block
    if n < block:
        raise RecordError(f"the estimator needs more than {block} samples", field="signals")
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
    nb = gram.shape[0]
    hj = np.zeros((nb, 4, len(STATE)))
    hj[:, 0, 0] = 1.0
    hj[:, 1, 4], hj[:, 1, 5] = per_block(i2 * ~a_high), per_block(i2 * a_high)
    hj[:, 2:, 6:8] = gram
    z = np.empty((nb, 4))
    z[:, 0] = theta[s][block - 1::block]
    z[:, 1] = per_block(p_rest)
    z[:, 2:] = np.einsum("inb,nb->ni", regs, dv[s].reshape(-1, block))
    return Blocks(
        drive=(plant.dt / plant.j_eq * (torque + h * reflect))[s].reshape(-1, block),
        coulomb_sign=np.sign(omega)[s].reshape(-1, block), z=z, h=hj,
        r=noise(per_block(np.abs(mech)), gram), theta0=float(theta[0]),
        omega0=float(omega[0]))


def noise(mech_power: FloatArray, gram: FloatArray, theta_sd: float = 0.01,
          tap_sd: float = 0.03) -> FloatArray:
    """Measurement covariances ``(n_blocks, 4, 4)`` (model error dominates the sensor noise).

    The power row's error grows with the mean mechanical power it subtracts (a few per cent of
    torque error); the taps' normal equations have covariance ``sigma^2*Gram``.
    """
    r = np.zeros((mech_power.size, 4, 4))
    r[:, 0, 0] = theta_sd * theta_sd
    r[:, 1, 1] = (0.3 + 0.05 * mech_power) ** 2
    r[:, 2:, 2:] = tap_sd * tap_sd * gram + 1e-9 * np.eye(2)
    return r


def propagate(plant: Plant, x: FloatArray, b: Blocks, k: int) -> tuple[FloatArray, FloatArray]:
    """Integrate block ``k`` sample by sample from state ``x``: the new state and ``F``.

    ``J domega/dt = T_e + H_m - B_nom*viscous*omega - Tc_nom*coulomb*sgn(omega)``,
    explicit in the forces (torque and hinge moment are inputs from the measured currents and
    position), then ``theta += dt*omega`` (semi-implicit Euler). ``F`` is the
    product of the per-sample Jacobians, carried as the sensitivities of (theta, omega) to
    (theta0, omega0, viscous, coulomb); the parameters are random walks (identity rows).
    The sample loop is a compiled kernel (:func:`_integrate`): the EKF calls it once per
    block, and a block's 20 samples in numpy cost more in call overhead than in arithmetic.
    """
    out = x.copy()
    f = _identity(x.shape[0]).copy()
    _integrate(b.drive[k], b.coulomb_sign[k], plant.dt, plant.dt / plant.j_eq,
               plant.viscous_nom, plant.coulomb_nom, out, f)
    return out, f


@functools.cache
def _identity(n: int) -> FloatArray:
    """The state-sized identity ``F`` starts from (copied per block, built once)."""
    return np.eye(n)


@kernel
def _integrate(drive: FloatArray, sgn: FloatArray, dt: float, dt_j: float, bn: float,
               cn: float, x: FloatArray, f: FloatArray) -> None:
    """One block's mechanics and sensitivities; updates ``x[0:2]`` and ``f[0:2, 0:4]``.

    Within a block the parameters are constant, so the speed recursion is linear with one
    decay ``g = 1 - dt/J*B_nom*viscous`` per sample, ``omega_j = g*omega_(j-1) + c_j`` with
    ``c_j = drive_j - dt/J*Tc_nom*coulomb*sgn_j``. Its sensitivities follow the same
    recursion: to ``omega0`` ``g**j``, to ``viscous`` ``g*w2 - dt/J*B_nom*omega_(j-1)``, to
    ``coulomb`` ``g*w3 - dt/J*Tc_nom*sgn_j``; theta sums ``dt*omega`` and its sensitivities.
    """
    om = x[1]
    g = 1.0 - dt_j * bn * x[2]
    c_coulomb = dt_j * cn * x[3]
    gp = 1.0
    w2 = 0.0
    w3 = 0.0
    sum_om = 0.0
    sum_gp = 0.0
    sum_w2 = 0.0
    sum_w3 = 0.0
    for j in range(drive.size):
        w2 = g * w2 - dt_j * bn * om
        w3 = g * w3 - dt_j * cn * sgn[j]
        om = g * om + drive[j] - c_coulomb * sgn[j]
        gp = g * gp
        sum_om += om
        sum_gp += gp
        sum_w2 += w2
        sum_w3 += w3
    x[0] = x[0] + dt * sum_om
    x[1] = om
    f[0, 1] = dt * sum_gp
    f[0, 2] = dt * sum_w2
    f[0, 3] = dt * sum_w3
    f[1, 1] = gp
    f[1, 2] = w2
    f[1, 3] = w3


def project(plant: Plant, x: FloatArray) -> None:
    """In place: viscous friction into the band the model's integration holds,
    ``|viscous| <= plant.viscous_max`` (per-sample decay ``g`` in [0, 2]).

    Why: the filter's update is linear and knows no domain; a block's innovation, or an
    adapted reference, can carry viscous friction past the explicit integration's stability
    bound, where the model itself (not the data) drives the estimate to ``g = -1`` and past
    it to overflow of ``F`` and ``P`` (and a very negative one grows ``g**20`` per block the
    same way). Projecting the estimate onto the band (the projected Kalman filter) leaves
    ``P`` as it is. Inside the band nothing changes: a healthy BIT's estimate, negative
    transients included, is not touched (Coulomb friction enters linearly and is left alone).
    """
    x[2] = min(max(x[2], -plant.viscous_max), plant.viscous_max)


def measure(x: FloatArray, b: Blocks, k: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Block ``k``'s measurement vector, its model value ``h(x)`` and the Jacobian ``H``.

    Rows: motor angle; the power balance; the two bus-tap normal equations.
    """
    hj = b.h[k]
    return b.z[k], hj @ x.reshape(-1), hj
