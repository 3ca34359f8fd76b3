"""The bus-monitor abstraction: :class:`BusMonitor`, :func:`open_monitor`, the backend table.

Shaped after python-can's ``Bus``: a backend implements only ``_recv_internal(timeout)``
(a batch of records, ``[]`` when nothing came in time, ``None`` at the end of the stream);
the base class gives ``recv(timeout)``, iteration, filtering, running statistics, the context
manager and an idempotent ``close()``.

    >>> with open_monitor("loopback", duration_s=0.01) as monitor:   # doctest: +SKIP
    ...     for record in monitor:
    ...         print(record.to_json())

:meth:`BusMonitor.batches` (and :meth:`BusMonitor.recv_batch`) hand out the same messages as
numpy columns, an :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch` per batch, with no
object per message: the fast way through a long recording. A backend that reads columns
(``chapter10``) implements ``_recv_columns(timeout)`` and gives them as they are (records are
then built from them a batch at a time, only when asked for); for the others the base class
packs their records into the same columns.

Backends are found by name in :data:`BACKENDS`, among those another package registered with
:func:`drivers.backends.register`, and in the entry-point group ``mapr.backends``
(``name = "package.module:Class"``), and imported only when opened, so a missing optional
dependency disables its backend (:class:`~drivers.errors.BackendUnavailable`), never the
package. A read error inside a backend reaches the caller as
:class:`~drivers.errors.BackendError`; records already received stay queued and the monitor
stays usable.
"""

from __future__ import annotations

import importlib
import inspect
import time
from abc import ABC, abstractmethod
from collections import Counter, deque
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from drivers.backends import BACKENDS, available_backends, plugin_backends
from drivers.errors import (
    BackendError,
    BackendOptionError,
    BackendUnavailable,
    MaprError,
    MonitorClosed,
)
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.mil1553.sides import message_matches, sides_mask
from drivers.mil1553.wordbatch import WORD_TIME_NS
from drivers.rtstats import TrafficStatistics, batch_arrays

if TYPE_CHECKING:
    from drivers.chapter10.ms1553_batch import Ms1553Batch

__all__ = ["BACKENDS", "BusMonitor", "BusStatistics", "MonitorFilter", "MonitorRecord",
           "available_backends", "open_monitor"]

@dataclass(frozen=True, slots=True)
class MonitorFilter:
    """Which records to keep. Every field given must match (AND); a monitor keeps a record
    that matches any of its filters (OR), or every record when it has none.

    ``rt``, ``sa`` and ``tr`` select one terminal's side of a message
    (:mod:`drivers.mil1553.sides`): an RT-RT transfer matches ``rt=2, tr="T"`` when RT 2
    transmits in it, and ``rt=5, sa=2`` only when RT 5's own subaddress is 2. ``rt``, ``sa``
    and ``format`` take one value or a set of them. ``error`` is True (any error), False
    (clean only), an error name or a set of them (any of them). ``start_ns``/``end_ns``
    keep messages starting in ``[start_ns, end_ns)`` of bus time.
    """

    rt: int | frozenset[int] | None = None
    sa: int | frozenset[int] | None = None
    tr: str | None = None
    format: str | frozenset[str] | None = None
    error: bool | str | frozenset[str] | None = None
    start_ns: int | None = None
    end_ns: int | None = None

    def matches(self, record: MonitorRecord) -> bool:
        transmit = None if self.tr is None else self.tr.upper() == "T"
        if not message_matches(record.command, record.command2, _as_set(self.rt),
                               _as_set(self.sa), transmit):
            return False
        if self.format is not None:
            formats = {self.format} if isinstance(self.format, str) else self.format
            if str(record.format) not in {f.upper() for f in formats}:
                return False
        if self.error is True and not record.errors:
            return False
        if self.error is False and record.errors:
            return False
        if isinstance(self.error, str) and self.error not in record.errors:
            return False
        if isinstance(self.error, frozenset) and not self.error.intersection(record.errors):
            return False
        if self.start_ns is not None and record.t_ns < self.start_ns:
            return False
        return self.end_ns is None or record.t_ns < self.end_ns

    def mask(self, batch: Ms1553Batch) -> npt.NDArray[np.bool_]:
        """:meth:`matches` over a batch of columns: True for each message it keeps."""
        from drivers.chapter10.ms1553_batch import ERROR_BIT, FORMATS

        transmit = None if self.tr is None else self.tr.upper() == "T"
        keep = sides_mask(batch.command, batch.command2, _as_set(self.rt), _as_set(self.sa),
                          transmit)
        if self.format is not None:
            formats = {self.format} if isinstance(self.format, str) else self.format
            wanted = {f.upper() for f in formats}
            codes = [i for i, f in enumerate(FORMATS) if str(f) in wanted]
            keep &= np.isin(batch.format, np.asarray(codes, np.int64))
        if self.error is True:
            keep &= batch.errors != 0
        elif self.error is False:
            keep &= batch.errors == 0
        elif self.error is not None:
            names = {self.error} if isinstance(self.error, str) else self.error
            bits = 0
            for name in names:
                bits |= ERROR_BIT.get(name, 0)
            keep &= batch.errors & bits != 0
        if self.start_ns is not None:
            keep &= batch.t_ns >= self.start_ns
        if self.end_ns is not None:
            keep &= batch.t_ns < self.end_ns
        return keep


