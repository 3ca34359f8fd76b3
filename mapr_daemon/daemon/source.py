"""What the daemon opens: the configured backend, or the simulated aircraft on the loopback.

Every backend but ``loopback`` gets ``backend.options`` as is. For ``backend.name:
loopback`` the bus is the testbed aircraft (:mod:`mapr_daemon.testbed.loopback`) flying the
config's ``testbed:`` section. That is the one place the daemon reaches the simulator, and it
does so lazily, inside the loopback branch: a daemon on a real card never imports
:mod:`mapr_daemon.testbed` (tests/test_imports.py holds every module to this rule).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from drivers.monitor import BusMonitor, open_monitor
from mapr_daemon.daemon.config import Config
from mapr_daemon.icd import Icd


def check(config: Config) -> None:
    """Validate what opening would need, so errors surface at start (exit 78), not later."""
    if config.backend.name == "loopback":
        from mapr_daemon.testbed import loopback  # the simulator: loopback only
        loopback.check(config)


def monitor_factory(config: Config, icd: Icd) -> Callable[[], BusMonitor]:
    """A function that opens the configured monitor (called again after each failure)."""
    if config.backend.name == "loopback":
        from mapr_daemon.testbed import loopback  # the simulator: loopback only
        return loopback.testbed_factory(config, icd)
    options: dict[str, Any] = dict(config.backend.options)
    return lambda: open_monitor(config.backend.name, **options)
