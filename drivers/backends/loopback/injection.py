"""Error injection on the loopback bus: what to break, on which messages, how many times.

An :class:`Injection` names a *kind* of error and a selector; the bus controller asks the
:class:`Injector` for the injections that apply to each message it is about to send (each
attempt: a retry on the other bus is a message of its own, so a one-shot injection leaves the
retry clean). With no selector an injection hits the next message::

    Injection("parity", rt=5, sa=10, tr="T", word=3)   # RT 5's second data word
    Injection("no_response", rt=5, count=2)            # the next two messages to RT 5
    Injection("late_response", gap_ns=13_000)          # the next message, answered late
    Injection("noise", count=None, format="RT_BC")     # a burst before every RT -> BC message
    Injection("manchester", rt=5, skip=9)              # the tenth message to RT 5

Several injections of different kinds may hit the same message; of one kind, the first
pending one that matches is used.

Kinds and what a monitor must then report (:data:`EXPECTED_ERRORS`):

``parity``, ``manchester``, ``bit_count_low``, ``bit_count_high``
    One word sent wrong: ``word`` is its position in the message in bus order (0 = command
    word, as in :attr:`MonitorRecord.word_errors`; negative counts from the end; default -1,
    the last word). A broken command makes the terminal ignore the message; a broken BC data
    word makes it set message error and keep silent; a broken status word makes the BC retry.
``sync``
    The word is sent with the other sync type.
``no_response``
    The responding terminal stays silent (``responder`` 0 = the first one to answer, 1 = the
    receiving terminal of an RT-RT transfer).
``late_response``, ``early_response``
    The response comes after ``gap_ns`` (default 13 µs / 3 µs, mid-crossing to mid-crossing).
``word_count_low``, ``word_count_high``
    One data word too few or too many, sent by ``source`` ("bc" or "rt"; default: the BC when
    the message has BC data, else the terminal).
``babbling``
    The terminal goes on transmitting data words for ``duration_ns`` (default 1 ms) in all.
``noise``
    A burst of random line states of ``duration_ns`` (default 6 µs) just before the message.
``wrong_rt_address``, ``reserved_status_bits``
    The status word carries another address, or a reserved bit.
``superseded``
    The BC breaks off its data words halfway and sends the whole message again at once (the
    new valid command supersedes the first; only messages with BC data words).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from drivers.mil1553.record import TransferFormat

WORD_FAULT_KINDS = ("parity", "manchester", "bit_count_low", "bit_count_high", "sync")
INJECTION_KINDS = (*WORD_FAULT_KINDS, "no_response", "late_response", "early_response",
                   "word_count_low", "word_count_high", "babbling", "noise",
                   "wrong_rt_address", "reserved_status_bits", "superseded")

EXPECTED_ERRORS: dict[str, str] = {kind: kind for kind in INJECTION_KINDS}
"""The error name (:data:`~drivers.mil1553.record.MESSAGE_ERROR_NAMES`) a monitor reports for
each kind. Noise is activity no sync explains, which decoders report as a ``sync`` error."""
EXPECTED_ERRORS["noise"] = "sync"

_DEFAULT_GAP_NS = {"late_response": 13_000, "early_response": 3_000}
_DEFAULT_DURATION_NS = {"babbling": 1_000_000, "noise": 6_000}


@dataclass(slots=True)
class Injection:
    """One error to inject; ``count`` messages are hit (None: every matching message)."""

    kind: str
    rt: int | None = None
    sa: int | None = None
    tr: str | None = None
    format: str | None = None
    count: int | None = 1
    word: int = -1
    responder: int = 0
    source: Literal["bc", "rt"] | None = None
    gap_ns: int | None = None
    duration_ns: int | None = None
    skip: int = 0
    """Let this many matching messages pass first (``skip=4``: hit the fifth)."""
    hits: int = 0
    """How many messages this injection has hit so far."""
    skipped: int = 0

    def __post_init__(self) -> None:
        if self.kind not in INJECTION_KINDS:
            raise ValueError(f"unknown injection {self.kind!r}; known: "
                             f"{', '.join(INJECTION_KINDS)}")
        if self.format is not None and self.format.upper() not in TransferFormat.__members__:
            raise ValueError(f"unknown transfer format {self.format!r}")
        if self.tr is not None and self.tr.upper() not in ("T", "R"):
            raise ValueError(f"tr must be 'T' or 'R', not {self.tr!r}")
        if self.count is not None and self.count < 1:
            raise ValueError(f"count={self.count}: must be at least 1 (None: forever)")

    @property
    def exhausted(self) -> bool:
        return self.count is not None and self.hits >= self.count

    @property
    def gap(self) -> int:
        return self.gap_ns if self.gap_ns is not None else _DEFAULT_GAP_NS.get(self.kind, 0)

    @property
    def duration(self) -> int:
        if self.duration_ns is not None:
            return self.duration_ns
        return _DEFAULT_DURATION_NS.get(self.kind, 0)

    def matches(self, command: int, command2: int | None, fmt: TransferFormat) -> bool:
        """Whether the selector picks a message with these command words and format."""
        rts = {command >> 11} | ({command2 >> 11} if command2 is not None else set())
        sas = {command >> 5 & 31} | ({command2 >> 5 & 31} if command2 is not None else set())
        if self.rt is not None and self.rt not in rts:
            return False
        if self.sa is not None and self.sa not in sas:
            return False
        if self.tr is not None and ("T" if command >> 10 & 1 else "R") != self.tr.upper():
            return False
        return self.format is None or str(fmt) == self.format.upper()


class Injector:
    """The pending injections, consumed as messages match them."""

    def __init__(self, injections: list[Injection] | None = None) -> None:
        self.pending: list[Injection] = list(injections or [])
        self.done: list[Injection] = []

    def add(self, injection: Injection) -> None:
        self.pending.append(injection)

    def take(self, command: int, command2: int | None, fmt: TransferFormat
             ) -> dict[str, Injection]:
        """The injections for this message by kind (first match of each kind), counted."""
        chosen: dict[str, Injection] = {}
        for injection in self.pending:
            if injection.kind not in chosen and injection.matches(command, command2, fmt):
                if injection.skipped < injection.skip:
                    injection.skipped += 1
                    continue
                chosen[injection.kind] = injection
                injection.hits += 1
        for injection in chosen.values():
            if injection.exhausted:
                self.pending.remove(injection)
                self.done.append(injection)
        return chosen


def message_format(command: int, command2: int | None) -> TransferFormat:
    """The transfer format the BC means to send with these command words."""
    rt, transmit, sa, count = command >> 11, command >> 10 & 1, command >> 5 & 31, command & 31
    broadcast = rt == 31
    if command2 is not None:
        return TransferFormat.BCAST_RT_RT if broadcast else TransferFormat.RT_RT
    if sa in (0, 31):
        has_data = count >= 16
        if broadcast:
            return TransferFormat.BCAST_MODE_RX_DATA if has_data else TransferFormat.BCAST_MODE
        if not has_data:
            return TransferFormat.MODE
        return TransferFormat.MODE_TX_DATA if transmit else TransferFormat.MODE_RX_DATA
    if broadcast:
        return TransferFormat.BCAST_BC_RT
    return TransferFormat.RT_BC if transmit else TransferFormat.BC_RT
