"""The message table as plain data: terminals, messages, parameters, groups and the schedule.

Shaped after cantools' Database -> Message -> Signal: an :class:`Icd` holds :class:`Message`
objects (one per RT/T-R/subaddress), each holding :class:`Parameter` objects with scale,
offset, unit, minimum and maximum. These objects are immutable and carry the YAML line they
came from, so every later check can point at it. Decoding and encoding live elsewhere
(:mod:`~mapr_daemon.icd.decoder`, :mod:`~mapr_daemon.icd.encoder`).

Bit numbering follows the standard: bit 15 is the most significant bit of a word and the first
on the bus. A two-word parameter is numbered 31..0 over the 32-bit value formed by its most
significant word (bits 31..16) and its least significant word (bits 15..0).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum


class ParamType(StrEnum):
    """How the raw bits of a parameter become an engineering value."""

    UNSIGNED = "unsigned"
    """Unsigned binary: value = raw * scale + offset."""
    TWOS = "twos"
    """Two's complement: the top bit of the field is the sign."""
    BNR = "bnr"
    """Binary (two's complement) scaled by the weight of the bit after the sign (``msb_weight``)."""
    BCD = "bcd"
    """Binary-coded decimal, four bits per digit, most significant digit first."""
    DISCRETE = "discrete"
    """One bit: 0 or 1."""
    ENUM = "enum"
    """A code with a label per value (``values:``); unknown codes are flagged."""
    FLOAT32 = "float32"
    """IEEE 754 single precision over two words."""
    COUNTER = "counter"
    """An unsigned sequence counter that wraps at 2**bits (blocks, frames)."""

    def __str__(self) -> str:
        return self.value


SIGNED_TYPES = frozenset({ParamType.TWOS, ParamType.BNR})
INTEGER_CODE_TYPES = frozenset({ParamType.DISCRETE, ParamType.ENUM, ParamType.COUNTER})
"""Types whose value is the raw code itself (no scale, offset or limits)."""


class WordOrder(StrEnum):
    """Word order of a two-word parameter."""

    MSW_FIRST = "msw_first"
    """Most significant word first, as MIL-STD-1553B prescribes for multi-word values."""
    LSW_FIRST = "lsw_first"
    """Least significant word first (some equipment does this; say so in the table)."""

    def __str__(self) -> str:
        return self.value


