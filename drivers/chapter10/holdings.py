"""What a Chapter 10 recording holds, in one line: its packet types and channels.

Said whenever a recording lacks what was asked of it (no 1553 data, not the asked channel), by
every command and by the fleet's workers alike, so the line reads the same everywhere.
"""

from __future__ import annotations

from drivers.chapter10.reader import Chapter10Reader

__all__ = ["holdings"]

_TYPE_NAMES = {0x01: "TMATS", 0x11: "time", 0x19: "1553", 0x38: "ARINC 429"}


def holdings(reader: Chapter10Reader) -> str:
    """What the recording held, by packet type and channel: ``TMATS channel 0; time channel
    2; video (0x40) channels 3, 4`` (``nothing readable`` when no whole packet was met)."""
    from chapter10.c10 import TYPES

    parts = []
    for data_type, ids in sorted(reader.walker.types_seen.items()):
        name = _TYPE_NAMES.get(data_type)
        if name is None:
            handler = TYPES.get(data_type)
            name = f"{handler.__name__ if handler else 'type'} (0x{data_type:02X})"
        word = "channel" if len(ids) == 1 else "channels"
        parts.append(f"{name} {word} {', '.join(map(str, sorted(ids)))}")
    return "; ".join(parts) or "nothing readable"
