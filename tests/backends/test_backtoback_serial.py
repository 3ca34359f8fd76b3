"""The back-to-back suite on the ``serial`` backend, through the open1553 card emulator on
real pty pairs (one card per bus).

``check_errors_detected`` is replaced by :func:`test_serial_errors_detected`: the open1553
line carries no Manchester or bit-count error class and no time tags, so of its six injected
errors only parity, word count and no-response can be seen on this card (docs/hardware.md).
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from drivers.backends.loopback import Injection, Schedule, rt_bc
from drivers.backends.serial_card import SerialMonitor
from drivers.monitor import BusMonitor

from .backtoback import (
    SUITE,
    MonitorFactory,
    Setup,
    check_errors_detected,
    reference_terminals,
)
from .card_emulators import SerialCard

PAUSE_S = 0.0
"""No quiet link between messages: boundaries come from the card's report alone (the quiet
link is exercised in test_serial_card.py)."""


def serial_factory(setup: Setup) -> BusMonitor:
    """A serial monitor on two emulated cards playing ``setup``; the stream ends when the
    emulator unplugs after the last frame (``reconnect=False``)."""
    card = SerialCard(buses=2, pause_s=PAUSE_S)
    monitor = SerialMonitor(port=card.path(0), port_b=card.path(1), reconnect=False,
                            filters=setup.filters)
    card.start(setup, drained=lambda: monitor.lines_read >= card.lines_written,
               stopped=lambda: monitor.closed)
    return monitor


CHECKS = [c for c in SUITE if c is not check_errors_detected]


@pytest.mark.parametrize("check", CHECKS, ids=[c.__name__ for c in CHECKS])
def test_serial_backtoback(check: Callable[[MonitorFactory], None]) -> None:
    check(serial_factory)


def test_serial_errors_detected() -> None:
    """The errors an open1553 card can show are each named once, on the message they hit;
    every record says its times are host times."""
    kinds = ("parity", "word_count_low", "no_response")
    setup = Setup(Schedule((rt_bc(12, 6, 6),), frame_ns=300_000), reference_terminals(),
                  len(kinds) + 2, injections=[Injection(k, skip=i) for i, k in enumerate(kinds)])
    with serial_factory(setup) as monitor:
        records = list(monitor)
    hit = [r for r in records if r.errors]
    for kind in kinds:
        assert sum(kind in r.errors for r in hit) == 1, (kind, [r.to_json() for r in hit])
    assert len(records) == len(kinds) + 2 + 1  # the no-response retried on bus B
    retried = [r for r in records if r.bus == "B"]
    assert len(retried) == 1 and retried[0].errors == ()
    assert all(r.extra["time_tags"] == "host" for r in records)
