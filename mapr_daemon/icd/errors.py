"""Errors of the message table, all under :class:`mapr_daemon.errors.IcdError`.

::

    IcdError (mapr_daemon.errors)      the table itself is wrong: file, line and field named
    └── IcdValueError                  a value handed to encode() does not fit the table
        └── IcdRangeError              a value lies outside the parameter's minimum/maximum
                                       or outside what its bits can hold (strict encoding)

Decoding never raises for bad data: values outside their range, bad BCD digits and unknown
enumeration codes come back flagged (see :mod:`mapr_daemon.icd.flags`).
"""

from __future__ import annotations

from mapr_daemon.errors import IcdError


class IcdValueError(IcdError, ValueError):
    """A value given to ``encode()`` is missing, unknown or of the wrong kind."""


class IcdRangeError(IcdValueError):
    """A value given to a strict ``encode()`` is outside its limits.

    ``parameter``, ``value``, ``minimum`` and ``maximum`` say which and why.
    """

    def __init__(self, message: str, *, parameter: str, value: object,
                 minimum: float | None, maximum: float | None) -> None:
        super().__init__(message, field=parameter)
        self.parameter = parameter
        self.value = value
        self.minimum = minimum
        self.maximum = maximum


__all__ = ["IcdError", "IcdRangeError", "IcdValueError"]
