"""Argument checks shared by the subcommands, run while the command line is parsed.

A bad value must stop ``mapr`` before any backend opens, with argparse's one-line error and
exit code 2, naming the flag and what it accepts: ``monitor --rt 40`` waiting silently on a
bus where no terminal 40 can ever speak looks exactly like a dead bus. ``type=`` functions
here raise :class:`argparse.ArgumentTypeError` (argparse adds the flag's name); checks that
need several flags at once (:func:`impossible_filter`) return the problem as text and the
subcommand registers them as ``parser.set_defaults(validate=...)``, which
:func:`mapr_daemon.cli.main.main` runs right after parsing.

Light on purpose (standard library only): it is imported to build the parsers.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

MODE_FORMATS = frozenset({"MODE", "MODE_TX_DATA", "MODE_RX_DATA", "BCAST_MODE",
                          "BCAST_MODE_RX_DATA"})
"""Transfer formats of mode-code messages (subaddress 0 or 31)."""
DATA_FORMATS = frozenset({"BC_RT", "RT_BC", "RT_RT", "BCAST_BC_RT", "BCAST_RT_RT"})
"""Transfer formats carrying data to or from a subaddress 1-30."""
RECEIVE_ONLY = frozenset({"BC_RT", "BCAST_BC_RT", "MODE_RX_DATA", "BCAST_MODE_RX_DATA"})
"""Formats whose (first) command word is a receive command (T/R bit 0)."""
TRANSMIT_ONLY = frozenset({"RT_BC", "MODE_TX_DATA"})
"""Formats whose command word is a transmit command (T/R bit 1)."""
BROADCAST_ONLY_RT31 = frozenset({"BCAST_BC_RT", "BCAST_MODE", "BCAST_MODE_RX_DATA"})
"""Broadcast formats whose only terminal address is 31 (BCAST_RT_RT also names the
transmitter, any address)."""


def bounded_int(low: int, high: int, what: str) -> Callable[[str], int]:
    """A ``type=`` for an integer in ``low..high`` (e.g. an RT address 0-31)."""

    def parse(text: str) -> int:
        try:
            value = int(text, 0)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{what} must be an integer {low}-{high}, not {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{what} must be {low}-{high}, not {value}")
        return value

    parse.__name__ = what  # argparse names the type in some messages
    return parse


def positive_int(what: str) -> Callable[[str], int]:
    """A ``type=`` for an integer >= 1 (a message count)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{what} must be a whole number >= 1, not {text!r}") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{what} must be >= 1, not {value}")
        return value

    parse.__name__ = what
    return parse


def positive_seconds(text: str) -> float:
    """A ``type=`` for a finite duration > 0 s."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seconds must be a number, not {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"seconds must be finite and > 0, not {text}")
    return value


def non_negative_seconds(text: str) -> float:
    """A ``type=`` for a finite duration >= 0 s (0 = off)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seconds must be a number, not {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"seconds must be finite and >= 0, not {text}")
    return value


def impossible_filter(rt: int | None, sa: int | None, tr: str | None,
                      fmt: str | None) -> str | None:
    """Why a message filter (``--rt/--sa/--tr/--format``, all to match) can never match a
    MIL-STD-1553B message, or None when some message can match it.

    Only combinations the standard rules out are refused: a mode-code format outside
    subaddress 0/31, a data format on subaddress 0/31, a receive-only format with ``--tr T``
    (and the reverse), a broadcast-only format on a terminal other than 31.
    """
    if fmt is None:
        return None
    if fmt in MODE_FORMATS and sa is not None and sa not in (0, 31):
        return (f"--format {fmt} is a mode-code message: its subaddress is 0 or 31, so "
                f"--sa {sa} can never match")
    if fmt in DATA_FORMATS and sa in (0, 31):
        return (f"--sa {sa} carries mode codes only: a {fmt} message is on subaddress 1-30, "
                "so the filter can never match")
    if tr is not None and fmt in RECEIVE_ONLY and tr.upper() == "T":
        return f"--format {fmt} is a receive command (R), so --tr T can never match"
    if tr is not None and fmt in TRANSMIT_ONLY and tr.upper() == "R":
        return f"--format {fmt} is a transmit command (T), so --tr R can never match"
    if fmt in BROADCAST_ONLY_RT31 and rt is not None and rt != 31:
        return f"--format {fmt} is broadcast (RT 31), so --rt {rt} can never match"
    return None
