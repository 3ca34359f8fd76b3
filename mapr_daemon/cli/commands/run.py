"""``mapr run``: the daemon — monitor the bus, reason, write the fault catalog.

::

    mapr run                                  # the embedded demo: the loopback testbed
    mapr run --config /etc/mapr/mapr.yaml     # what systemd runs (systemd/mapr.service)
    mapr run --check --config mapr.yaml       # validate the config and ICD, then exit

Runs until SIGTERM or Ctrl-C (exit 0); SIGHUP reloads the config. A config or ICD error
exits 78 with one line ``file:line: field: problem``; a backend that can never open here (its
library is missing), 69. An asset's fault dictionary is built, not shipped: when it is
missing, the check prints the ``mapr dictionary build`` command line that makes it. See
docs/service.md.
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

from drivers.errors import BackendUnavailable
from mapr_daemon.cli import exitcodes
from mapr_daemon.errors import ConfigError


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("run", help="run the daemon (monitor, reason, catalog)",
                                   description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", metavar="FILE",
                        help="daemon config (default: built-in defaults, the loopback testbed)")
    parser.add_argument("--check", action="store_true",
                        help="only validate the config, ICD and dictionary")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.service import logs
    from mapr_daemon.service.preflight import load_checked
    from mapr_daemon.service.service import Service, prepare

    log = logs.setup("info")
    try:
        config = load_checked(args.config)
        logs.setup(config.log_level)
        if args.check:
            prepare(config)
            log.info("%s: OK (config %s)", args.config or "defaults", config.digest())
            return exitcodes.OK
        service = Service(config, args.config)
    except ConfigError as error:
        log.error("mapr run: %s", error)
        if args.config:
            from mapr_daemon.cli.dictionary_hint import build_command

            command = build_command(args.config, str(error))
            if command:   # a built product, not a shipped file: say how to build it
                log.error("mapr run: build it first: %s", command)
        return exitcodes.CONFIG
    except BackendUnavailable as error:  # can never open here: retrying would not help
        log.error("mapr run: %s", error)
        return exitcodes.UNAVAILABLE
    try:
        return service.run()
    except Exception:
        logging.getLogger("mapr").exception("internal error")
        return exitcodes.FAILURE