def _as_set(value: int | frozenset[int] | None) -> frozenset[int] | None:
    return frozenset((value,)) if isinstance(value, int) else value


@dataclass
class BusStatistics:
    """Running counts per bus: messages, words, errors by class, and bus load."""

    messages: Counter[str] = field(default_factory=Counter)
    words: Counter[str] = field(default_factory=Counter)
    errors: dict[str, Counter[str]] = field(default_factory=dict)
    busy_ns: Counter[str] = field(default_factory=Counter)
    first_ns: dict[str, int] = field(default_factory=dict)
    last_ns: dict[str, int] = field(default_factory=dict)

    def add(self, record: MonitorRecord) -> None:
        bus = record.bus
        words = (record.command is not None) + (record.command2 is not None) + \
            len(record.data) + len(record.status)
        self.messages[bus] += 1
        self.words[bus] += words
        self.busy_ns[bus] += words * WORD_TIME_NS
        self.errors.setdefault(bus, Counter()).update(record.errors)
        self.first_ns.setdefault(bus, record.t_ns)
        self.last_ns[bus] = max(self.last_ns.get(bus, 0), record.end_ns,
                                record.t_ns + words * WORD_TIME_NS)

    def add_columns(self, batch: Ms1553Batch) -> None:
        """Count a Chapter 10 reader's batch of columns as :meth:`add` counts each of its
        records, without building them."""
        if not len(batch):
            return
        from drivers.chapter10.ms1553_batch import ERROR_BIT

        words = (batch.command >= 0).astype(np.int64) + (batch.command2 >= 0) + \
            batch.data_count + batch.n_status
        ends = np.maximum(batch.end_ns, batch.t_ns + words * WORD_TIME_NS)
        for code, bus in ((0, "A"), (1, "B")):
            mine = np.flatnonzero(batch.bus == code)
            if not mine.size:
                continue
            count = int(words[mine].sum())
            self.messages[bus] += int(mine.size)
            self.words[bus] += count
            self.busy_ns[bus] += count * WORD_TIME_NS
            errors = self.errors.setdefault(bus, Counter())
            masks = batch.errors[mine]
            for name, bit in ERROR_BIT.items():
                flagged = int(np.count_nonzero(masks & bit))
                if flagged:
                    errors[name] += flagged
            self.first_ns.setdefault(bus, int(batch.t_ns[mine[0]]))
            self.last_ns[bus] = max(self.last_ns.get(bus, 0), int(ends[mine].max()))

    def load(self, bus: str) -> float:
        """Share of time the bus carried words, in %, over the whole time monitored: from the
        first record's start on either bus to the last record's end. A record ends no sooner
        than its words take (its start plus 20 µs a word): the time counted busy always lies
        inside the span, so a span of one message (or a recorded end that comes before the
        last word's, or no recorded end) cannot make a bus more than 100 % busy. The
        per-window load of :mod:`drivers.rtstats` ends its span the same way."""
        if not self.first_ns:
            return 0.0
        span = max(self.last_ns.values()) - min(self.first_ns.values())
        return 100.0 * self.busy_ns[bus] / span if span > 0 else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {bus: {"messages": self.messages[bus], "words": self.words[bus],
                      "load_percent": round(self.load(bus), 2),
                      "errors": dict(sorted(self.errors.get(bus, Counter()).items()))}
                for bus in sorted(self.messages)}

    def table(self) -> str:
        """The statistics as a fixed-width table a bus engineer reads at a glance."""
        lines = [f"{'bus':<4}{'messages':>10}{'words':>10}{'load %':>8}  errors"]
        for bus, row in self.as_dict().items():
            errs = ", ".join(f"{k} {v}" for k, v in row["errors"].items()) or "-"
            lines.append(f"{bus:<4}{row['messages']:>10}{row['words']:>10}"
                         f"{row['load_percent']:>8.1f}  {errs}")
        return "\n".join(lines)


