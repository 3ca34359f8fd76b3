"""The message grammar in plain Python: the reference the compiled grammar is checked against.

:class:`ReferenceAssembler` is :class:`~drivers.mil1553.assembler.MessageAssembler` with its
one-bus pass written as readable Python (slow: docs/figures.md), as the assembler was before
the grammar was compiled. It returns exactly the same records; the tests compare the two on
random and adversarial word streams, so the compiled kernel has a specification to meet.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drivers.mil1553.assembler import MessageAssembler
from drivers.mil1553.modecodes import MODE_CODES, direction_legal
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.mil1553.timing import SYNC_MID_NS
from drivers.mil1553.wordbatch import BUS_NAMES, WORD_ERROR_NAMES, WordBatch

_STATUS_RESERVED = 0x00E0
_STATUS_BUSY = 0x0008
_STATUS_ME = 0x0400
_BIG_GAP = 1 << 60
_ERROR_TEXT = {bit: name for bit, name in WORD_ERROR_NAMES}


@dataclass
class _Words:
    """One bus's words as Python lists, for the per-transmission pass."""

    t: list[int]
    end: list[int]
    sync: list[int]
    value: list[int]
    errors: list[int]
    gap: list[int]
    """Gap before each word, mid-crossing to mid-crossing (huge for the first)."""
    stop: list[int]
    """Index one past the last word of each word's transmission."""
    syncs_before: list[int]
    """Command/status-sync words before each index (prefix sum), to test slices at once."""
    errors_before: list[int]
    """Words with errors before each index (prefix sum)."""


@dataclass
class _Message:
    start: int
    fmt: TransferFormat
    command: int
    command2: int | None = None
    data: list[int] = field(default_factory=list)
    status: list[int] = field(default_factory=list)
    gaps: list[int] = field(default_factory=list)
    errors: set[str] = field(default_factory=set)
    positions: list[int] = field(default_factory=list)
    """Word indices in bus order (for word errors)."""


