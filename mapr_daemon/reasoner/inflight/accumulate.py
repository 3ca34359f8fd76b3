"""A flight's traffic as it streams in: keep only the windows the tracker will filter.

The daemon sees a flight in batches of bus records, hours of them. Holding a whole flight's
2 kHz channels (six of them: ~350 MB per actuator-hour) to run the tracker at its end is not
needed: :class:`FlightAccumulator` cuts each batch into the tracker's windows as they
complete, computes their excitation (:func:`~mapr_daemon.reasoner.inflight.segments.excitation`)
and keeps only the windows that qualify for some parameter group (a fifth of the bus time on
the testbed's flights), with the stretches where time jumps marked. :meth:`finish` then runs
the tracker on what was kept, with the same segments the whole flight would have given.

Example::

    acc = FlightAccumulator(tracker)
    for channels, q in batches_between_bits:      # 1-D channels at the bus rate, in order
        acc.feed(channels, q)
    estimate = acc.finish()                        # None when nothing qualified
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.ekf.model import BLOCK, NEEDED
from mapr_daemon.reasoner.inflight.segments import Excitation, Segment, excitation, select
from mapr_daemon.reasoner.inflight.tracker import FlightEstimate, FlightTracker

OPTIONAL: tuple[str, ...] = ("inverter_duty",)
"""Channels kept when the bus carries them (the tracker reads the duty if it is there)."""


class FlightAccumulator:
    """One actuator's flight as it streams in; :meth:`feed` in time order, then :meth:`finish`.

    A gap in the traffic (a BIT cut out, a lost stretch) is marked with :meth:`gap`: the
    window in progress is dropped and the next one starts a new stretch.
    """

    def __init__(self, tracker: FlightTracker) -> None:
        self.tracker = tracker
        self._reset()

    def _reset(self) -> None:
        self._pending: dict[str, FloatArray] = {}
        self._pending_q = np.zeros(0)
        self._kept: list[dict[str, FloatArray]] = []
        self._kept_q: list[FloatArray] = []
        self._exc: list[Excitation] = []
        self._kept_n = 0
        self._last_kept = False
        self.samples = 0
        """Samples seen this flight (the flight's bus time, gaps excluded)."""

    @property
    def kept_samples(self) -> int:
        return self._kept_n

    def feed(self, channels: Mapping[str, FloatArray],
             dynamic_pressure_pa: float | FloatArray) -> None:
        """Append a batch (1-D channels of one length at the bus rate)."""
        names = [k for k in (*NEEDED, *OPTIONAL) if k in channels]
        missing = [k for k in NEEDED if k not in channels]
        if missing:
            raise ConfigError("missing channel for the in-flight tracker", field=missing[0])
        n = np.asarray(channels["position_deg"]).size
        q = np.broadcast_to(np.asarray(dynamic_pressure_pa, dtype=np.float64), (n,))
        if self._pending and set(names) != set(self._pending):
            raise ConfigError("the channels changed within a flight", field="channels")
        for k in names:
            new = np.asarray(channels[k], dtype=np.float64).reshape(-1)
            self._pending[k] = (np.concatenate((self._pending[k], new)) if k in self._pending
                                else new.copy())
        self._pending_q = np.concatenate((self._pending_q, q))
        self.samples += n
        self._cut()

    def gap(self) -> None:
        """The traffic does not continue from here: drop the unfinished window."""
        self._pending = {}
        self._pending_q = np.zeros(0)
        self._last_kept = False

    def _cut(self) -> None:
        """Process every whole window that has one sample after it (the speed at a window's
        last block needs the next window's first angle, as in a whole flight)."""
        window = self._window()
        n = self._pending_q.size
        m = (n - 1) // window if n > 0 else 0
        if m < 1:
            return
        use = m * window
        chunk = {k: v[: use + 1] for k, v in self._pending.items()}
        exc = excitation(self.tracker.plant, chunk, self.tracker.criterion)
        keep: npt.NDArray[np.bool_] = np.asarray(
            exc.qualifies(self.tracker.criterion).any(axis=1), dtype=np.bool_)
        if keep.any():
            self._exc.append(exc.kept(keep, self._kept_n, self._last_kept))
            idx = np.flatnonzero(keep)
            rows = (idx[:, None] * window + np.arange(window)[None, :]).reshape(-1)
            self._kept.append({k: v[rows] for k, v in self._pending.items()})
            self._kept_q.append(self._pending_q[rows])
            self._kept_n += rows.size
        self._last_kept = bool(keep[-1])
        self._pending = {k: v[use:] for k, v in self._pending.items()}
        self._pending_q = self._pending_q[use:]

    def _window(self) -> int:
        per = max(1, round(self.tracker.criterion.window_s / (self.tracker.plant.dt * BLOCK)))
        return per * BLOCK

    def segments(self) -> list[Segment]:
        """The kept windows as segments (sample positions in the kept buffer), as the
        tracker will filter them."""
        return select(Excitation.join(self._exc, self._window()), self.tracker.criterion)

    def finish(self) -> FlightEstimate | None:
        """The flight's estimate from the kept windows (None: none qualified); resets for
        the next flight. The unfinished last window is dropped."""
        if not self._kept:
            self._reset()
            return None
        names = list(self._kept[0])
        channels = {k: np.concatenate([c[k] for c in self._kept]) for k in names}
        q = np.concatenate(self._kept_q)
        exc = Excitation.join(self._exc, self._window())
        flight_s = self.samples * self.tracker.plant.dt
        self._reset()
        return self.tracker.track_excitation(channels, q, exc, flight_s)
