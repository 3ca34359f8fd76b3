"""Each actuator's traffic between BITs, fed to its in-flight tracker; one row per flight.

Between BITs the bus carries the actuator's currents, position and DC-link signals at the
drive's sample rate for the whole flight. :class:`InflightWatch` takes each batch of decoded
series, puts the tracker's channels (:data:`~mapr_daemon.reasoner.ekf.model.NEEDED`) on the
timebase signal's time tags (the fast block's: the ICD samples them together), with the
air-data computer's dynamic pressure held between its updates, and feeds the stretches that
are flight traffic to a :class:`~mapr_daemon.reasoner.inflight.FlightAccumulator`:

* a **BIT** is not flight traffic: from each ``INITIATED_BIT`` request to the end of its
  record (the BIT motion's span) and :data:`AFTER_BIT_S` more, the samples are dropped (the
  BIT is the reasoner's, :mod:`.bitwatch`);
* a **gap** (samples missing, a BIT dropped, the daemon restarted) splits the stretch: the
  accumulator's unfinished window is dropped (:meth:`FlightAccumulator.gap`).

At the flight's end (:meth:`finish`: the pipeline calls it when its flight log moves to the
next flight, a replay or fleet run at the end of the recording) the accumulator runs the
tracker on the kept windows and :class:`~mapr_daemon.reasoner.inflight.baseline.Baseline`
turns the estimate into the stored row (change from the unit's commissioned baseline).
Cost: the accumulator keeps and filters only the qualifying windows (docs/reasoner.md).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Mapping, Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.catalog.model import InflightEstimate
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import RecordError
from mapr_daemon.icd import Series
from mapr_daemon.pipeline.bitcut import INITIATED_BIT, BitCutter
from mapr_daemon.reasoner.ekf.model import NEEDED
from mapr_daemon.reasoner.inflight.accumulate import FlightAccumulator
from mapr_daemon.reasoner.inflight.baseline import Baseline
from mapr_daemon.reasoner.inflight.tracker import FlightTracker

AFTER_BIT_S = 0.5
"""Seconds after a BIT record's end still left out (the drive settling back to command)."""
JUMP = 1.5
"""A step between samples longer than this many sample periods is a gap."""


