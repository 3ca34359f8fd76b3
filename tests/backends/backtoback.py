"""The back-to-back suite: checks any backend against traffic whose content is known.

Each check takes a *monitor factory*: ``factory(setup) -> BusMonitor``, a monitor that sees
the traffic of ``setup`` (a schedule, the terminals answering it, error injections and a
number of minor frames). On the loopback bus the factory simply builds a
:class:`~drivers.backends.loopback.LoopbackMonitor`; a hardware backend's factory plays the same
traffic onto a real bus (a bus controller card, or the loopback's samples through a signal
source) and opens the hardware monitor on it. The checks are then identical, so the hardware
is held to the loopback's reference behaviour (python-can's back-to-back tests do the same).

Every check is listed in :data:`SUITE`; ``tests/backends/test_backtoback_loopback.py`` runs it
on the loopback, and :func:`hardware_factory_or_skip` gates the hardware runs on the
``MAPR_TEST_HW`` environment variable.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field

import pytest

from drivers.backends.loopback import (
    Injection,
    RemoteTerminal,
    Schedule,
    ScheduledMessage,
    bc_rt,
    mode,
    rt_bc,
    rt_rt,
)
from drivers.errors import MonitorClosed
from drivers.mil1553.record import MonitorRecord
from drivers.monitor import BusMonitor, MonitorFilter


@dataclass
class Setup:
    """The traffic a factory must put in front of its monitor."""

    schedule: Schedule
    terminals: list[RemoteTerminal]
    frames: int
    injections: list[Injection] = field(default_factory=list)
    filters: list[MonitorFilter] = field(default_factory=list)


MonitorFactory = Callable[[Setup], BusMonitor]


def _data(sa: int, words: int) -> Callable[[int], list[int]]:
    return lambda t_ns: [(sa << 8 | i) ^ 0x5A00 for i in range(words)]


def reference_terminals() -> list[RemoteTerminal]:
    """RT 3 and RT 12, transmit SA ``k`` sending ``k`` known words (SA 30 sends 30)."""
    return [RemoteTerminal(rt, transmit={sa: _data(sa, sa) for sa in range(1, 31)},
                           bit_word=0x0B17, vector=0x7EC0) for rt in (3, 12)]


FORMATS = (
    bc_rt(3, 1, 32, data=[0x8000, 0x7FFF, 0x0000, 0xFFFF, 0x5555, 0xAAAA] * 5 + [1, 2]),
    rt_bc(12, 30, 30),
    rt_rt(3, 2, 12, 4, 4),
    mode(12, 1),
    mode(3, 16),
    mode(12, 17, data=[0x2C22]),
    bc_rt(31, 5, 2, data=[0x6901, 0x7160]),
    rt_rt(31, 6, 3, 2, 2),
    mode(31, 3),
    mode(31, 20, data=[0x0002]),
)
"""One message of each of the ten formats, with the standard's test words as data."""
FORMAT_NAMES = ("BC_RT", "RT_BC", "RT_RT", "MODE", "MODE_TX_DATA", "MODE_RX_DATA",
                "BCAST_BC_RT", "BCAST_RT_RT", "BCAST_MODE", "BCAST_MODE_RX_DATA")


def one_per_frame(messages: tuple[ScheduledMessage, ...], frame_ns: int = 1_000_000
                  ) -> Schedule:
    """Each message in its own minor frame, in order, repeating."""
    n = len(messages)
    return Schedule(tuple(ScheduledMessage(m.rt, m.sa, m.transmit, m.count, rt2=m.rt2,
                                           sa2=m.sa2, every=n, offset=i, data=m.data,
                                           bus=m.bus) for i, m in enumerate(messages)),
                    frame_ns=frame_ns)


def _run(factory: MonitorFactory, setup: Setup) -> list[MonitorRecord]:
    with factory(setup) as monitor:
        return list(monitor)


def check_every_format(factory: MonitorFactory) -> None:
    """All ten formats come out as sent, clean, with their data and status words."""
    records = _run(factory, Setup(one_per_frame(FORMATS), reference_terminals(), 10))
    assert [str(r.format) for r in records] == list(FORMAT_NAMES)
    assert all(r.errors == () for r in records), [r.to_json() for r in records if r.errors]
    assert records[0].data == tuple(FORMATS[0].bc_data(0, 0))
    assert records[1].data == tuple(_data(30, 30)(0)) and records[1].status == (12 << 11,)
    assert records[2].status == (12 << 11, 3 << 11)
    assert records[4].data == (0x7EC0,) and records[5].data == (0x2C22,)
    assert all(r.status == () for r in records if r.is_broadcast and r.rt2 is None)


