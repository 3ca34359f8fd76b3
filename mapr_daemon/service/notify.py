"""A stdlib-only systemd notifier (``sd_notify``): READY, STATUS, WATCHDOG, STOPPING.

systemd hands a Type=notify service the path of a unix datagram socket in ``$NOTIFY_SOCKET``
(a leading ``@`` means the abstract namespace) and, with ``WatchdogSec=``, the interval in
``$WATCHDOG_USEC``. Without ``NOTIFY_SOCKET`` (run by hand, in a test) every call is a no-op,
so the daemon never needs to know how it was started. A lost datagram is logged once and
otherwise ignored: notification must never take the service down.

    notifier = Notifier.from_environment()
    notifier.ready()
    notifier.status("1985 msg/s, 0 errors, 1 event")
    if notifier.watchdog_due(): notifier.watchdog()
"""

from __future__ import annotations

import logging
import os
import socket
import time

log = logging.getLogger("mapr.notify")


class Notifier:
    """Sends ``KEY=value`` datagrams to systemd's notify socket, if there is one."""

    def __init__(self, address: str | None, watchdog_usec: int | None = None) -> None:
        self.address = address
        self.watchdog_interval_s = None if not watchdog_usec else watchdog_usec / 2e6
        """Half of ``WATCHDOG_USEC``: how often :meth:`watchdog` must be called."""
        self._sock: socket.socket | None = None
        self._last_ping = 0.0
        self._warned = False
        if address:
            self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)

    @classmethod
    def from_environment(cls) -> Notifier:
        """From ``$NOTIFY_SOCKET`` and ``$WATCHDOG_USEC`` (honouring ``$WATCHDOG_PID``)."""
        address = os.environ.get("NOTIFY_SOCKET") or None
        usec: int | None = None
        raw = os.environ.get("WATCHDOG_USEC", "")
        pid = os.environ.get("WATCHDOG_PID", "")
        if raw.isdigit() and (not pid or pid == str(os.getpid())):
            usec = int(raw)
        return cls(address, usec)

    @property
    def enabled(self) -> bool:
        return self._sock is not None

    def notify(self, *lines: str) -> None:
        """Send one datagram of newline-separated assignments (no-op without a socket)."""
        if self._sock is None or self.address is None:
            return
        target = "\0" + self.address[1:] if self.address.startswith("@") else self.address
        try:
            self._sock.sendto("\n".join(lines).encode(), target)
        except OSError as error:
            if not self._warned:
                log.warning("cannot notify systemd at %s: %s", self.address, error)
                self._warned = True

    def ready(self, status: str | None = None) -> None:
        self.notify("READY=1", *([f"STATUS={status}"] if status else []))

    def status(self, text: str) -> None:
        self.notify(f"STATUS={text}")

    def stopping(self) -> None:
        self.notify("STOPPING=1")

    def reloading(self) -> None:
        usec = time.clock_gettime_ns(time.CLOCK_MONOTONIC) // 1000
        self.notify("RELOADING=1", f"MONOTONIC_USEC={usec}")

    def watchdog_due(self) -> bool:
        """True when a watchdog is configured and half its interval has passed."""
        if self.watchdog_interval_s is None or self._sock is None:
            return False
        return time.monotonic() - self._last_ping >= self.watchdog_interval_s

    def watchdog_next(self) -> float | None:
        """When (``time.monotonic()``) :meth:`watchdog` is next due; None without a watchdog."""
        if self.watchdog_interval_s is None or self._sock is None:
            return None
        return self._last_ping + self.watchdog_interval_s

    def watchdog(self) -> None:
        self._last_ping = time.monotonic()
        self.notify("WATCHDOG=1")

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None
