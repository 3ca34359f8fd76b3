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
"""

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
from mapr_daemon.icd.render import format_decoded, format_values
from mapr_daemon.icd.signals import SignalStream, StreamStats, collect
from mapr_daemon.icd.traffic import pattern_values, schedule_records
from mapr_daemon.icd.values import DecodedMessage, Series

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
