"""The open1553 card's host line protocol, and word times for a card without time tags.

open1553 (an open FPGA design on a pmod1553 transceiver board) decodes the bus itself and
sends one line per word over a 2,000,000-baud serial link (../shared/REFERENCE.md)::

    CMDS;D1;P1;I0;Hx5555\\r

``CMDS`` (command/status sync) or ``DATA`` (data sync); ``D1`` = at least 4 µs of idle bus
before the word; ``P1`` = parity good; ``I1`` = the word was received inverted; then the 16
bits in hex. Here: :func:`parse_line` / :func:`format_line` (the emulator in the tests speaks
the protocol through the same function), :class:`LineSplitter` (bytes to lines, resynchronizing
on the next terminator after garbage) and :class:`WordClock`, which gives each word a time.

Why a synthetic clock: the card sends no time tags, and its link is slower than the bus (a
21-byte line takes 105 µs at 2 Mbaud, a bus word 20 µs), so host arrival times say nothing
about µs gaps. :class:`WordClock` therefore lays words out on a synthetic timeline the message
assembler can segment: a ``D0`` word 20 µs after the previous one (contiguous), a ``D1`` word
a nominal response gap after it — unless the link sat idle for ``idle_ns`` before the line
came, in which case the bus was idle too, and the word is anchored to its host arrival time.
Response times are thus never measured on this card; ``no_response`` is seen only when the bus
falls idle for ``idle_ns`` after the unanswered command.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from drivers.mil1553.timing import SYNC_MID_NS
from drivers.mil1553.wordbatch import SYNC_CMD, SYNC_DATA, WORD_TIME_NS

BAUD_RATE = 2_000_000
MAX_LINE = 64
"""Longer runs without a terminator are garbage: they are cut and flagged."""
RESPONSE_GAP_NS = 8_000
"""The gap given to a ``D1`` word that came without link idle (mid-crossing to mid-crossing,
inside the standard's 4-12 µs response window)."""
_END_TO_MID = WORD_TIME_NS - 500
_LINE = re.compile(rb"(CMDS|DATA);D([01]);P([01]);I([01]);Hx([0-9A-Fa-f]{4})")


@dataclass(frozen=True, slots=True)
class LineWord:
    """One word as the card reports it."""

    sync: int
    """:data:`~drivers.mil1553.wordbatch.SYNC_CMD` or ``SYNC_DATA``."""
    gap: bool
    parity_ok: bool
    inverted: bool
    value: int


def parse_line(line: bytes) -> LineWord | None:
    """A line without its terminator, parsed; None when it is not a well-formed word."""
    match = _LINE.fullmatch(line.strip(b" \t\n\r\0"))
    if match is None:
        return None
    kind, gap, parity, inverted, value = match.groups()
    return LineWord(SYNC_CMD if kind == b"CMDS" else SYNC_DATA, gap == b"1", parity == b"1",
                    inverted == b"1", int(value, 16))


def format_line(word: LineWord) -> bytes:
    """The line the card sends for ``word`` (terminator included)."""
    kind = "CMDS" if word.sync == SYNC_CMD else "DATA"
    return (f"{kind};D{int(word.gap)};P{int(word.parity_ok)};I{int(word.inverted)};"
            f"Hx{word.value:04X}\r").encode("ascii")


class LineSplitter:
    """Bytes in, complete lines out. ``\\r`` or ``\\n`` ends a line; empty lines are skipped;
    a run longer than :data:`MAX_LINE` is cut (and will fail to parse), so the stream
    resynchronizes at the next terminator whatever came before."""

    def __init__(self) -> None:
        self._partial = b""

    def feed(self, data: bytes) -> list[bytes]:
        parts = re.split(rb"[\r\n]", self._partial + data)
        self._partial = parts.pop()
        if len(self._partial) > MAX_LINE:
            parts.append(self._partial)
            self._partial = b""
        return [p for p in parts if p.strip(b" \t\0")]

    def reset(self) -> bytes:
        """Forget a partial line (after a reconnect); returns what was dropped."""
        dropped, self._partial = self._partial, b""
        return dropped


class WordClock:
    """Synthetic word times for one bus (see the module docstring).

    ``place(gap, arrival_wall_ns, arrival_mono_ns)`` returns the sync leading-edge time of the
    next word; ``idle_ns`` is how long the link must stay quiet before a line to count as an
    idle bus.
    """

    def __init__(self, idle_ns: int) -> None:
        self.idle_ns = idle_ns
        self.last_t: int | None = None
        self._last_mono: int | None = None

    def place(self, gap: bool, arrival_wall_ns: int, arrival_mono_ns: int) -> int:
        previous, quiet_since = self.last_t, self._last_mono
        self._last_mono = arrival_mono_ns
        if previous is None or quiet_since is None:
            t = arrival_wall_ns
        elif not gap:
            t = previous + WORD_TIME_NS
        else:
            t = previous + _END_TO_MID + RESPONSE_GAP_NS - SYNC_MID_NS
            if arrival_mono_ns - quiet_since >= self.idle_ns:
                t = max(t, arrival_wall_ns)
        self.last_t = t
        return t

    def horizon(self, now_wall_ns: int, now_mono_ns: int) -> int | None:
        """Up to when this bus's word stream is known complete: the last word's end while
        lines flow; the present once the link has been quiet for ``idle_ns`` (the next word
        will then be anchored at its arrival). None before any word."""
        if self.last_t is None or self._last_mono is None:
            return None
        end = self.last_t + _END_TO_MID
        if now_mono_ns - self._last_mono >= self.idle_ns:
            return max(end, now_wall_ns)
        return end

    def restart(self) -> None:
        """After a reconnect: the next word is anchored to its arrival time."""
        self.last_t = self._last_mono = None