class _Columns:
    """A batch of columns a backend delivered, handed out from message :attr:`pos` on."""

    __slots__ = ("batch", "counted", "next", "pos", "records", "rows")

    def __init__(self, batch: Ms1553Batch) -> None:
        self.batch = batch
        self.pos = 0
        """The first message neither handed out nor passed over by the filters."""
        self.counted = 0
        """Messages counted in the statistics."""
        self.rows: list[int] = []
        """The batch index of each of :attr:`records`."""
        self.records: list[MonitorRecord] | None = None
        """The records from :attr:`pos` on that pass the filters (built when first asked)."""
        self.next = 0
        """The next of :attr:`records` to hand out."""

    def select(self, filters: Sequence[MonitorFilter]) -> None:
        """Build the records from :attr:`pos` on that pass ``filters``."""
        rest = self.batch.take(slice(self.pos, None))
        if filters:
            keep = np.flatnonzero(_mask(filters, rest))
            rest = rest.take(keep)
            self.rows = (keep + self.pos).tolist()
        else:
            self.rows = list(range(self.pos, len(self.batch)))
        self.records = rest.records()
        self.next = 0

    def rest(self, filters: Sequence[MonitorFilter]) -> Ms1553Batch:
        """The columns from :attr:`pos` on that pass ``filters``; all handed out."""
        rest = self.batch.take(slice(self.pos, None))
        self.pos = len(self.batch)
        self.records = None
        return rest.take(_mask(filters, rest)) if filters else rest


def _mask(filters: Sequence[MonitorFilter], batch: Ms1553Batch) -> npt.NDArray[np.bool_]:
    keep = filters[0].mask(batch)
    for more in filters[1:]:
        keep |= more.mask(batch)
    return keep


