"""The ``loopback`` backend: a simulated 1553 bus and the monitor's tap on it.

Every :meth:`LoopbackMonitor._recv_internal` call runs one minor frame of the bus controller
(bounded work: one frame of bus time), then hands the traffic to the monitor: at bit level
(the default) through the Manchester encoder, the decoder and the message assembler, as a
hardware capture would go; on the fast path (``bit_level=False``) as word batches straight
into the assembler. Simulated time runs as fast as the host allows, or paced to the wall
clock with ``realtime=True``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from typing import Any

from drivers.backends.loopback.controller import BusController, SentMessage
from drivers.backends.loopback.injection import Injection, Injector
from drivers.backends.loopback.line import SampleWriter, traffic_words
from drivers.backends.loopback.schedule import (
    Schedule,
    ScheduledMessage,
    default_schedule,
    default_terminals,
)
from drivers.backends.loopback.terminal import RemoteTerminal
from drivers.mil1553.assembler import MessageAssembler
from drivers.mil1553.decoder import ManchesterDecoder
from drivers.mil1553.encoder import Impairments
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.monitor import BusMonitor, MonitorFilter


class LoopbackMonitor(BusMonitor):
    """A monitor on a software 1553 bus (bus controller + remote terminals).

    Options (all keyword-only):

    ``terminals``
        :class:`RemoteTerminal` objects; default: the two terminals of the default schedule.
    ``schedule``
        A :class:`Schedule`; default :func:`default_schedule` (all ten formats).
    ``injections``
        :class:`Injection` objects applied as messages match them (more with :meth:`inject`).
    ``bit_level`` / ``sample_rate`` / ``impairments``
        Encode and decode the waveform (default True, 16 MS/s, a clean signal).
    ``realtime``
        Pace the bus to the wall clock (default False: as fast as possible).
    ``frames`` / ``duration_s``
        Stop after that many minor frames / that much bus time (None: run forever).
    ``seed``
        Seeds the noise and impairments: equal options give equal records.
    ``response_gap_ns``, ``intermessage_gap_ns``, ``no_response_ns``, ``retries``
        Bus controller timing (8 µs, 10 µs, 14 µs; gaps mid-crossing to mid-crossing) and
        how many times a message that got no valid status is retried on the other bus (1).
    ``timing``
        The monitor's :class:`BusTiming` thresholds.
    """

    def __init__(self, *, filters: Sequence[MonitorFilter] | None = None,
                 terminals: Iterable[RemoteTerminal] | None = None,
                 schedule: Schedule | None = None,
                 injections: Iterable[Injection] = (),
                 bit_level: bool = True, sample_rate: float = 16e6,
                 impairments: Impairments | None = None, realtime: bool = False,
                 frames: int | None = None, duration_s: float | None = None, seed: int = 0,
                 response_gap_ns: int = 8_000, intermessage_gap_ns: int = 10_000,
                 no_response_ns: int = 14_000, retries: int = 1,
                 timing: BusTiming | None = None, **config: Any) -> None:
        super().__init__(filters=filters, **config)
        if terminals is None:
            terminals = [RemoteTerminal(address, transmit=callbacks)
                         for address, callbacks in default_terminals()]
        stretch = 1.0 + max(0.0, impairments.rate_error if impairments else 0.0)
        self.controller = BusController(
            schedule or default_schedule(), terminals, injector=Injector(list(injections)),
            response_gap_ns=response_gap_ns, intermessage_gap_ns=intermessage_gap_ns,
            no_response_ns=no_response_ns, retries=retries, word_ns=20_000.0 * stretch,
            seed=seed)
        self.bit_level = bit_level
        self.realtime = realtime
        self.frames = frames
        self.end_ns = None if duration_s is None else round(duration_s * 1e9)
        self.assembler = MessageAssembler(timing)
        self.decoder = ManchesterDecoder(sample_rate) if bit_level else None
        self.writer = SampleWriter(sample_rate, impairments, seed) if bit_level else None
        self._started = time.monotonic()
        self._finished = False

    # --- control while running ---------------------------------------------------------------
    @property
    def terminals(self) -> dict[int, RemoteTerminal]:
        """The terminals by address (change their flags or callbacks at any time)."""
        return self.controller.terminals

    @property
    def sent(self) -> list[SentMessage]:
        """The controller's log of recent attempts (what it meant to send)."""
        return list(self.controller.log)

    def inject(self, injection: Injection) -> None:
        """Add an error injection; it applies from the next minor frame."""
        self.controller.injector.add(injection)

    def send(self, message: ScheduledMessage) -> None:
        """Send a one-off (acyclic) message at the end of the next minor frame."""
        self.controller.send(message)

    @property
    def bus_time_ns(self) -> int:
        """Simulated time the bus has reached."""
        return self.controller.time_ns

    # --- the backend ---------------------------------------------------------------------------
    def _done(self) -> bool:
        if self.frames is not None and self.controller.frame >= self.frames:
            return True
        return self.end_ns is not None and self.controller.time_ns >= self.end_ns

    def _recv_internal(self, timeout: float | None) -> list[MonitorRecord] | None:
        if self._finished:
            return None
        if self._done():
            self._finished = True
            return self._flush()
        if self.realtime:
            due = self._started + self.controller.time_ns / 1e9
            wait = due - time.monotonic()
            if timeout is not None and wait > timeout:
                time.sleep(max(0.0, timeout))
                return []
            time.sleep(max(0.0, wait))
        traffic = self.controller.run_frame()
        if self.writer is None or self.decoder is None:
            return self.assembler.feed(traffic_words(traffic), horizon_ns=traffic.end_ns)
        words = self.decoder.feed(self.writer.write(traffic))
        horizon = self.decoder.complete_until_ns
        known = int(horizon) if math.isfinite(horizon) else 0  # -inf: nothing known yet
        return self.assembler.feed(words, horizon_ns=known)

    def _flush(self) -> list[MonitorRecord]:
        if self.decoder is None:
            return self.assembler.flush()
        return self.assembler.feed(self.decoder.flush()) + self.assembler.flush()