@dataclass(frozen=True, slots=True)
class Parameter:
    """One named value in a message (or one channel of a repeating group).

    ``word`` is the offset of its first word in the message, or in the sample for a group
    channel. ``msb``/``lsb`` are bit numbers (15..0, or 31..0 for two-word values).
    """

    name: str
    type: ParamType
    word: int
    msb: int
    lsb: int
    words: int = 1
    word_order: WordOrder = WordOrder.MSW_FIRST
    scale: float = 1.0
    offset: float = 0.0
    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    labels: Mapping[int, str] = field(default_factory=dict)
    description: str = ""
    line: int = 0
    key_lines: Mapping[str, int] = field(default_factory=dict, compare=False, repr=False)

    def line_of(self, key: str) -> int:
        """The YAML line of ``key`` in this parameter's mapping (its own line if absent)."""
        return self.key_lines.get(key, self.line)

    @property
    def width(self) -> int:
        """Number of bits in the field."""
        return self.msb - self.lsb + 1

    @property
    def signed(self) -> bool:
        return self.type in SIGNED_TYPES

    @property
    def raw_min(self) -> int:
        """Smallest raw integer the bits can hold (BCD: in decimal digits)."""
        return -(1 << (self.width - 1)) if self.signed else 0

    @property
    def raw_max(self) -> int:
        """Largest raw integer the bits can hold (BCD: the largest decimal number)."""
        if self.signed:
            return (1 << (self.width - 1)) - 1
        if self.type is ParamType.BCD:
            return int(10 ** (self.width // 4)) - 1
        return (1 << self.width) - 1

    @property
    def tolerance(self) -> float:
        """How far a decoded value may pass a limit before it is flagged (rounding slack)."""
        if self.type is ParamType.FLOAT32:
            span = max(abs(self.minimum or 0.0), abs(self.maximum or 0.0), 1e-38)
            return span * 2.0 ** -23 * abs(self.scale)
        return abs(self.scale) / 2.0

    def word_indices(self, base: int = 0) -> tuple[int, ...]:
        """Message word indices holding this parameter, most significant word first."""
        first = base + self.word
        if self.words == 1:
            return (first,)
        if self.word_order is WordOrder.MSW_FIRST:
            return (first, first + 1)
        return (first + 1, first)

    def label(self, code: int) -> str | None:
        """The enumeration label of ``code`` (None if the table lists none)."""
        label: str | None = self.labels.get(int(code))
        return label

    def decimals(self) -> int:
        """Digits after the point that the LSB justifies, for printing."""
        if self.type in INTEGER_CODE_TYPES:
            return 0
        if self.type is ParamType.FLOAT32 or self.scale == 0:
            return 6
        return max(0, min(9, math.ceil(-math.log10(abs(self.scale)) - 1e-9)))


@dataclass(frozen=True, slots=True)
class Group:
    """A repeating group: ``samples`` samples of ``channels``, ``stride`` words per sample.

    Sample ``i`` (0 = oldest) of a block received at record time ``t`` was taken at
    ``t - latency - (samples - 1 - i) * period``. ``latency`` defaults to one sample period:
    the newest sample was latched one period before the bus controller asked for the block.
    ``counter`` names a :attr:`ParamType.COUNTER` parameter of the message that counts blocks.
    """

    start: int
    samples: int
    stride: int
    sample_rate_hz: float
    channels: tuple[Parameter, ...]
    counter: str | None = None
    latency_s: float | None = None
    line: int = 0
    key_lines: Mapping[str, int] = field(default_factory=dict, compare=False, repr=False)

    def line_of(self, key: str) -> int:
        return self.key_lines.get(key, self.line)

    @property
    def period_ns(self) -> float:
        return 1e9 / self.sample_rate_hz

    @property
    def latency_ns(self) -> float:
        return self.period_ns if self.latency_s is None else self.latency_s * 1e9

    def sample_offsets_ns(self) -> list[float]:
        """Offset of each sample's time from the record's time tag (all <= 0 by default)."""
        return [-self.latency_ns - (self.samples - 1 - i) * self.period_ns
                for i in range(self.samples)]


@dataclass(frozen=True, slots=True)
class Terminal:
    """A remote terminal: address 0-30 and a name, on one bus of a recording or on any.

    ``channel`` is the Chapter 10 channel ID of the bus the terminal is on (each 1553 channel
    of a recording is a bus of its own, and two buses may each have an RT 5); None, the
    default, puts it on every bus: a table for one bus, a capture or a live card.
    """

    address: int
    name: str
    description: str = ""
    channel: int | None = None
    line: int = 0
    key_lines: Mapping[str, int] = field(default_factory=dict, compare=False, repr=False)

    def line_of(self, key: str) -> int:
        return self.key_lines.get(key, self.line)


@dataclass(frozen=True, slots=True)
class Message:
    """One message: an RT, transmit or receive, a subaddress, a word count and what it holds.

    ``transmit`` is the T/R bit of the command that names this RT. For an RT-RT transfer the
    message is declared at the receiving RT and ``source`` is (RT address, subaddress) of the
    transmitting one. ``channel`` is its terminal's (:attr:`Terminal.channel`): a message
    on a channel describes that channel's messages only.
    """

    name: str
    rt: int
    rt_name: str
    transmit: bool
    subaddress: int
    word_count: int
    rate_hz: float
    parameters: tuple[Parameter, ...] = ()
    group: Group | None = None
    source: tuple[int, int] | None = None
    description: str = ""
    line: int = 0
    key_lines: Mapping[str, int] = field(default_factory=dict, compare=False, repr=False)
    channel: int | None = None

    def line_of(self, key: str) -> int:
        return self.key_lines.get(key, self.line)

    @property
    def tr(self) -> str:
        return "T" if self.transmit else "R"

    @property
    def kind(self) -> str:
        """The transfer format: ``BC->RT``, ``RT->BC`` or ``RT->RT``."""
        if self.source is not None:
            return "RT->RT"
        return "RT->BC" if self.transmit else "BC->RT"

    @property
    def command(self) -> int:
        """The command word a bus controller sends for this message (the receive one for RT-RT)."""
        return (self.rt << 11 | int(self.transmit) << 10 | self.subaddress << 5
                | (self.word_count & 31))

    @property
    def source_command(self) -> int | None:
        """For RT-RT, the transmit command to the source RT."""
        if self.source is None:
            return None
        rt, sa = self.source
        return rt << 11 | 1 << 10 | sa << 5 | (self.word_count & 31)

    def all_parameters(self) -> tuple[Parameter, ...]:
        """Scalar parameters, then group channels."""
        return self.parameters + (self.group.channels if self.group else ())


@dataclass(frozen=True, slots=True)
class ScheduleEntry:
    """``message`` goes in every ``every``-th minor frame, starting at minor frame ``offset``."""

    message: str
    every: int
    offset: int = 0
    line: int = 0
    key_lines: Mapping[str, int] = field(default_factory=dict, compare=False, repr=False)

    def line_of(self, key: str) -> int:
        return self.key_lines.get(key, self.line)


@dataclass(frozen=True, slots=True)
class Schedule:
    """The bus controller's cyclic schedule: minor frames of a fixed length in a major frame.

    Gaps are dead bus time in µs (the standard's mid-bit figures less 2 µs):
    ``response_time_us`` before each status word, ``intermessage_gap_us`` after each message.
    """

    minor_frame_us: int
    minor_frames: int
    entries: tuple[ScheduleEntry, ...]
    response_time_us: float = 10.0
    intermessage_gap_us: float = 10.0
    line: int = 0
    key_lines: Mapping[str, int] = field(default_factory=dict, compare=False, repr=False)

    def line_of(self, key: str) -> int:
        return self.key_lines.get(key, self.line)

    @property
    def major_frame_us(self) -> int:
        return self.minor_frame_us * self.minor_frames

    def frame(self, index: int) -> tuple[str, ...]:
        """Names of the messages sent in minor frame ``index`` (modulo the major frame)."""
        k = index % self.minor_frames
        return tuple(e.message for e in self.entries if k % e.every == e.offset)

    def rate_hz(self, entry: ScheduleEntry) -> float:
        return 1e6 / (self.minor_frame_us * entry.every)
