"""What the daemon opens: the configured backend, by name, like any other.

``backend.name: loopback`` in a daemon config means the simulated aircraft on the loopback
bus (a bare loopback bus carries no EMA): the ``testbed`` backend, which
:mod:`mapr_daemon` registers by name in the drivers' backend registry. It gets the config's
``testbed:`` section, ICD and ``assets:`` as options, beside ``backend.options``. The daemon
never imports the simulator (tests/test_imports.py holds every module to this rule): the
registry imports it when, and only when, it is opened.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from drivers.errors import BackendUnavailable
from drivers.monitor import BusMonitor, backend_class, open_monitor
from mapr_daemon import TESTBED_BACKEND
from mapr_daemon.icd import Icd
from mapr_daemon.service.config import Config

LOOPBACK = "loopback"
"""The daemon config's name for the testbed aircraft on the loopback bus."""


def backend_name(config: Config) -> str:
    """The registered backend the config names (``loopback`` is the testbed)."""
    name = config.backend.name
    return TESTBED_BACKEND if name == LOOPBACK else name


def backend_options(config: Config, icd: Icd | None) -> dict[str, Any]:
    """The options the backend is opened with: ``backend.options``, and for the testbed
    also the ``testbed:`` section, the ICD and the assets (plain data)."""
    options: dict[str, Any] = dict(config.backend.options)
    if backend_name(config) == TESTBED_BACKEND:
        options = {"testbed": dataclasses.asdict(config.testbed), "icd": icd or config.icd,
                   "assets": [dataclasses.asdict(a) for a in config.assets], **options}
    return options


def check(config: Config) -> None:
    """Validate what opening would need, so errors surface at start (exit 78), not later.
    A backend that cannot be imported here is left to the reader, which reports it and
    retries opening it (a driver installed later)."""
    try:
        cls = backend_class(backend_name(config))
    except BackendUnavailable:
        return
    cls.check_options(**backend_options(config, None))


def monitor_factory(config: Config, icd: Icd) -> Callable[[], BusMonitor]:
    """A function that opens the configured monitor (called again after each failure)."""
    name, options = backend_name(config), backend_options(config, icd)
    return lambda: open_monitor(name, **options)
