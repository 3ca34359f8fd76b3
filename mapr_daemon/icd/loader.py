"""Read an ICD YAML file into the :mod:`~mapr_daemon.icd.model` objects, checking each field.

This module checks what one mapping can tell on its own: types, required and unknown keys,
bit ranges, and whether the limits and enumeration codes fit their bits. Checks that need the
whole table (overlaps, duplicates, schedule) are in :mod:`~mapr_daemon.icd.validate`. The
format is documented in ``docs/icd.md``.
"""

from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass
from typing import Any

from mapr_daemon.errors import IcdError
from mapr_daemon.icd.fields import Fields
from mapr_daemon.icd.model import (
    INTEGER_CODE_TYPES,
    Group,
    Message,
    Parameter,
    ParamType,
    Schedule,
    ScheduleEntry,
    Terminal,
    WordOrder,
)

SPEC_VERSION = 1
"""The ``spec:`` version this code reads."""

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_FLOAT32_MAX = struct.unpack(">f", b"\x7f\x7f\xff\xff")[0]


@dataclass(frozen=True, slots=True)
class Table:
    """The parsed file, before cross-checks."""

    path: str
    name: str
    description: str
    buses: tuple[str, ...]
    terminals: tuple[Terminal, ...]
    messages: tuple[Message, ...]
    schedule: Schedule | None


def parse_table(tree: Any, path: str) -> Table:
    """Turn the YAML tree of an ICD file into a :class:`Table`, or raise ``IcdError``."""
    top = Fields(tree, path, "")
    spec = top.integer("spec")
    if spec != SPEC_VERSION:
        top.fail("spec", f"unsupported version {spec}; this MAPR reads spec {SPEC_VERSION}")
    name = top.string("name")
    description = top.string("description", "")
    buses = tuple(_names(top, "buses", ["A", "B"]))
    by_name: dict[str, Terminal] = {}
    for i in range(len(top.listing("terminals"))):
        terminal = _terminal(top.child_at("terminals", i))
        if terminal.name in by_name:
            raise IcdError(f"name {terminal.name!r} already used by the terminal on line "
                           f"{by_name[terminal.name].line}", path=path,
                           line=terminal.line_of("name"), field="terminals.name")
        by_name[terminal.name] = terminal
    terminals = tuple(by_name.values())
    messages = tuple(_message(top.child_at("messages", i), by_name)
                     for i in range(len(top.listing("messages"))))
    schedule = _schedule(top.child("schedule")) if top.has("schedule") else None
    top.done()
    return Table(path, name, description, buses, terminals, messages, schedule)


def _names(f: Fields, key: str, default: list[str]) -> list[str]:
    items = f.listing(key, default)
    for item in items:
        if not isinstance(item, str) or not item:
            f.fail(key, f"must list names, got {item!r}")
    return list(items)


def _identifier(f: Fields, key: str) -> str:
    value: str = f.string(key)
    if not _NAME.match(value):
        f.fail(key, f"{value!r} is not a name (letters, digits and _, not starting with a digit)")
    return value


def _terminal(f: Fields) -> Terminal:
    terminal = Terminal(
        address=f.integer("address", lo=0, hi=30),
        name=_identifier(f, "name"),
        description=f.string("description", ""),
        channel=f.integer("channel", None, lo=1, hi=0xFFFE),
        line=f.line, key_lines=f.lines,
    )
    f.done()
    return terminal


def _rt(f: Fields, key: str, terminals: dict[str, Terminal]) -> Terminal:
    value = f.raw(key)
    if isinstance(value, str):
        if value not in terminals:
            f.fail(key, f"no terminal named {value!r}")
        return terminals[value]
    address = f.integer(key, lo=0, hi=30)
    found = [t for t in terminals.values() if t.address == address]
    if len(found) > 1:   # the same address on several channels (buses): name the one meant
        f.fail(key, f"address {address} is the terminal of several channels ("
               + ", ".join(f"{t.name} on channel {t.channel}" for t in found)
               + "); name the terminal")
    if not found:
        f.fail(key, f"no terminal with address {address}")
    return found[0]


def _bus(channel: int | None) -> str:
    return "every channel" if channel is None else f"channel {channel}"


def _subaddress(f: Fields, key: str) -> int:
    sa: int = f.integer(key, lo=0, hi=31)
    if sa in (0, 31):
        f.fail(key, f"subaddress {sa} is reserved for mode codes and cannot carry data")
    return sa