def check_clean_traffic(factory: MonitorFactory) -> None:
    """A few hundred messages of steady traffic: every one clean, in time order."""
    schedule = Schedule((rt_bc(3, 8, 8), bc_rt(12, 4, 4), rt_rt(12, 3, 3, 3, 3),
                         mode(3, 2, every=2), mode(31, 1, every=5)), frame_ns=400_000)
    records = _run(factory, Setup(schedule, reference_terminals(), 100))
    assert len(records) == 100 * 3 + 50 + 20
    assert all(r.errors == () for r in records), [r.to_json() for r in records if r.errors][:3]
    times = [r.t_ns for r in records]
    assert times == sorted(times)
    assert all(4_000 <= g <= 12_000 for r in records for g in r.gaps_ns)


def check_errors_detected(factory: MonitorFactory) -> None:
    """Injected errors are each named once, on the message they hit; the rest stay clean."""
    kinds = ("parity", "manchester", "bit_count_low", "late_response", "word_count_low",
             "no_response")  # last: its retry on bus B is an attempt of its own
    setup = Setup(Schedule((rt_bc(12, 6, 6),), frame_ns=300_000), reference_terminals(),
                  len(kinds) + 2, injections=[Injection(k, skip=i) for i, k in enumerate(kinds)])
    records = _run(factory, setup)
    hit = [r for r in records if r.errors]
    for kind in kinds:
        assert sum(kind in r.errors for r in hit) == 1, (kind, [r.to_json() for r in hit])
    retried = [r for r in records if r.bus == "B"]
    assert len(retried) == 1 and retried[0].errors == ()


def check_filters_and_statistics(factory: MonitorFactory) -> None:
    """Filters keep only what they name (``rt=12, tr="T"``: messages in which RT 12 transmits,
    as the receive command's or an RT-RT transfer's transmit command); statistics count
    every record, filtered or not."""
    setup = Setup(one_per_frame(FORMATS), reference_terminals(), 10,
                  filters=[MonitorFilter(rt=12, tr="T")])
    with factory(setup) as monitor:
        records = list(monitor)
        stats = monitor.stats
    assert records and all(any(w is not None and w >> 11 & 31 == 12 and w >> 10 & 1
                               for w in (r.command, r.command2)) for r in records)
    assert stats.messages["A"] == 10
    assert stats.as_dict()["A"]["errors"] == {}


def check_close(factory: MonitorFactory) -> None:
    """close() is idempotent; recv() after it raises MonitorClosed.

    The first record is awaited without a time-out (the traffic holds ten messages, so it
    comes, or the stream ends and the assertion names that), however slowly the host runs."""
    monitor = factory(Setup(one_per_frame(FORMATS), reference_terminals(), 10))
    first = monitor.recv()
    assert first is not None
    monitor.close()
    monitor.close()
    assert monitor.closed
    with pytest.raises(MonitorClosed):
        monitor.recv(timeout=0.1)


SUITE: tuple[Callable[[MonitorFactory], None], ...] = (
    check_every_format, check_clean_traffic, check_errors_detected,
    check_filters_and_statistics, check_close,
)

HARDWARE_FACTORIES: dict[str, str] = {}
"""``MAPR_TEST_HW`` value -> "module:function" returning a :data:`MonitorFactory` (the
hardware issues add theirs here)."""


def hardware_factory_or_skip(name: str) -> MonitorFactory:
    """The factory for hardware backend ``name``, or skip the test saying why.

    Hardware runs only when ``MAPR_TEST_HW`` lists the backend (``MAPR_TEST_HW=usb`` or
    ``usb,serial``): a machine without the card must not fail, and one with it must opt in.
    """
    wanted = {v.strip() for v in os.environ.get("MAPR_TEST_HW", "").split(",") if v.strip()}
    if name not in wanted:
        pytest.skip(f"hardware back-to-back run for {name!r} needs MAPR_TEST_HW={name}")
    target = HARDWARE_FACTORIES.get(name)
    if target is None:
        pytest.skip(f"no back-to-back factory registered for {name!r} yet")
    import importlib
    module_name, _, function = target.partition(":")
    factory: MonitorFactory = getattr(importlib.import_module(module_name), function)()
    return factory
