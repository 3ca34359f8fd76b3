"""The MIL-STD-1553B mode-code table (section 4.3.3.5.1.7 of the standard).

Each code says whether a data word goes with it, which direction (T/R bit) is legal,
whether broadcast is allowed, and whether it is reserved. Codes 0-15 never carry a data
word; 16-31 always do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class ModeCode:
    """One row of the mode-code table."""

    code: int
    name: str
    transmit: bool
    """The legal T/R bit: True = transmit (T/R=1), False = receive (T/R=0)."""
    has_data: bool
    broadcast_allowed: bool
    reserved: bool


def _row(code: int, name: str, tr: str, broadcast: bool, reserved: bool = False) -> ModeCode:
    return ModeCode(code, name, tr == "T", code >= 16, broadcast, reserved)


MODE_CODES: tuple[ModeCode, ...] = (
    _row(0, "dynamic bus control", "T", False),
    _row(1, "synchronize", "T", True),
    _row(2, "transmit status word", "T", False),
    _row(3, "initiate self test", "T", True),
    _row(4, "transmitter shutdown", "T", True),
    _row(5, "override transmitter shutdown", "T", True),
    _row(6, "inhibit terminal flag bit", "T", True),
    _row(7, "override inhibit terminal flag bit", "T", True),
    _row(8, "reset remote terminal", "T", True),
    *(_row(c, f"reserved {c}", "T", True, reserved=True) for c in range(9, 16)),
    _row(16, "transmit vector word", "T", False),
    _row(17, "synchronize with data word", "R", True),
    _row(18, "transmit last command word", "T", False),
    _row(19, "transmit built-in-test word", "T", False),
    _row(20, "selected transmitter shutdown", "R", True),
    _row(21, "override selected transmitter shutdown", "R", True),
    *(_row(c, f"reserved {c}", "T", True, reserved=True) for c in range(22, 32)),
)
"""Indexed by mode code. Reserved codes list T as direction; the standard leaves it open,
so a monitor must not flag either direction of a reserved code as illegal (only as reserved)."""

# Lookup arrays for vectorized checks over many command words at once.
MODE_HAS_DATA: npt.NDArray[np.bool_] = np.array([m.has_data for m in MODE_CODES])
MODE_TRANSMIT: npt.NDArray[np.bool_] = np.array([m.transmit for m in MODE_CODES])
MODE_BROADCAST_OK: npt.NDArray[np.bool_] = np.array([m.broadcast_allowed for m in MODE_CODES])
MODE_RESERVED: npt.NDArray[np.bool_] = np.array([m.reserved for m in MODE_CODES])

MODE_RESETS_STATUS = frozenset(c for c in range(32) if c not in (2, 18))
"""Mode codes 2 and 18 leave the status word alone; every other valid command resets it."""


def mode_code(code: int) -> ModeCode:
    """The table row for ``code`` (0-31)."""
    if not 0 <= code <= 31:
        raise ValueError(f"mode code {code} is outside 0-31")
    return MODE_CODES[code]


def direction_legal(code: int, transmit: bool) -> bool:
    """True when the T/R bit is legal for this mode code (reserved codes accept either)."""
    row = mode_code(code)
    return row.reserved or row.transmit == transmit