class BusMonitor(ABC):
    """A passive 1553 bus monitor: records out, never anything onto the bus.

    Records one by one (:meth:`recv`, iteration) or as numpy columns a batch at a time
    (:meth:`recv_batch`, :meth:`batches`); the two may be mixed, each message handed out
    once.
    """

    def __init__(self, *, filters: Sequence[MonitorFilter] | None = None, **config: Any
                 ) -> None:
        if config:
            raise TypeError(f"unknown option(s) {', '.join(sorted(config))}")
        self.filters: list[MonitorFilter] = list(filters or [])
        self._stats = BusStatistics()
        self.traffic: TrafficStatistics | None = None
        """Per-RT/SA statistics of every batch the backend delivers, when set (None: off)."""
        self._queue: deque[MonitorRecord] = deque()
        self._columns: _Columns | None = None
        self._closed = False
        self._ended = False

    # --- what a backend implements --------------------------------------------------------
    @abstractmethod
    def _recv_internal(self, timeout: float | None) -> list[MonitorRecord] | None:
        """Wait up to ``timeout`` s (None: as long as it takes) for records; return them
        (``[]`` when none came in time), or ``None`` when the stream has ended."""

    def _recv_columns(self, timeout: float | None
                      ) -> Ms1553Batch | list[MonitorRecord] | None:
        """As :meth:`_recv_internal`, for a backend that reads messages as columns: an
        :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch` (or records, or ``[]``, or
        ``None`` at the end). The monitor calls this one; the default calls
        :meth:`_recv_internal`."""
        return self._recv_internal(timeout)

    def _close(self) -> None:  # noqa: B027 - optional hook, most backends hold nothing
        """Release the backend's resources (called once)."""

    @classmethod  # noqa: B027 - optional hook, most backends have nothing to check early
    def check_options(cls, **config: Any) -> None:
        """Validate options without opening (a service checks its configuration at start);
        raises the error opening would. The default checks nothing."""

    # --- the API ----------------------------------------------------------------------------
    @property
    def stats(self) -> BusStatistics:
        """Running counts per bus of every message handed out or passed over by the filters
        so far (not of what the backend has delivered but nobody has taken yet)."""
        self._count_columns()
        return self._stats

    @stats.setter
    def stats(self, stats: BusStatistics) -> None:
        self._count_columns()
        self._stats = stats

    def recv(self, timeout: float | None = None) -> MonitorRecord | None:
        """The next record that passes the filters, or None on time-out or end of stream;
        :class:`~drivers.errors.MonitorClosed` once :meth:`close` was called, whatever the
        backend had already delivered (close means stop, as reading a closed file does)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            if self._closed:
                raise MonitorClosed("the monitor is closed")
            while self._queue:
                record = self._queue.popleft()
                self._stats.add(record)  # counted as taken, filtered or not: the stats are
                if self._wanted(record):  # the bus's, up to the last record handed out
                    return record
            columns = self._columns
            if columns is not None:
                if columns.records is None:
                    columns.select(self.filters)
                    assert columns.records is not None
                if columns.next < len(columns.records):
                    i = columns.next
                    columns.next = i + 1
                    columns.pos = columns.rows[i] + 1
                    return columns.records[i]
                columns.pos = len(columns.batch)
                self._count_columns()
                self._columns = None
                continue
            if self._ended:
                return None
            if not self._fetch(deadline) and deadline is not None and \
                    time.monotonic() >= deadline:
                return None

    def recv_batch(self, timeout: float | None = None) -> Ms1553Batch | None:
        """The next messages that pass the filters, as numpy columns (an
        :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch`, never empty): what the
        backend delivered in one go (a ``chapter10`` monitor: up to 8192 messages), or the
        rest of it when records of it were taken by :meth:`recv`. None on time-out or end of
        stream (:attr:`ended` tells which); :class:`~drivers.errors.MonitorClosed` once
        closed. ``batch.records()`` are the records :meth:`recv` would have handed out."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            if self._closed:
                raise MonitorClosed("the monitor is closed")
            if self._queue:
                records = list(self._queue)
                self._queue.clear()
                for record in records:
                    self._stats.add(record)
                if self.filters:
                    records = [r for r in records if self._wanted(r)]
                if records:
                    from drivers.chapter10.ms1553_batch import Ms1553Batch
                    return Ms1553Batch.from_records(records)
                continue
            columns = self._columns
            if columns is not None:
                batch = columns.rest(self.filters)
                self._count_columns()
                self._columns = None
                if len(batch):
                    return batch
                continue
            if self._ended:
                return None
            if not self._fetch(deadline) and deadline is not None and \
                    time.monotonic() >= deadline:
                return None

    def batches(self) -> Iterator[Ms1553Batch]:
        """Every batch :meth:`recv_batch` hands out, to the end of the stream.

            >>> with open_monitor("chapter10", path="flight.c10") as monitor:  # doctest: +SKIP
            ...     for batch in monitor.batches():
            ...         print(len(batch), batch.rt, batch.t_ns[-1])
        """
        while (batch := self.recv_batch()) is not None:
            yield batch

    def _fetch(self, deadline: float | None) -> bool:
        """Ask the backend for more, up to ``deadline``; True when something came (or the
        stream ended)."""
        remaining = None if deadline is None else max(0.0, deadline - time.monotonic())
        try:
            got = self._recv_columns(remaining)
        except MaprError:
            raise
        except Exception as error:  # a backend fault must reach the caller, named
            raise BackendError(f"{type(self).__name__}: {error}") from error
        if got is None:
            self._ended = True
            return True
        if isinstance(got, list):
            if self.traffic is not None:
                self.traffic.add_batch(got)
            self._queue.extend(got)
            return bool(got)
        if not len(got):
            return False
        if self.traffic is not None:
            self.traffic.add_arrays(batch_arrays(got))
        self._columns = _Columns(got)
        return True

    def _count_columns(self) -> None:
        """Count in the statistics the column messages handed out or passed over since."""
        columns = self._columns
        if columns is not None and columns.pos > columns.counted:
            self._stats.add_columns(columns.batch.take(slice(columns.counted, columns.pos)))
            columns.counted = columns.pos

    def __iter__(self) -> Iterator[MonitorRecord]:
        """Every record :meth:`recv` hands out, to the end of the stream (from a batch of
        columns, without a :meth:`recv` call per record)."""
        while True:
            columns = self._columns
            if columns is not None and not self._queue:
                if columns.records is None:
                    columns.select(self.filters)
                records, rows = columns.records, columns.rows
                assert records is not None
                i, n = columns.next, len(records)
                while i < n:
                    if self._closed:
                        raise MonitorClosed("the monitor is closed")
                    columns.next = i + 1
                    columns.pos = rows[i] + 1
                    yield records[i]
                    if columns.records is not records or self._columns is not columns:
                        break   # filters set, or records taken by recv() meanwhile
                    i = columns.next
            record = self.recv()
            if record is None:
                return
            yield record

    def set_filters(self, filters: Iterable[MonitorFilter] | None) -> None:
        self.filters = list(filters or [])
        if self._columns is not None:   # records not handed out are chosen again
            self._columns.records = None

    def _wanted(self, record: MonitorRecord) -> bool:
        return not self.filters or any(f.matches(record) for f in self.filters)

    def close(self) -> None:
        """Stop monitoring; safe to call more than once."""
        if not self._closed:
            self._closed = True
            self._close()

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def ended(self) -> bool:
        """True once the source has no more records (a file replayed to its end)."""
        return self._ended and not self._queue and self._columns is None

    def __enter__(self) -> BusMonitor:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()


def backend_class(name: str) -> type[BusMonitor]:
    """Import and return a backend's class; unknown or unusable backends raise
    :class:`~drivers.errors.BackendUnavailable` with the reason."""
    if name in BACKENDS:
        module_name, class_name = BACKENDS[name]
    else:
        target = plugin_backends().get(name)
        if target is None:
            raise BackendUnavailable(
                f"unknown backend {name!r}; known: {', '.join(available_backends())}")
        module_name, _, class_name = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise BackendUnavailable(
            f"backend {name!r} is unavailable: {error} (install its dependency)") from error
    cls = getattr(module, class_name, None)
    if not (isinstance(cls, type) and issubclass(cls, BusMonitor)):
        raise BackendUnavailable(f"backend {name!r}: {module_name}.{class_name} is not a "
                                 "BusMonitor")
    return cls


def open_monitor(backend: str, **config: Any) -> BusMonitor:
    """Open a monitor on the named backend; ``config`` goes to the backend (``filters=`` to
    the base class). Options the backend does not take, or required ones missing, raise
    :class:`~drivers.errors.BackendOptionError` before anything is opened."""
    cls = backend_class(backend)
    check_options(backend, cls, config)
    try:
        return cls(**config)
    except MaprError:
        raise
    except (TypeError, ValueError) as error:  # an option value the backend refuses
        raise BackendOptionError(f"backend {backend!r}: {error}") from error


def check_options(name: str, cls: type[BusMonitor], config: dict[str, Any]) -> None:
    """Raise :class:`~drivers.errors.BackendOptionError` naming the options ``cls`` does not
    take (with those it does) or the required ones ``config`` lacks."""
    signature = inspect.signature(cls.__init__).parameters.values()
    params = [p for p in signature
              if p.name != "self" and p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
    known = {p.name for p in params}
    own_check = cls.check_options.__func__ is not BusMonitor.check_options.__func__  # type: ignore[attr-defined]
    if own_check and any(p.kind == p.VAR_KEYWORD for p in signature):
        cls.check_options(**config)   # a backend that takes more options checks them itself
        return
    unknown = sorted(set(config) - known)
    if unknown:
        takes = ", ".join(sorted(known - {"filters"})) or "none"
        raise BackendOptionError(f"backend {name!r}: unknown option {', '.join(unknown)} "
                                 f"(its options: {takes})", option=unknown[0])
    missing = [p.name for p in params if p.default is p.empty and p.name not in config]
    if missing:
        hint = " ".join(f"-O {m}=VALUE" for m in missing)
        raise BackendOptionError(f"backend {name!r} needs option {', '.join(missing)} "
                                 f"({hint} on the command line, backend.options in a config)",
                                 option=missing[0])


FORMAT_NAMES = tuple(str(f) for f in TransferFormat)
