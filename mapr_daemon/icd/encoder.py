"""Engineering values -> data words, range-checked: what the loopback remote terminals send.

``encode_message(message, values, strict=True)`` takes a mapping of parameter names to values
(a sequence of ``samples`` values for each repeating-group channel) and returns the message's
data words. With ``strict=True`` a value outside its minimum/maximum, or one its bits cannot
hold, raises :class:`IcdRangeError`; with ``strict=False`` it saturates to what the bits can
hold (counters wrap instead). Missing or unknown names always raise :class:`IcdValueError`.
This runs per message, off the monitor's hot path.

:func:`build_record` wraps the words in a well-formed :class:`MonitorRecord`, as a bus
controller and its terminals would put them on the bus.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from typing import Any

from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.icd.errors import IcdRangeError, IcdValueError
from mapr_daemon.icd.model import Message, Parameter, ParamType


def encode_message(message: Message, values: Mapping[str, Any], *,
                   strict: bool = True) -> tuple[int, ...]:
    """The data words of ``message`` carrying ``values``."""
    words = [0] * message.word_count
    names = {p.name for p in message.all_parameters()}
    unknown = sorted(set(values) - names)
    if unknown:
        raise IcdValueError(f"message {message.name!r} has no parameter "
                            + ", ".join(repr(u) for u in unknown), field=unknown[0])
    for p in message.parameters:
        _place(words, p, 0, to_raw(p, _get(values, p), strict=strict))
    g = message.group
    if g is not None:
        for c in g.channels:
            samples = _get(values, c)
            if isinstance(samples, (str, bytes)) or not hasattr(samples, "__len__") \
                    or len(samples) != g.samples:
                raise IcdValueError(f"needs a sequence of {g.samples} samples, got "
                                    f"{samples!r}", field=c.name)
            for i, v in enumerate(samples):
                _place(words, c, g.start + i * g.stride, to_raw(c, v, strict=strict))
    return tuple(words)


def _get(values: Mapping[str, Any], p: Parameter) -> Any:
    if p.name not in values:
        raise IcdValueError("no value given", field=p.name)
    return values[p.name]


def _place(words: list[int], p: Parameter, base: int, bits: int) -> None:
    field = bits << p.lsb
    indices = p.word_indices(base)
    if p.words == 1:
        words[indices[0]] |= field
    else:
        words[indices[0]] |= field >> 16
        words[indices[1]] |= field & 0xFFFF


def to_raw(p: Parameter, value: Any, *, strict: bool = True) -> int:
    """The unsigned bit pattern (``width`` bits, before shifting) that carries ``value``."""
    mask = (1 << p.width) - 1
    if p.type is ParamType.ENUM:
        return _enum(p, value, strict) & mask
    if p.type in (ParamType.DISCRETE, ParamType.COUNTER):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if not isinstance(value, int) and not hasattr(value, "__index__"):
            raise IcdValueError(f"needs an integer, got {value!r}", field=p.name)
        code = int(value)
        if p.type is ParamType.COUNTER and not strict:
            return code & mask
        if not 0 <= code <= mask:
            _range(p, value, f"{code} does not fit in {p.width} bit(s)")
        return code
    number = _number(p, value)
    if p.type is ParamType.FLOAT32:
        return _float32(p, number, strict)
    if not math.isfinite(number):
        raise IcdValueError(f"{number} cannot be carried by a {p.type}", field=p.name)
    if strict:
        _check_limits(p, number)
    code = math.floor((number - p.offset) / p.scale + 0.5)
    if not p.raw_min <= code <= p.raw_max:
        if strict:
            _range(p, number, f"{number} needs raw {code}, outside the {p.width}-bit "
                              f"range {p.raw_min}..{p.raw_max}")
        code = min(max(code, p.raw_min), p.raw_max)
    if p.type is ParamType.BCD:
        return int(str(code), 16)       # decimal digits become nibbles
    return code & mask


def _number(p: Parameter, value: Any) -> float:
    if isinstance(value, (bool, str)):
        raise IcdValueError(f"needs a number, got {value!r}", field=p.name)
    try:
        return float(value)
    except (TypeError, ValueError):
        raise IcdValueError(f"needs a number, got {value!r}", field=p.name) from None


def _check_limits(p: Parameter, number: float) -> None:
    if math.isnan(number):
        if p.minimum is not None or p.maximum is not None:
            _range(p, number, "NaN is outside the limits")
        return
    if p.minimum is not None and number < p.minimum:
        _range(p, number, f"{number} is below the minimum {p.minimum:g}")
    if p.maximum is not None and number > p.maximum:
        _range(p, number, f"{number} is above the maximum {p.maximum:g}")


def _float32(p: Parameter, number: float, strict: bool) -> int:
    if strict:
        _check_limits(p, number)
    x = (number - p.offset) / p.scale
    try:
        packed = struct.pack(">f", x)
    except OverflowError:
        if strict:
            _range(p, number, f"{number} overflows a float32")
        packed = struct.pack(">f", math.copysign(math.inf, x))
    return int.from_bytes(packed, "big")


def _enum(p: Parameter, value: Any, strict: bool) -> int:
    if isinstance(value, str):
        for code, label in p.labels.items():
            if label == value:
                return code
        raise IcdValueError(f"{value!r} is not one of " + ", ".join(p.labels.values()),
                            field=p.name)
    if isinstance(value, bool) or not hasattr(value, "__index__"):
        raise IcdValueError(f"needs a label or a code, got {value!r}", field=p.name)
    code = int(value)
    if not 0 <= code < 1 << p.width or (strict and code not in p.labels):
        _range(p, value, f"code {code} is not listed")
    return code


def _range(p: Parameter, value: Any, problem: str) -> None:
    raise IcdRangeError(problem, parameter=p.name, value=value, minimum=p.minimum,
                        maximum=p.maximum)


def build_record(message: Message, words: Sequence[int], t_ns: int, *, bus: str = "A",
                 status_bits: int = 0) -> MonitorRecord:
    """A clean record of ``message`` carrying ``words``, as the bus would show it."""
    status = message.rt << 11 | status_bits
    if message.source is not None:
        source_status = message.source[0] << 11 | status_bits
        return MonitorRecord(t_ns=t_ns, bus=bus, format=TransferFormat.RT_RT,
                             command=message.command, command2=message.source_command,
                             data=tuple(words), status=(source_status, status))
    fmt = TransferFormat.RT_BC if message.transmit else TransferFormat.BC_RT
    return MonitorRecord(t_ns=t_ns, bus=bus, format=fmt, command=message.command,
                         data=tuple(words), status=(status,))
