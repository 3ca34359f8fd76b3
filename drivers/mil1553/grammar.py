"""The message grammar of one bus, compiled: word arrays in, message boundaries out.

:func:`parse_bus` walks one bus's words (sorted by time) and splits them into messages by the
ten transfer formats and the bus timing rules, exactly as
:mod:`tests.support.assembler_reference` does in Python, at a small fraction of the cost
(that grammar took most of the monitor's CPU; docs/figures.md). It returns numbers only,
one row of :data:`MESSAGE_COLUMNS` per message; the assembler builds the records from them.

Every message covers a contiguous run of words ``START .. NEXT - 1`` in bus order: the
command (two for RT-RT), then data words, with up to two status words at ``S0``/``S1``
(their response gaps ``G0``/``G1``). ``ERR`` is a bit set over
:data:`~drivers.mil1553.record.MESSAGE_ERROR_NAMES` (bit ``i`` = the ``i``-th name) of the
grammar's errors; ``WBITS`` ORs the word-level error bits of the message's words.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.jit import kernel
from drivers.mil1553.modecodes import MODE_CODES
from drivers.mil1553.record import MESSAGE_ERROR_NAMES, TransferFormat
from drivers.mil1553.timing import SYNC_MID_NS, BusTiming

MESSAGE_COLUMNS = ("START", "NEXT", "FMT", "CMD2", "NSTATUS", "S0", "S1", "G0", "G1", "ERR",
                   "WBITS")
"""Columns of :func:`parse_bus`'s output rows (``CMD2`` is -1 when there is none)."""
START, NEXT, FMT, CMD2, NSTATUS, S0, S1, G0, G1, ERR, WBITS = range(len(MESSAGE_COLUMNS))

FORMATS: tuple[TransferFormat, ...] = tuple(TransferFormat)
"""``FMT`` codes: the index of the format in :class:`TransferFormat`."""
_F_BC_RT, _F_RT_BC, _F_RT_RT, _F_MODE, _F_MODE_TX_DATA, _F_MODE_RX_DATA, _F_BCAST_BC_RT, \
    _F_BCAST_RT_RT, _F_BCAST_MODE, _F_BCAST_MODE_RX_DATA, _F_UNKNOWN = range(len(FORMATS))


def _bit(name: str) -> int:
    return 1 << MESSAGE_ERROR_NAMES.index(name)


_E_NO_RESPONSE = _bit("no_response")
_E_EARLY = _bit("early_response")
_E_LATE = _bit("late_response")
_E_COUNT_LOW = _bit("word_count_low")
_E_COUNT_HIGH = _bit("word_count_high")
_E_NON_CONTIGUOUS = _bit("non_contiguous_data")
_E_SYNC = _bit("sync")
_E_WRONG_RT = _bit("wrong_rt_address")
_E_RESERVED_STATUS = _bit("reserved_status_bits")
_E_ILLEGAL = _bit("illegal_format")
_E_RESERVED_MODE = _bit("reserved_mode_code")
_E_BABBLING = _bit("babbling")
_E_INTERMESSAGE = _bit("intermessage_gap_short")
_E_SUPERSEDED = _bit("superseded")
_E_ORPHAN = _bit("orphan_words")

_STATUS_RESERVED = 0x00E0
_STATUS_BUSY_OR_ME = 0x0008 | 0x0400
_BIG_GAP = 1 << 60

_M_HAS_DATA, _M_TRANSMIT, _M_BROADCAST_OK, _M_RESERVED = 1, 2, 4, 8
MODE_TABLE: npt.NDArray[np.int64] = np.array(
    [(_M_HAS_DATA if m.has_data else 0) | (_M_TRANSMIT if m.transmit else 0)
     | (_M_BROADCAST_OK if m.broadcast_allowed else 0) | (_M_RESERVED if m.reserved else 0)
     for m in MODE_CODES], dtype=np.int64)
"""The mode-code table as flag bits, indexed by mode code."""

