"""The message-level record a bus monitor produces: :class:`MonitorRecord`.

One record per 1553 message (or per stray word that fits no message, flagged). It is the
public API of the monitor, the CLI's JSON output and what the Chapter 10 reader produces.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from enum import StrEnum
from typing import Any

from drivers.mil1553.words import BROADCAST_RT, MODE_SUBADDRESSES, CommandWord, StatusWord


class TransferFormat(StrEnum):
    """The ten information-transfer formats of MIL-STD-1553B, plus words that fit none."""

    BC_RT = "BC_RT"
    RT_BC = "RT_BC"
    RT_RT = "RT_RT"
    MODE = "MODE"
    MODE_TX_DATA = "MODE_TX_DATA"
    MODE_RX_DATA = "MODE_RX_DATA"
    BCAST_BC_RT = "BCAST_BC_RT"
    BCAST_RT_RT = "BCAST_RT_RT"
    BCAST_MODE = "BCAST_MODE"
    BCAST_MODE_RX_DATA = "BCAST_MODE_RX_DATA"
    UNKNOWN = "UNKNOWN"
    """Words that fit no message (e.g. data words with no command before them)."""

    def __str__(self) -> str:
        return self.value


MESSAGE_ERROR_NAMES: tuple[str, ...] = (
    "no_response", "early_response", "late_response", "word_count_low", "word_count_high",
    "non_contiguous_data", "word_error", "manchester", "parity", "bit_count_low",
    "bit_count_high", "sync", "wrong_rt_address", "reserved_status_bits", "illegal_format",
    "reserved_mode_code", "both_buses_active", "babbling", "intermessage_gap_short",
    "superseded", "orphan_words", "time_tags_unavailable",
)
"""Error names a record may carry, in snake_case as the CLI prints them."""


@dataclass(frozen=True, slots=True)
class MonitorRecord:
    """One message as seen on the bus.

    ``t_ns`` is the leading edge of the first command word's sync. For RT-RT transfers
    ``command`` is the receive command (the receiving terminal) and ``command2`` the transmit
    command. ``data`` and ``status`` list words in bus order; ``gaps_ns`` the response gaps
    (mid-crossing to mid-crossing). ``word_errors`` maps a word's position in the message
    (0 = first word on the bus) to the names of its word-level errors.
    """

    t_ns: int
    bus: str
    format: TransferFormat
    command: int | None
    data: tuple[int, ...] = ()
    status: tuple[int, ...] = ()
    gaps_ns: tuple[int, ...] = ()
    errors: tuple[str, ...] = ()
    command2: int | None = None
    word_errors: tuple[tuple[int, tuple[str, ...]], ...] = ()
    end_ns: int = 0
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    # --- fields a user filters on -----------------------------------------------------
    @property
    def cmd(self) -> CommandWord | None:
        return None if self.command is None else CommandWord.from_value(self.command)

    @property
    def cmd2(self) -> CommandWord | None:
        return None if self.command2 is None else CommandWord.from_value(self.command2)

    @property
    def rt(self) -> int | None:
        return None if self.command is None else self.command >> 11 & 31

    @property
    def tr(self) -> str | None:
        return None if self.command is None else ("T" if self.command >> 10 & 1 else "R")

    @property
    def sa(self) -> int | None:
        return None if self.command is None else self.command >> 5 & 31

    @property
    def is_mode(self) -> bool:
        return self.sa in MODE_SUBADDRESSES

    @property
    def is_broadcast(self) -> bool:
        return self.rt == BROADCAST_RT

    @property
    def wc(self) -> int | None:
        """Word count the command calls for (None for mode codes and stray words)."""
        if self.command is None or self.is_mode:
            return None
        return (self.command & 31) or 32

    @property
    def mode_code(self) -> int | None:
        return self.command & 31 if self.command is not None and self.is_mode else None

    @property
    def rt2(self) -> int | None:
        return None if self.command2 is None else self.command2 >> 11 & 31

    @property
    def sa2(self) -> int | None:
        return None if self.command2 is None else self.command2 >> 5 & 31

    @property
    def statuses(self) -> tuple[StatusWord, ...]:
        return tuple(StatusWord.from_value(s) for s in self.status)

    @property
    def ok(self) -> bool:
        return not self.errors

    def to_json(self) -> dict[str, Any]:
        """The record as the CLI prints it (one JSON object per message)."""
        out: dict[str, Any] = {"t_ns": self.t_ns, "bus": self.bus, "format": str(self.format)}
        if self.command is not None:
            out["rt"] = self.rt
            out["tr"] = self.tr
            out["sa"] = self.sa
            if self.is_mode:
                out["mode_code"] = self.mode_code
            else:
                out["wc"] = self.wc
        if self.command2 is not None:
            out["rt2"] = self.rt2
            out["sa2"] = self.sa2
        out["data"] = list(self.data)
        out["status"] = list(self.status)
        out["gaps_ns"] = list(self.gaps_ns)
        out["errors"] = list(self.errors)
        if self.word_errors:
            out["word_errors"] = {str(i): list(e) for i, e in self.word_errors}
        return out


SLOT_SETTERS = tuple(getattr(MonitorRecord, f.name).__set__ for f in fields(MonitorRecord))
"""Each field's slot setter, in field order: builds a record without the frozen dataclass's
per-field ``object.__setattr__`` (:func:`new_records`, ``Ms1553Batch.records``)."""
assert tuple(f.name for f in fields(MonitorRecord)) == MonitorRecord.__slots__


def new_records(t_ns: Sequence[int], bus: str, format: Sequence[TransferFormat],
                command: Sequence[int | None], data: Sequence[tuple[int, ...]],
                status: Sequence[tuple[int, ...]], gaps_ns: Sequence[tuple[int, ...]],
                errors: Sequence[tuple[str, ...]], command2: Sequence[int | None],
                word_errors: Sequence[tuple[tuple[int, tuple[str, ...]], ...]],
                end_ns: Sequence[int]) -> list[MonitorRecord]:
    """Records of one bus from their fields as columns (one sequence per field, ``extra``
    each its own empty dict): the records ``MonitorRecord(...)`` builds, about twice as fast.
    The slots are set directly, not through the frozen dataclass's ``object.__setattr__``
    per field; the assembler builds thousands a second.
    """
    records: list[MonitorRecord] = []
    _fill(records, bus, t_ns, format, command, data, status, gaps_ns, errors, command2,
          word_errors, end_ns)
    return records


def _fill(records: list[MonitorRecord], bus: str, t_ns: Sequence[int],
          format: Sequence[TransferFormat], command: Sequence[int | None],
          data: Sequence[tuple[int, ...]], status: Sequence[tuple[int, ...]],
          gaps_ns: Sequence[tuple[int, ...]], errors: Sequence[tuple[str, ...]],
          command2: Sequence[int | None],
          word_errors: Sequence[tuple[tuple[int, tuple[str, ...]], ...]],
          end_ns: Sequence[int]) -> None:
    """Append the records of :func:`new_records` to ``records``."""
    new = object.__new__
    cls = MonitorRecord
    (set_t, set_bus, set_format, set_command, set_data, set_status, set_gaps, set_errors,
     set_command2, set_word_errors, set_end, set_extra) = SLOT_SETTERS
    for t, f, c, d, s, g, e, c2, w, n in zip(t_ns, format, command, data, status, gaps_ns,
                                             errors, command2, word_errors, end_ns,
                                             strict=True):
        record: MonitorRecord = new(cls)
        set_t(record, t)
        set_bus(record, bus)
        set_format(record, f)
        set_command(record, c)
        set_data(record, d)
        set_status(record, s)
        set_gaps(record, g)
        set_errors(record, e)
        set_command2(record, c2)
        set_word_errors(record, w)
        set_end(record, n)
        set_extra(record, {})
        records.append(record)


@contextmanager
def collector_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector while a batch of records is built.

    Run every 700 new objects, it moves the records under construction (alive, in their
    lists) to its older generations, whose growth then sets off full collections of every
    object the process holds: measured, about as much CPU as building the records. Records
    and their tuples hold no reference cycles, so nothing is left for it to find; it resumes
    (if it was running) as soon as the batch is built.
    """
    running = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if running:
            gc.enable()
