"""MIL-STD-1553B words: command, status and data, their fields, odd parity and formatting.

Layouts are declared once, with :mod:`construct`, as bit structures MSB first (bit 15 is the
first bit on the bus). The same declarations are turned into a shift/mask table at import, so
the hot path (numpy arrays of thousands of words) uses shifts and masks, and ``construct``
stays off it: construct parses a word many times slower than shifts do (docs/figures.md).

>>> str(CommandWord.from_value(0x2822))
'RT05 R SA01 WC02'
>>> CommandWord(rt=5, transmit=True, subaddress=0, count=2).value
10242
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import construct as cs
import numpy as np
import numpy.typing as npt

from drivers.mil1553.modecodes import MODE_CODES

BROADCAST_RT = 31
"""RT address 31 is the broadcast address."""

MODE_SUBADDRESSES = (0, 31)
"""Subaddresses 0 and 31 mean the word-count field carries a mode code."""

COMMAND_LAYOUT = cs.BitStruct(
    "rt" / cs.BitsInteger(5),
    "transmit" / cs.Flag,
    "subaddress" / cs.BitsInteger(5),
    "count" / cs.BitsInteger(5),
)
"""Command word: RT address b15-11, T/R b10 (1 = transmit), subaddress/mode b9-5,
word count/mode code b4-0."""

STATUS_LAYOUT = cs.BitStruct(
    "rt" / cs.BitsInteger(5),
    "message_error" / cs.Flag,
    "instrumentation" / cs.Flag,
    "service_request" / cs.Flag,
    "reserved" / cs.BitsInteger(3),
    "broadcast_received" / cs.Flag,
    "busy" / cs.Flag,
    "subsystem_flag" / cs.Flag,
    "dynamic_bus_control" / cs.Flag,
    "terminal_flag" / cs.Flag,
)
"""Status word: RT address b15-11 then the status bits, b10 message error to b0 terminal flag."""


def _field_table(layout: Any) -> dict[str, tuple[int, int]]:
    """Derive ``name -> (shift, mask)`` from a 16-bit construct BitStruct declaration."""
    fields: dict[str, tuple[int, int]] = {}
    position = 16
    for sub in layout.subcon.subcons:
        width = 1 if isinstance(sub.subcon, type(cs.Flag)) else sub.subcon.sizeof()
        position -= width
        fields[sub.name] = (position, (1 << width) - 1)
    if position != 0:
        raise AssertionError(f"layout does not cover 16 bits ({position} left)")
    return fields


COMMAND_FIELDS = _field_table(COMMAND_LAYOUT)
STATUS_FIELDS = _field_table(STATUS_LAYOUT)

STATUS_FLAG_NAMES: tuple[str, ...] = tuple(
    name for name in STATUS_FIELDS if name not in ("rt", "reserved")
)
"""Status-bit names in bus order (b10 first)."""

STATUS_FLAG_ABBREV = {
    "message_error": "ME",
    "instrumentation": "INS",
    "service_request": "SRQ",
    "broadcast_received": "BCR",
    "busy": "BUSY",
    "subsystem_flag": "SSF",
    "dynamic_bus_control": "DBCA",
    "terminal_flag": "TF",
}
"""The short names bus analyzers print for status bits."""

UIntArray = npt.NDArray[np.unsignedinteger[Any]]


def field(values: UIntArray, table: dict[str, tuple[int, int]], name: str) -> UIntArray:
    """Extract one field from an array of 16-bit words (vectorized shift and mask)."""
    shift, mask = table[name]
    out: UIntArray = ((values >> shift) & mask).astype(values.dtype)
    return out


# --- parity --------------------------------------------------------------------------------

_POPCOUNT8 = np.array([bin(i).count("1") & 1 for i in range(256)], dtype=np.uint8)


def parity_bit(values: UIntArray | int) -> Any:
    """The odd-parity bit to transmit after ``values`` (1 when the 16 bits hold an even count).

    Works on an int or a numpy array of 16-bit words.

    >>> [parity_bit(v) for v in (0x0000, 0xFFFF, 0x2C22, 0x8000, 0x5555)]
    [1, 1, 0, 0, 1]
    """
    if isinstance(values, (int, np.integer)):
        return (bin(int(values) & 0xFFFF).count("1") & 1) ^ 1
    v = np.asarray(values).astype(np.uint16)
    ones = _POPCOUNT8[v & 0xFF] ^ _POPCOUNT8[v >> 8]
    return ones ^ 1


# --- typed views of single words (off the hot path) --------------------------------------


@dataclass(frozen=True, slots=True)
class CommandWord:
    """A command word. ``count`` is the raw 5-bit field: word count (0 = 32) or mode code."""

    rt: int
    transmit: bool
    subaddress: int
    count: int

    def __post_init__(self) -> None:
        for name, value in (("rt", self.rt), ("subaddress", self.subaddress),
                            ("count", self.count)):
            if not 0 <= value <= 31:
                raise ValueError(f"command word {name}={value} is outside 0-31")

    @classmethod
    def from_value(cls, value: int) -> CommandWord:
        v = int(value)
        return cls(v >> 11 & 31, bool(v >> 10 & 1), v >> 5 & 31, v & 31)

    @property
    def value(self) -> int:
        return self.rt << 11 | int(self.transmit) << 10 | self.subaddress << 5 | self.count

    @property
    def is_mode_code(self) -> bool:
        return self.subaddress in MODE_SUBADDRESSES

    @property
    def is_broadcast(self) -> bool:
        return self.rt == BROADCAST_RT

    @property
    def word_count(self) -> int:
        """Data words this command calls for: 0-1 for mode codes, else 1-32 (field 0 = 32)."""
        if self.is_mode_code:
            return int(MODE_CODES[self.count].has_data)
        return self.count or 32

    def build(self) -> bytes:
        """The word as two big-endian bytes, built with the construct layout."""
        return bytes(COMMAND_LAYOUT.build(
            {"rt": self.rt, "transmit": self.transmit, "subaddress": self.subaddress,
             "count": self.count}))

    def __str__(self) -> str:
        tr = "T" if self.transmit else "R"
        if self.is_mode_code:
            return f"RT{self.rt:02d} {tr} MC{self.count:02d} ({MODE_CODES[self.count].name})"
        return f"RT{self.rt:02d} {tr} SA{self.subaddress:02d} WC{self.word_count:02d}"


@dataclass(frozen=True, slots=True)
class StatusWord:
    """A status word with every bit of the standard, reserved bits included."""

    rt: int
    message_error: bool = False
    instrumentation: bool = False
    service_request: bool = False
    reserved: int = 0
    broadcast_received: bool = False
    busy: bool = False
    subsystem_flag: bool = False
    dynamic_bus_control: bool = False
    terminal_flag: bool = False

    @classmethod
    def from_value(cls, value: int) -> StatusWord:
        v = int(value)
        kwargs: dict[str, Any] = {}
        for name, (shift, mask) in STATUS_FIELDS.items():
            raw = v >> shift & mask
            kwargs[name] = bool(raw) if mask == 1 else raw
        return cls(**kwargs)

    @property
    def value(self) -> int:
        v = 0
        for name, (shift, mask) in STATUS_FIELDS.items():
            v |= (int(getattr(self, name)) & mask) << shift
        return v

    @property
    def flags(self) -> tuple[str, ...]:
        """Names of the status bits that are set, in bus order."""
        return tuple(n for n in STATUS_FLAG_NAMES if getattr(self, n))

    def __str__(self) -> str:
        parts = [f"RT{self.rt:02d}"]
        parts += [STATUS_FLAG_ABBREV[n] for n in self.flags]
        if self.reserved:
            parts.append(f"RSV={self.reserved:#x}")
        return " ".join(parts)


def format_data(value: int) -> str:
    """A data word as bus analyzers show it: four upper-case hex digits."""
    return f"{int(value) & 0xFFFF:04X}"
