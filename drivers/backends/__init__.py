"""Bus-monitor backends: the name table. Each backend is imported only when opened (see
:mod:`drivers.monitor`), so this module is light: the command line lists and checks backend
names without importing any backend or numpy.

Besides the built-in ones (:data:`BACKENDS`) and the entry points other packages install
(group ``mapr.backends``), an application registers its own backends by name with
:func:`register` (:data:`REGISTERED`), without installing an entry point; like the built-in
ones, they are imported only when opened."""

from __future__ import annotations

BACKENDS: dict[str, tuple[str, str]] = {
    "loopback": ("drivers.backends.loopback", "LoopbackMonitor"),
    "capture": ("drivers.backends.capture", "CaptureMonitor"),
    "serial": ("drivers.backends.serial_card", "SerialMonitor"),
    "usb": ("drivers.backends.usb_card", "UsbMonitor"),
    "chapter10": ("drivers.backends.chapter10", "Chapter10Monitor"),
}
"""Built-in backends: name -> (module, class)."""


REGISTERED: dict[str, str] = {}
"""Backend name -> ``"package.module:Class"``, added by :func:`register`."""


def register(name: str, target: str) -> None:
    """Make the backend ``target`` (``"package.module:Class"``, not imported now) available as
    ``name`` to :func:`drivers.monitor.open_monitor`. Raises ValueError on a malformed target
    or a name already registered to another target."""
    module, _, cls = target.partition(":")
    if not name or not module or not cls:
        raise ValueError(f"backend {name!r}: target {target!r} is not 'package.module:Class'")
    if REGISTERED.get(name, target) != target:
        raise ValueError(f"backend {name!r} is already registered to {REGISTERED[name]!r}")
    REGISTERED[name] = target


def plugin_backends() -> dict[str, str]:
    """Registered backends, then installed entry points (which win on a name clash)."""
    return {**REGISTERED, **entry_point_backends()}


def entry_point_backends() -> dict[str, str]:
    """Backends other packages declare in the entry-point group ``mapr.backends``:
    name -> ``"package.module:Class"``."""
    from importlib.metadata import entry_points
    return {ep.name: ep.value for ep in entry_points(group="mapr.backends")}


def available_backends() -> list[str]:
    """Names of every known backend (whether or not its dependencies are installed)."""
    return sorted({*BACKENDS, *plugin_backends()})
