"""The loaded message table, :class:`Icd` — cantools' ``Database`` for 1553.

Load once with :func:`load_icd`; it parses, validates and compiles a decoder per message.
Then ``icd.decode(record)`` gives one record's engineering values, ``icd.decode_batch(records)``
decodes many at once (records are grouped by RT/T-R/subaddress, their data words stacked
into a 2-D array and every parameter pulled out with numpy), and
``icd.encode(name, values)`` / ``icd.build_record(name, values, t_ns)`` go the other way.

>>> icd = load_icd("configs/icd/ema-testbed.yaml")             # doctest: +SKIP
>>> words = icd.encode("ema_position_command", {...})          # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.icd.busload import BusLoad, bus_load, frame_slots
from mapr_daemon.icd.decoder import U16, IntP, MessageDecoder
from mapr_daemon.icd.encoder import build_record, encode_message
from mapr_daemon.icd.errors import IcdError
from mapr_daemon.icd.loader import Table, parse_table
from mapr_daemon.icd.model import Message, Parameter, Schedule, Terminal
from mapr_daemon.icd.validate import validate_table
from mapr_daemon.icd.values import DecodedMessage, Series
from mapr_daemon.icd.yamlsrc import load_file, load_text

DECODABLE_FORMATS = frozenset({TransferFormat.BC_RT, TransferFormat.RT_BC, TransferFormat.RT_RT,
                        TransferFormat.BCAST_BC_RT, TransferFormat.BCAST_RT_RT})


@dataclass(slots=True)
class BatchResult:
    """What :meth:`Icd.decode_batch` returns: series per parameter and counts."""

    series: dict[str, Series] = field(default_factory=dict)
    """Parameter name -> its samples, in record order."""
    records: dict[str, int] = field(default_factory=dict)
    """Message name -> records decoded."""
    data_words: int = 0
    """Data words decoded."""
    unmatched: int = 0
    """Records no message of the table describes (mode codes, unknown RT/SA, stray words)."""
    empty: int = 0
    """Records of a known message that carried no data word (no response, busy)."""


class Icd:
    """A validated message table with its compiled decoders."""

    def __init__(self, table: Table) -> None:
        validate_table(table)
        self.path = table.path
        self.name = table.name
        self.description = table.description
        self.buses = table.buses
        self.terminals: tuple[Terminal, ...] = table.terminals
        self.messages: tuple[Message, ...] = table.messages
        self.schedule: Schedule | None = table.schedule
        self._by_name = {m.name: m for m in self.messages}
        self._decoders = {m.name: MessageDecoder(m) for m in self.messages}
        self._params = {p.name: m for m in self.messages for p in m.all_parameters()}
        self._by_key: dict[int, Message] = {}
        """Messages on every bus by RT/T-R/subaddress (the command word's top 11 bits)."""
        self._by_channel_key: dict[tuple[int, int], Message] = {}
        """Messages of terminals on one channel, by (channel, RT/T-R/subaddress)."""
        for m in self.messages:
            for command in (m.command, m.source_command):
                if command is None:
                    continue
                if m.channel is None:
                    self._by_key[command >> 5] = m
                else:
                    self._by_channel_key[(m.channel, command >> 5)] = m
        self.channels: tuple[int, ...] = tuple(sorted({
            t.channel for t in self.terminals if t.channel is not None}))
        """The Chapter 10 channels the table's terminals name (empty: a table for any bus)."""

    # --- lookups ------------------------------------------------------------------------
    def message(self, name: str) -> Message:
        """The message called ``name`` (``KeyError`` if none)."""
        return self._by_name[name]

    def parameter(self, name: str) -> tuple[Message, Parameter]:
        """The message holding parameter ``name``, and the parameter."""
        message = self._params[name]
        return message, next(p for p in message.all_parameters() if p.name == name)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(self._params)

    def lookup(self, rt: int, tr: str, sa: int, channel: int | None = None) -> Message | None:
        """The message at RT ``rt``, ``tr`` ("T"/"R"), subaddress ``sa``, if the table has one
        (on Chapter 10 channel ``channel``, or on every bus)."""
        return self._keyed(rt << 6 | int(tr == "T") << 5 | sa, channel)

    def _keyed(self, key: int, channel: int | None) -> Message | None:
        """The message at ``key`` (RT/T-R/subaddress) on ``channel``: a terminal of that
        channel's, else one on every bus (validation keeps the two apart)."""
        if channel is not None and self._by_channel_key:
            message = self._by_channel_key.get((channel, key))
            if message is not None:
                return message
        return self._by_key.get(key)

    def match(self, record: MonitorRecord) -> Message | None:
        """The message a record carries, or None (mode codes, unknown RT/SA, stray words).
        A Chapter 10 record's channel (``record.extra["channel"]``) picks its bus's terminals."""
        if record.format not in DECODABLE_FORMATS or record.command is None:
            return None
        return self.match_key(record.command, record.command2, record.extra.get("channel"))

    def bus_load(self) -> BusLoad | None:
        """The load the schedule puts on the bus (None without a schedule)."""
        if self.schedule is None:
            return None
        return bus_load(self.schedule, self._by_name)

    def frame_slots(self, index: int) -> tuple[tuple[float, Message], ...]:
        """(start µs within the frame, message) for minor frame ``index`` of the schedule."""
        if self.schedule is None:
            return ()
        return frame_slots(self.schedule, self._by_name, index)

    # --- decode -------------------------------------------------------------------------
    def decode(self, record: MonitorRecord) -> DecodedMessage | None:
        """One record's named, scaled, time-stamped values (None if the table lacks it)."""
        message = self.match(record)
        if message is None:
            return None
        result = self.decode_batch([record])
        return DecodedMessage(message, record, result.series)

    def decode_batch(self, records: Iterable[MonitorRecord]) -> BatchResult:
        """Decode many records at once, grouped by message and vectorized per parameter."""
        buckets: dict[str, list[MonitorRecord]] = {}
        result = BatchResult()
        by_key = self._by_key
        by_channel = bool(self._by_channel_key)
        for rec in records:
            cmd = rec.command
            message = None
            if cmd is not None and rec.format in DECODABLE_FORMATS:
                if by_channel:
                    message = self.match_key(cmd, rec.command2, rec.extra.get("channel"))
                else:   # the common case, a table for any bus: one dict look-up
                    message = by_key.get(cmd >> 5)
                    if message is None and rec.command2 is not None:
                        message = by_key.get(rec.command2 >> 5)
            if message is None:
                result.unmatched += 1
            elif not rec.data:
                result.empty += 1
            else:
                buckets.setdefault(message.name, []).append(rec)
        for name, recs in buckets.items():
            decoder = self._decoders[name]
            data, length = _stack(recs, decoder.message.word_count)
            t_ns = np.fromiter((r.t_ns for r in recs), dtype=np.int64, count=len(recs))
            errors = np.fromiter((bool(r.errors) for r in recs), dtype=np.bool_,
                                 count=len(recs))
            result.series.update(decoder.decode(data, length, t_ns, errors))
            result.records[name] = len(recs)
            result.data_words += int(length.sum())
        return result

    def match_key(self, command: int, command2: int | None = None,
                  channel: int | None = None) -> Message | None:
        """The message of a decodable record with these command words on Chapter 10 channel
        ``channel`` (None: a bus without one, a capture or a card), what :meth:`match` gives
        once the format is known to be one the table can describe."""
        message = self._keyed(command >> 5, channel)
        if message is None and command2 is not None:
            message = self._keyed(command2 >> 5, channel)
        return message

    def decode_block(self, name: str, data: U16, length: IntP, t_ns: npt.NDArray[np.int64],
                     record_error: npt.NDArray[np.bool_]) -> dict[str, Series]:
        """Decode records of message ``name`` already stacked as :meth:`decode_batch` stacks
        them (``data``: n x word count, zero-padded; ``length``: words each record had, at
        most the word count): parameter name -> series, record-major."""
        return self._decoders[name].decode(data, length, t_ns, record_error)

    # --- encode -------------------------------------------------------------------------
    def encode(self, message: str, values: Mapping[str, Any], *,
               strict: bool = True) -> tuple[int, ...]:
        """Data words of message ``message`` carrying ``values`` (see :mod:`.encoder`)."""
        return encode_message(self._message_or_fail(message), values, strict=strict)

    def build_record(self, message: str, values: Mapping[str, Any], t_ns: int, *,
                     bus: str = "A", strict: bool = True) -> MonitorRecord:
        """A clean :class:`MonitorRecord` of ``message`` carrying ``values`` at ``t_ns``."""
        m = self._message_or_fail(message)
        return build_record(m, encode_message(m, values, strict=strict), t_ns, bus=bus)

    def _message_or_fail(self, name: str) -> Message:
        if name not in self._by_name:
            raise IcdError(f"no message named {name!r}", path=self.path, field="message")
        return self._by_name[name]


def _stack(recs: list[MonitorRecord], wc: int) -> tuple[U16, IntP]:
    """Data words as an (n, wc) uint16 array and how many words each record really had."""
    n = len(recs)
    try:
        data = np.array([r.data for r in recs], dtype=np.uint16)
    except ValueError:          # ragged: some records are short or long
        data = np.zeros((0, 0), dtype=np.uint16)
    if data.ndim == 2 and data.shape[1] == wc:
        return data, np.full(n, wc, dtype=np.intp)
    data = np.zeros((n, wc), dtype=np.uint16)
    length = np.zeros(n, dtype=np.intp)
    for i, r in enumerate(recs):
        k = min(len(r.data), wc)
        data[i, :k] = r.data[:k]
        length[i] = k
    return data, length


def load_icd(path: str | Path) -> Icd:
    """Load, validate and compile an ICD file. Raises :class:`IcdError` naming file:line."""
    return Icd(parse_table(load_file(path), str(path)))


def loads_icd(text: str, path: str = "<string>") -> Icd:
    """Like :func:`load_icd`, from YAML text (``path`` is used in error messages)."""
    return Icd(parse_table(load_text(text, path), path))
