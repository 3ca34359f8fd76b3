"""The noise-free model flown through recorded BITs: per run, the fit signals on the fit's
decimated time grid — what a record is compared with after commissioning.

:func:`fly` is the one batched plant call behind the learned discrepancy
(:mod:`~mapr_daemon.reasoner.commissioning.discrepancy`) and the severity reading against the
unit's own baseline (:mod:`~mapr_daemon.reasoner.commissioning.severity`): each run names its
BIT (command, dynamic pressure, and the condition read from the record's own channels), the
faults seeded on the model and the flight's friction factor. The model is
:func:`~mapr_daemon.reasoner.commissioning.prior.quiet` (no sensor noise, drift or ripple), as
in the identification, so a difference of two runs is the parameters' effect alone.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import (
    FIT_CHANNELS,
    FIT_SIGNALS,
    PHASE_SUM,
    BitRecord,
    condition,
    fit_signals,
    signal_noise,
)

CHUNK = 500
"""Samples advanced per plant call (bounds the batch's memory)."""
FRICTION = ("motor.viscous_friction_nm_s", "motor.coulomb_friction_nm")
"""The friction terms a flight's grease scatter multiplies together."""


@dataclasses.dataclass(frozen=True)
class Flight:
    """One model run: which BIT it flies, the faults seeded on the model, the flight's
    friction factor (the grease's scatter; 1 = the unit's own)."""

    bit: BitRecord
    faults: FaultSet = dataclasses.field(default_factory=FaultSet)
    friction: float = 1.0


def decimated(y: FloatArray, decimate: int) -> FloatArray:
    """Means over ``decimate`` samples along the last axis (the tail that does not fill a
    block is dropped)."""
    t = y.shape[-1] // decimate
    out: FloatArray = np.asarray(y[..., : t * decimate], dtype=np.float64).reshape(
        *y.shape[:-1], t, decimate).mean(axis=-1)
    return out


def recorded(bits: Sequence[BitRecord], decimate: int) -> FloatArray:
    """The records' fit signals, ``(n_bits, K, T)``, in channel units."""
    return np.stack([[decimated(v, decimate) for v in fit_signals(b.channels).values()]
                     for b in bits])


def fly(params: ActuatorParams, flights: Sequence[Flight], decimate: int) -> FloatArray:
    """The model ``params`` flown through each flight, ``(n, K, T)`` fit signals in channel
    units (:data:`~mapr_daemon.reasoner.commissioning.bits.FIT_SIGNALS` order). All flights'
    BITs must have one length (one BIT profile)."""
    model = ip.quiet(params)
    noise = signal_noise(params)
    phase_noise = noise[PHASE_SUM] / math.sqrt(3.0)
    specs = []
    for f in flights:
        amb, bus = condition(params, f.bit)
        p = model if f.friction == 1.0 else ip.scaled(model, dict.fromkeys(FRICTION,
                                                                           f.friction))
        specs.append(RunSpec(p, f.faults, seed=0, ambient_c=amb, bus_v=bus))
    cmd = np.stack([f.bit.command_deg for f in flights])
    q = np.array([f.bit.dynamic_pressure_pa for f in flights])
    return flown(specs, cmd, q, decimate, phase_noise)


def flown(specs: Sequence[RunSpec], command_deg: FloatArray, dynamic_pressure_pa: FloatArray,
          decimate: int, phase_noise: float, chunk: int = CHUNK) -> FloatArray:
    """One batched plant call: run ``i`` of ``specs`` flown through row ``i`` of
    ``command_deg`` at ``dynamic_pressure_pa[i]``, advanced ``chunk`` samples at a time; its
    fit signals, ``(n, K, T)`` in channel units (FIT_SIGNALS order), ``decimate``-sample
    means. What :func:`fly` and the identification's Jacobian runs both fly."""
    channels = flown_channels(specs, command_deg, dynamic_pressure_pa, FIT_CHANNELS, chunk)
    sig = fit_signals(channels, phase_noise)
    return np.stack([decimated(sig[k], decimate) for k in FIT_SIGNALS], axis=1)


def flown_channels(specs: Sequence[RunSpec], command_deg: FloatArray,
                   dynamic_pressure_pa: FloatArray | float,
                   channels: Sequence[str] | None = None,
                   chunk: int = CHUNK) -> dict[str, FloatArray]:
    """One batched plant call, as :func:`flown`, its raw ``channels`` (None: every channel
    the plant gives) at the plant's rate, ``(n, samples)`` each: what the fit and the
    visibility's added departures (:mod:`~mapr_daemon.reasoner.commissioning.visibility`)
    both fly."""
    plant = EmaBatch(list(specs))
    q = np.asarray(dynamic_pressure_pa, dtype=np.float64).reshape(-1, 1)
    n = command_deg.shape[1]
    parts: dict[str, list[FloatArray]] = {}
    for start in range(0, n, chunk):
        stop = min(n, start + chunk)
        block = plant.advance(stop - start, np.ascontiguousarray(command_deg[:, start:stop]),
                              q)
        for k in (block.channels if channels is None else channels):
            parts.setdefault(k, []).append(np.asarray(block.channels[k], dtype=np.float64))
    return {k: np.concatenate(v, axis=1) for k, v in parts.items()}


def noise_scale(params: ActuatorParams, decimate: int) -> FloatArray:
    """Per fit signal, the sensor noise of a ``decimate``-sample mean: the unit a residual
    of 1 is "down to the noise" in."""
    noise = signal_noise(params)
    return np.array([noise[k] for k in FIT_SIGNALS]) / math.sqrt(decimate)
