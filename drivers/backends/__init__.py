"""Bus-monitor backends. Each is imported only when opened (see :mod:`drivers.monitor`).

:data:`REGISTERED` holds backends that live in another package and register themselves by
name with :func:`register` (an application's own backends, without installing an entry
point); like the built-in ones, they are imported only when opened.
"""

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
