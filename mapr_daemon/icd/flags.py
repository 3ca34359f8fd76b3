"""Quality flags a decoded value carries, as bits of a ``uint8`` so arrays of them stay cheap.

A monitor must see a value that is outside its range rather than have it silently passed on
(cantools does not range-check on decode; we do). Every decoded sample has a flag byte;
0 means clean.

>>> flag_names(FLAG_ABOVE_MAX | FLAG_RECORD_ERROR)
('above_max', 'record_error')
"""

from __future__ import annotations

FLAG_BELOW_MIN = 1 << 0
"""The value is below the parameter's minimum (by more than half an LSB)."""
FLAG_ABOVE_MAX = 1 << 1
"""The value is above the parameter's maximum (by more than half an LSB)."""
FLAG_NAN = 1 << 2
"""A float32 parameter carried NaN."""
FLAG_INVALID = 1 << 3
"""A BCD nibble above 9 (value NaN), or an enumeration code the table does not list
(value is the code)."""
FLAG_MISSING = 1 << 4
"""The words holding the value were not received (word count low, no response); value NaN."""
FLAG_RECORD_ERROR = 1 << 5
"""The record that carried the value has bus errors (parity, Manchester, gaps ...)."""
FLAG_AFTER_GAP = 1 << 6
"""First sample after blocks were lost (the block sequence counter skipped)."""

FLAG_NAMES: tuple[tuple[int, str], ...] = (
    (FLAG_BELOW_MIN, "below_min"),
    (FLAG_ABOVE_MAX, "above_max"),
    (FLAG_NAN, "nan"),
    (FLAG_INVALID, "invalid"),
    (FLAG_MISSING, "missing"),
    (FLAG_RECORD_ERROR, "record_error"),
    (FLAG_AFTER_GAP, "after_gap"),
)
"""Flag bits and the names the CLI prints, lowest bit first."""


def flag_names(mask: int) -> tuple[str, ...]:
    """The names of the flags set in ``mask``, lowest bit first."""
    return tuple(name for bit, name in FLAG_NAMES if int(mask) & bit)
