"""What the instrumentation adds: ADC noise and quantisation, the aircraft bus, temperatures.

Every sensor channel is the mean of the integrator steps of its sample period (an integrating,
anti-aliased ADC), plus white noise, then quantised to ``2*full_scale/2**bits`` and clipped to
``[-full_scale, full_scale)``. The RMS detector channel reports the AC content of the DC-link
voltage: the within-sample variance of the averaged model plus the analytic sub-step ripple.

The aircraft bus is the 28 V supply of MIL-STD-704: each flight draws its own mean around the
nominal value, drifts slowly (an Ornstein-Uhlenbeck process), carries generator ripple, sags
by the feeder resistance times the SMPS input current and is clipped to the normal band.

Random numbers come from one generator per run, drawn sample-major, so a run's noise depends
only on its seed and not on how the simulation is chunked or which batch it shares.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import BatchArrays
from mapr_daemon.ema.params import CHANNELS

EXTRA_DRAWS = 2
"""Random columns per sample besides the channels: bus drift and bus ripple."""


@dataclasses.dataclass
class SlowState:
    """States updated once per output sample — temperatures and the aircraft bus — at the
    start of a flight (the compiled step, :mod:`mapr_daemon.ema.step`, advances them)."""

    motor_c: FloatArray
    stage_c: FloatArray
    bus_offset: FloatArray
    bus_drift: FloatArray
    bus_v: FloatArray

    @classmethod
    def start(cls, p: BatchArrays, rngs: list[np.random.Generator]) -> SlowState:
        offset = np.array([g.standard_normal() for g in rngs]) * p.bus_mean_sd
        drift = np.array([g.standard_normal() for g in rngs]) * p.bus_drift_sd
        bus = np.clip(p.bus_nominal + offset + drift, p.bus_min, p.bus_max)
        return cls(p.t_amb.copy(), p.t_amb.copy(), offset, drift, bus)


def draw(rngs: list[np.random.Generator], n_samples: int, n_channels: int,
         extra: int = EXTRA_DRAWS) -> FloatArray:
    """Standard normal draws ``(n_channels + extra, n_runs, n_samples)``."""
    cols = n_channels + extra
    per_run = [g.standard_normal((n_samples, cols)) for g in rngs]
    out: FloatArray = np.stack(per_run, axis=0).transpose(2, 0, 1)
    return out


def adc(p: BatchArrays, values: FloatArray, z: FloatArray) -> FloatArray:
    """Gain and offset errors, noise and quantisation; ``values`` and ``z`` are
    ``(n_channels, n_runs, n_samples)``. The gain and offset errors are the runs' model form
    (:class:`~mapr_daemon.ema.form.ModelForm`); ideal channels skip them."""
    fs = p.full_scale[:, :, None]
    lsb = p.lsb[:, :, None]
    if (p.sensor_gain != 1.0).any() or (p.sensor_offset != 0.0).any():
        values = values * p.sensor_gain[:, :, None] + p.sensor_offset[:, :, None]
    noisy = values + p.noise[:, :, None] * z
    out: FloatArray = np.clip(np.round(noisy / lsb) * lsb, -fs, fs - lsb)
    return out


def quantise_as(p: BatchArrays, like: str, values: FloatArray) -> FloatArray:
    """Quantisation and clipping of channel ``like`` (one of
    :data:`~mapr_daemon.ema.params.CHANNELS`) for other sensors of its kind; ``values`` are
    ``(n_sensors, n_runs, ...)``."""
    k = CHANNELS.index(like)
    shape = (1, -1) + (1,) * (values.ndim - 2)
    fs = p.full_scale[k].reshape(shape)
    lsb = p.lsb[k].reshape(shape)
    out: FloatArray = np.clip(np.round(values / lsb) * lsb, -fs, fs - lsb)
    return out