def _message(f: Fields, terminals: dict[str, Terminal]) -> Message:
    name = _identifier(f, "name")
    terminal = _rt(f, "rt", terminals)
    tr = f.string("tr")
    if tr not in ("T", "R"):
        f.fail("tr", f"must be T (RT transmits) or R (RT receives), got {tr!r}")
    sa = _subaddress(f, "sa")
    wc = f.integer("wc", lo=1, hi=32)
    rate = f.number("rate_hz")
    if rate < 0:
        f.fail("rate_hz", f"must be 0 (aperiodic) or more, got {rate}")
    source = None
    if f.has("source"):
        if tr != "R":
            f.fail("source", "only a receive (tr: R) message can have an RT-RT source")
        sf = f.child("source")
        source_rt = _rt(sf, "rt", terminals)
        if source_rt.channel != terminal.channel:
            sf.fail("rt", f"{source_rt.name} is on {_bus(source_rt.channel)} and "
                    f"{terminal.name} on {_bus(terminal.channel)}: an RT-RT transfer is "
                    "on one bus")
        if source_rt.address == terminal.address:
            sf.fail("rt", "an RT-RT transfer needs two different terminals")
        source = (source_rt.address, _subaddress(sf, "sa"))
        sf.done()
    parameters = tuple(_parameter(f.child_at("parameters", i))
                       for i in range(len(f.listing("parameters", []))))
    group = _group(f.child("group")) if f.has("group") else None
    if not parameters and group is None:
        f.fail("parameters", "a message needs parameters or a group")
    message = Message(
        name=name, rt=terminal.address, rt_name=terminal.name, transmit=tr == "T",
        subaddress=sa, word_count=wc, rate_hz=rate, parameters=parameters, group=group,
        source=source, description=f.string("description", ""), line=f.line,
        key_lines=f.lines, channel=terminal.channel)
    f.done()
    return message


def _group(f: Fields) -> Group:
    start = f.integer("start", lo=0, hi=31)
    samples = f.integer("samples", lo=1, hi=32)
    rate = f.number("sample_rate_hz", positive=True)
    channels = tuple(_parameter(f.child_at("channels", i))
                     for i in range(len(f.listing("channels"))))
    if not channels:
        f.fail("channels", "a group needs at least one channel")
    needed = max(c.word + c.words for c in channels)
    stride = f.integer("stride", needed, lo=1, hi=32)
    for channel in channels:
        if channel.word + channel.words > stride:
            raise_at = f.child_at("channels", channels.index(channel))
            raise_at.fail("word", f"word {channel.word} is past the sample's {stride} words")
    latency = f.number("latency_s", None)
    if latency is not None and latency < 0:
        f.fail("latency_s", f"must be 0 or more, got {latency}")
    group = Group(start=start, samples=samples, stride=stride, sample_rate_hz=rate,
                  channels=channels, counter=f.string("counter", None), latency_s=latency,
                  line=f.line, key_lines=f.lines)
    f.done()
    return group


def _bits(f: Fields, words: int) -> tuple[int, int]:
    top = 16 * words - 1
    if not f.has("bits"):
        f.raw("bits", None)
        return top, 0
    value = f.raw("bits")
    if isinstance(value, int) and not isinstance(value, bool):
        msb = lsb = value
    elif (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, int) and not isinstance(v, bool) for v in value)):
        msb, lsb = value
    else:
        f.fail("bits", f"must be a bit number or [msb, lsb], got {value!r}")
    if not top >= msb >= lsb >= 0:
        f.fail("bits", f"[{msb}, {lsb}] is not a range within bits {top}..0 (msb first)")
    return msb, lsb


def _parameter(f: Fields) -> Parameter:
    name = _identifier(f, "name")
    type_name = f.string("type")
    try:
        ptype = ParamType(type_name)
    except ValueError:
        f.fail("type", f"unknown type {type_name!r}; one of "
                       + ", ".join(t.value for t in ParamType))
    word = f.integer("word", lo=0, hi=31)
    words = f.integer("words", 2 if ptype is ParamType.FLOAT32 else 1, lo=1, hi=2)
    if ptype is ParamType.FLOAT32 and words != 2:
        f.fail("words", "a float32 takes two words")
    order = WordOrder.MSW_FIRST
    if f.has("word_order"):
        if words != 2:
            f.fail("word_order", "only a two-word parameter has a word order")
        try:
            order = WordOrder(f.string("word_order"))
        except ValueError:
            f.fail("word_order", "must be msw_first or lsw_first")
    msb, lsb = _bits(f, words)
    width = msb - lsb + 1
    _check_width(f, ptype, width)
    scale, offset, minimum, maximum = _scaling(f, ptype, width)
    labels = _labels(f, ptype, width)
    parameter = Parameter(
        name=name, type=ptype, word=word, msb=msb, lsb=lsb, words=words, word_order=order,
        scale=scale, offset=offset, unit=f.string("unit", ""), minimum=minimum,
        maximum=maximum, labels=labels, description=f.string("description", ""), line=f.line,
        key_lines=f.lines)
    _check_fit(f, parameter)
    f.done()
    return parameter


