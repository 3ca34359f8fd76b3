"""Logging to stderr with systemd priority prefixes (``<3>`` error, ``<4>`` warning, ...).

journald reads a leading ``<N>`` on each stderr line as the syslog priority (sd-daemon(3)),
so the service needs no syslog connection and ``journalctl -p warning`` works. Run by hand the
prefixes stay: they are short and greppable.
"""

from __future__ import annotations

import logging
import sys

PRIORITY = {logging.CRITICAL: 2, logging.ERROR: 3, logging.WARNING: 4, logging.INFO: 6,
            logging.DEBUG: 7}


class SystemdFormatter(logging.Formatter):
    """``<6>mapr: message`` — priority prefix, then the message (journald adds the time)."""

    def format(self, record: logging.LogRecord) -> str:
        prio = PRIORITY.get(record.levelno, 6)
        text = super().format(record)
        return "\n".join(f"<{prio}>{line}" for line in text.splitlines() or [""])


def setup(level: str = "info") -> logging.Logger:
    """Route the ``mapr`` loggers to stderr with priority prefixes; returns ``mapr``."""
    logger = logging.getLogger("mapr")
    for handler in list(logger.handlers):
        logger.removeHandler(handler)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(SystemdFormatter("%(message)s"))
    logger.addHandler(handler)
    logger.setLevel(level.upper())
    logger.propagate = False
    return logger
