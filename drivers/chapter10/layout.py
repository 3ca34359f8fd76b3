"""Words stored in bus order, split into command, status and data as the transfer format says.

A Chapter 10 MS1553F1 message stores every word the recorder saw, in bus order, with no
word-type marks. The command word (two for RT-RT, which the block status word flags) decides
the transfer format, and the format decides which word is which::

    BC-RT         cmd  data x wc  status          RT-BC        cmd  status  data x wc
    RT-RT         rx-cmd  tx-cmd  tx-status  data x wc  rx-status
    mode, no data cmd  status                     mode, T data cmd  status  data
    mode, R data  cmd  data  status               broadcast    as above, with no status

A message that timed out holds only what was on the bus: the words up to the status the
silent terminal owed (the command alone for a transmit command; the command and its data for
a receive command; both commands, or everything but the receiver's status, for RT-RT). Too
few words cut the layout short; words beyond it are data (the last word stays the status
when the format ends with one and nobody timed out).

:func:`split_message` also finds again the errors the block status word has no bit for but
the words and gaps show (status from the wrong RT, reserved status bits, early or late
response, reserved mode code, illegal format), so a replayed record reads like a live one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

from drivers.mil1553.modecodes import MODE_CODES, direction_legal
from drivers.mil1553.record import TransferFormat
from drivers.mil1553.timing import BusTiming
from drivers.mil1553.words import BROADCAST_RT, MODE_SUBADDRESSES

_STATUS_RESERVED = 0x00E0
_TIMING = BusTiming()

COMMAND, DATA, STATUS = "C", "D", "S"


@dataclass(frozen=True, slots=True)
class Layout:
    """The roles of a complete message's words in bus order, and where each terminal's
    status word would be (``status_positions``, with the RT expected to send it)."""

    format: TransferFormat
    roles: tuple[str, ...]
    status_positions: tuple[tuple[int, int], ...]
    errors: frozenset[str]
    """Errors the command word(s) alone show (reserved mode code, illegal format)."""

    data_start: int = field(init=False)
    """Where the data words' run starts (where it would, when there is none)."""
    data_count: int = field(init=False)

    def __post_init__(self) -> None:
        roles = self.roles
        if DATA in roles:
            start = roles.index(DATA)
        else:
            start = len(roles) - 1 if roles[-1] == STATUS else len(roles)
        object.__setattr__(self, "data_start", start)
        object.__setattr__(self, "data_count", roles.count(DATA))


@dataclass(frozen=True, slots=True)
class SplitMessage:
    """One stored message split into its parts."""

    format: TransferFormat
    command: int
    command2: int | None
    data: tuple[int, ...]
    status: tuple[int, ...]
    expected_words: int
    """Words a message with these commands holds, up to a timed-out terminal's status."""
    errors: frozenset[str]


@lru_cache(maxsize=8192)
def layout_for(command: int, command2: int | None) -> Layout:
    """The complete layout of a message starting with ``command`` (and, for RT-RT, the
    transmit command ``command2``)."""
    rt, tx, sa, count = command >> 11, bool(command >> 10 & 1), command >> 5 & 31, command & 31
    broadcast = rt == BROADCAST_RT
    errors: set[str] = set()
    if command2 is not None:
        rt2, sa2, count2 = command2 >> 11, command2 >> 5 & 31, command2 & 31
        if (tx or not command2 >> 10 & 1 or rt2 in (BROADCAST_RT, rt)
                or sa in MODE_SUBADDRESSES or sa2 in MODE_SUBADDRESSES or count2 != count):
            errors.add("illegal_format")
        roles = [COMMAND, COMMAND, STATUS, *[DATA] * (count2 or 32)]
        statuses = [(2, rt2)]
        if not broadcast:
            statuses.append((len(roles), rt))
            roles.append(STATUS)
        fmt = TransferFormat.BCAST_RT_RT if broadcast else TransferFormat.RT_RT
        return Layout(fmt, tuple(roles), tuple(statuses), frozenset(errors))
    if sa in MODE_SUBADDRESSES:
        mode = MODE_CODES[count]
        if mode.reserved:
            errors.add("reserved_mode_code")
        if not direction_legal(count, tx) or (broadcast and not mode.broadcast_allowed):
            errors.add("illegal_format")
        if broadcast:
            fmt = TransferFormat.BCAST_MODE_RX_DATA if mode.has_data else \
                TransferFormat.BCAST_MODE
            roles = [COMMAND, DATA] if mode.has_data and not tx else [COMMAND]
            return Layout(fmt, tuple(roles), (), frozenset(errors))
        if not mode.has_data:
            return Layout(TransferFormat.MODE, (COMMAND, STATUS), ((1, rt),), frozenset(errors))
        if tx:
            return Layout(TransferFormat.MODE_TX_DATA, (COMMAND, STATUS, DATA), ((1, rt),),
                          frozenset(errors))
        return Layout(TransferFormat.MODE_RX_DATA, (COMMAND, DATA, STATUS), ((2, rt),),
                      frozenset(errors))
    words = count or 32
    if broadcast:
        if tx:
            errors.add("illegal_format")  # no terminal may answer a broadcast
        roles = [COMMAND] if tx else [COMMAND, *[DATA] * words]
        return Layout(TransferFormat.BCAST_BC_RT, tuple(roles), (), frozenset(errors))
    if tx:
        return Layout(TransferFormat.RT_BC, (COMMAND, STATUS, *[DATA] * words), ((1, rt),),
                      frozenset(errors))
    return Layout(TransferFormat.BC_RT, (COMMAND, *[DATA] * words, STATUS),
                  ((words + 1, rt),), frozenset(errors))