def _check_width(f: Fields, ptype: ParamType, width: int) -> None:
    if ptype is ParamType.DISCRETE and width != 1:
        f.fail("bits", f"a discrete is one bit, got {width}")
    if ptype is ParamType.FLOAT32 and width != 32:
        f.fail("bits", f"a float32 needs all 32 bits, got {width}")
    if ptype is ParamType.BCD and width % 4:
        f.fail("bits", f"BCD needs a multiple of 4 bits (one digit each), got {width}")
    if ptype in (ParamType.TWOS, ParamType.BNR) and width < 2:
        f.fail("bits", "a signed value needs at least 2 bits")


def _scaling(f: Fields, ptype: ParamType,
             width: int) -> tuple[float, float, float | None, float | None]:
    if ptype in INTEGER_CODE_TYPES:
        for key in ("scale", "lsb", "msb_weight", "offset", "minimum", "maximum"):
            if f.has(key):
                f.fail(key, f"a {ptype} parameter has no {key}")
        return 1.0, 0.0, None, None
    given = [k for k in ("scale", "lsb", "msb_weight") if f.has(k)]
    if len(given) > 1:
        f.fail(given[1], f"give one of scale, lsb, msb_weight (also has {given[0]})")
    if ptype is ParamType.BNR and given != ["msb_weight"]:
        f.fail(given[0] if given else "msb_weight", "a bnr parameter is scaled by msb_weight")
    if ptype is not ParamType.BNR and given == ["msb_weight"]:
        f.fail("msb_weight", "msb_weight is for bnr parameters; use lsb")
    scale = 1.0
    if given:
        scale = f.number(given[0])
        if scale == 0:
            f.fail(given[0], "must not be 0")
    if ptype is ParamType.BNR:
        scale = scale / 2.0 ** (width - 2)
    offset = f.number("offset", 0.0)
    minimum = f.number("minimum", None)
    maximum = f.number("maximum", None)
    if minimum is not None and maximum is not None and minimum > maximum:
        f.fail("maximum", f"maximum {maximum} is below minimum {minimum}")
    return scale, offset, minimum, maximum


def _labels(f: Fields, ptype: ParamType, width: int) -> dict[int, str]:
    if ptype is not ParamType.ENUM:
        if f.has("values"):
            f.fail("values", "only an enum parameter has values")
        return {}
    values = f.raw("values")
    if not isinstance(values, dict) or not values:
        f.fail("values", "must map codes to labels, e.g. {0: OFF, 1: ON}")
    labels: dict[int, str] = {}
    for code, label in values.items():
        if isinstance(code, bool) or not isinstance(code, int):
            f.fail("values", f"code {code!r} is not an integer")
        if not 0 <= code < 1 << width:
            f.fail("values", f"code {code} cannot fit in {width} bit(s)")
        if not isinstance(label, str) or not label:
            f.fail("values", f"label of code {code} must be a string")
        if label in labels.values():
            f.fail("values", f"label {label!r} is used twice")
        labels[code] = label
    return labels


def _check_fit(f: Fields, p: Parameter) -> None:
    """Limits must be values the bits can carry."""
    for key, limit in (("minimum", p.minimum), ("maximum", p.maximum)):
        if limit is None:
            continue
        raw = (limit - p.offset) / p.scale
        if p.type is ParamType.FLOAT32:
            if abs(raw) > _FLOAT32_MAX:
                f.fail(key, f"{limit} cannot be held by a float32")
            continue
        code = math.floor(raw + 0.5)
        if not p.raw_min <= code <= p.raw_max:
            lo = p.raw_min * p.scale + p.offset
            hi = p.raw_max * p.scale + p.offset
            lo, hi = min(lo, hi), max(lo, hi)
            f.fail(key, f"{limit} cannot fit in {p.width} bits of {p.type} "
                        f"(they hold {lo:g} to {hi:g})")


def _schedule(f: Fields) -> Schedule:
    entries = []
    for i in range(len(f.listing("messages"))):
        e = f.child_at("messages", i)
        every = e.integer("every", lo=1)
        entries.append(ScheduleEntry(message=e.string("message"), every=every,
                                     offset=e.integer("offset", 0, lo=0, hi=every - 1),
                                     line=e.line, key_lines=e.lines))
        e.done()
    schedule = Schedule(
        minor_frame_us=f.integer("minor_frame_us", lo=100),
        minor_frames=f.integer("minor_frames", lo=1),
        entries=tuple(entries),
        response_time_us=f.number("response_time_us", 10.0),
        intermessage_gap_us=f.number("intermessage_gap_us", 10.0),
        line=f.line, key_lines=f.lines)
    f.done()
    return schedule
