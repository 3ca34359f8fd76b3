"""Window features around the built-in-test profile's corners: the paper's 32-row matrix M.

The paper (III.D) cuts the four-corner BIT response into 32 windows, eight per corner (four
left, four right), and computes eight *intermediate values* per window and per signal:

=========  ==================================================================================
mean       the DC value
std        standard deviation
cube       ``std**3``
frequency  the DFT peak (DC excluded), refined with the two neighbouring bins (parabolic fit
           of the log power — the "hybrid DFT" of the paper)
power      the refined peak power
left       the frequency, left of the peak, where the power falls to half (linear crossing)
right      the same on the right
bandwidth  ``right - left``
=========  ==================================================================================

Columns are feature-major per signal group, as in the paper: for the paper's signals (three
phase currents, then position) the first three columns are the three currents' means, the
next three their standard deviations, ..., 24 current columns, then the eight values of
position — a 32 x 32 matrix. :data:`EXTENDED_SIGNALS` adds the DC-bus channels (where the
SMPS faults live, see docs/observability.md) and the position tracking error.

Window length: the paper used 4096 samples of its simulation rate. Our signals arrive at the
bus rate (2 kHz in the shipped ICD), and the BIT profile's corners are 30 ms and 600 ms apart,
so :data:`DEFAULT_WINDOW` is 32 samples (16 ms): eight windows span 128 ms per corner, the
peak frequency resolves in 62.5 Hz bins. Corners 1-2 (and 3-4) are only 60 samples apart, so
their window sets overlap — the paper's ramp was longer; we keep its 4+4 layout anyway.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis.sector import CHANNELS, a_high_driven, a_high_resistance

FEATURES: tuple[str, ...] = ("mean", "std", "cube", "frequency", "power", "left", "right",
                             "bandwidth")
PAPER_SIGNALS: tuple[str, ...] = ("phase_a_current_a", "phase_b_current_a", "phase_c_current_a",
                                  "position_deg")
"""The paper's M: the three phase currents and position (32 columns)."""
EXTENDED_SIGNALS: tuple[str, ...] = (*PAPER_SIGNALS, "dc_link_current_a", "dc_bus_voltage_v",
                                     "ripple_rms_v", "smps_input_current_a", "tracking_error_deg",
                                     "smps_loss_w", "smps_input_voltage_v", "stage_temperature_c")
"""Ours: the paper's signals plus the DC-bus side, the tracking error, the SMPS conversion loss
and the two operating-condition channels (aircraft-bus voltage, power-stage temperature, which
reads ambient at the start of a BIT) — 96 columns."""
SECTOR_SIGNALS: tuple[str, ...] = ("duty_a_high", "duty_other", "dc_link_a_high_a",
                                   "a_high_share", "a_high_resistance_ohm")
"""Ours, when the drive reports its commutation sector and applied duty: the duty while phase
A's high side is the PWM'd switch and while another is, the DC-link current in A-high sectors,
the share of time in them (phase A's high-side Ron is only visible per sector), and the
record's sector-resolved loop resistance (:mod:`~mapr_daemon.reasoner.diagnosis.sector`; one value
per
record, repeated over its samples)."""
SWITCH_SIGNALS: tuple[str, ...] = ("smps_high_side_rise_k", "smps_low_side_rise_k",
                                   "inverter_a_high_rise_k")
"""Ours, when the actuator has temperature-sensing power switches and the dictionary is built
with them (``switch_temperatures: true``): each switch's junction temperature over the power
stage's (the heat sink's), which takes out the ambient and the stage's slow warming and leaves
the switch's own loss (:data:`SWITCH_SOURCES`)."""
SWITCH_SOURCES: dict[str, str] = dict(zip(SWITCH_SIGNALS, (
    "smps_high_side_temperature_c", "smps_low_side_temperature_c",
    "inverter_a_high_temperature_c"), strict=True))
"""Each switch signal's temperature channel (the stage's, ``stage_temperature_c``, is the
other input)."""
CURRENT_GROUP: tuple[str, ...] = PAPER_SIGNALS[:3]
DEFAULT_WINDOW = 32
WINDOWS_PER_SIDE = 4


@dataclasses.dataclass(frozen=True)
class WindowSpec:
    """Where the windows sit: ``per_side`` windows of ``length`` samples each side of a corner."""

    length: int = DEFAULT_WINDOW
    per_side: int = WINDOWS_PER_SIDE

    def starts(self, corners: Sequence[int], n_samples: int) -> npt.NDArray[np.int64]:
        """First sample of every window, corner by corner, left to right."""
        if self.length < 4 or self.per_side < 1:
            raise ConfigError("window length >= 4 and per_side >= 1", field="windows")
        out = [c + k * self.length for c in corners
               for k in range(-self.per_side, self.per_side)]
        if min(out) < 0 or max(out) + self.length > n_samples:
            raise ConfigError(f"windows run outside the record ({n_samples} samples)",
                              field="windows")
        return np.asarray(out, dtype=np.int64)


