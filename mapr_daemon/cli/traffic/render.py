"""How a record looks on a terminal: one line a bus engineer reads at a glance (candump-style).

    0.001997  A  BC_RT         RT05 R SA01 WC02   8000 7FFF        RT05       8.0us
    0.002517  A  RT_BC         RT05 T SA02 WC01   5555             RT05 SRQ   8.0us
    0.180003  A  UNKNOWN       -                  AAAA                             ! orphan_words

An RT-RT transfer is written as every text view writes it (``decode --text`` too): in bus
order, the receive command, ``<`` ("receives from"), the transmit command:
``RT05 R SA03 WC08 < RT06 T SA01 WC08`` here, ``05-03<06-01`` in ``decode --text``.
A record of a Chapter 10 recording has its channel ID after the time (``decode --text``'s
``ch`` column)::

    0.001064      3  B  RT_RT         RT05 R SA03 WC08 < RT06 T SA01 WC08 ...
"""

from __future__ import annotations

import json
from typing import Any

from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.words import CommandWord, StatusWord

MAX_DATA_SHOWN = 8


def command_text(record: MonitorRecord) -> str:
    if record.command is None:
        return "-"
    text = str(CommandWord.from_value(record.command))
    if record.is_mode and "(" in text:
        text = text[: text.index("(")].rstrip()
    if record.command2 is not None:
        text += " < " + str(CommandWord.from_value(record.command2))
    return text


def record_line(record: MonitorRecord, values: str = "") -> str:
    """The record on one line; ``values`` (engineering values from an ICD) is appended.

    A record of a Chapter 10 recording (``record.extra["channel"]``) gets the channel ID after
    the time, right-aligned in 5 columns, as ``decode --text`` writes its ``ch`` column: each
    1553 channel is a bus of its own, so bus A of two channels must not read as one bus. A
    record from a live backend has no channel, and no column."""
    data = " ".join(f"{d:04X}" for d in record.data[:MAX_DATA_SHOWN])
    if len(record.data) > MAX_DATA_SHOWN:
        data += f" +{len(record.data) - MAX_DATA_SHOWN}"
    status = " ".join(str(StatusWord.from_value(s)) for s in record.status) or "-"
    gaps = " ".join(f"{g / 1000:.1f}us" for g in record.gaps_ns)
    channel = record.extra.get("channel")
    ch = "" if channel is None else f" {channel:>5}"
    line = (f"{record.t_ns / 1e9:12.6f}{ch}  {record.bus}  {record.format!s:<12} "
            f"{command_text(record):<18} {data:<30} {status:<10} {gaps}")
    if record.errors:
        line += "  ! " + ",".join(record.errors)
    if values:
        line += "\n" + " " * (16 + len(ch)) + values
    return line.rstrip() if not values else line


def record_json(record: MonitorRecord, values: dict[str, Any] | None = None) -> str:
    """The record as one JSON object (with ``values`` from an ICD when given), with the
    ``channel`` of a Chapter 10 record (its bus), as ``decode`` writes it."""
    out = record.to_json()
    channel = record.extra.get("channel")
    if channel is not None:
        out["channel"] = channel
    if values is not None:
        out["values"] = values
    return json.dumps(out)