@dataclass(frozen=True, slots=True)
class SplitPlan:
    """Where a stored message's parts sit, from its command word(s), its word count and its
    time-out flag alone: what :func:`split_message` slices by, and what the batch reader
    (:mod:`drivers.chapter10.ms1553_batch`) computes once per distinct message shape."""

    format: TransferFormat
    data_start: int
    data_count: int
    status_positions: tuple[tuple[int, int], ...]
    """(position in the message, RT expected to send it) per status word kept."""
    expected_words: int
    errors: frozenset[str]


@lru_cache(maxsize=16384)
def split_plan(command: int, command2: int | None, n: int, timed_out: bool) -> SplitPlan:
    """The split of an ``n``-word message starting with ``command`` (``command2``: the
    transmit command of an RT-RT transfer; ``timed_out``: the block status TM flag)."""
    layout = layout_for(command, command2)
    size, start, count = len(layout.roles), layout.data_start, layout.data_count
    statuses = list(layout.status_positions)
    if timed_out and statuses:
        # The silent terminal is the first whose status would sit at or past the words kept.
        size = next((pos for pos, _ in statuses if pos >= n), statuses[-1][0])
        statuses = [s for s in statuses if s[0] < size]
        if start >= size:
            start, count = size, 0
        count = min(start + count, size) - start
    expected = size
    if n > size:
        if statuses and statuses[-1][0] == size - 1 and not timed_out:
            statuses[-1] = (n - 1, statuses[-1][1])  # the last word stays the status
        count += n - size
    elif n < size:
        statuses = [s for s in statuses if s[0] < n]
        count = max(0, min(start + count, n) - start)
    return SplitPlan(layout.format, start, count, tuple(statuses), expected, layout.errors)


def split_message(words: tuple[int, ...], *, rt_to_rt: bool, timed_out: bool,
                  gaps_ns: tuple[int, ...] = (), timing: BusTiming | None = None
                  ) -> SplitMessage:
    """Split a stored message (``words`` in bus order, at least one) into its parts.

    ``rt_to_rt`` and ``timed_out`` are the block status word's RR and TM flags; ``gaps_ns``
    the response gaps in bus order, checked against ``timing`` (early/late response).
    In every format the data words are one run, so the split is slicing, not a pass per word.
    """
    timing = timing or _TIMING
    n = len(words)
    command = words[0]
    command2 = words[1] if rt_to_rt and n > 1 else None
    plan = split_plan(command, command2, n, timed_out)
    statuses = plan.status_positions
    data = words[plan.data_start:plan.data_start + plan.data_count]
    status = tuple(words[pos] for pos, _ in statuses)
    errors = set(plan.errors)
    for word, (_, owner) in zip(status, statuses, strict=True):
        if word >> 11 != owner:
            errors.add("wrong_rt_address")
        if word & _STATUS_RESERVED:
            errors.add("reserved_status_bits")
    for gap in gaps_ns[:len(status)]:
        if gap == 0:
            continue  # not measured: no response gap is shorter than contiguous words
        if gap < timing.response_min_ns:
            errors.add("early_response")
        elif gap > timing.response_max_ns:
            errors.add("late_response")
    return SplitMessage(plan.format, command, command2, data, status, plan.expected_words,
                        frozenset(errors))
