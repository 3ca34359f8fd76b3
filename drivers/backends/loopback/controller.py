"""The loopback bus controller: runs the schedule, plays the terminals, lays words on the bus.

Each minor frame the controller sends the frame's messages one after another (then any
one-off messages queued with :meth:`BusController.send`), asks the addressed
:class:`~drivers.backends.loopback.terminal.RemoteTerminal` objects for their replies, and
places every word in time as the standard's timing says (all gaps mid-crossing to
mid-crossing: contiguous words 2 µs apart, responses after the response gap, the next
command after the intermessage gap). The result, :class:`Traffic`, is what a monitor's
transceiver would see: words with their injected faults, and noise bursts.

When no valid status word comes back in time (no response, or a status word received
broken) the controller retries the message on the other bus, ``retries`` times (default
once). Injections (:mod:`~drivers.backends.loopback.injection`) are drawn per attempt.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field

from drivers.backends.loopback.injection import (
    WORD_FAULT_KINDS,
    Injection,
    Injector,
    message_format,
)
from drivers.backends.loopback.schedule import Schedule, ScheduledMessage
from drivers.backends.loopback.terminal import RemoteTerminal, Reply
from drivers.mil1553.encoder import NO_FAULT, WordFault
from drivers.mil1553.timing import SYNC_MID_NS
from drivers.mil1553.wordbatch import SYNC_CMD, SYNC_DATA

_FAULTS = {
    "parity": WordFault(parity=True),
    "manchester": WordFault(no_transition=8),
    "bit_count_low": WordFault(bit_count=-1),
    "bit_count_high": WordFault(bit_count=1),
    "sync": WordFault(inverted_sync=True),
}


@dataclass(slots=True)
class BusWord:
    """One word put on the bus: sync leading edge, bus, nominal sync type, value, fault."""

    t_ns: int
    bus: int
    sync: int
    value: int
    fault: WordFault = NO_FAULT
    end_ns: int = 0
    """Its last mid-bit crossing."""
    stop_ns: int = 0
    """When the line falls idle after it (the next contiguous word's start)."""

    @property
    def valid(self) -> bool:
        """Whether a terminal receives it as a valid word of its nominal sync type."""
        return not self.fault.any


@dataclass(frozen=True, slots=True)
class Burst:
    """Random line states on ``bus`` from ``t_ns`` to ``end_ns``."""

    t_ns: int
    end_ns: int
    bus: int
    seed: int


@dataclass(slots=True)
class Traffic:
    """What one minor frame put on the bus, in time order, and when the bus was quiet again."""

    start_ns: int
    end_ns: int
    words: list[BusWord] = field(default_factory=list)
    bursts: list[Burst] = field(default_factory=list)


@dataclass(frozen=True, slots=True)
class SentMessage:
    """The controller's log of one attempt (what was meant, not what the monitor saw)."""

    t_ns: int
    bus: int
    label: str
    injected: tuple[str, ...]
    answered: bool
    retry: int


class _Attempt:
    """The words of one attempt, placed one after another; applies word-fault injections."""

    def __init__(self, bus: int, t_ns: int, word_ns: float, faults: dict[int, WordFault]
                 ) -> None:
        self.bus = bus
        self.cursor = t_ns
        self.word_ns = word_ns
        self.faults = faults
        self.words: list[BusWord] = []

    def emit(self, value: int, sync: int) -> BusWord:
        fault = self.faults.get(len(self.words), NO_FAULT)
        half = self.word_ns / 40
        length = math.ceil((40 + 2 * fault.bit_count) * half)
        word = BusWord(self.cursor, self.bus, sync, value & 0xFFFF, fault,
                       end_ns=self.cursor + length - round(half), stop_ns=self.cursor + length)
        self.words.append(word)
        self.cursor += length
        return word

    def gap_to(self, after: BusWord, gap_ns: int) -> None:
        """Move the cursor so the next word starts ``gap_ns`` after ``after`` (mid to mid)."""
        self.cursor = max(after.end_ns + gap_ns - SYNC_MID_NS, after.stop_ns)


class BusController:
    """Runs a :class:`Schedule` over a set of terminals; one :meth:`run_frame` per minor frame.

    Times are ns of simulated bus time from 0. ``response_gap_ns`` (default 8 µs, i.e. 6 µs of
    idle line) is the terminals' response time unless a terminal has its own;
    ``intermessage_gap_ns`` (default 10 µs) separates messages; the BC gives up waiting for a
    status word after ``no_response_ns``.
    """

    def __init__(self, schedule: Schedule, terminals: Iterable[RemoteTerminal], *,
                 injector: Injector | None = None, response_gap_ns: int = 8_000,
                 intermessage_gap_ns: int = 10_000, no_response_ns: int = 14_000,
                 retries: int = 1, word_ns: float = 20_000.0, seed: int = 0) -> None:
        self.schedule = schedule
        self.terminals: dict[int, RemoteTerminal] = {}
        for terminal in terminals:
            if terminal.address in self.terminals:
                raise ValueError(f"two terminals at address {terminal.address}")
            self.terminals[terminal.address] = terminal
        self.injector = injector or Injector()
        self.response_gap_ns = response_gap_ns
        self.intermessage_gap_ns = intermessage_gap_ns
        self.no_response_ns = no_response_ns
        self.retries = retries
        self.word_ns = word_ns
        self.seed = seed
        self.frame = 0
        self.time_ns = 0
        self.sequence = 0
        self.queued: list[ScheduledMessage] = []
        self.log: deque[SentMessage] = deque(maxlen=10_000)

    def send(self, message: ScheduledMessage) -> None:
        """Queue a one-off message for the end of the next minor frame."""
        self.queued.append(message)

    def run_frame(self) -> Traffic:
        """Send the next minor frame; the bus time moves to the next frame's start."""
        start = self.time_ns
        traffic = Traffic(start, start)
        t = start + self.intermessage_gap_ns
        messages = self.schedule.frame(self.frame) + self.queued
        self.queued = []
        for message in messages:
            t = self._send(message, t, traffic)
        quiet = max([t] + [w.stop_ns + 4_000 for w in traffic.words] +
                    [b.end_ns + 4_000 for b in traffic.bursts])
        traffic.end_ns = max(start + self.schedule.frame_ns, quiet)
        traffic.words.sort(key=lambda w: w.t_ns)
        self.time_ns = traffic.end_ns
        self.frame += 1
        return traffic

    # --- one message -----------------------------------------------------------------------
    def _send(self, message: ScheduledMessage, t: int, traffic: Traffic) -> int:
        """Send ``message`` at ``t`` (retrying on the other bus); returns the next start."""
        cmd, cmd2 = message.commands()
        fmt = message_format(cmd, cmd2)
        bus = message.bus
        data = message.bc_data(t, self.sequence)
        self.sequence += 1
        for retry in range(self.retries + 1):
            injected = self.injector.take(cmd, cmd2, fmt)
            noise = injected.get("noise")
            if noise is not None:
                traffic.bursts.append(Burst(t, t + noise.duration, bus,
                                            self.seed * 1_000_003 + len(traffic.bursts) +
                                            t % 1_000_000))
                t += noise.duration + self.intermessage_gap_ns
            t_next, answered = self._attempt(cmd, cmd2, list(data), bus, t, injected, traffic)
            self.log.append(SentMessage(t, bus, message.label, tuple(sorted(injected)),
                                        answered, retry))
            t = t_next
            if answered or (cmd >> 11 == 31 and cmd2 is None):
                break
            bus = 1 - bus
        return t

    def _attempt(self, cmd: int, cmd2: int | None, data: list[int], bus: int, t: int,
                 injected: dict[str, Injection], traffic: Traffic) -> tuple[int, bool]:
        """Put one attempt on the bus; returns (next command time, valid status received)."""
        broadcast = cmd >> 11 == 31
        wc = injected.get("word_count_low") or injected.get("word_count_high")
        bc_side = wc is not None and (wc.source or ("bc" if data else "rt")) == "bc"
        if bc_side and wc is not None:
            data = data[:-1] if wc.kind == "word_count_low" else [*data, 0xC0DE]
        total = self._nominal_words(cmd, cmd2, len(data), wc if not bc_side else None)
        faults: dict[int, WordFault] = {}
        for kind in WORD_FAULT_KINDS:
            if kind in injected:
                position = injected[kind].word % total if total else 0
                old = faults.get(position, NO_FAULT)
                new = _FAULTS[kind]
                faults[position] = WordFault(
                    parity=old.parity or new.parity,
                    no_transition=new.no_transition if new.no_transition is not None
                    else old.no_transition,
                    bit_count=old.bit_count + new.bit_count,
                    inverted_sync=old.inverted_sync or new.inverted_sync)
        supersede = "superseded" in injected and len(data) > 1
        att = _Attempt(bus, t, self.word_ns, {} if supersede else faults)
        if supersede:
            # Broken off halfway: the command and some data, then the message again.
            att.emit(cmd, SYNC_CMD)
            for d in data[:len(data) // 2]:
                att.emit(d, SYNC_DATA)
            att.faults = {p + len(att.words): f for p, f in faults.items()}
        first = att.emit(cmd, SYNC_CMD)
        second = att.emit(cmd2, SYNC_CMD) if cmd2 is not None else None
        sent = [att.emit(d, SYNC_DATA) for d in data]
        last = att.words[-1]
        rt_injections = {k: v for k, v in injected.items() if not (k.startswith("word_count")
                                                                    and bc_side)}
        expected = 0 if broadcast else 1
        statuses: list[BusWord] = []
        if cmd2 is None:
            for terminal in self._addressed(cmd >> 11):
                reply = terminal.command(cmd, [w.value for w in sent],
                                         data_valid=all(w.valid for w in sent), bus=bus,
                                         t_ns=t) if first.valid else None
                if reply is not None and not broadcast:
                    status = self._respond(att, terminal, reply, last, 0, rt_injections)
                    if status is not None:
                        statuses.append(status)
        else:
            expected = 1 if broadcast else 2
            tx = self.terminals.get(cmd2 >> 11)
            tx_data: list[BusWord] = []
            if tx is not None and second is not None and second.valid:
                reply = tx.command(cmd2, bus=bus, t_ns=t)
                if reply is not None:
                    status = self._respond(att, tx, reply, last, 0, rt_injections)
                    if status is not None:
                        statuses.append(status)
                        tx_data = att.words[att.words.index(status) + 1:]
                        last = att.words[-1]
            for terminal in self._addressed(cmd >> 11, exclude=cmd2 >> 11):
                reply = terminal.command(cmd, [w.value for w in tx_data],
                                         data_valid=all(w.valid for w in tx_data), bus=bus,
                                         t_ns=t) if first.valid else None
                if reply is not None and not broadcast:
                    status = self._respond(att, terminal, reply, last, 1, rt_injections)
                    if status is not None:
                        statuses.append(status)
        traffic.words += att.words
        answered = len(statuses) == expected and all(s.valid for s in statuses)
        end = att.words[-1].end_ns
        if len(statuses) < expected:
            end = max(end, last.end_ns + self.no_response_ns)
        return end + self.intermessage_gap_ns - SYNC_MID_NS, answered

    def _addressed(self, rt: int, exclude: int | None = None) -> list[RemoteTerminal]:
        if rt == 31:
            return [t for a, t in sorted(self.terminals.items()) if a != exclude]
        terminal = self.terminals.get(rt)
        return [] if terminal is None else [terminal]

    def _nominal_words(self, cmd: int, cmd2: int | None, bc_words: int,
                       wc: Injection | None) -> int:
        """Words the attempt should hold (for word-fault positions counted from the end)."""
        broadcast = cmd >> 11 == 31
        n = 1 + bc_words
        if cmd2 is not None:
            n += 2 + ((cmd2 & 31) or 32) + (0 if broadcast else 1)
        elif not broadcast:
            transmit, sa, count = cmd >> 10 & 1, cmd >> 5 & 31, cmd & 31
            rt_words = (1 if count >= 16 else 0) if sa in (0, 31) else (count or 32)
            n += 1 + (rt_words if transmit else 0)
        if wc is not None:
            n += -1 if wc.kind == "word_count_low" else 1
        return n

    def _respond(self, att: _Attempt, terminal: RemoteTerminal, reply: Reply, after: BusWord,
                 responder: int, injected: dict[str, Injection]) -> BusWord | None:
        """Place a terminal's reply after ``after``; returns its status word (None: silent)."""
        mine = {k: v for k, v in injected.items() if v.responder == responder}
        if "no_response" in mine:
            return None
        gap = terminal.response_gap_ns or self.response_gap_ns
        for kind in ("late_response", "early_response"):
            if kind in mine:
                gap = mine[kind].gap
        status_value = reply.status
        if "wrong_rt_address" in mine:
            status_value = status_value & 0x07FF | ((terminal.address + 1) % 31) << 11
        if "reserved_status_bits" in mine:
            status_value |= 0x0020
        data = list(reply.data)
        if data and "word_count_low" in mine:
            data = data[:-1]
        elif data and "word_count_high" in mine:
            data.append(0xC0DE)
        att.gap_to(after, gap)
        status = att.emit(status_value, SYNC_CMD)
        for d in data:
            att.emit(d, SYNC_DATA)
        if "babbling" in mine:
            extra = 0
            while att.cursor - status.t_ns < mine["babbling"].duration:
                att.emit((0xBABB + extra) & 0xFFFF, SYNC_DATA)
                extra += 1
        return status
