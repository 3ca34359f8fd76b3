"""From bus signals to the reasoner: find each built-in test in the traffic, diagnose it.

The reasoner decides on one BIT record (the four-corner motion of the actuator's ``bit:``
section, :func:`~mapr_daemon.ema.bit.bit_profile`) sampled at the dictionary's rate and
aligned on the profile's time axis. Which ICD signal is which reasoner channel is the
asset's wiring (:mod:`.wiring`, ``assets[].signals`` in the daemon config). The EMA runs
that motion itself when the flight control computer sends ``INITIATED_BIT`` with a new
sequence number in the BIT request message; by the EMA's contract (docs/testbed.md) the
profile's first sample is the drive's first sample after the request arrives. So the record
starts at the first fast-block sample time-tagged after the request message: the EMA's
sample blocks (2 kHz) are taken from there sample for sample (and the power block's, taken
with them), the slow block (100 Hz temperatures, which the reasoner uses only as a
condition) is interpolated onto the same grid, and the record goes to
:meth:`Reasoner.diagnose` with the dynamic pressure the air-data computer reported
meanwhile. Other motion (a pilot's aileron inputs) is not a BIT and is ignored.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.params import CHANNELS, BitParams
from mapr_daemon.ema.profile import Profile
from mapr_daemon.findings import Diagnosis
from mapr_daemon.icd import Series
from mapr_daemon.pipeline import wiring
from mapr_daemon.reasoner.reasoner import Reasoner

log = logging.getLogger("mapr.reasoner")
INITIATED_BIT = 2
"""``bit_request`` code of an initiated BIT (configs/icd/ema-testbed.yaml)."""
KEEP_S = 4.0
"""Seconds of each signal kept between batches (at least): a BIT record (1.46 s for the
shipped actuators) and the margin before it, whatever the batches' length."""


@dataclasses.dataclass(frozen=True)
class BitFound:
    """One BIT found on the bus and diagnosed."""

    request_ns: int
    """Time tag of the record that carried the request (the event's bus time)."""
    onset_ns: int
    """Time tag of the BIT record's first sample."""
    decision: Diagnosis
    """The reasoner's diagnosis, its evidence saying where on the bus the BIT was."""