class InflightWatch:
    """One actuator's flight traffic into its tracker: :meth:`feed` each batch, then
    :meth:`finish` at the flight's end."""

    def __init__(self, asset: str, params: ActuatorParams, cutter: BitCutter,
                 baseline: Baseline | None = None) -> None:
        self.asset = asset
        self.acc = FlightAccumulator(FlightTracker(params))
        self.baseline = baseline if baseline is not None else Baseline()
        by_channel = {c: s for s, c in cutter.channels.items()}
        self.signals = {c: by_channel[c] for c in NEEDED}
        """Reasoner channel -> ICD signal, for the tracker's channels."""
        self.timebase, self.request, self.pressure = \
            cutter.timebase, cutter.request, cutter.pressure
        self.period_ns = 1e9 / params.sensors.sample_rate_hz
        self.bit_ns = cutter.span_ns + 2 * cutter.period_ns + AFTER_BIT_S * 1e9
        self.bit_until = -np.inf
        """Requests up to this time tag fall within a BIT (the EMA ignores them)."""
        self._bits: list[tuple[float, float]] = []
        """Spans (time tags) of the BITs requested, not yet past."""
        self.last_t: float | None = None
        self.q = 0.0
        self.flight: int | None = None
        """The flight the accumulator holds (set by the pipeline)."""
        self.end_ns: int | None = None
        """Time tag of the last sample fed."""
        self.end_abs: int | None = None
        """Absolute time (epoch ns) of the last sample fed (the pipeline's clock)."""
        self.skipped = 0
        """Batches the tracker could not use (see :meth:`feed`)."""
        self.last_error: str | None = None

    def resume(self, rows: Sequence[InflightEstimate]) -> None:
        """Continue the baseline from this actuator's stored rows (oldest first)."""
        self.baseline.resume((r.flight, r.parameters) for r in rows if r.asset == self.asset)

    def feed(self, series: Mapping[str, Series]) -> None:
        """Take a batch of decoded series (in time order, as the pipeline gets them). The
        tracker is a second reading beside the BITs: a batch it cannot use costs its own
        stretch (counted in :attr:`skipped`, the error kept in :attr:`last_error`), never
        the daemon, the replay or the BITs."""
        try:
            self._feed(series)
        except (ArithmeticError, ValueError, IndexError, np.linalg.LinAlgError) as exc:
            self.skipped += 1
            self.last_error = f"{type(exc).__name__}: {exc}"
            self._gap()

    def _feed(self, series: Mapping[str, Series]) -> None:
        tb = series.get(self.timebase)
        self._requests(series)
        if tb is None or tb.t_ns.size == 0:
            return
        t = np.asarray(tb.t_ns, dtype=np.float64)
        channels: dict[str, FloatArray] = {}
        for channel, name in self.signals.items():
            s = series.get(name)
            if s is None or s.t_ns.size < 2:
                self._gap()
                return
            v = np.asarray(s.value, dtype=np.float64).reshape(s.t_ns.size, -1)[:, 0]
            same = s.t_ns.size == t.size and np.array_equal(s.t_ns, tb.t_ns)
            channels[channel] = v if same else np.interp(t, s.t_ns.astype(np.float64), v)
        q = self._pressure(series, t)
        # a sample the decoder could not read (NaN: a short message, a bad word) is not
        # flight traffic: it splits the stretch as a BIT does, never reaches the estimator
        finite = np.isfinite(q) & np.logical_and.reduce(
            [np.isfinite(v) for v in channels.values()])
        keep = ~self._in_bit(t) & finite
        cut = np.flatnonzero(np.diff(t) > JUMP * self.period_ns) + 1
        starts = np.concatenate(([0], cut))
        stops = np.concatenate((cut, [t.size]))
        for a, b in zip(starts, stops, strict=True):
            self._run(t[a:b], {k: v[a:b] for k, v in channels.items()}, q[a:b], keep[a:b])
        self.end_ns = int(t[-1])

    def _run(self, t: FloatArray, channels: Mapping[str, FloatArray], q: FloatArray,
             keep: np.ndarray) -> None:
        """One stretch without time jumps: its flight-traffic parts into the accumulator."""
        edges = np.flatnonzero(np.diff(keep.astype(np.int8))) + 1
        bounds = np.concatenate(([0], edges, [t.size]))
        for a, b in itertools.pairwise(bounds):
            if b <= a or not keep[a]:
                continue
            if self.last_t is None or a > 0 or t[a] - self.last_t > JUMP * self.period_ns:
                self.acc.gap()   # after a jump, a BIT or unreadable samples: not contiguous
            self.acc.feed({k: v[a:b] for k, v in channels.items()}, q[a:b])
            self.last_t = float(t[b - 1])

    def _gap(self) -> None:
        self.acc.gap()
        self.last_t = None

    def _requests(self, series: Mapping[str, Series]) -> None:
        """BIT requests in the batch: each starts a stretch that is not flight traffic."""
        s = series.get(self.request)
        if s is None or s.t_ns.size == 0:
            return
        hits = np.asarray(s.t_ns, dtype=np.float64)[np.asarray(s.value) == INITIATED_BIT]
        for r in hits:
            if r > self.bit_until:   # a request during a BIT is ignored by the EMA
                self._bits.append((float(r), float(r) + self.bit_ns))
                self.bit_until = float(r) + self.bit_ns

    def _in_bit(self, t: FloatArray) -> np.ndarray:
        out = np.zeros(t.size, dtype=bool)
        for a, b in self._bits:
            out |= (t >= a) & (t <= b)
        self._bits = [(a, b) for a, b in self._bits if t.size == 0 or b > t[-1]]
        return out

    def _pressure(self, series: Mapping[str, Series], t: FloatArray) -> FloatArray:
        """The dynamic pressure on ``t``: the air-data computer's, held between updates."""
        s = series.get(self.pressure)
        if s is None or s.t_ns.size == 0:
            return np.full(t.size, self.q)
        tq = np.asarray(s.t_ns, dtype=np.float64)
        vq = np.asarray(s.value, dtype=np.float64).reshape(tq.size, -1)[:, 0]
        idx = np.searchsorted(tq, t, side="right") - 1
        out = np.where(idx >= 0, vq[np.maximum(idx, 0)], self.q)
        readable = vq[np.isfinite(vq)]
        if readable.size:   # an unreadable pressure is never carried into later batches
            self.q = float(readable[-1])
        return out

    def finish(self, tail: str) -> InflightEstimate | None:
        """The flight's row (None: no window of it qualified), stamped with its last
        sample's absolute time; the watch starts the next flight."""
        flight_s = self.acc.samples / (1e9 / self.period_ns)
        try:
            estimate = self.acc.finish()
        except (RecordError, ArithmeticError, ValueError, np.linalg.LinAlgError):
            estimate = None   # no estimate this flight; the flight's BITs are unaffected
        self.last_t = None
        flight, self.flight = self.flight, None
        t_ns, self.end_abs = self.end_abs, None
        if estimate is None:
            return None
        return InflightEstimate(
            tail=tail, asset=self.asset, flight=flight,
            t_ns=time.time_ns() if t_ns is None else int(t_ns),
            flight_s=round(flight_s, 3), filtered_s=round(estimate.filtered_s, 3),
            parameters=self.baseline.rebase(estimate.as_event(), flight),
            qualified_s={k: round(v, 3) for k, v in estimate.qualified_s.items()})
