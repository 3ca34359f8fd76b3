"""The MAPR reasoner daemon: message table, EMA model, reasoner, fault catalog, CLI.

Importing it registers MAPR's own bus-monitor backend with the drivers' registry, by name
only (nothing is imported until it is opened): ``testbed``, the simulated aircraft on the
loopback bus (:mod:`mapr_daemon.testbed.backend`), which the daemon opens for
``backend.name: testbed`` (its default) as it opens any backend.
"""

from importlib.metadata import PackageNotFoundError, version

from drivers.backends import register

try:
    __version__ = version("mapr")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

TESTBED_BACKEND = "testbed"
"""Name of the simulated aircraft's backend."""
register(TESTBED_BACKEND, "mapr_daemon.testbed.backend:TestbedMonitor")

__all__ = ["TESTBED_BACKEND", "__version__"]
