"""What the daemon opens: the configured backend, by name, like any other.

``backend.name: testbed`` in a daemon config (the default) is the simulated aircraft on the
loopback bus, which :mod:`mapr_daemon` registers by name in the drivers' backend registry. It
gets the config's ``testbed:`` section as written (with the config file's name, for its
``file:line`` errors and relative paths), the ICD and ``assets:`` as options, beside
``backend.options``. The daemon never imports the simulator (tests/test_imports.py holds every
module to this rule): the registry imports it when, and only when, it is opened or checked.
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


def backend_options(config: Config, icd: Icd | None) -> dict[str, Any]:
    """The options the backend is opened with: ``backend.options``, and for the testbed
    also the ``testbed:`` section, the config file, the ICD and the assets (plain data)."""
    options: dict[str, Any] = dict(config.backend.options)
    if config.backend.name == TESTBED_BACKEND:
        options = {"testbed": config.testbed, "config_file": config.source,
                   "icd": icd or config.icd,
                   "assets": [dataclasses.asdict(a) for a in config.assets], **options}
    return options


def check(config: Config, icd: Icd | None = None) -> None:
    """Validate what opening would need, so errors surface at start (exit 78), not later.
    A backend that cannot be imported here is left to the reader, which reports it and
    retries opening it (a driver installed later)."""
    try:
        cls = backend_class(config.backend.name)
    except BackendUnavailable:
        return
    cls.check_options(**backend_options(config, icd))


def monitor_factory(config: Config, icd: Icd) -> Callable[[], BusMonitor]:
    """A function that opens the configured monitor (called again after each failure)."""
    name, options = config.backend.name, backend_options(config, icd)
    return lambda: open_monitor(name, **options)