class BitWatch:
    """Buffers the signals a BIT needs and yields the reasoner's event for each BIT seen.

    ``signals`` is the asset's wiring (ICD signal -> reasoner channel or role; default the
    shipped testbed ICD's), ``bit`` its BIT motion (default the reasoner's actuator's).
    """

    def __init__(self, reasoner: Reasoner, *, signals: Mapping[str, str] | None = None,
                 bit: BitParams | None = None, threshold: float | None = None,
                 paper: bool = False) -> None:
        self.reasoner = reasoner
        self.paper = paper
        if threshold is not None:
            reasoner.dictionary.threshold = float(threshold)
        role = wiring.by_role(wiring.DEFAULT_SIGNALS if signals is None else signals)
        self.channels = {role[c]: c for c in CHANNELS}
        """ICD signal -> reasoner sensor channel."""
        self.request, self.pressure, self.timebase = \
            role[wiring.REQUEST], role[wiring.PRESSURE], role[wiring.TIMEBASE]
        self.drive = tuple(role.get(r) for r in (wiring.SECTOR, wiring.DUTY, wiring.DIRECTION))
        rate = reasoner.dictionary.sample_rate_hz
        self.profile: Profile = bit_profile(rate, "ground",
                                            reasoner.params.bit if bit is None else bit)
        self.period_ns = 1e9 / rate
        self.span_ns = int(self.profile.n_samples * self.period_ns)
        names = (*self.channels, self.request, self.pressure,
                 *(d for d in self.drive if d is not None))
        self.buffers: dict[str, tuple[list[FloatArray], list[FloatArray]]] = {
            name: ([], []) for name in names}
        self.pending: tuple[int, int] | None = None
        """Request and first-sample time tags of the BIT being collected."""
        self.ignore_until = -1.0
        """Requests up to this time tag are taken (or, during a BIT, ignored by the EMA)."""
        self.bits_seen = 0
        self.last_onset: int | None = None
        """First-sample time tag of the last BIT diagnosed."""
        self.failures: list[tuple[int, str]] = []
        """(first-sample time tag, error) of each BIT the reasoner failed on in the last
        :meth:`feed` call."""
        self.failure_count = 0

    def seen(self, series: Mapping[str, Series]) -> bool:
        """Whether a batch carries any of this actuator's sensor channels."""
        return any(name in series and series[name].t_ns.size for name in self.channels)

    def feed(self, series: Mapping[str, Series]) -> list[BitFound]:
        """Take a batch of decoded series; returns the BITs completed by it, diagnosed."""
        self.failures = []
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
        events = self._complete(now)
        self._trim()
        return events

    def _complete(self, now: float | None) -> list[BitFound]:
        """Diagnose every BIT whose record has come by ``now`` (the last sample time tag),
        from the whole buffers: a batch may span more than :data:`KEEP_S` of bus (a file
        read in large batches), and the buffers are trimmed only after."""
        events: list[BitFound] = []
        while True:
            if self.pending is None:
                self.pending = self._onset()
            if self.pending is None or now is None or \
                    now < self.pending[1] + self.span_ns + 4 * self.period_ns:
                return events
            (request, onset), self.pending = self.pending, None
            try:
                decision = self._diagnose(onset)
            except Exception as error:  # a reasoner fault costs this BIT, not the daemon
                log.exception("BIT at bus time %.3f s: the reasoner failed; BIT skipped",
                              onset / 1e9)
                self.failures.append((onset, f"{type(error).__name__}: {error}"))
                self.failure_count += 1
                continue
            if decision is not None:
                events.append(BitFound(request, onset, decision))

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

    def record(self, onset: int) -> tuple[dict[str, FloatArray], float] | None:
        """The BIT record whose first sample is time-tagged ``onset`` (reasoner channel ->
        samples on the profile's grid) and the median dynamic pressure during it; None (with a
        warning) when a channel was not on the bus for the whole test."""
        grid: FloatArray = onset + np.arange(self.profile.n_samples, dtype=np.float64) * \
            self.period_ns
        channels: dict[str, FloatArray] = {}
        for icd_name, channel in self.channels.items():
            t, v = self._series(icd_name)
            if t.size < 2 or t[0] > grid[0] + 0.05e9 or t[-1] < grid[-1] - 0.05e9:
                log.warning("BIT at bus time %.3f s: %s not on the bus for the whole test; "
                            "skipped", onset / 1e9, icd_name)
                return None
            channels[channel] = np.interp(grid, t, v)
        channels.update(self._drive_state(grid))
        tq, vq = self._series(self.pressure)
        inside = (tq >= grid[0]) & (tq <= grid[-1])
        q = float(np.median(vq[inside])) if inside.any() else \
            float(vq[-1]) if vq.size else 0.0
        return channels, q

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

    def _diagnose(self, onset: int) -> Diagnosis | None:
        self.bits_seen += 1
        self.last_onset = onset
        record = self.record(onset)
        if record is None:
            return None
        channels, q = record
        diagnosis = self.reasoner.diagnose(channels, self.profile.command_deg, q,
                                           paper=self.paper).with_evidence(
            bit_bus_time_s=round(onset / 1e9, 6), dynamic_pressure_pa=round(q, 1))
        log.info("BIT at bus time %.3f s: %s (score %.0f, threshold %.0f)", onset / 1e9,
                 f"{diagnosis.fault} anomaly" if diagnosis.anomaly else "nominal",
                 diagnosis.evidence.get("score", 0.0), diagnosis.evidence.get("threshold", 0.0))
        return diagnosis
