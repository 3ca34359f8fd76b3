"""Healthy BIT records for commissioning: where each came from, its flight condition, and
whether it can be used at all.

A :class:`BitRecord` is one BIT (1-D channels at the actuator's sample rate, the command it
followed, the dynamic pressure it flew at) plus its provenance (source file, index in it,
time if the source has one). :func:`from_runs` cuts the records out of a
:class:`~mapr_daemon.reasoner.training.corpus.Runs` batch (a ``mapr simulate`` file, or a simulator
bench). :func:`condition` reads the record's flight condition from its own channels — the
ambient temperature from the power stage and motor temperatures at the start (both start at
ambient and warm by < 0.1 K over a BIT), the aircraft bus's mean from the SMPS input voltage
plus the feeder drop — so the model flies the BIT in the air it was recorded in.
:func:`unusable` says in one line why a record cannot be used (wrong rate, too short, not a
BIT motion, non-finite values, a channel the fit needs missing), or ``None``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from scipy import special

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.reasoner.training.corpus import Runs

FIT_CHANNELS: tuple[str, ...] = (
    "dc_link_current_a", "phase_a_current_a", "phase_b_current_a", "phase_c_current_a",
    "dc_bus_voltage_v", "position_deg", "smps_input_current_a", "ripple_rms_v",
)
"""Channels the fit reads (through :func:`fit_signals`). Left out: the temperatures (a BIT is
1.46 s, the thermal time constants are minutes) and the SMPS input voltage (the aircraft bus:
an input of the model, read by :func:`condition`)."""
PHASE_CHANNELS: tuple[str, ...] = ("phase_a_current_a", "phase_b_current_a", "phase_c_current_a")
"""The phase-current channels, phases A, B, C in order."""
PHASE_SUM = "phase_current_sum_a"
FIT_SIGNALS: tuple[str, ...] = (
    "dc_link_current_a", PHASE_SUM, "position_deg", "dc_bus_voltage_v",
    "smps_input_current_a", "ripple_rms_v",
)
"""The time series compared with the model. The three phase currents enter as one signal,
``|i_a| + |i_b| + |i_c|`` (twice the conducting current): each phase's own sample means
jump when a commutation moves by one integrator step, in the model as in the drive, so a
parameter's effect on them is rough at the 1 % scale; their absolute sum is smooth."""
CONDITION_CHANNELS: tuple[str, ...] = (
    "stage_temperature_c", "motor_temperature_c", "smps_input_voltage_v",
    "smps_input_current_a")
START_S = 0.1
"""Ambient temperature: mean of the temperatures over the record's first 100 ms."""
MIN_MOTION_DEG = 2.0
"""A BIT moves the surface: a command spanning less than this is not a BIT."""


@dataclasses.dataclass(frozen=True)
class BitRecord:
    """One healthy BIT to commission from, with where it came from."""

    channels: dict[str, FloatArray]
    command_deg: FloatArray
    dynamic_pressure_pa: float
    sample_rate_hz: float
    source: str
    index: int
    time: str | None = None
    """When it was recorded (ISO 8601), if the source says; ``mapr simulate`` files do not."""
    label: str = ""

    @property
    def n_samples(self) -> int:
        return int(self.command_deg.size)

    def name(self) -> str:
        """``source#index``: how messages and the record name this BIT."""
        return f"{self.source}#{self.index}"


def fit_signals(channels: dict[str, FloatArray], phase_noise: float | None = None
                ) -> dict[str, FloatArray]:
    """:data:`FIT_SIGNALS` from channels of any shape ``(..., samples)``.

    ``phase_noise``: for the noise-free model, the phase channels' noise sd. A recorded
    ``|i + noise|`` is larger than ``|i|`` where ``i`` is small (the noise is rectified), so
    the model's phase sum is the mean of that folded normal,
    ``i erf(i / (s sqrt 2)) + s sqrt(2/pi) exp(-i^2 / 2 s^2)``, not ``|i|``.
    """
    phases = [channels[k] for k in PHASE_CHANNELS]
    if phase_noise is None or phase_noise <= 0.0:
        phase_sum = np.abs(phases[0]) + np.abs(phases[1]) + np.abs(phases[2])
    else:
        s = phase_noise
        phase_sum = sum(i * special.erf(i / (s * math.sqrt(2.0)))
                        + s * math.sqrt(2.0 / math.pi) * np.exp(-0.5 * (i / s) ** 2)
                        for i in phases)
    return {k: phase_sum if k == PHASE_SUM else channels[k] for k in FIT_SIGNALS}