# Indices of the timing array handed to the kernel.
_T_BREAK, _T_NO_RESPONSE, _T_RESPONSE_MIN, _T_RESPONSE_MAX, _T_INTERMESSAGE, _T_BABBLE = \
    range(6)


def timing_array(timing: BusTiming) -> npt.NDArray[np.int64]:
    """The thresholds :func:`parse_bus` takes, in the order it reads them."""
    return np.array([timing.break_ns, timing.no_response_ns, timing.response_min_ns,
                     timing.response_max_ns, timing.intermessage_min_ns, timing.babble_ns],
                    dtype=np.int64)


@kernel
def _closed(end: npt.NDArray[np.int64], k: int, wait_ns: int, horizon: int,
            has_horizon: bool) -> bool:
    """Whether the stream holds nothing more within ``wait_ns`` after word ``k - 1``."""
    return has_horizon and horizon >= end[k - 1] + wait_ns


@kernel
def _fits_as_command(sync: npt.NDArray[np.int64], value: npt.NDArray[np.int64], k: int,
                     stop: int) -> bool:
    """Whether word ``k`` read as a command is followed by exactly its BC data words."""
    cmd = value[k]
    tx, sa, count = cmd >> 10 & 1, cmd >> 5 & 31, cmd & 31
    if sa == 0 or sa == 31:
        follows = 1 if (MODE_TABLE[count] & _M_HAS_DATA) != 0 and tx == 0 else 0
    else:
        follows = 0 if tx else (count if count else 32)
    rest = stop - k - 1
    if rest == 1 and tx == 0 and follows != 1 and sync[k + 1] != 0 and \
            (value[k + 1] >> 10 & 1) != 0:
        return True  # an RT-RT pair: receive command then transmit command
    return rest == follows


@kernel
def _take_data(end: npt.NDArray[np.int64], sync: npt.NDArray[np.int64],
               value: npt.NDArray[np.int64], gap: npt.NDArray[np.int64],
               stops: npt.NDArray[np.int64], n: int, k: int, stop: int, wanted: int,
               no_response_ns: int, horizon: int, has_horizon: bool, final: bool,
               from_bc: bool) -> tuple[int, int, bool, int, int]:
    """Take up to ``wanted`` data words from ``k``: (next, stop, complete?, taken, errors).

    In the BC's data, a command word the rest of the transmission fits exactly is a new
    command superseding the message; any other command sync there is a data word's sync error.
    """
    errors = 0
    taken = 0
    while taken < wanted:
        if from_bc and k < stop and sync[k] != 0 and _fits_as_command(sync, value, k, stop):
            return k, stop, True, taken, errors | _E_SUPERSEDED | _E_COUNT_LOW
        if k >= stop:
            if k >= n:
                if not final and not _closed(end, k, no_response_ns, horizon, has_horizon):
                    return k, stop, False, taken, errors
                return k, stop, True, taken, errors | _E_COUNT_LOW
            if sync[k] != 0 or gap[k] > no_response_ns:
                return k, stop, True, taken, errors | _E_COUNT_LOW
            errors |= _E_NON_CONTIGUOUS  # data continuing after a break, within the time-out
            stop = stops[k]
        if sync[k] != 0:
            errors |= _E_SYNC
        taken += 1
        k += 1
    return k, stop, True, taken, errors