class ReferenceAssembler(MessageAssembler):
    """The assembler with the grammar in Python (same records, slower)."""

    # --- one bus ---------------------------------------------------------------------------
    def _assemble(self, batch: WordBatch, bus: int, horizon_ns: int | None,
                  final: bool = False) -> tuple[list[MonitorRecord], int]:
        if batch.size == 0:
            return [], 0
        w = _prepare(batch, self.timing.break_ns, self._previous_end[bus])
        n = len(w.t)
        records: list[MonitorRecord] = []
        i = 0
        while i < n:
            msg, j, complete = self._message(w, i, n, horizon_ns, final)
            if not complete:
                break
            previous = self._previous_end[bus]
            if self._superseded[bus]:
                previous = None  # a superseding command follows its victim without a gap
            self._superseded[bus] = "superseded" in msg.errors
            if previous is not None and msg.fmt is not TransferFormat.UNKNOWN and \
                    w.t[i] + SYNC_MID_NS - previous < self.timing.intermessage_min_ns and \
                    self.time_tags:
                msg.errors.add("intermessage_gap_short")
            self._previous_end[bus] = w.end[j - 1]
            records.append(_record(msg, w, bus, j))
            i = j
        return records, i

    def _message(self, w: _Words, i: int, n: int, horizon: int | None, final: bool
                 ) -> tuple[_Message, int, bool]:
        """Parse the message starting at word ``i``: (message, next index, complete?)."""
        timing = self.timing
        stop = w.stop[i]
        if not w.sync[i]:
            # Data words where a command belongs: they fit no message.
            msg = _Message(i, TransferFormat.UNKNOWN, -1, errors={"orphan_words"})
            msg.data = w.value[i:stop]
            msg.positions = list(range(i, stop))
            return msg, stop, final or _closed(w, stop, wait_ns=timing.break_ns, horizon=horizon)
        cmd = w.value[i]
        msg = _Message(i, TransferFormat.UNKNOWN, cmd, positions=[i])
        k = i + 1
        rt, tx, sa, count = cmd >> 11, bool(cmd >> 10 & 1), cmd >> 5 & 31, cmd & 31
        broadcast = rt == 31
        responses: list[tuple[int, int]] = []  # (expected RT, data words it sends)
        bc_data = 0
        if (not tx and sa not in (0, 31) and k < stop and w.sync[k]
                and w.value[k] >> 10 & 1):
            # RT to RT: receive command, then transmit command, back to back.
            cmd2 = w.value[k]
            msg.command2 = cmd2
            msg.positions.append(k)
            k += 1
            rt2, sa2, count2 = cmd2 >> 11, cmd2 >> 5 & 31, cmd2 & 31
            msg.fmt = TransferFormat.BCAST_RT_RT if broadcast else TransferFormat.RT_RT
            if rt2 == 31 or rt2 == rt or sa2 in (0, 31) or count2 != count:
                msg.errors.add("illegal_format")
            responses.append((rt2, count2 or 32))
            if not broadcast:
                responses.append((rt, 0))
        elif sa in (0, 31):
            mode = MODE_CODES[count]
            if mode.reserved:
                msg.errors.add("reserved_mode_code")
            if not direction_legal(count, tx) or (broadcast and not mode.broadcast_allowed):
                msg.errors.add("illegal_format")
            bc_data = 1 if mode.has_data and not tx else 0
            if broadcast:
                msg.fmt = TransferFormat.BCAST_MODE_RX_DATA if mode.has_data else \
                    TransferFormat.BCAST_MODE
            else:
                msg.fmt = (TransferFormat.MODE_TX_DATA if tx else TransferFormat.MODE_RX_DATA) \
                    if mode.has_data else TransferFormat.MODE
                responses.append((rt, 1 if mode.has_data and tx else 0))
        else:
            words = count or 32
            if broadcast:
                msg.fmt = TransferFormat.BCAST_BC_RT
                if tx:
                    msg.errors.add("illegal_format")  # no terminal may answer a broadcast
                bc_data = 0 if tx else words
            elif tx:
                msg.fmt = TransferFormat.RT_BC
                responses.append((rt, words))
            else:
                msg.fmt = TransferFormat.BC_RT
                bc_data = words
                responses.append((rt, 0))
        # The BC's data words, which may continue past a break (non-contiguous data).
        k, stop, ok = self._take_data(w, msg, k, stop, bc_data, n, horizon, final, from_bc=True)
        if not ok:
            return msg, k, False
        if "superseded" in msg.errors:
            return msg, k, True
        if k < stop and bc_data == len(msg.data):
            # The BC went on sending after the words its command calls for.
            msg.errors.add("word_count_high")
            msg.data += w.value[k:stop]
            msg.positions += range(k, stop)
            k = stop
        for expected_rt, data_words in responses:
            if k >= n:
                if not final and not _closed(w, k, wait_ns=timing.no_response_ns,
                                             horizon=horizon):
                    return msg, k, False
                msg.errors.add("no_response")
                break
            gap = w.gap[k]
            if gap > timing.no_response_ns:
                msg.errors.add("no_response")
                break
            if self.time_tags:
                if gap < timing.response_min_ns:
                    msg.errors.add("early_response")
                elif gap > timing.response_max_ns:
                    msg.errors.add("late_response")
            msg.gaps.append(gap)
            status = w.value[k]
            msg.status.append(status)
            msg.positions.append(k)
            if not w.sync[k]:
                msg.errors.add("sync")
            if status >> 11 != expected_rt:
                msg.errors.add("wrong_rt_address")
            if status & _STATUS_RESERVED:
                msg.errors.add("reserved_status_bits")
            stop = w.stop[k]
            if status & (_STATUS_BUSY | _STATUS_ME) and data_words:
                data_words = 0 if stop == k + 1 else data_words  # busy/ME: status only
            start_rt = k
            k, stop, ok = self._take_data(w, msg, k + 1, stop, data_words, n, horizon, final)
            if not ok:
                return msg, k, False
            if k < stop:
                # The terminal went on after the words it owed: they are its, not the next
                # terminal's status (which, having received too many, will not come).
                if stop >= n and not final and not _closed(w, stop, wait_ns=timing.break_ns,
                                                           horizon=horizon):
                    return msg, stop, False
                msg.errors.add("word_count_high")
                msg.data += w.value[k:stop]
                msg.positions += range(k, stop)
                k = stop
            if w.end[k - 1] - w.t[start_rt] > timing.babble_ns:
                msg.errors.add("babbling")
        # Words still in the last transmission belong to it: too many words.
        if k < stop:
            msg.errors.add("word_count_high")
            msg.data += w.value[k:stop]
            msg.positions += range(k, stop)
            if w.end[stop - 1] - w.t[k] > timing.babble_ns:
                msg.errors.add("babbling")
            k = stop
        if k >= n and not final and not _closed(w, k, wait_ns=timing.break_ns, horizon=horizon):
            return msg, k, False
        return msg, k, True

    def _take_data(self, w: _Words, msg: _Message, k: int, stop: int, wanted: int, n: int,
                   horizon: int | None, final: bool, from_bc: bool = False
                   ) -> tuple[int, int, bool]:
        """Append up to ``wanted`` data words from ``k``; returns (next, stop, complete).

        In the BC's data, a command word that the rest of the transmission fits exactly
        (the data words it calls for, no more, no less) is a new command superseding this
        message (the standard: a new valid command supersedes one in progress); any other
        command-sync word there is a data word with the wrong sync.
        """
        if k + wanted <= stop and w.syncs_before[k + wanted] == w.syncs_before[k]:
            # The common case: all the words are there, contiguous, with data syncs.
            msg.data += w.value[k:k + wanted]
            msg.positions += range(k, k + wanted)
            return k + wanted, stop, True
        taken = 0
        while taken < wanted:
            if from_bc and k < stop and w.sync[k] and _fits_as_command(w, k, stop):
                msg.errors.update(("superseded", "word_count_low"))
                return k, stop, True
            if k >= stop:
                # The transmission broke off: data continuing within the time-out is
                # non-contiguous; anything else means words are missing.
                if k >= n:
                    if not final and not _closed(w, k, wait_ns=self.timing.no_response_ns,
                                                 horizon=horizon):
                        return k, stop, False
                    msg.errors.add("word_count_low")
                    return k, stop, True
                if w.sync[k] or w.gap[k] > self.timing.no_response_ns:
                    msg.errors.add("word_count_low")
                    return k, stop, True
                msg.errors.add("non_contiguous_data")
                stop = w.stop[k]
            if w.sync[k]:
                msg.errors.add("sync")  # a command/status sync where a data word belongs
            msg.data.append(w.value[k])
            msg.positions.append(k)
            taken += 1
            k += 1
        return k, stop, True



