"""The MAPR daemon (``mapr run``): the systemd service around the pipeline.

:mod:`.config` loads ``configs/mapr.yaml`` (its sections read by :mod:`.sections`) and
:mod:`.preflight` checks it against this machine; :mod:`.source` opens the configured
backend (the simulated aircraft too, by name); :mod:`.reader` owns the backend (retries,
bounded queue); :mod:`.service` runs the loop: records -> :mod:`mapr_daemon.pipeline` ->
fault catalog, with :mod:`.recorder` writing the session's Chapter 10 file, :mod:`.notify`
speaking sd_notify, :mod:`.wakeup` waking the loop, :mod:`.logs` writing stderr lines with
systemd priority prefixes. See docs/service.md.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mapr_daemon.service.config import Config, load_config, parse
    from mapr_daemon.service.notify import Notifier
    from mapr_daemon.service.preflight import load_checked
    from mapr_daemon.service.recorder import SessionRecorder
    from mapr_daemon.service.service import Service, prepare
    from mapr_daemon.service.source import monitor_factory
    from mapr_daemon.service.spool import CatalogSpool

_HOME = {
    "Config": "mapr_daemon.service.config",
    "load_config": "mapr_daemon.service.config",
    "parse": "mapr_daemon.service.config",
    "Notifier": "mapr_daemon.service.notify",
    "load_checked": "mapr_daemon.service.preflight",
    "SessionRecorder": "mapr_daemon.service.recorder",
    "Service": "mapr_daemon.service.service",
    "prepare": "mapr_daemon.service.service",
    "monitor_factory": "mapr_daemon.service.source",
    "CatalogSpool": "mapr_daemon.service.spool",
}
"""Each public name and the module it lives in, imported when first asked for: importing
one module of the package (a subcommand's parser) does not import them all."""

__all__ = ["CatalogSpool", "Config", "Notifier", "Service", "SessionRecorder", "load_checked",
           "load_config", "monitor_factory", "parse", "prepare"]


def __getattr__(name: str) -> Any:
    """The public name ``name``, from its module (PEP 562)."""
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_HOME[name]), name)
