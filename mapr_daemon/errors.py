"""Errors of the daemon side, grafted onto the one tree rooted at :class:`drivers.errors.MaprError`.

::

    MaprError (drivers.errors)
    ├── ConfigError       a configuration or ICD file is wrong; names file, line and field
    │   └── IcdError      an interface-control-document (message table) error
    ├── CatalogError      the fault catalog file is missing, corrupt, newer than us, or unusable
    ├── EpisodeError      a fault episode cannot be acknowledged (unknown id, already done)
    ├── RecordError       one record (a run of a file, one BIT) cannot be diagnosed
    └── ClusterError      the Dask cluster of a fleet run cannot be reached, or was lost
"""

from __future__ import annotations

from drivers.errors import MaprError


class ConfigError(MaprError):
    """A configuration file is invalid. ``str()`` is one line: ``file:line: field: problem``."""

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None,
                 field: str | None = None) -> None:
        self.path = path
        self.line = line
        self.field = field
        self.detail = message
        where = ""
        if path is not None:
            where = f"{path}:{line}: " if line is not None else f"{path}: "
        what = f"{field}: " if field else ""
        super().__init__(f"{where}{what}{message}")


class IcdError(ConfigError):
    """The message table (ICD YAML) is invalid or a value does not fit it."""


class CatalogError(MaprError):
    """The SQLite fault catalog cannot be used. ``str()`` is one line that names the file."""

    def __init__(self, message: str, *, path: str | None = None) -> None:
        self.path = path
        self.detail = message
        super().__init__(f"catalog {path}: {message}" if path is not None else message)


class EpisodeError(MaprError):
    """A fault episode cannot be acknowledged: its id is unknown, or it already was (the
    first acknowledgment stands). ``str()`` is one line."""


class RecordError(MaprError):
    """One record cannot be diagnosed: non-finite samples, too few samples, or a numerical
    failure on its data (the estimator's covariance, a statistic that is not finite).

    It concerns that record alone: a batch flags the record (``mapr diagnose`` prints an event
    whose ``evidence.error`` names this class and the message) and goes on with the others.
    ``str()`` is one line: ``field: problem``.
    """

    def __init__(self, message: str, *, field: str | None = None) -> None:
        self.field = field
        self.detail = message
        super().__init__(f"{field}: {message}" if field else message)


class ClusterError(MaprError):
    """The Dask scheduler of a fleet run (``mapr fleet --scheduler``) cannot be reached, or
    its connection was lost mid-run. The recordings stored before stay stored (a later run
    resumes); ``str()`` is one line naming the address."""

    def __init__(self, message: str, *, address: str | None = None) -> None:
        self.address = address
        self.detail = message
        super().__init__(f"Dask scheduler {address}: {message}" if address else message)