def signal_noise(params: ActuatorParams) -> dict[str, float]:
    """Per-sample noise sd of each fit signal: the channel's noise and quantisation (the
    phase sum: three channels' noise added in quadrature)."""
    out = {k: channel_noise(params, k) for k in FIT_CHANNELS}
    out[PHASE_SUM] = math.sqrt(sum(out[k] ** 2 for k in PHASE_CHANNELS))
    return {k: out[k] for k in FIT_SIGNALS}


def channel_noise(params: ActuatorParams, channel: str) -> float:
    """Per-sample noise sd of one recorded channel: its white noise and its quantisation
    (``lsb / sqrt 12``) in quadrature."""
    c = params.sensors.channels[channel]
    lsb = 2.0 * c.full_scale / 2.0**c.bits
    return math.sqrt(c.noise_rms**2 + lsb**2 / 12.0)


def from_runs(runs: Runs, source: str, indices: Sequence[int] | None = None
              ) -> list[BitRecord]:
    """The BIT records of a batch of runs (all, or ``indices``)."""
    picks = range(runs.n) if indices is None else indices
    return [BitRecord(
        channels={k: np.asarray(v[i], dtype=np.float64) for k, v in runs.channels.items()},
        command_deg=np.asarray(runs.command_deg, dtype=np.float64),
        dynamic_pressure_pa=float(runs.dynamic_pressure_pa[i]),
        sample_rate_hz=float(runs.sample_rate_hz), source=source, index=int(i),
        label=runs.labels[i] if i < len(runs.labels) else "") for i in picks]


def condition(params: ActuatorParams, bit: BitRecord) -> tuple[float, float]:
    """(ambient temperature C, aircraft bus mean V) of the flight the BIT was recorded on."""
    n0 = max(1, round(START_S * bit.sample_rate_hz))
    temps = [bit.channels[k][:n0] for k in ("stage_temperature_c", "motor_temperature_c")]
    ambient = float(np.mean(np.concatenate(temps)))
    bus = bit.channels["smps_input_voltage_v"] + (
        params.bus.source_resistance_ohm * bit.channels["smps_input_current_a"])
    return ambient, float(np.mean(bus))


def unusable(params: ActuatorParams, bit: BitRecord, n_samples: int | None = None
             ) -> str | None:
    """Why ``bit`` cannot be commissioned from (one line), or ``None`` if it can.

    ``n_samples``: the length the other records have (a BIT profile has one length).
    """
    rate = params.sensors.sample_rate_hz
    if abs(bit.sample_rate_hz - rate) > 1e-9 * rate:
        return f"sampled at {bit.sample_rate_hz:g} Hz, the actuator file says {rate:g} Hz"
    missing = [k for k in (*FIT_CHANNELS, *CONDITION_CHANNELS) if k not in bit.channels]
    if missing:
        return f"no {missing[0]} channel"
    lengths = {bit.channels[k].shape for k in (*FIT_CHANNELS, *CONDITION_CHANNELS)}
    if lengths != {(bit.n_samples,)}:
        return "channels and command differ in length"
    if n_samples is not None and bit.n_samples != n_samples:
        return f"{bit.n_samples} samples, the other BITs have {n_samples}"
    if bit.n_samples < round(0.5 * rate):
        return f"{bit.n_samples} samples: too short for a BIT"
    bad = [k for k in (*FIT_CHANNELS, *CONDITION_CHANNELS)
           if not np.all(np.isfinite(bit.channels[k]))]
    if bad or not np.all(np.isfinite(bit.command_deg)):
        return f"non-finite values in {bad[0] if bad else 'the command'}"
    if not np.isfinite(bit.dynamic_pressure_pa) or bit.dynamic_pressure_pa < 0.0:
        return f"dynamic pressure {bit.dynamic_pressure_pa:g} Pa"
    if float(np.ptp(bit.command_deg)) < MIN_MOTION_DEG:
        return "the command does not move: not a BIT"
    ambient, bus = condition(params, bit)
    env = params.envelope
    if not env.ambient_min_c - 10.0 <= ambient <= env.ambient_max_c + 10.0:
        return f"ambient {ambient:.1f} C is outside the actuator's envelope"
    if not params.bus.min_v - 1.0 <= bus <= params.bus.max_v + 1.0:
        return f"aircraft bus {bus:.2f} V is outside the actuator's band"
    return None
