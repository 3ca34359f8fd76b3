"""Word times for the open1553 card from the card's own report, never from host timing.

The card sends no time tags (drivers/backends/open1553.py): per word only its sync type and
the ``D`` flag (at least 4 µs of idle bus before it). Host arrival times cannot stand in for
bus times: the link is slower than the bus, a USB serial adapter delivers bytes in bursts,
and a busy host reads late. A framing that looked at when lines arrived would cut messages
wherever the host's scheduler paused the reader.

:class:`LineFramer` therefore decides every message boundary from what the card reported:

- a ``D0`` word is contiguous with the word before it (20 µs later);
- a ``D1`` word is either the response the message in progress is waiting for (a status
  word, or its non-contiguous data) and gets a nominal response gap (:data:`RESPONSE_GAP_NS`),
  or it starts a new message and gets an idle gap longer than the no-response time-out
  (:data:`IDLE_GAP_NS`). Which one follows from the 1553 grammar: the framer tracks what the
  message in progress still owes (the BC's data, each expected status and the data behind
  it) exactly as the assembler will parse it. A ``D1`` word is taken as the awaited status only
  if it has a command/status sync, the expected RT address and no reserved status bit set;
  otherwise the command went unanswered and the word opens the next message.
- :meth:`LineFramer.quiet` is called when the reader saw the link empty for a whole read
  time-out (an empty read: the kernel held no byte for that long, whatever the host's load).
  The card sends each word within one line time (105 µs) of the bus, so an empty link means an
  idle bus: a response still awaited will not come.

The assembler is fed with :func:`horizon`: a bus still reporting holds it at its last word
(the next word may still belong to the message in progress); a bus seen quiet holds nothing
back, since its next word can only open a message, placed past the horizon.

What the card cannot tell apart (no gap lengths): a status word with a wrong RT address or a
reserved bit reads as no response followed by a word of its own; a command to the same RT
whose subaddress is a multiple of 8 (mode codes included), right after an unanswered command,
reads as that command's status. Response times are never measured (``gaps_ns`` are nominal).

New messages are anchored to host arrival time when that is later than the synthetic
timeline, so record times stay near wall time; this moves timestamps only, never a boundary.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from drivers.mil1553.modecodes import MODE_CODES
from drivers.mil1553.timing import SYNC_MID_NS
from drivers.mil1553.wordbatch import SYNC_CMD, WORD_TIME_NS

RESPONSE_GAP_NS = 8_000
"""The gap given to a response (mid-crossing to mid-crossing, inside the standard's 4-12 µs)."""
IDLE_GAP_NS = 40_000
"""The gap before a word that opens a message: past the 14 µs no-response time-out."""
_END_TO_MID = WORD_TIME_NS - 500
_STATUS_RESERVED = 0x00E0


@dataclass
class _Owed:
    """What the message in progress still expects, in order."""

    bc_data: int = 0
    """Data words the BC still sends after its command."""
    responses: list[tuple[int, int]] = field(default_factory=list)
    """(RT address, data words it sends after its status), for each status still awaited."""
    rt_data: int = 0
    """Data words still owed behind the status word just received."""
    receive_command: int | None = None
    """A receive command just seen: a transmit command right behind it makes an RT-RT."""

    @property
    def nothing(self) -> bool:
        return not (self.bc_data or self.responses or self.rt_data)


def _owed_by(command: int) -> _Owed:
    """What a command (the first word of a message) calls for, as the assembler parses it."""
    rt, tx, sa, count = command >> 11, bool(command >> 10 & 1), command >> 5 & 31, command & 31
    broadcast = rt == 31
    if sa in (0, 31):
        mode = MODE_CODES[count]
        bc_data = 1 if mode.has_data and not tx else 0
        responses = [] if broadcast else [(rt, 1 if mode.has_data and tx else 0)]
        return _Owed(bc_data=bc_data, responses=responses)
    words = count or 32
    if broadcast:
        return _Owed(bc_data=0 if tx else words,
                     receive_command=None if tx else command)
    if tx:
        return _Owed(responses=[(rt, words)])
    return _Owed(bc_data=words, responses=[(rt, 0)], receive_command=command)


class LineFramer:
    """Synthetic word times for one bus (see the module docstring)."""

    def __init__(self) -> None:
        self.last_t: int | None = None
        self._owed = _Owed()
        self._floor = 0
        """No word may be placed at or before a horizon already handed out."""
        self.idle = True
        """No word since the link was last seen quiet (or none yet)."""

    def place(self, sync: int, gap: bool, value: int, arrival_wall_ns: int) -> int:
        """The sync leading-edge time of the next word the card reported."""
        previous = self.last_t
        if previous is None or self.idle:
            t = max(arrival_wall_ns, self._floor + 1)
            if previous is not None:
                t = max(t, previous + _END_TO_MID + IDLE_GAP_NS - SYNC_MID_NS)
            self._start(sync, value)
        elif not gap:
            t = previous + WORD_TIME_NS
            self._contiguous(sync, value)
        elif self._is_response(sync, value):
            t = previous + _END_TO_MID + RESPONSE_GAP_NS - SYNC_MID_NS
        else:
            t = max(previous + _END_TO_MID + IDLE_GAP_NS - SYNC_MID_NS, arrival_wall_ns,
                    self._floor + 1)
            self._start(sync, value)
        self.last_t = t
        self.idle = False
        return t

    def place_unreadable(self, arrival_wall_ns: int) -> int:
        """A line that did not parse: a data word owed takes its place (contiguous, so the
        message it belongs to is flagged); otherwise it opens a record of its own."""
        owed = self._owed
        if self.last_t is not None and (owed.bc_data or owed.rt_data):
            if owed.bc_data:
                owed.bc_data -= 1
            else:
                owed.rt_data -= 1
            owed.receive_command = None
            self.last_t += WORD_TIME_NS
            return self.last_t
        t = self.place(0, True, 0, arrival_wall_ns)
        self._owed = _Owed()
        return t

    def _start(self, sync: int, value: int) -> None:
        self._owed = _owed_by(value) if sync == SYNC_CMD else _Owed()

    def _contiguous(self, sync: int, value: int) -> None:
        owed = self._owed
        receive, owed.receive_command = owed.receive_command, None
        if receive is not None and sync == SYNC_CMD and value >> 10 & 1:
            # RT to RT: the transmit command follows the receive command back to back.
            rt, rt2, count2 = receive >> 11, value >> 11, value & 31
            owed.bc_data = 0
            owed.responses = [(rt2, count2 or 32)] + ([] if rt == 31 else [(rt, 0)])
        elif owed.bc_data:
            owed.bc_data -= 1
        elif owed.rt_data:
            owed.rt_data -= 1

    def _is_response(self, sync: int, value: int) -> bool:
        owed = self._owed
        owed.receive_command = None
        if owed.bc_data or owed.rt_data:
            # Data broken off and going on after a gap (non-contiguous data), if data sync.
            if sync == SYNC_CMD:
                return False
            if owed.bc_data:
                owed.bc_data -= 1
            else:
                owed.rt_data -= 1
            return True
        if not owed.responses or sync != SYNC_CMD:
            return False
        rt, data_words = owed.responses[0]
        if value >> 11 != rt or value & _STATUS_RESERVED:
            return False
        owed.responses.pop(0)
        owed.rt_data = data_words
        return True

    def quiet(self) -> None:
        """The link was seen empty for a whole read time-out: the bus is idle, nothing more
        belongs to the message in progress, and the next word opens a message."""
        self._owed = _Owed()
        self.idle = True

    def end(self) -> int | None:
        """The end of the last word placed (None before any)."""
        return None if self.last_t is None else self.last_t + _END_TO_MID

    def settled(self) -> int | None:
        """Once the bus is idle: a time past the no-response time-out after its last word,
        up to which this bus's stream is complete; None while words may still follow."""
        end = self.end()
        if end is None or not self.idle:
            return None
        return end + IDLE_GAP_NS - SYNC_MID_NS - 1

    def raise_floor(self, horizon_ns: int) -> None:
        """A horizon handed to the assembler: no later word may be placed at or before it."""
        self._floor = max(self._floor, horizon_ns)

    def restart(self) -> None:
        """After a reconnect: words lost, the next word is anchored to its arrival time."""
        self.last_t = None
        self._owed = _Owed()
        self.idle = True


def horizon(framers: list[LineFramer]) -> int | None:
    """The time up to which every bus's word stream is known complete.

    A bus that is active (words came since it was last seen quiet) holds the horizon at the
    end of its last word: the next word it reports may still belong to its message in
    progress (a status, or data words beyond the count, which the assembler must see). A bus
    seen quiet holds nothing back: its next word opens a message and is placed past the
    horizon. With every bus quiet, the horizon passes the no-response time-out after the
    latest word, so the last messages come out. The horizon is recorded in every framer."""
    active = [end for f in framers if not f.idle and (end := f.end()) is not None]
    if active:
        found = min(active)
    else:
        settled = [s for f in framers if (s := f.settled()) is not None]
        if not settled:
            return None
        found = max(settled)
    for framer in framers:
        framer.raise_floor(found)
    return found