def _fits_as_command(w: _Words, k: int, stop: int) -> bool:
    """Whether word ``k`` read as a command is followed by exactly its BC data words."""
    cmd = w.value[k]
    tx, sa, count = cmd >> 10 & 1, cmd >> 5 & 31, cmd & 31
    if sa in (0, 31):
        follows = 1 if MODE_CODES[count].has_data and not tx else 0
    else:
        follows = 0 if tx else (count or 32)
    rest = stop - k - 1
    if rest == 1 and not tx and follows != 1 and w.sync[k + 1] and w.value[k + 1] >> 10 & 1:
        return True  # an RT-RT pair: receive command then transmit command
    return rest == follows


def _closed(w: _Words, k: int, *, wait_ns: int, horizon: int | None) -> bool:
    """True when the stream is known to hold nothing more within ``wait_ns`` after word
    ``k - 1`` (the horizon is past that point)."""
    if horizon is None:
        return False
    return horizon >= w.end[k - 1] + wait_ns


def _prepare(batch: WordBatch, break_ns: int, previous_end: int | None) -> _Words:
    """Gaps and transmission boundaries, computed with numpy, handed over as lists."""
    t = batch["t_ns"].astype(np.int64)
    end = batch["end_ns"].astype(np.int64)
    gap = np.empty(t.size, dtype=np.int64)
    gap[0] = _BIG_GAP if previous_end is None else t[0] + SYNC_MID_NS - previous_end
    gap[1:] = t[1:] + SYNC_MID_NS - end[:-1]
    starts = np.flatnonzero(gap > break_ns)
    if starts.size == 0 or starts[0] != 0:
        starts = np.r_[0, starts]
    bounds = np.r_[starts[1:], t.size]
    stop = np.repeat(bounds, np.diff(np.r_[starts, t.size]))
    sync = batch["sync"]
    syncs_before = np.concatenate([[0], np.cumsum(sync != 0)])
    errors_before = np.concatenate([[0], np.cumsum(batch["errors"] != 0)])
    return _Words(t.tolist(), end.tolist(), sync.tolist(), batch["value"].tolist(),
                  batch["errors"].tolist(), gap.tolist(), stop.tolist(),
                  syncs_before.tolist(), errors_before.tolist())


def _record(msg: _Message, w: _Words, bus: int, j: int) -> MonitorRecord:
    word_errors = []
    errors = msg.errors
    clean = w.errors_before[j] == w.errors_before[msg.start]
    for position, index in enumerate(() if clean else msg.positions):
        bits = w.errors[index]
        if bits:
            names = tuple(name for bit, name in _ERROR_TEXT.items() if bits & bit)
            word_errors.append((position, names))
            errors.update(names)
    if word_errors:
        errors.add("word_error")
    return MonitorRecord(
        t_ns=w.t[msg.start], bus=BUS_NAMES[bus], format=msg.fmt,
        command=None if msg.command < 0 else msg.command, data=tuple(msg.data),
        status=tuple(msg.status), gaps_ns=tuple(msg.gaps), errors=tuple(sorted(errors)),
        command2=msg.command2, word_errors=tuple(word_errors), end_ns=w.end[j - 1])
