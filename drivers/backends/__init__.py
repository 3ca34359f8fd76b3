"""Bus-monitor backends: the name table. Each backend is imported only when opened (see
:mod:`drivers.monitor`), so this module is light: the command line lists and checks backend
names without importing any backend or numpy."""

from __future__ import annotations

BACKENDS: dict[str, tuple[str, str]] = {
    "loopback": ("drivers.backends.loopback", "LoopbackMonitor"),
    "capture": ("drivers.backends.capture", "CaptureMonitor"),
    "serial": ("drivers.backends.serial_card", "SerialMonitor"),
    "usb": ("drivers.backends.usb_card", "UsbMonitor"),
    "chapter10": ("drivers.backends.chapter10", "Chapter10Monitor"),
}
"""Built-in backends: name -> (module, class)."""


def entry_point_backends() -> dict[str, str]:
    """Backends other packages declare in the entry-point group ``mapr.backends``:
    name -> ``"package.module:Class"``."""
    from importlib.metadata import entry_points
    return {ep.name: ep.value for ep in entry_points(group="mapr.backends")}


def available_backends() -> list[str]:
    """Names of every known backend (whether or not its dependencies are installed)."""
    return sorted({*BACKENDS, *entry_point_backends()})
