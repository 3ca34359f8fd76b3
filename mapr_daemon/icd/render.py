"""One record's engineering values on one line, with units: what ``--icd`` shows in the CLI.

Scalars print as ``name=value unit``, enumerations by label, group channels as a bracketed
list of samples; a flagged value gets ``!flag`` appended so it cannot pass unnoticed::

    ema_position_command: position_command=35.000 deg!above_max drive_enable=1 ...
"""

from __future__ import annotations

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.icd.database import Icd
from mapr_daemon.icd.flags import flag_names
from mapr_daemon.icd.values import DecodedMessage, Series


def format_values(icd: Icd, record: MonitorRecord) -> str:
    """The record's values on one line, or "" if the table has no message for it."""
    decoded = icd.decode(record)
    return "" if decoded is None else format_decoded(decoded)


def format_decoded(decoded: DecodedMessage) -> str:
    """One line: the message name, then ``name=value unit`` for each parameter."""
    group = decoded.message.group
    channels = {c.name for c in group.channels} if group is not None else set()
    parts = [f"{decoded.message.name}:"]
    for name, s in decoded.values.items():
        if name in channels:
            text = "[" + " ".join(_sample(s, i) for i in range(len(s))) + "]"
        else:
            text = _sample(s, 0)
        parts.append(f"{name}={text}{' ' + s.unit if s.unit else ''}")
    return " ".join(parts)


def _sample(s: Series, index: int) -> str:
    flags = flag_names(int(s.flags[index]))
    return s.text(index) + "".join(f"!{f}" for f in flags)