def record_starts(n_samples: int, length: int, skip: int) -> npt.NDArray[np.int64]:
    """Windows tiling the whole record after the first ``skip`` samples (our record rows)."""
    if length < 4 or skip < 0 or skip + length > n_samples:
        raise ConfigError(f"record windows of {length} samples after {skip} do not fit "
                          f"{n_samples} samples", field="windows")
    return np.arange(skip, n_samples - length + 1, length, dtype=np.int64)


def corner_samples(corners_s: Sequence[float], sample_rate_hz: float) -> tuple[int, ...]:
    """Sample index of each corner time (sample k is at time (k+1)/rate in the plant)."""
    return tuple(round(c * sample_rate_hz) - 1 for c in corners_s)


def _spectral(x: FloatArray, rate: float) -> FloatArray:
    """Frequency, power, left and right half-power points of ``x[..., L]`` (mean removed)."""
    length = x.shape[-1]
    centred = x - x.mean(axis=-1, keepdims=True)
    hann = np.hanning(length)
    spec = np.abs(np.fft.rfft(centred * hann, axis=-1)) ** 2 / (hann.sum() ** 2)
    df = rate / length
    nb = spec.shape[-1]
    k = 1 + np.argmax(spec[..., 1:], axis=-1)  # DC excluded
    take = np.take_along_axis
    p0 = take(spec, k[..., None], -1)[..., 0]
    pl = take(spec, np.maximum(k - 1, 0)[..., None], -1)[..., 0]
    pr = take(spec, np.minimum(k + 1, nb - 1)[..., None], -1)[..., 0]
    tiny = 1e-30
    a, b, c = np.log(pl + tiny), np.log(p0 + tiny), np.log(pr + tiny)
    den = a - 2 * b + c
    edge = (k == nb - 1)
    delta = np.where((np.abs(den) > 1e-12) & ~edge, 0.5 * (a - c) / np.where(den == 0, 1, den),
                     0.0)
    delta = np.clip(delta, -0.5, 0.5)
    freq = (k + delta) * df
    power = np.exp(b - 0.25 * (a - c) * delta) - tiny
    half = 0.5 * power
    idx = np.arange(nb)
    below = spec < half[..., None]
    # left: last bin below half at or before the peak; right: first bin below half after it
    left_mask = below & (idx <= k[..., None])
    right_mask = below & (idx >= k[..., None])
    li = np.where(left_mask.any(-1), nb - 1 - np.argmax(left_mask[..., ::-1], -1), 0)
    ri = np.where(right_mask.any(-1), np.argmax(right_mask, -1), nb - 1)

    def cross(i0: npt.NDArray[np.int64], i1: npt.NDArray[np.int64]) -> FloatArray:
        s0 = take(spec, i0[..., None], -1)[..., 0]
        s1 = take(spec, i1[..., None], -1)[..., 0]
        span = np.where(np.abs(s1 - s0) > tiny, s1 - s0, 1.0)
        frac = np.clip((half - s0) / span, 0.0, 1.0)
        out: FloatArray = (i0 + frac * (i1 - i0)) * df
        return out

    left = cross(li, np.minimum(li + 1, nb - 1))
    right = cross(np.maximum(ri - 1, 0), ri)
    return np.stack([freq, power, left, right], axis=-1)


def window_values(x: FloatArray, rate: float) -> FloatArray:
    """The eight intermediate values of windows ``x[..., L]`` -> ``[..., 8]`` (FEATURES order)."""
    mean = x.mean(axis=-1)
    std = x.std(axis=-1)
    sp = _spectral(x, rate)
    return np.stack([mean, std, std**3, sp[..., 0], sp[..., 1], sp[..., 2], sp[..., 3],
                     sp[..., 3] - sp[..., 2]], axis=-1)


LOSS_INPUTS = ("smps_input_voltage_v", "smps_input_current_a", "dc_bus_voltage_v",
               "dc_link_current_a")


def derived_signals(channels: Mapping[str, FloatArray],
                    command_deg: FloatArray | None) -> dict[str, FloatArray]:
    """The channels plus what is computed from them.

    ``tracking_error_deg`` is position minus command (when a command is known);
    ``smps_loss_w`` is the SMPS's conversion loss, input power minus output power
    ``Vin*Iin - Vbus*Idc``: the switch resistances dissipate ``(D*Ron_high + (1-D)*Ron_low)*I^2``
    there, which the regulated output voltage hides.
    """
    out = dict(channels)
    if command_deg is not None and "position_deg" in channels:
        pos = channels["position_deg"]
        out["tracking_error_deg"] = pos - np.broadcast_to(command_deg, pos.shape)
    if all(k in channels for k in LOSS_INPUTS):
        vin, iin, vbus, idc = (np.asarray(channels[k], dtype=np.float64) for k in LOSS_INPUTS)
        out["smps_loss_w"] = vin * iin - vbus * idc
    if "commutation_sector" in channels and "inverter_duty" in channels:
        out.update(sector_signals(channels))
    if "stage_temperature_c" in channels:
        stage = np.asarray(channels["stage_temperature_c"], dtype=np.float64)
        for name, source in SWITCH_SOURCES.items():
            if source in channels:
                out[name] = np.asarray(channels[source], dtype=np.float64) - stage
    return out


