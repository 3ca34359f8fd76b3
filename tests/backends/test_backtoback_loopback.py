"""The back-to-back suite on the loopback bus (bit level and word level), and its hardware
runs, skipped unless ``MAPR_TEST_HW`` names the card."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from drivers.backends.loopback import LoopbackMonitor
from drivers.monitor import BusMonitor

from .backtoback import SUITE, MonitorFactory, Setup, hardware_factory_or_skip


def loopback_factory(bit_level: bool) -> MonitorFactory:
    def factory(setup: Setup) -> BusMonitor:
        return LoopbackMonitor(schedule=setup.schedule, terminals=setup.terminals,
                               frames=setup.frames, injections=setup.injections,
                               filters=setup.filters, bit_level=bit_level)
    return factory


@pytest.mark.parametrize("check", SUITE, ids=[c.__name__ for c in SUITE])
@pytest.mark.parametrize("bit_level", [True, False], ids=["bits", "words"])
def test_loopback(check: Callable[[MonitorFactory], None], bit_level: bool) -> None:
    check(loopback_factory(bit_level))


@pytest.mark.parametrize("check", SUITE, ids=[c.__name__ for c in SUITE])
@pytest.mark.parametrize("hardware", ["usb", "serial"])
def test_hardware(check: Callable[[MonitorFactory], None], hardware: str) -> None:
    check(hardware_factory_or_skip(hardware))
