"""Cut the traffic between BITs into windows with enough excitation for each parameter.

A flight's bus carries the actuator's currents, position and DC-link signals for hours, but
most of it says little about the parameters the EKF tracks: a held surface in cruise draws a
small steady holding current, and one steady state cannot tell the winding's resistance from
the back-EMF constant (``V = R*i + K*omega`` is one equation in two unknowns there). So the
traffic is cut into windows (1 s by default), and a window *qualifies* for a parameter group
when the data in it alone would pin that group down to a stated standard deviation, counting
the nuisance directions it must be told apart from.

The criterion is each window's Fisher information on three linear regressions, the same
physics the EKF's measurement rows use (:mod:`~mapr_daemon.reasoner.ekf.model`), per 10 ms
block:

* **friction** — the torque balance ``J*a - T_e - H_m = -f*(B_nom*omega + Tc_nom*sgn(omega))``
  in the block-mean speed ``omega`` (blocks above :data:`MIN_SPEED_RAD_S`, windows moving
  for at least :data:`MIN_MOVING` of their blocks), for the friction *factor* ``f`` the
  fault scales and the tracker trends (viscous and Coulomb friction apart are not asked of a
  window: at the speeds flight gives, viscous friction is a tenth of the Coulomb torque);
  noise ``5 % of |T_e|`` (torque model error, the share the EKF's power row allows) plus
  the torque of one current-sensor noise rms. Qualifies below :attr:`Criterion.friction_sd`.
* **resistance** — the DC-link power left after the back-EMF power, ``P = R_o*i2_o +
  R_a*i2_a + kappa*omega*T_e`` (``i2`` the squared line current in the four other and the two
  phase-A-high sectors, ``kappa`` an error in the back-EMF constant), noise as the EKF's power
  row. The loop resistance qualifies when ``R_o``'s marginal sd, *with kappa free*, is below
  :attr:`Criterion.loop_sd`: this is the R-vs-K test — in a steady move ``i2`` and
  ``omega*T_e`` are collinear and the marginal sd blows up; at rest or in a speed change they
  are not. The phase-A high-side contrast ``R_a - R_o`` qualifies on its own sd
  (:attr:`Criterion.phase_a_sd`).
* **bus** — the two DC-bus taps' normal equations (sample-to-sample steps of the DC-link
  current), information ``Gram/tap_sd**2`` as in the EKF, less the Gram the current sensor's
  white noise alone gives (its steps are not excitation); qualifies below
  :attr:`Criterion.bus_sd`.

Thresholds are per window; a flight averages many windows, so the per-flight sd is far below
them. Everything is numpy over all blocks and windows at once (``einsum`` of the regressors,
a batched 3x3 inverse). Only the regressors and the noise set the information, not the
response, so the air data (the hinge moment) is not needed here.

Example::

    exc = excitation(Plant.of(params), channels)
    segs = select(exc)        # [Segment(start=..., stop=..., groups=frozenset({...})), ...]
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.inverter import trapezoid
from mapr_daemon.errors import ConfigError, RecordError
from mapr_daemon.reasoner.ekf.model import BLOCK, NEEDED, Plant

GROUPS: tuple[str, ...] = ("friction", "loop", "phase_a", "bus")
"""Parameter groups a window can qualify for, in :attr:`Excitation.sd` column order."""
TORQUE_MODEL_ERROR = 0.05
"""Share of the electromagnetic torque the friction regression allows as model error."""
CURRENT_NOISE_A = 0.02
"""Phase-current sensor noise rms (the shipped actuator files') for the torque noise floor."""
TAP_SD = 0.03
"""The bus taps' noise sd (the EKF's, :func:`~mapr_daemon.reasoner.ekf.model.noise`)."""
MIN_SPEED_RAD_S = 10.0
"""Blocks slower than this (motor, block mean) give the friction regression no row.

Why: the EKF takes Coulomb friction's sign from the measured speed, and the plant smooths it
over ``tanh(omega/0.5 rad/s)`` (a mismatched unit may add stiction); cruise's slow trim
corrections sit in that zone, where the model is wrong rather than uninformative. Chosen on a
design flight (``flight_profile`` seed 1, not a bench seed): with 2 and 5 rad/s the cruise
corrections qualified and the healthy friction factor read 0.3-0.4 high; 10 and 20 rad/s
agreed (within 0.01)."""


MIN_MOVING = 0.2
"""Share of a window's blocks that must be moving for the window to inform friction.

Why: a step command slews the surface in a few milliseconds, inside one or two 10 ms blocks;
such a window's information comes from one burst at hundreds of rad/s, where the block-mean
speed and the current loop's lag dominate the friction torque, and on the design flight
(seed 1) those windows read viscous friction at 10-160x nominal with Coulomb friction
negative. Sustained motion (0.2 s of a 1 s window) reads both consistently."""


@dataclasses.dataclass(frozen=True)
class Criterion:
    """Per-window standard deviations a group's parameters must be pinned to, and the window.

    Why these values: each is a per-flight target sd times ``sqrt(100)``, i.e. a window
    qualifies when a hundred like it (100 s of such motion in a flight) would reach the
    target. Targets: friction 0.05 in ratio to nominal (2.5 % of the change to failure, 3x);
    loop resistance 0.05 ohm (7 % of the shipped actuator's 0.67 ohm); the phase-A-high
    contrast 0.01 ohm (a failed Ron adds 0.036 ohm, seen through the duty, typically a third
    of it); the first bus tap 0.005 V/A (a tenth of the nominal ESR).
    """

    friction_sd: float = 0.5
    """The friction factor's sd (ratio to nominal)."""
    loop_sd: float = 0.5
    """Ohm, the loop resistance's marginal sd with the back-EMF error free."""
    phase_a_sd: float = 0.1
    """Ohm, the phase-A-high minus other-sector loop resistance's marginal sd."""
    bus_sd: float = 0.05
    """V/A, the first bus tap's marginal sd."""
    window_s: float = 1.0
    """Window length (s); whole 10 ms blocks."""

    def limits(self) -> FloatArray:
        """The thresholds in :data:`GROUPS` order."""
        return np.array([self.friction_sd, self.loop_sd, self.phase_a_sd, self.bus_sd])


CRITERION = Criterion()
"""The default criterion."""


@dataclasses.dataclass(frozen=True)
class Excitation:
    """Per-window information, as the marginal sd each window alone gives each group."""

    window: int
    """Samples per window."""
    start: npt.NDArray[np.int64]
    """First sample of each window."""
    sd: FloatArray
    """``(n_windows, len(GROUPS))`` marginal sd (inf where the window has no information)."""
    breaks: npt.NDArray[np.bool_] | None = None
    """Where a window does not follow the one before in time (windows kept from a stream,
    :class:`~mapr_daemon.reasoner.inflight.accumulate.FlightAccumulator`); None: contiguous."""

    def kept(self, mask: npt.NDArray[np.bool_], offset: int, continues: bool) -> Excitation:
        """The windows of ``mask``, renumbered from sample ``offset`` of a buffer that holds
        only kept windows; a window whose predecessor was dropped starts a new stretch (the
        first one too, unless ``continues``: the window before it, in an earlier chunk, was
        kept)."""
        idx = np.flatnonzero(mask)
        brk = np.ones(idx.size, dtype=np.bool_)
        brk[1:] = np.diff(idx) > 1
        if idx.size:
            brk[0] = not (continues and idx[0] == 0)
        return Excitation(self.window, offset + np.arange(idx.size, dtype=np.int64) * self.window,
                          self.sd[idx], brk)

    @classmethod
    def join(cls, parts: list[Excitation], window: int) -> Excitation:
        """Kept windows of successive stream chunks, in order (``breaks`` kept)."""
        if not parts:
            return cls(window, np.zeros(0, dtype=np.int64), np.zeros((0, len(GROUPS))),
                       np.zeros(0, dtype=np.bool_))
        brk = [p.breaks if p.breaks is not None else np.zeros(p.start.size, dtype=np.bool_)
               for p in parts]
        return cls(window, np.concatenate([p.start for p in parts]),
                   np.concatenate([p.sd for p in parts]), np.concatenate(brk))

    def qualifies(self, criterion: Criterion) -> npt.NDArray[np.bool_]:
        """``(n_windows, len(GROUPS))``: which windows qualify for which group."""
        out: npt.NDArray[np.bool_] = self.sd < criterion.limits()[None, :]
        return out


@dataclasses.dataclass(frozen=True)
class Segment:
    """A run of consecutive qualifying windows: samples ``[start, stop)`` and the groups any
    of its windows qualified for."""

    start: int
    stop: int
    groups: frozenset[str]

    @property
    def n_samples(self) -> int:
        return self.stop - self.start


def _per_block(x: FloatArray, nb: int, block: int) -> FloatArray:
    out: FloatArray = x[: nb * block].reshape(nb, block).mean(axis=1)
    return out


def _marginal_sd(info: FloatArray, contrast: FloatArray) -> FloatArray:
    """sd of ``contrast @ theta`` under information ``info`` ``(n, k, k)``; inf if singular."""
    k = info.shape[-1]
    scale = np.sqrt(np.maximum(np.einsum("nii->ni", info), 1e-300))
    norm = info / (scale[:, :, None] * scale[:, None, :])  # unit diagonal: conditioning
    ok = np.linalg.cond(norm) < 1e10
    safe = np.where(ok[:, None, None], norm, np.eye(k)[None])
    cov = np.linalg.inv(safe) / (scale[:, :, None] * scale[:, None, :])
    var = np.einsum("i,nij,j->n", contrast, cov, contrast)
    out: FloatArray = np.where(ok & (var > 0.0), np.sqrt(np.abs(var)), np.inf)
    return out


def excitation(plant: Plant, channels: Mapping[str, FloatArray],
               criterion: Criterion = CRITERION, block: int = BLOCK) -> Excitation:
    """Each window's marginal sd per group (see the module docstring for the regressions).

    ``channels`` are one actuator's 1-D channels at the actuator file's sample rate
    (:data:`~mapr_daemon.reasoner.ekf.model.NEEDED`). The information depends on the
    regressors and the noise only, not on the response, so the hinge moment (the air data)
    is not needed. The tail shorter than a window is left out.
    """
    for name in NEEDED:
        if name not in channels:
            raise ConfigError("missing channel for the in-flight tracker", field=name)
    arr = {k: np.asarray(channels[k], dtype=np.float64).reshape(-1) for k in NEEDED}
    n = arr["position_deg"].size
    per_window = max(1, round(criterion.window_s / (plant.dt * block)))
    window = per_window * block
    nw = n // window
    if nw < 1:
        raise RecordError(f"a window needs {window} samples, got {n}", field="signals")
    nb = nw * per_window
    delta = np.radians(arr["position_deg"])
    theta = delta * plant.ratio
    i = np.stack([arr["phase_a_current_a"], arr["phase_b_current_a"],
                  arr["phase_c_current_a"]])
    torque = plant.k_e * np.add.reduce(trapezoid(plant.pole_pairs * theta) * i, axis=0)
    # block-mean speed from the angle at block boundaries (a 10 ms difference, not a
    # per-sample gradient: the position's quantisation would swamp it)
    edges = theta[: nb * block + 1: block]
    if edges.size < nb + 1:
        edges = np.append(edges, theta[-1])
    omega = np.diff(edges) / (block * plant.dt)
    t_e = _per_block(torque, nb, block)
    # friction: one row, the friction torque at nominal, against J*a - T_e - H_m
    moving = np.abs(omega) > MIN_SPEED_RAD_S
    sgn = np.where(moving, np.sign(omega), 0.0)
    sd_t = TORQUE_MODEL_ERROR * np.abs(t_e) + 2.0 * plant.k_e * CURRENT_NOISE_A
    f_rows = (np.where(moving, plant.viscous_nom * omega + plant.coulomb_nom * sgn, 0.0)
              / sd_t)[:, None]
    # resistance: rows (i2_other, i2_a_high, omega*T_e) against the power left
    line = np.add.reduce(np.abs(i), axis=0) / 2.0
    a_high = (i[0] > 0.5 * line) & (line > 0.2)
    i2 = line * line
    mech = _per_block(np.gradient(theta, plant.dt) * torque, nb, block)
    sd_p = 0.3 + 0.05 * np.abs(mech)
    r_rows = np.stack([_per_block(i2 * ~a_high, nb, block), _per_block(i2 * a_high, nb, block),
                       mech], axis=1) / sd_p[:, None]
    # bus taps: Gram of the DC-link current steps
    di = np.diff(arr["dc_link_current_a"], prepend=arr["dc_link_current_a"][0])
    di1 = np.concatenate(([0.0], di[:-1]))
    regs = np.stack([di, di1])[:, : nb * block].reshape(2, nb, block)
    gram = np.einsum("inb,jnb->nij", regs, regs)

    def windows(rows: FloatArray) -> FloatArray:
        w = rows.reshape(nw, per_window, rows.shape[-1])
        out: FloatArray = np.einsum("nbi,nbj->nij", w, w)
        return out

    f_info = windows(f_rows)
    sustained = moving.reshape(nw, per_window).sum(axis=1) >= MIN_MOVING * per_window
    f_info = np.where(sustained[:, None, None], f_info, 0.0)
    r_info = windows(r_rows)
    # sensor noise alone gives every window a Gram of N*sigma^2*[[2, -1], [-1, 2]] (the
    # steps of white noise): only the excess is excitation (and the regressors' noise biases
    # the taps, it does not inform them)
    noise_gram = window * CURRENT_NOISE_A**2 * np.array([[2.0, -1.0], [-1.0, 2.0]])
    excess = gram.reshape(nw, per_window, 2, 2).sum(axis=1) - noise_gram[None]
    eig = np.linalg.eigvalsh(excess)
    b_info = np.where((eig[:, :1] > 0.0)[:, :, None], excess, 0.0) / (TAP_SD * TAP_SD)
    sd = np.stack([
        _marginal_sd(f_info, np.array([1.0])),
        _marginal_sd(r_info, np.array([1.0, 0.0, 0.0])),
        _marginal_sd(r_info, np.array([-1.0, 1.0, 0.0])),
        _marginal_sd(b_info, np.array([1.0, 0.0])),
    ], axis=1)
    return Excitation(window=window, start=np.arange(nw, dtype=np.int64) * window, sd=sd)


def select(exc: Excitation, criterion: Criterion = CRITERION,
           groups: tuple[str, ...] = GROUPS) -> list[Segment]:
    """Merge consecutive windows that qualify for any of ``groups`` into segments."""
    cols = [GROUPS.index(g) for g in groups]
    ok = exc.qualifies(criterion)[:, cols]
    anyq: npt.NDArray[np.bool_] = np.asarray(ok.any(axis=1), dtype=np.bool_)
    if not anyq.any():
        return []
    brk = np.zeros(anyq.size, dtype=np.bool_) if exc.breaks is None else exc.breaks
    before = np.concatenate(([False], anyq[:-1])) & ~brk      # continues the window before
    after = np.concatenate((anyq[1:] & ~brk[1:], [False]))    # continued by the window after
    starts = np.flatnonzero(anyq & ~before)
    stops = np.flatnonzero(anyq & ~after) + 1
    out: list[Segment] = []
    for a, b in zip(starts, stops, strict=True):
        hit = [bool(h) for h in np.asarray(ok[a:b].any(axis=0)).reshape(-1)]
        out.append(Segment(int(exc.start[a]), int(exc.start[b - 1]) + exc.window,
                           frozenset(g for k, g in enumerate(groups) if hit[k])))
    return out
