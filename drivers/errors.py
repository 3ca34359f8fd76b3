"""The one exception tree of MAPR.

Every error MAPR raises on purpose derives from :class:`MaprError`, so a caller can catch
the whole family in one clause and still tell the kinds apart::

    MaprError
    ├── EncodeError            a word list or impairment the encoder cannot produce
    └── MonitorError           bus-monitor failures
        ├── BackendUnavailable the backend is unknown or its optional dependency is missing
        ├── BackendOptionError an option the backend does not take, or one it needs, missing
        ├── BackendError       a backend failed while running (card unplugged, read error)
        ├── CaptureFormatError a capture file that cannot be read at all (names file and cause)
        │   └── SampleRateError a sample rate the decoder cannot guarantee its words at
        └── MonitorClosed      recv() on a monitor that has been closed

Bad *signal* is never an exception: a malformed word or message is data, returned with
error flags. Exceptions are for files that cannot be opened, wrong arguments and dead
hardware. :mod:`mapr_daemon.errors` extends this tree for configuration and ICD errors.
"""

from __future__ import annotations


class MaprError(Exception):
    """Root of every error MAPR raises on purpose."""


class EncodeError(MaprError, ValueError):
    """The encoder was asked for something it cannot produce (bad value, rate, fault)."""


class MonitorError(MaprError):
    """Base of the bus-monitor errors."""


class BackendUnavailable(MonitorError):
    """The backend name is unknown, or an optional dependency it needs is missing."""


class BackendOptionError(MonitorError, ValueError, TypeError):
    """The options given to a backend do not fit it: one it does not take, one it needs and
    did not get, or a value it refuses. Nothing was opened. Also a ValueError and TypeError,
    what Python raises for a bad value or keyword, so callers catching those still do."""

    def __init__(self, message: str, *, option: str | None = None) -> None:
        self.option = option
        """The option at fault, when it is one."""
        super().__init__(message)


class BackendError(MonitorError):
    """A backend failed while running; the monitor keeps what it already received."""


class CaptureFormatError(MonitorError):
    """A capture file cannot be read: wrong format, missing metadata, unreadable."""


class SampleRateError(CaptureFormatError, ValueError):
    """A capture's sample rate is outside what the decoder supports (too slow to see every
    half-bit under the standard's tolerances): refused rather than decoded unreliably."""


class MonitorClosed(MonitorError):
    """The monitor was closed; no more records will come."""
