"""Cut each built-in test out of an actuator's decoded bus signals: the one way MAPR finds a BIT.

A BIT record is the four-corner motion of the actuator's ``bit:`` section
(:func:`~mapr_daemon.ema.bit.bit_profile`) as the drive flew it, one sample per plant sample,
aligned on the profile's time axis. The EMA runs that motion itself when the flight control
computer sends ``INITIATED_BIT`` with a new sequence number in the BIT request message; by the
EMA's contract (docs/testbed.md) the profile's first sample is the drive's first sample after
the request arrives. So the record starts at the first fast-block sample time-tagged after the
request message: the EMA's sample blocks (2 kHz) are taken from there sample for sample (and
the power block's, taken with them), the slow block (100 Hz temperatures, only a condition)
is interpolated onto the same grid, and the dynamic pressure is the air-data computer's median
over the test. Other motion (a pilot's aileron inputs) is not a BIT and is ignored.

:class:`BitCutter` does only that: it buffers what a BIT needs and hands back each
:class:`CutBit` once its last sample has come. Two users share it, so there is one rule for
where a BIT starts and what it holds: the daemon's BIT watcher
(:class:`~mapr_daemon.pipeline.bitwatch.BitWatch`) diagnoses each cut BIT, and commissioning
from a recording (:mod:`.recorded_bits`) fits the data sheet to them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.params import CHANNELS, BitParams
from mapr_daemon.ema.profile import Profile
from mapr_daemon.icd import Series
from mapr_daemon.pipeline import wiring

INITIATED_BIT = 2
"""``bit_request`` code of an initiated BIT (configs/icd/ema-testbed.yaml)."""
KEEP_S = 4.0
"""Seconds of each signal kept between batches (at least): a BIT record (1.46 s for the
shipped actuators) and the margin before it, whatever the batches' length."""


@dataclasses.dataclass(frozen=True)
class CutBit:
    """One BIT cut out of the traffic."""

    request_ns: int
    """Time tag of the record that carried the request (the BIT's bus time)."""
    onset_ns: int
    """Time tag of the BIT record's first sample."""
    channels: dict[str, FloatArray]
    """Reasoner channel -> samples on the profile's grid (with the drive's sector and signed
    duty when the bus carries them); empty when :attr:`missing` says why there is no record."""
    dynamic_pressure_pa: float
    """The air-data computer's median dynamic pressure during the test."""
    missing: str | None = None
    """The ICD signal that was not on the bus for the whole test (no record), or None."""


