"""The open1553 card's host line protocol: parsing and formatting its lines, splitting bytes.

open1553 (an open FPGA design on a pmod1553 transceiver board) decodes the bus itself and
sends one line per word over a 2,000,000-baud serial link (../shared/REFERENCE.md)::

    CMDS;D1;P1;I0;Hx5555\\r

``CMDS`` (command/status sync) or ``DATA`` (data sync); ``D1`` = at least 4 µs of idle bus
before the word; ``P1`` = parity good; ``I1`` = the word was received inverted; then the 16
bits in hex. Here: :func:`parse_line` / :func:`format_line` (the emulator in the tests speaks
the protocol through the same function) and :class:`LineSplitter` (bytes to lines,
resynchronizing on the next terminator after garbage).

The card sends no time tags, and its link is slower than the bus (a 21-byte line takes 105 µs
at 2 Mbaud, a bus word 20 µs), so host arrival times say nothing about µs gaps: word times
come from :mod:`drivers.backends.open1553_framer`, from the card's report alone.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from drivers.mil1553.wordbatch import SYNC_CMD, SYNC_DATA

BAUD_RATE = 2_000_000
MAX_LINE = 64
"""Longer runs without a terminator are garbage: they are cut and flagged."""
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