@kernel
def _message(t: npt.NDArray[np.int64], end: npt.NDArray[np.int64],
             sync: npt.NDArray[np.int64], value: npt.NDArray[np.int64],
             gap: npt.NDArray[np.int64], stops: npt.NDArray[np.int64], n: int, i: int,
             horizon: int, has_horizon: bool, final: bool, timing: npt.NDArray[np.int64],
             time_tags: bool, out: npt.NDArray[np.int64], m: int) -> tuple[int, bool]:
    """Parse the message starting at word ``i`` into row ``m``: (next index, complete?)."""
    break_ns = timing[_T_BREAK]
    no_response_ns = timing[_T_NO_RESPONSE]
    out[m, START] = i
    out[m, CMD2] = -1
    out[m, NSTATUS] = 0
    stop = stops[i]
    if sync[i] == 0:
        # Data words where a command belongs: they fit no message.
        out[m, FMT] = _F_UNKNOWN
        out[m, ERR] = _E_ORPHAN
        return stop, final or _closed(end, stop, break_ns, horizon, has_horizon)
    cmd = value[i]
    k = i + 1
    rt, tx, sa, count = cmd >> 11, cmd >> 10 & 1, cmd >> 5 & 31, cmd & 31
    broadcast = rt == 31
    errors = 0
    fmt = _F_UNKNOWN
    bc_data = 0
    responses = 0               # expected responses: (RT, data words it sends) below
    rt_a = words_a = rt_b = words_b = 0
    if tx == 0 and sa != 0 and sa != 31 and k < stop and sync[k] != 0 and \
            (value[k] >> 10 & 1) != 0:
        # RT to RT: receive command, then transmit command, back to back.
        cmd2 = value[k]
        out[m, CMD2] = cmd2
        k += 1
        rt2, sa2, count2 = cmd2 >> 11, cmd2 >> 5 & 31, cmd2 & 31
        fmt = _F_BCAST_RT_RT if broadcast else _F_RT_RT
        if rt2 == 31 or rt2 == rt or sa2 == 0 or sa2 == 31 or count2 != count:
            errors |= _E_ILLEGAL
        rt_a, words_a, responses = rt2, (count2 if count2 else 32), 1
        if not broadcast:
            rt_b, words_b, responses = rt, 0, 2
    elif sa == 0 or sa == 31:
        flags = MODE_TABLE[count]
        has_data = (flags & _M_HAS_DATA) != 0
        reserved = (flags & _M_RESERVED) != 0
        if reserved:
            errors |= _E_RESERVED_MODE
        legal = reserved or ((flags & _M_TRANSMIT) != 0) == (tx != 0)
        if not legal or (broadcast and (flags & _M_BROADCAST_OK) == 0):
            errors |= _E_ILLEGAL
        bc_data = 1 if has_data and tx == 0 else 0
        if broadcast:
            fmt = _F_BCAST_MODE_RX_DATA if has_data else _F_BCAST_MODE
        else:
            fmt = (_F_MODE_TX_DATA if tx else _F_MODE_RX_DATA) if has_data else _F_MODE
            rt_a, words_a, responses = rt, (1 if has_data and tx else 0), 1
    else:
        words = count if count else 32
        if broadcast:
            fmt = _F_BCAST_BC_RT
            if tx:
                errors |= _E_ILLEGAL  # no terminal may answer a broadcast
            bc_data = 0 if tx else words
        elif tx:
            fmt = _F_RT_BC
            rt_a, words_a, responses = rt, words, 1
        else:
            fmt = _F_BC_RT
            bc_data = words
            rt_a, words_a, responses = rt, 0, 1
    out[m, FMT] = fmt
    # The BC's data words, which may continue past a break (non-contiguous data).
    k, stop, ok, taken, more = _take_data(end, sync, value, gap, stops, n, k, stop, bc_data,
                                          no_response_ns, horizon, has_horizon, final, True)
    errors |= more
    if not ok:
        return k, False
    if (errors & _E_SUPERSEDED) != 0:
        out[m, ERR] = errors
        return k, True
    if k < stop and bc_data == taken:
        errors |= _E_COUNT_HIGH  # the BC went on after the words its command calls for
        k = stop
    for r in range(responses):
        expected_rt = rt_a if r == 0 else rt_b
        data_words = words_a if r == 0 else words_b
        if k >= n:
            if not final and not _closed(end, k, no_response_ns, horizon, has_horizon):
                return k, False
            errors |= _E_NO_RESPONSE
            break
        response_gap = gap[k]
        if response_gap > no_response_ns:
            errors |= _E_NO_RESPONSE
            break
        if time_tags:
            if response_gap < timing[_T_RESPONSE_MIN]:
                errors |= _E_EARLY
            elif response_gap > timing[_T_RESPONSE_MAX]:
                errors |= _E_LATE
        slot = out[m, NSTATUS]
        out[m, S0 + slot] = k
        out[m, G0 + slot] = response_gap
        out[m, NSTATUS] = slot + 1
        status = value[k]
        if sync[k] == 0:
            errors |= _E_SYNC
        if status >> 11 != expected_rt:
            errors |= _E_WRONG_RT
        if (status & _STATUS_RESERVED) != 0:
            errors |= _E_RESERVED_STATUS
        stop = stops[k]
        if (status & _STATUS_BUSY_OR_ME) != 0 and data_words and stop == k + 1:
            data_words = 0  # busy / message error: status only
        start_rt = k
        k, stop, ok, taken, more = _take_data(end, sync, value, gap, stops, n, k + 1, stop,
                                              data_words, no_response_ns, horizon,
                                              has_horizon, final, False)
        errors |= more
        if not ok:
            return k, False
        if k < stop:
            # The terminal went on after the words it owed: they are its own.
            if stop >= n and not final and not _closed(end, stop, break_ns, horizon,
                                                       has_horizon):
                return stop, False
            errors |= _E_COUNT_HIGH
            k = stop
        if end[k - 1] - t[start_rt] > timing[_T_BABBLE]:
            errors |= _E_BABBLING
    # Words still in the last transmission belong to it: too many words.
    if k < stop:
        errors |= _E_COUNT_HIGH
        if end[stop - 1] - t[k] > timing[_T_BABBLE]:
            errors |= _E_BABBLING
        k = stop
    if k >= n and not final and not _closed(end, k, break_ns, horizon, has_horizon):
        return k, False
    out[m, ERR] = errors
    return k, True


