"""UTC time as text: the one form MAPR writes a wall-clock time in, and the forms it reads.

Times are shown in UTC with a ``Z`` (``2026-05-09 04:13:20Z``), the way flight logs are kept.
The catalog's own messages (an episode already acknowledged, and when), its views and the
CLI all write times this way, so the text lives here, below all of them, rather than in a
view that storage would then have to import. ``--since``/``--until`` read the same form, an
ISO date, or an age (``90m``, ``2h``, ``7d``).
"""

from __future__ import annotations

import datetime as dt
import re

_AGE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([smhdw])\s*$")
_UNIT_S = {"s": 1, "m": 60, "h": 3600, "d": 86400, "w": 604800}


def parse_time(text: str, now_ns: int) -> int:
    """``2026-05-09``, ``2026-05-09T12:00``, ``...Z``/``+02:00``, ``now`` or an age such as
    ``2h`` (that long before ``now_ns``) -> epoch ns. Naive times are UTC. ValueError else."""
    if text.strip().lower() == "now":
        return now_ns
    age = _AGE.match(text)
    if age:
        return now_ns - int(float(age.group(1)) * _UNIT_S[age.group(2)] * 1e9)
    try:
        when = dt.datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(f"{text!r} is not a time (try 2026-05-09, 2026-05-09T14:30Z, "
                         "2h or 7d)") from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=dt.UTC)
    return int(when.timestamp()) * 1_000_000_000 + when.microsecond * 1000


def fmt_time(t_ns: int | None) -> str:
    """Epoch ns as ``2026-05-09 04:13:20Z`` (whole seconds, UTC); ``-`` for None."""
    if t_ns is None:
        return "-"
    when = dt.datetime.fromtimestamp(t_ns // 1_000_000_000, tz=dt.UTC)
    return when.strftime("%Y-%m-%d %H:%M:%SZ")
