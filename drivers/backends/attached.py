"""What ``mapr devices`` reports about one attached card, and how to open it.

The hardware backends enumerate what is plugged in (:func:`~drivers.backends.serial_card.
serial_cards`, :func:`~drivers.backends.usb_card.usb_cards`) and describe each card as an
:class:`AttachedCard`: what the operating system calls it, its USB identity, its state, a
problem if one stands in the way (permissions, a missing firmware), and the backend options
that open exactly this card — printed both as ``mapr monitor -O key=value`` arguments and as
the daemon config's ``backend:`` line, so a user can copy either.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import yaml

UDEV_HINT = ("install the udev rule systemd/60-mapr.rules (udevadm control --reload && "
             "udevadm trigger) and add the user to the dialout group (log in again)")


@dataclasses.dataclass(frozen=True)
class AttachedCard:
    """One card a backend recognizes, as ``mapr devices`` lists it."""

    backend: str
    """The backend that opens it: ``serial`` or ``usb``."""
    device: str
    """What the operating system calls it: ``/dev/ttyUSB0``, ``usb bus 1 address 7``."""
    usb_id: str
    """``vvvv:pppp`` (hex vendor and product IDs)."""
    description: str
    """Maker and product as the device reports them."""
    state: str
    """What the card is doing: ``fx2lafw 1.4 running``, ``bare FX2: firmware loaded when
    opened``, ``USB serial adapter``."""
    options: dict[str, Any]
    """Backend options that open this card (``{}``: the defaults find it)."""
    serial_number: str | None = None
    stable_path: str | None = None
    """A path that survives replugging and other ports (``/dev/serial/by-id/...``)."""
    problem: str | None = None
    """What stands in the way of opening it, with what to do (None: nothing known)."""

    def monitor_args(self) -> str:
        """The ``mapr monitor`` arguments that open this card."""
        options = " ".join(f"-O {key}={value}" for key, value in self.options.items())
        return f"--backend {self.backend}" + (f" {options}" if options else "")

    def config_line(self) -> str:
        """The daemon config's ``backend:`` line (YAML) that opens this card."""
        inner = yaml.safe_dump({"name": self.backend, "options": self.options},
                               default_flow_style=True, sort_keys=False, width=10_000)
        return f"backend: {inner.strip()}"

    def as_json(self) -> dict[str, Any]:
        """The card as a JSON object (``mapr devices --json``)."""
        return {**dataclasses.asdict(self), "monitor_args": self.monitor_args(),
                "config_line": self.config_line()}


def access_problem(path: str) -> str | None:
    """A one-line problem if this process may not read and write the device node ``path``
    (None when it may, or when the node does not exist here to be checked)."""
    if not os.path.exists(path):
        return None
    # Effective IDs: they are what open() is checked against.
    if os.access(path, os.R_OK | os.W_OK, effective_ids=os.access in os.supports_effective_ids):
        return None
    return f"permission denied on {path}: {UDEV_HINT}"
