"""The MAPR daemon (``mapr run``): the systemd service around the pipeline.

:mod:`.config` loads ``configs/mapr.yaml`` (its sections read by :mod:`.sections`) and
:mod:`.preflight` checks it against this machine; :mod:`.source` opens the configured
backend (the simulated aircraft too, by name); :mod:`.reader` owns the backend (retries,
bounded queue); :mod:`.service` runs the loop: records -> :mod:`mapr_daemon.pipeline` ->
fault catalog, with :mod:`.recorder` writing the session's Chapter 10 file, :mod:`.notify`
speaking sd_notify, :mod:`.wakeup` waking the loop, :mod:`.logs` writing stderr lines with
systemd priority prefixes. See docs/service.md.
"""

from mapr_daemon.service.config import Config, load_config, parse
from mapr_daemon.service.notify import Notifier
from mapr_daemon.service.preflight import load_checked
from mapr_daemon.service.recorder import SessionRecorder
from mapr_daemon.service.service import Service, prepare
from mapr_daemon.service.source import monitor_factory

__all__ = ["Config", "Notifier", "Service", "SessionRecorder", "load_checked", "load_config",
           "monitor_factory", "parse", "prepare"]