def sector_signals(channels: Mapping[str, FloatArray]) -> dict[str, FloatArray]:
    """:data:`SECTOR_SIGNALS` from the drive's sector and signed duty channels.

    Why: a phase-A high-side Ron fault adds its resistance only while that switch carries the
    current, so the current loop asks for a little more duty there than in the other sectors for
    the same current; averaged over all sectors that difference drowns.
    """
    sector = np.rint(np.asarray(channels["commutation_sector"], dtype=np.float64))
    duty = np.asarray(channels["inverter_duty"], dtype=np.float64)
    mask = a_high_driven(sector, duty).astype(np.float64)
    out = {"duty_a_high": np.abs(duty) * mask, "duty_other": np.abs(duty) * (1.0 - mask),
           "a_high_share": mask}
    if "dc_link_current_a" in channels:
        out["dc_link_a_high_a"] = np.asarray(channels["dc_link_current_a"]) * mask
    if all(k in channels for k in CHANNELS):
        r = a_high_resistance({k: np.atleast_2d(channels[k]) for k in CHANNELS})
        out["a_high_resistance_ohm"] = np.broadcast_to(
            r[:, None], np.atleast_2d(duty).shape).reshape(duty.shape)
    return out


def reasoner_signals(channels: Sequence[str],
                     switch_temperatures: bool = False) -> tuple[str, ...]:
    """Our M's signals for records carrying ``channels``: :data:`EXTENDED_SIGNALS`, plus
    :data:`SECTOR_SIGNALS` when the drive reports its sector and duty, plus
    :data:`SWITCH_SIGNALS` when asked for (a dictionary built with the switch temperatures:
    the plant always has them, an aircraft may not, so they are the dictionary's choice)."""
    base = ((*EXTENDED_SIGNALS, *SECTOR_SIGNALS)
            if "commutation_sector" in channels and "inverter_duty" in channels
            else EXTENDED_SIGNALS)
    return (*base, *SWITCH_SIGNALS) if switch_temperatures else base


def missing_sources(signals: Sequence[str], channels: Sequence[str]) -> list[str]:
    """The channels a record lacks for ``signals`` that only optional sensors give (the
    switch temperatures): what to name when a dictionary built with them meets a record
    without them."""
    have = set(channels)
    need = [SWITCH_SOURCES[s] for s in signals if s in SWITCH_SOURCES]
    if any(s in SWITCH_SOURCES for s in signals):
        need.append("stage_temperature_c")
    return [c for c in dict.fromkeys(need) if c not in have]


def column_names(signals: Sequence[str]) -> list[str]:
    """Names of M's columns: ``feature:signal``, the paper's order (feature-major per group)."""
    groups = _groups(signals)
    return [f"{f}:{s}" for g in groups for f in FEATURES for s in g]


def _groups(signals: Sequence[str]) -> list[tuple[str, ...]]:
    """The three currents form one group (as in the paper), every other signal its own."""
    sig = tuple(signals)
    if sig[:3] == CURRENT_GROUP:
        return [CURRENT_GROUP, *[(s,) for s in sig[3:]]]
    return [(s,) for s in sig]


BATCH_SAMPLES = 1 << 18
"""Window samples :func:`feature_matrix` hands :func:`window_values` at once (2 MiB of float64):
one record's windows of every signal fit; many runs go through in groups of this size."""


def feature_matrix(signals: Mapping[str, FloatArray], starts: npt.NDArray[np.int64],
                   length: int, rate: float,
                   names: Sequence[str] = PAPER_SIGNALS) -> FloatArray:
    """M for every run: ``signals[name]`` is ``(n_runs, n)`` -> ``(n_runs, windows, columns)``.

    >>> # m = feature_matrix(channels, WindowSpec().starts(corners, n), 32, 2000.0)
    """
    missing = [s for s in names if s not in signals]
    if missing:
        raise ConfigError(f"missing signals {', '.join(missing)}", field="signals")
    idx = starts[:, None] + np.arange(length)[None, :]
    runs = np.stack(np.broadcast_arrays(*(np.atleast_2d(np.asarray(signals[s], dtype=np.float64))
                                          for s in names)))     # (signals, runs, n)
    # every signal's windows in one batch (one pass of each numpy call, not one per signal),
    # in groups of runs small enough that the temporaries stay in cache and memory stays flat
    group = max(1, BATCH_SAMPLES // (len(names) * idx.size))
    values = np.concatenate([window_values(runs[:, r:r + group][:, :, idx], rate)
                             for r in range(0, runs.shape[1], group)], axis=1)
    per_signal = dict(zip(names, values, strict=True))  # (runs, windows, 8) each
    cols = [per_signal[s][..., f] for g in _groups(names) for f in range(len(FEATURES))
            for s in g]
    return np.stack(cols, axis=-1)
