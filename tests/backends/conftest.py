"""Fixtures of the backend tests: run a few messages over the loopback bus."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from typing import Any

import pytest

from drivers.backends.loopback import (
    LoopbackMonitor,
    RemoteTerminal,
    Schedule,
    ScheduledMessage,
)
from drivers.mil1553.record import MonitorRecord


def pattern(sa: int, words: int) -> Callable[[int], list[int]]:
    """Transmit data of SA ``sa``: ``sa`` in the high byte, the word index in the low."""
    return lambda t_ns: [sa << 8 | i for i in range(words)]


def terminal(address: int, **options: Any) -> RemoteTerminal:
    """A terminal whose transmit SA ``k`` sends ``k`` words (so ``rt_bc(a, k, k)`` works)."""
    return RemoteTerminal(address, transmit={sa: pattern(sa, sa) for sa in range(1, 31)},
                          **options)


Runner = Callable[..., tuple[list[MonitorRecord], LoopbackMonitor]]


def run_messages(messages: Iterable[ScheduledMessage], *,
                 terminals: Iterable[RemoteTerminal] | None = None, frame_ns: int = 200_000,
                 **options: Any) -> tuple[list[MonitorRecord], LoopbackMonitor]:
    """Send ``messages`` one per minor frame, once each; return the records and the monitor."""
    listed = list(messages)
    schedule = Schedule(tuple(dataclasses.replace(m, every=len(listed), offset=i)
                              for i, m in enumerate(listed)), frame_ns=frame_ns)
    if terminals is None:
        terminals = [terminal(5), terminal(6), terminal(7)]
    options.setdefault("frames", len(listed))
    monitor = LoopbackMonitor(terminals=list(terminals), schedule=schedule, **options)
    with monitor:
        records = list(monitor)
    return records, monitor


@pytest.fixture
def run_bus() -> Runner:
    return run_messages