@kernel
def parse_bus(t: npt.NDArray[np.int64], end: npt.NDArray[np.int64],
              sync: npt.NDArray[np.int64], value: npt.NDArray[np.int64],
              word_errors: npt.NDArray[np.int64], horizon: int, has_horizon: bool,
              final: bool, timing: npt.NDArray[np.int64], time_tags: bool,
              previous_end: int, has_previous: bool, superseded: bool,
              out: npt.NDArray[np.int64]) -> tuple[int, int, int, bool, bool]:
    """The complete messages of one bus's words, one row of ``out`` (``n`` x 11) each.

    ``previous_end``/``has_previous`` is the end of the last message before these words and
    ``superseded`` whether that one was superseded (the state a stream carries between
    calls). Returns (messages, words used, previous_end, has_previous, superseded).
    """
    n = t.size
    if n == 0:
        return 0, 0, previous_end, has_previous, superseded
    gap = np.empty(n, dtype=np.int64)   # before each word, mid-crossing to mid-crossing
    gap[0] = t[0] + SYNC_MID_NS - previous_end if has_previous else _BIG_GAP
    for i in range(1, n):
        gap[i] = t[i] + SYNC_MID_NS - end[i - 1]
    stops = np.empty(n, dtype=np.int64)  # one past the last word of each word's transmission
    stops[n - 1] = n
    for i in range(n - 2, -1, -1):
        stops[i] = i + 1 if gap[i + 1] > timing[_T_BREAK] else stops[i + 1]
    i = 0
    m = 0
    while i < n:
        j, complete = _message(t, end, sync, value, gap, stops, n, i, horizon, has_horizon,
                               final, timing, time_tags, out, m)
        if not complete:
            break
        errors = out[m, ERR]
        follows = has_previous and not superseded  # a superseding command has no gap
        superseded = (errors & _E_SUPERSEDED) != 0
        if follows and out[m, FMT] != _F_UNKNOWN and time_tags and \
                t[i] + SYNC_MID_NS - previous_end < timing[_T_INTERMESSAGE]:
            errors |= _E_INTERMESSAGE
        previous_end = end[j - 1]
        has_previous = True
        bits = 0
        for x in range(i, j):
            bits |= word_errors[x]
        out[m, ERR] = errors
        out[m, NEXT] = j
        out[m, WBITS] = bits
        m += 1
        i = j
    return m, i, previous_end, has_previous, superseded
