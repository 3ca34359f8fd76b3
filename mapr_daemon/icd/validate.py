"""Checks that need the whole table: overlaps, duplicates, words past the count, the schedule.

Each check raises :class:`IcdError` naming the file, the line of the offending entry and a
dotted field (``message.parameter.bits``). Checks local to one mapping (types, bit ranges,
limits that cannot fit) happen while loading, in :mod:`~mapr_daemon.icd.loader`.
"""

from __future__ import annotations

import math

from mapr_daemon.errors import IcdError
from mapr_daemon.icd.busload import bus_load
from mapr_daemon.icd.loader import Table
from mapr_daemon.icd.model import Message, Parameter, ParamType


def validate_table(table: Table) -> None:
    """Raise :class:`IcdError` at the first inconsistency in ``table``."""
    _terminals(table)
    _names(table)
    _subaddresses(table)
    for message in table.messages:
        _layout(table.path, message)
    _schedule(table)


def _fail(table: Table, line: int, field: str, problem: str) -> None:
    raise IcdError(problem, path=table.path, line=line, field=field)


def _on(channel: int | None) -> str:
    return "" if channel is None else f" on channel {channel}"


def _bus(channel: int | None) -> str:
    return "every channel" if channel is None else f"channel {channel}"


def _terminals(table: Table) -> None:
    """Addresses are unique on each bus (names are checked while loading: messages refer to
    them); a terminal on every bus (no channel) shares its address with none."""
    seen: dict[tuple[int | None, int], int] = {}
    for t in table.terminals:
        clash = seen.get((t.channel, t.address))
        if clash is None and t.channel is None:
            clash = next((line for (_, a), line in seen.items() if a == t.address), None)
        elif clash is None:
            clash = seen.get((None, t.address))
        if clash is not None:
            _fail(table, t.line_of("address"), "terminals.address",
                  f"address {t.address}{_on(t.channel)} already used by the terminal on line "
                  f"{clash}")
        seen[(t.channel, t.address)] = t.line


def _names(table: Table) -> None:
    messages: dict[str, int] = {}
    parameters: dict[str, tuple[str, int]] = {}
    for m in table.messages:
        if m.name in messages:
            _fail(table, m.line_of("name"), f"{m.name}.name",
                  f"message name {m.name!r} already used on line {messages[m.name]}")
        messages[m.name] = m.line
        for p in m.all_parameters():
            if p.name in parameters:
                other, line = parameters[p.name]
                _fail(table, p.line_of("name"), f"{m.name}.{p.name}.name",
                      f"parameter name {p.name!r} already used in {other} on line {line}")
            parameters[p.name] = (m.name, p.line)


def _subaddresses(table: Table) -> None:
    """Each RT/T-R/subaddress of a bus is one message (a subaddress of a terminal on one
    channel is that bus's alone)."""
    used: dict[tuple[int | None, int, str, int], Message] = {}
    for m in table.messages:
        keys = [((m.channel, m.rt, m.tr, m.subaddress), "sa")]
        if m.source is not None:
            keys.append(((m.channel, m.source[0], "T", m.source[1]), "source.sa"))
        for key, field in keys:
            if key in used:
                channel, rt, tr, sa = key
                _fail(table, m.line_of(field.split(".")[0]), f"{m.name}.{field}",
                      f"RT{rt:02d} {tr} SA{sa:02d}{_on(channel)} is already used by message "
                      f"{used[key].name!r} (line {used[key].line})")
            used[key] = m


def _cells(p: Parameter, base: int) -> list[tuple[int, int]]:
    """(word, bit) pairs a parameter occupies, ``base`` = word of its sample or 0."""
    indices = p.word_indices(base)
    cells = []
    for bit in range(p.lsb, p.msb + 1):
        word = indices[0] if (p.words == 2 and bit >= 16) or p.words == 1 else indices[1]
        cells.append((word, bit % 16))
    return cells


def _layout(path: str, m: Message) -> None:
    def fail(p_line: int, field: str, problem: str) -> None:
        raise IcdError(problem, path=path, line=p_line, field=f"{m.name}.{field}")

    owner: dict[tuple[int, int], Parameter] = {}
    placed: list[tuple[Parameter, int, str]] = [(p, 0, p.name) for p in m.parameters]
    g = m.group
    if g is not None:
        end = g.start + g.samples * g.stride
        if end > m.word_count:
            fail(g.line_of("samples"), "group.samples",
                 f"{g.samples} samples of {g.stride} words from word {g.start} end at word "
                 f"{end - 1}, past the word count {m.word_count}")
        for i in range(g.samples):
            base = g.start + i * g.stride
            placed += [(c, base, f"group.{c.name}") for c in g.channels]
        if g.counter is not None:
            counters = {p.name: p for p in m.parameters}
            if g.counter not in counters or counters[g.counter].type is not ParamType.COUNTER:
                fail(g.line_of("counter"), "group.counter",
                     f"{g.counter!r} is not a counter parameter of this message")
    for p, base, label in placed:
        last = max(p.word_indices(base))
        if last >= m.word_count:
            fail(p.line_of("word"), f"{label}.word",
                 f"word {last} is past the word count {m.word_count} (words 0-{m.word_count - 1})")
        for cell in _cells(p, base):
            other = owner.get(cell)
            if other is not None:
                fail(p.line_of("bits"), f"{label}.bits",
                     f"bit {cell[1]} of word {cell[0]} overlaps {other.name!r} "
                     f"(line {other.line})")
            owner[cell] = p


def _schedule(table: Table) -> None:
    s = table.schedule
    if s is None:
        return
    by_name = {m.name: m for m in table.messages}
    seen: set[str] = set()
    for e in s.entries:
        where = f"schedule.{e.message}"
        if e.message not in by_name:
            _fail(table, e.line_of("message"), "schedule.message",
                  f"no message named {e.message!r}")
        if e.message in seen:
            _fail(table, e.line_of("message"), where, "message scheduled twice")
        first = by_name[next(iter(seen))] if seen else None
        if first is not None and by_name[e.message].channel != first.channel:
            _fail(table, e.line_of("message"), where,   # one bus controller, one bus
                  f"{e.message!r} is on {_bus(by_name[e.message].channel)} and "
                  f"{first.name!r} on {_bus(first.channel)}: a schedule is one bus's")
        seen.add(e.message)
        if s.minor_frames % e.every:
            _fail(table, e.line_of("every"), f"{where}.every",
                  f"every {e.every} does not divide the {s.minor_frames} minor frames")
        rate = s.rate_hz(e)
        declared = by_name[e.message].rate_hz
        if not math.isclose(rate, declared, rel_tol=1e-9):
            _fail(table, e.line_of("every"), f"{where}.every",
                  f"runs at {rate:g} Hz but the message declares rate_hz {declared:g}")
    for m in table.messages:
        if m.rate_hz > 0 and m.name not in seen:
            _fail(table, m.line_of("rate_hz"), f"{m.name}.rate_hz",
                  f"periodic ({m.rate_hz:g} Hz) but not in the schedule")
    load = bus_load(s, by_name)
    for k, used in enumerate(load.frame_us):
        if used > s.minor_frame_us:
            _fail(table, s.line_of("minor_frame_us"), "schedule.minor_frame_us",
                  f"minor frame {k} needs {used:g} µs of bus time, more than its "
                  f"{s.minor_frame_us} µs ({', '.join(s.frame(k))})")
