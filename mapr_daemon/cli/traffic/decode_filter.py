"""``mapr decode``'s message filters: RT, SA, T/R, format, errors, a time window.

The same flags, lists and ranges (``--rt 1-4,7``) as ``mapr monitor``; ``--rt``, ``--tr``
and ``--sa`` select one terminal's side of a message (:mod:`drivers.mil1553.sides`: an RT-RT
transfer matches ``--rt 2 --tr T`` when RT 2 transmits in it). They are checked before the file
is opened: a value that can never match is a usage error naming the flag and the allowed
range (:class:`FilterError`, exit 2), not a silent empty output. On a Chapter 10 batch the
filter is a numpy mask (:meth:`DecodeFilter.mask`); on records, :meth:`DecodeFilter.matches`.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from drivers.chapter10.ms1553_batch import ERROR_BIT, FORMATS, Ms1553Batch
from drivers.errors import MaprError
from drivers.mil1553.record import MESSAGE_ERROR_NAMES, MonitorRecord
from drivers.mil1553.sides import message_matches, sides_mask
from drivers.monitor import MonitorFilter
from mapr_daemon.cli.validate import impossible_filter

Mask = npt.NDArray[np.bool_]


class FilterError(MaprError, ValueError):
    """A filter flag whose value can never match (one line: the flag and what is allowed)."""


@dataclass(frozen=True, slots=True)
class DecodeFilter:
    """What to keep; None (or False) for a field means any."""

    rts: frozenset[int] | None = None
    sas: frozenset[int] | None = None
    transmit: bool | None = None
    formats: frozenset[int] | None = None
    """Indexes into :data:`~drivers.chapter10.ms1553_batch.FORMATS`."""
    errors: bool = False
    error_bits: int = 0
    start_ns: int | None = None
    end_ns: int | None = None

    @property
    def active(self) -> bool:
        return self != DecodeFilter()

    def mask(self, batch: Ms1553Batch) -> Mask:
        """True for the messages of ``batch`` to keep."""
        keep = sides_mask(batch.command, batch.command2, self.rts, self.sas, self.transmit)
        if self.formats is not None:
            keep &= np.isin(batch.format, np.fromiter(self.formats, np.int64))
        if self.errors:
            keep &= batch.errors != 0
        if self.error_bits:
            keep &= batch.errors & self.error_bits != 0
        if self.start_ns is not None:
            keep &= batch.t_ns >= self.start_ns
        if self.end_ns is not None:
            keep &= batch.t_ns < self.end_ns
        return keep

    def monitor_filter(self) -> MonitorFilter:
        """The same selection as a :class:`~drivers.monitor.MonitorFilter` (for
        ``mapr monitor``, whose backends filter records)."""
        names = frozenset(n for n, bit in ERROR_BIT.items() if bit & self.error_bits)
        return MonitorFilter(
            rt=self.rts, sa=self.sas, tr=None if self.transmit is None else
            "T" if self.transmit else "R",
            format=None if self.formats is None else frozenset(str(FORMATS[i])
                                                               for i in self.formats),
            error=names or (True if self.errors else None),
            start_ns=self.start_ns, end_ns=self.end_ns)

    def matches(self, record: MonitorRecord) -> bool:
        """The same test on one record (bit-level captures)."""
        if not message_matches(record.command, record.command2, self.rts, self.sas,
                               self.transmit):
            return False
        if self.formats is not None and FORMATS.index(record.format) not in self.formats:
            return False
        if self.errors and not record.errors:
            return False
        if self.error_bits and not any(ERROR_BIT[e] & self.error_bits for e in record.errors):
            return False
        if self.start_ns is not None and record.t_ns < self.start_ns:
            return False
        return self.end_ns is None or record.t_ns < self.end_ns


def filter_from_args(args: argparse.Namespace) -> DecodeFilter:
    """The filter the flags ask for; :class:`FilterError` for a value that cannot match."""
    start = _seconds("--from", args.t_from)
    end = _seconds("--to", args.t_to)
    if start is not None and end is not None and end <= start:
        raise FilterError(f"--to {args.t_to}: must be later than --from {args.t_from}")
    transmit = None
    if args.tr is not None:
        if args.tr.upper() not in ("T", "R"):
            raise FilterError(f"--tr {args.tr}: allowed T or R")
        transmit = args.tr.upper() == "T"
    formats = None
    if args.fmt is not None:
        names = [f.name for f in FORMATS]
        chosen = set()
        for part in _parts("--format", args.fmt):
            if part.upper() not in names:
                raise FilterError(f"--format {part}: allowed {', '.join(names)}")
            chosen.add(names.index(part.upper()))
        formats = frozenset(chosen)
    bits = 0
    if args.error is not None:
        for part in _parts("--error", args.error):
            if part not in ERROR_BIT:
                raise FilterError(f"--error {part}: allowed {', '.join(MESSAGE_ERROR_NAMES)}")
            bits |= ERROR_BIT[part]
    rts, sas = _numbers("--rt", args.rt), _numbers("--sa", args.sa)
    problem = impossible_filter(
        rts, sas, args.tr, None if formats is None else frozenset(FORMATS[i].name
                                                                  for i in formats))
    if problem:
        raise FilterError(problem)
    return DecodeFilter(rts=rts, sas=sas, transmit=transmit, formats=formats,
                        errors=bool(args.errors), error_bits=bits, start_ns=start, end_ns=end)


def _parts(flag: str, text: str) -> list[str]:
    parts = [p.strip() for p in text.split(",")]
    if not all(parts):
        raise FilterError(f"{flag} {text}: an empty item in the list")
    return parts


def _numbers(flag: str, text: str | None) -> frozenset[int] | None:
    """``5``, ``1-4,7``: addresses 0-31."""
    if text is None:
        return None
    chosen: set[int] = set()
    for part in _parts(flag, text):
        low, _, high = part.partition("-")
        try:
            first, last = int(low), int(high or low)
        except ValueError:
            raise FilterError(f"{flag} {part}: allowed numbers 0-31, lists and ranges "
                              "(1-4,7)") from None
        if not 0 <= first <= last <= 31:
            raise FilterError(f"{flag} {part}: allowed 0-31 (a range low-high)")
        chosen.update(range(first, last + 1))
    return frozenset(chosen)


def _seconds(flag: str, text: str | None) -> int | None:
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise FilterError(f"{flag} {text}: allowed a number of seconds") from None
    if not np.isfinite(value):
        raise FilterError(f"{flag} {text}: allowed a finite number of seconds")
    return round(value * 1e9)


def filter_problem(args: argparse.Namespace) -> str | None:
    """The filter flags' problem as one line (for a subcommand's ``validate=`` hook), or
    None when :func:`filter_from_args` takes them."""
    try:
        filter_from_args(args)
    except FilterError as error:
        return str(error)
    return None


def address_set(flag: str, text: str | None) -> frozenset[int] | None:
    """``--rt``/``--sa`` values (``5``, ``1-4,7``: 0-31) as a set, None when not given;
    :class:`FilterError` naming the flag otherwise."""
    return _numbers(flag, text)
