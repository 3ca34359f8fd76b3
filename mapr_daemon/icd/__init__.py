"""The RT/SA message table (interface control document): YAML -> engineering values and back.

Shaped after cantools: an :class:`Icd` (the database) holds :class:`Message` objects, one per
RT / T-R / subaddress, each holding :class:`Parameter` objects with scale, offset, unit,
minimum and maximum. Load once::

    icd = load_icd("configs/icd/ema-testbed.yaml")
    decoded = icd.decode(record)                      # one MonitorRecord -> values
    batch = icd.decode_batch(records)                 # many, vectorized with numpy
    words = icd.encode("ema_position_command", {"position_command": 12.5, ...})

:class:`SignalStream` turns a monitor's records into the per-parameter time series the
reasoner consumes; :func:`format_values` renders one record's values on one line. The file
format is documented in ``docs/icd.md``.

The signal stream, the renderers and the traffic generator are imported on first use (PEP
562), so decoding with a table (``mapr decode --icd``) does not pay for them at start-up.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from mapr_daemon.icd.busload import BusLoad, bus_load, message_time_us
from mapr_daemon.icd.database import BatchResult, Icd, load_icd, loads_icd
from mapr_daemon.icd.errors import IcdError, IcdRangeError, IcdValueError
from mapr_daemon.icd.flags import flag_names
from mapr_daemon.icd.model import (
    Group,
    Message,
    Parameter,
    ParamType,
    Schedule,
    ScheduleEntry,
    Terminal,
    WordOrder,
)
from mapr_daemon.icd.values import DecodedMessage, Series

if TYPE_CHECKING:
    from mapr_daemon.icd.render import format_decoded, format_values
    from mapr_daemon.icd.signals import SignalStream, StreamStats, collect
    from mapr_daemon.icd.traffic import pattern_values, schedule_records

_ON_FIRST_USE = {
    "format_decoded": "render", "format_values": "render",
    "SignalStream": "signals", "StreamStats": "signals", "collect": "signals",
    "pattern_values": "traffic", "schedule_records": "traffic",
}
"""Names of this package imported from their module when first asked for."""


def __getattr__(name: str) -> Any:
    """``format_decoded``, ``SignalStream`` and the like, from their module, on first use."""
    module = _ON_FIRST_USE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value

__all__ = [
    "BatchResult",
    "BusLoad",
    "DecodedMessage",
    "Group",
    "Icd",
    "IcdError",
    "IcdRangeError",
    "IcdValueError",
    "Message",
    "ParamType",
    "Parameter",
    "Schedule",
    "ScheduleEntry",
    "Series",
    "SignalStream",
    "StreamStats",
    "Terminal",
    "WordOrder",
    "bus_load",
    "collect",
    "flag_names",
    "format_decoded",
    "format_values",
    "load_icd",
    "loads_icd",
    "message_time_us",
    "pattern_values",
    "schedule_records",
]
