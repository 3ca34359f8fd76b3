"""From bus signals to the reasoner: find each built-in test in the traffic, diagnose it.

The reasoner decides on one BIT record (the four-corner motion of
:func:`~mapr_daemon.testbed.profiles.bit_profile`) sampled at the dictionary's rate and
aligned on the profile's time axis. On the bus the flight control computer's position
command (100 Hz) shows when a BIT starts: the command leaves zero after a quiet spell and
reaches the BIT amplitude within the ramp time. The EMA's sample blocks (2 kHz) and slow
block are then resampled onto the profile's grid, anchored at that command message, and the
record goes to :meth:`Reasoner.diagnose` with the dynamic pressure the air-data computer
reported meanwhile. Other motion (a pilot's aileron inputs) is not a BIT and is ignored.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import numpy as np

from mapr_daemon.icd import Series
from mapr_daemon.reasoner.events import Reasoner
from mapr_daemon.reasoner.features import FloatArray
from mapr_daemon.testbed.aircraft import FAST_CHANNELS, SLOW_CHANNELS
from mapr_daemon.testbed.profiles import Profile, bit_profile

log = logging.getLogger("mapr.reasoner")
COMMAND = "position_command"
PRESSURE = "dynamic_pressure"
CHANNELS = {**FAST_CHANNELS, **SLOW_CHANNELS}
"""ICD parameter -> reasoner channel name (the testbed aircraft's wiring)."""
KEEP_S = 4.0
QUIET_S = 0.15
QUIET_DEG = 0.05


class BitWatch:
    """Buffers the signals a BIT needs and yields the reasoner's event for each BIT seen."""

    def __init__(self, reasoner: Reasoner, *, threshold: float | None = None,
                 paper: bool = False) -> None:
        self.reasoner = reasoner
        self.paper = paper
        if threshold is not None:
            reasoner.dictionary.threshold = float(threshold)
        rate = reasoner.dictionary.sample_rate_hz
        self.profile: Profile = bit_profile(rate, "ground")
        self.period_ns = 1e9 / rate
        self.lead_ns = int(self.profile.corners_s[0] * 1e9)
        self.span_ns = int(self.profile.n_samples * self.period_ns)
        self.amplitude = float(self.profile.command_deg.max())
        self.ramp_ns = int((self.profile.corners_s[1] - self.profile.corners_s[0]) * 1e9)
        self.buffers: dict[str, tuple[list[FloatArray], list[FloatArray]]] = {
            name: ([], []) for name in (*CHANNELS, COMMAND, PRESSURE)}
        self.pending: int | None = None
        """Bus time of the command message that started the BIT being collected."""
        self.last_onset = -1
        self.bits_seen = 0

    def feed(self, series: Mapping[str, Series]) -> list[dict[str, Any]]:
        """Take a batch of decoded series; returns the events of BITs completed by it."""
        now = None
        for name, (times, values) in self.buffers.items():
            s = series.get(name)
            if s is None or s.t_ns.size == 0:
                continue
            times.append(np.asarray(s.t_ns, dtype=np.float64))
            values.append(np.asarray(s.value, dtype=np.float64).reshape(s.t_ns.size, -1)[:, 0])
            if name == "phase_current_a":
                now = float(s.t_ns[-1])
        self._compact()
        events: list[dict[str, Any]] = []
        if self.pending is None:
            self.pending = self._onset()
        if self.pending is not None and now is not None and \
                now >= self.pending - self.lead_ns + self.span_ns + 4 * self.period_ns:
            event = self._diagnose(self.pending)
            self.last_onset = self.pending
            self.pending = None
            if event is not None:
                events.append(event)
        return events

    def _compact(self) -> None:
        for times, values in self.buffers.values():
            if len(times) > 1:
                t, v = np.concatenate(times), np.concatenate(values)
                times[:], values[:] = [t], [v]
            if times and times[0].size:
                keep = times[0] >= times[0][-1] - KEEP_S * 1e9
                times[0], values[0] = times[0][keep], values[0][keep]

    def _series(self, name: str) -> tuple[FloatArray, FloatArray]:
        times, values = self.buffers[name]
        if not times:
            return np.zeros(0), np.zeros(0)
        return times[0], values[0]

    def _onset(self) -> int | None:
        """Bus time of a BIT's first command step, or None if no BIT start is in the buffer."""
        t, v = self._series(COMMAND)
        moving = np.flatnonzero((np.abs(v) > QUIET_DEG) & (t > self.last_onset))
        for i in moving:
            quiet = (t >= t[i] - QUIET_S * 1e9) & (t < t[i])
            if not quiet.any() or np.abs(v[quiet]).max() > QUIET_DEG or \
                    t[i] - t[0] < QUIET_S * 1e9:
                continue
            later = (t >= t[i]) & (t <= t[i] + self.ramp_ns + 20e6)
            if later.any() and v[later].max() >= 0.9 * self.amplitude:
                return int(t[i])
        return None

    def _diagnose(self, onset: int) -> dict[str, Any] | None:
        self.bits_seen += 1
        start = onset - self.lead_ns
        grid = start + np.arange(1, self.profile.n_samples + 1) * self.period_ns
        channels: dict[str, FloatArray] = {}
        for icd_name, channel in CHANNELS.items():
            t, v = self._series(icd_name)
            if t.size < 2 or t[0] > grid[0] + 0.05e9 or t[-1] < grid[-1] - 0.05e9:
                log.warning("BIT at bus time %.3f s: %s not on the bus for the whole test; "
                            "skipped", onset / 1e9, icd_name)
                return None
            channels[channel] = np.interp(grid, t, v)
        tq, vq = self._series(PRESSURE)
        inside = (tq >= grid[0]) & (tq <= grid[-1])
        q = float(np.median(vq[inside])) if inside.any() else \
            float(vq[-1]) if vq.size else 0.0
        event = self.reasoner.diagnose(channels, self.profile.command_deg, q, paper=self.paper)
        event["evidence"]["bit_bus_time_s"] = round(onset / 1e9, 6)
        event["evidence"]["dynamic_pressure_pa"] = round(q, 1)
        log.info("BIT at bus time %.3f s: %s (score %.0f, threshold %.0f)", onset / 1e9,
                 f"{event['fault']} anomaly" if event["anomaly"] else "nominal",
                 event["evidence"].get("score", 0.0), event["evidence"].get("threshold", 0.0))
        return event