class BitCutter:
    """Buffers the signals a BIT needs and cuts each BIT requested on the bus.

    ``signals`` is the asset's wiring (ICD signal -> reasoner channel or role, :mod:`.wiring`;
    default the shipped testbed ICD's), ``bit`` its BIT motion, ``sample_rate_hz`` the drive's
    sample rate (the record's grid).
    """

    def __init__(self, bit: BitParams, sample_rate_hz: float, *,
                 signals: Mapping[str, str] | None = None) -> None:
        wired = wiring.DEFAULT_SIGNALS if signals is None else signals
        role = wiring.by_role(wired)
        self.channels = {role[c]: c for c in CHANNELS}
        """ICD signal -> reasoner sensor channel."""
        self.optional = {role[c]: c for c in wiring.switch_channels(wired)}
        """ICD signal -> optional reasoner channel (the switch temperatures, when wired): a
        BIT is cut without one the bus did not carry, and the reasoner says what it lacks."""
        self.request, self.pressure, self.timebase = \
            role[wiring.REQUEST], role[wiring.PRESSURE], role[wiring.TIMEBASE]
        self.drive = tuple(role.get(r) for r in (wiring.SECTOR, wiring.DUTY, wiring.DIRECTION))
        self.profile: Profile = bit_profile(sample_rate_hz, "ground", bit)
        """The BIT motion on the record's grid (its command is what the drive followed)."""
        self.period_ns = 1e9 / sample_rate_hz
        self.span_ns = int(self.profile.n_samples * self.period_ns)
        names = (*self.channels, *self.optional, self.request, self.pressure,
                 *(d for d in self.drive if d is not None))
        self.buffers: dict[str, tuple[list[FloatArray], list[FloatArray]]] = {
            name: ([], []) for name in names}
        self.pending: tuple[int, int] | None = None
        """Request and first-sample time tags of the BIT being collected."""
        self.ignore_until = -1.0
        """Requests up to this time tag are taken (or, during a BIT, ignored by the EMA)."""

    def seen(self, series: Mapping[str, Series]) -> bool:
        """Whether a batch carries any of this actuator's sensor channels."""
        return any(name in series and series[name].t_ns.size for name in self.channels)

    def feed(self, series: Mapping[str, Series]) -> list[CutBit]:
        """Take a batch of decoded series; returns the BITs completed by it, in time order."""
        now = None
        for name, (times, values) in self.buffers.items():
            s = series.get(name)
            if s is None or s.t_ns.size == 0:
                continue
            times.append(np.asarray(s.t_ns, dtype=np.float64))
            values.append(np.asarray(s.value, dtype=np.float64).reshape(s.t_ns.size, -1)[:, 0])
            if name == self.timebase:
                now = float(s.t_ns[-1])
        self._merge()
        cuts = self._complete(now)
        self._trim()
        return cuts

    def _complete(self, now: float | None) -> list[CutBit]:
        """Cut every BIT whose record has come by ``now`` (the last sample time tag), from
        the whole buffers: a batch may span more than :data:`KEEP_S` of bus (a file read in
        large batches), and the buffers are trimmed only after."""
        cuts: list[CutBit] = []
        while True:
            if self.pending is None:
                self.pending = self._onset()
            if self.pending is None or now is None or \
                    now < self.pending[1] + self.span_ns + 4 * self.period_ns:
                return cuts
            (request, onset), self.pending = self.pending, None
            cuts.append(self.cut(request, onset))

    def _merge(self) -> None:
        """Each buffer as one array of time tags and one of values."""
        for times, values in self.buffers.values():
            if len(times) > 1:
                t, v = np.concatenate(times), np.concatenate(values)
                times[:], values[:] = [t], [v]

    def _trim(self) -> None:
        """Keep the last :data:`KEEP_S` of each buffer, or a BIT record and a second more
        where the actuator's BIT is longer: what a BIT still being collected needs (a request
        is taken, and its record's start known, as soon as a sample follows it)."""
        window = max(KEEP_S * 1e9, self.span_ns + 1e9)
        for times, values in self.buffers.values():
            if times and times[0].size:
                keep = times[0] >= times[0][-1] - window
                times[0], values[0] = times[0][keep], values[0][keep]

    def _series(self, name: str) -> tuple[FloatArray, FloatArray]:
        times, values = self.buffers[name]
        if not times:
            return np.zeros(0), np.zeros(0)
        return times[0], values[0]

    def _onset(self) -> tuple[int, int] | None:
        """Time tags of the request and of the first sample of a requested BIT, or None
        while none is due.

        A request the EMA would ignore (one that arrives while a BIT runs) is ignored here too.
        """
        t, v = self._series(self.request)
        requests = t[(v == INITIATED_BIT) & (t > self.ignore_until)]
        if requests.size == 0:
            return None
        fast, _ = self._series(self.timebase)
        after = fast[fast > requests[0]]
        if after.size == 0:
            return None
        onset = float(after[0])
        self.ignore_until = onset + self.span_ns
        return int(requests[0]), int(onset)

    def cut(self, request: int, onset: int) -> CutBit:
        """The BIT requested at ``request`` whose first sample is time-tagged ``onset``, from
        what the buffers hold; with :attr:`CutBit.missing` set when a channel was not on the
        bus for the whole test (the caller says so: each user in its own words)."""
        grid: FloatArray = onset + np.arange(self.profile.n_samples, dtype=np.float64) * \
            self.period_ns
        channels: dict[str, FloatArray] = {}
        tq, vq = self._series(self.pressure)
        inside = (tq >= grid[0]) & (tq <= grid[-1])
        q = float(np.median(vq[inside])) if inside.any() else \
            float(vq[-1]) if vq.size else 0.0
        for icd_name, channel in self.channels.items():
            t, v = self._series(icd_name)
            if t.size < 2 or t[0] > grid[0] + 0.05e9 or t[-1] < grid[-1] - 0.05e9:
                return CutBit(request, onset, {}, q, missing=icd_name)
            channels[channel] = np.interp(grid, t, v)
        for icd_name, channel in self.optional.items():
            t, v = self._series(icd_name)
            if t.size >= 2 and t[0] <= grid[0] + 0.05e9 and t[-1] >= grid[-1] - 0.05e9:
                channels[channel] = np.interp(grid, t, v)
        channels.update(self._drive_state(grid))
        return CutBit(request, onset, channels, q)

    def _drive_state(self, grid: FloatArray) -> dict[str, FloatArray]:
        """Sector and signed duty on the grid (nearest sample: both are discrete), if present."""
        if any(name is None for name in self.drive):
            return {}
        series = [self._series(name) for name in self.drive if name is not None]
        if any(t.size < 2 or t[0] > grid[0] or t[-1] < grid[-1] for t, _ in series):
            return {}
        (t, sector), (_, duty), (_, direction) = series
        nearest = np.clip(np.searchsorted(t, grid - 0.5 * self.period_ns), 0, t.size - 1)
        return {"commutation_sector": sector[nearest],
                "inverter_duty": np.where(direction[nearest] > 0.5, 1.0, -1.0) * duty[nearest]}
