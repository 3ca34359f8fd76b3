"""Per-RT/SA traffic statistics and windowed bus load, accumulated batch by batch with numpy.

What a bus analyzer shows beside the message list: for every remote terminal, subaddress and
direction (and every mode code) how many messages went, at what rate, with which errors, how
fast the terminal answered (response time min/mean/max, from the record's ``gaps_ns``) and
when it was last seen; and per bus the share of each window (1 s by default) it carried words.

    stats = TrafficStatistics()
    for batch in batches:                   # lists of MonitorRecord
        stats.add_batch(batch)
    print(stats.table())

A batch is turned into arrays once (:func:`record_arrays`); the per-key sums, minima and
maxima are ``np.unique``/``np.bincount``/``ufunc.at`` over those arrays, merged into dense
per-key arrays indexed by the command word with its word count masked off (65536 keys), so a
message costs no Python dictionary update. An RT-RT transfer counts under both terminals: the
receive command's key with the receiver's response gap, the transmit command's with the
transmitter's. Errors of a message count under each key it counts under.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from drivers.mil1553.modecodes import MODE_CODES
from drivers.mil1553.record import MESSAGE_ERROR_NAMES, MonitorRecord
from drivers.mil1553.sides import side_matches
from drivers.mil1553.wordbatch import WORD_TIME_NS

if TYPE_CHECKING:
    from drivers.chapter10.ms1553_batch import Ms1553Batch

__all__ = ["ERROR_CLASSES", "KEYS", "RecordArrays", "RtSaRow", "TrafficStatistics",
           "WindowLoad", "batch_arrays", "key_of_command", "record_arrays"]

ERROR_CLASSES: tuple[str, ...] = (*MESSAGE_ERROR_NAMES, "other")
"""Error classes counted; a name the record module does not list counts as ``other``."""
_ERROR_BIT = {name: i for i, name in enumerate(ERROR_CLASSES)}
KEYS = 1 << 16
"""Size of the key space: one key per command word with the word count masked off (a mode
command keeps its mode code)."""

I64 = npt.NDArray[np.int64]


def key_of_command(command: I64) -> I64:
    """The statistics key of command words: RT, T/R and SA (plus the mode code for SA 0/31)."""
    sa = (command >> 5) & 31
    mode = (sa == 0) | (sa == 31)
    return np.where(mode, command, command & ~np.int64(31))


@dataclass(frozen=True, slots=True)
class RecordArrays:
    """One batch of records as columns (absent values are -1)."""

    t_ns: I64
    bus: npt.NDArray[np.str_]
    command: I64
    command2: I64
    words: I64
    gap0: I64
    gap1: I64
    errors: I64
    """Bit i set: the message had error ``ERROR_CLASSES[i]``."""


def _mask(names: tuple[str, ...]) -> int:
    mask = 0
    for name in names:
        mask |= 1 << _ERROR_BIT.get(name, len(ERROR_CLASSES) - 1)
    return mask


def record_arrays(records: Sequence[MonitorRecord]) -> RecordArrays:
    """The columns of ``records``, built once per batch."""
    def col(values: list[int]) -> I64:
        return np.asarray(values, dtype=np.int64).reshape(-1)

    return RecordArrays(
        t_ns=col([r.t_ns for r in records]),
        bus=np.asarray([r.bus for r in records], dtype=np.str_).reshape(-1),
        command=col([-1 if r.command is None else r.command for r in records]),
        command2=col([-1 if r.command2 is None else r.command2 for r in records]),
        words=col([(r.command is not None) + (r.command2 is not None) + len(r.data)
                   + len(r.status) for r in records]),
        gap0=col([r.gaps_ns[0] if r.gaps_ns else -1 for r in records]),
        gap1=col([r.gaps_ns[1] if len(r.gaps_ns) > 1 else -1 for r in records]),
        errors=col([_mask(r.errors) if r.errors else 0 for r in records]),
    )


_BUS_NAMES = np.asarray(["A", "B"], dtype=np.str_)


def batch_arrays(batch: Ms1553Batch) -> RecordArrays:
    """The columns of a Chapter 10 batch, straight from its arrays (no record objects): the
    same values :func:`record_arrays` gives for ``batch.records()``. The batch's error bits
    are over :data:`~drivers.mil1553.record.MESSAGE_ERROR_NAMES`, the first bits of
    :data:`ERROR_CLASSES`, so they carry over as they are."""
    n_status = batch.n_status
    gaps = batch.gaps_ns
    width = gaps.shape[1] if gaps.ndim == 2 else 0
    gap0 = np.where(n_status > 0, gaps[:, 0], -1) if width > 0 else np.full(len(batch), -1)
    gap1 = np.where(n_status > 1, gaps[:, 1], -1) if width > 1 else np.full(len(batch), -1)
    return RecordArrays(
        t_ns=batch.t_ns.astype(np.int64, copy=False),
        bus=_BUS_NAMES[batch.bus.astype(np.int64)],
        command=batch.command.astype(np.int64, copy=False),
        command2=batch.command2.astype(np.int64, copy=False),
        words=(1 + (batch.command2 >= 0) + batch.data_count + n_status).astype(np.int64),
        gap0=gap0.astype(np.int64, copy=False), gap1=gap1.astype(np.int64, copy=False),
        errors=batch.errors.astype(np.int64, copy=False))


@dataclass(frozen=True, slots=True)
class RtSaRow:
    """The statistics of one RT / direction / subaddress (or mode code)."""

    rt: int
    tr: str
    sa: int
    mode_code: int | None
    wc: int | None
    """Largest word count commanded (None for a mode code)."""
    wc_min: int | None
    messages: int
    rate_hz: float
    """Messages per second over the whole time observed (first to last message of any key):
    a key's own first-to-last span would make two retries microseconds apart a kHz rate.
    0 for a key seen once (no rate can be told)."""
    errors: dict[str, int]
    responses: int
    """Messages with a response gap (the ones the terminal answered)."""
    response_sum_ns: int
    response_min_ns: int | None
    response_max_ns: int | None
    first_ns: int
    last_ns: int

    @property
    def response_min_us(self) -> float | None:
        return None if self.response_min_ns is None else self.response_min_ns / 1e3

    @property
    def response_mean_us(self) -> float | None:
        return self.response_sum_ns / self.responses / 1e3 if self.responses else None

    @property
    def response_max_us(self) -> float | None:
        return None if self.response_max_ns is None else self.response_max_ns / 1e3

    @property
    def label(self) -> str:
        """``RT05 T SA04`` or ``RT13 T MC02``."""
        if self.mode_code is not None:
            return f"RT{self.rt:02d} {self.tr} MC{self.mode_code:02d}"
        return f"RT{self.rt:02d} {self.tr} SA{self.sa:02d}"

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"rt": self.rt, "tr": self.tr, "sa": self.sa}
        if self.mode_code is not None:
            out["mode_code"] = self.mode_code
            out["mode"] = MODE_CODES[self.mode_code].name
        else:
            out["wc"] = self.wc
        out.update(messages=self.messages, rate_hz=round(self.rate_hz, 3),
                   errors=self.errors,
                   response_us={"min": _r(self.response_min_us),
                                "mean": _r(self.response_mean_us),
                                "max": _r(self.response_max_us)},
                   first_ns=self.first_ns, last_ns=self.last_ns)
        return out


def _r(value: float | None) -> float | None:
    return None if value is None else round(value, 2)


@dataclass(frozen=True, slots=True)
class WindowLoad:
    """Share of one window a bus carried words, over the part of the window observed (the
    first and last windows are cut at the first and last word seen on any bus)."""

    bus: str
    start_ns: int
    window_ns: int
    observed_ns: int
    busy_ns: int

    @property
    def load_percent(self) -> float:
        return 100.0 * self.busy_ns / self.observed_ns if self.observed_ns > 0 else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"bus": self.bus, "start_ns": self.start_ns, "window_s": self.window_ns / 1e9,
                "observed_s": self.observed_ns / 1e9,
                "load_percent": round(self.load_percent, 2)}


@dataclass
class TrafficStatistics:
    """Running per-RT/SA statistics and per-bus windowed load (see the module docstring)."""

    window_ns: int = 1_000_000_000
    messages: I64 = field(default_factory=lambda: np.zeros(KEYS, np.int64))
    resp_n: I64 = field(default_factory=lambda: np.zeros(KEYS, np.int64))
    resp_sum: I64 = field(default_factory=lambda: np.zeros(KEYS, np.int64))
    resp_min: I64 = field(default_factory=lambda: np.full(KEYS, np.iinfo(np.int64).max))
    resp_max: I64 = field(default_factory=lambda: np.full(KEYS, -1, np.int64))
    first_ns: I64 = field(default_factory=lambda: np.full(KEYS, np.iinfo(np.int64).max))
    last_ns: I64 = field(default_factory=lambda: np.full(KEYS, np.iinfo(np.int64).min))
    wc_min: I64 = field(default_factory=lambda: np.full(KEYS, 99, np.int64))
    wc_max: I64 = field(default_factory=lambda: np.zeros(KEYS, np.int64))
    errors: dict[int, I64] = field(default_factory=dict)
    """key -> counts per :data:`ERROR_CLASSES` (only keys that had errors)."""
    busy: dict[tuple[str, int], int] = field(default_factory=dict)
    """(bus, window index) -> ns of words on the bus."""
    rt_rt: dict[tuple[int, int], int] = field(default_factory=dict)
    """(receive key, transmit key) -> RT-RT transfers seen."""
    unkeyed: int = 0
    """Records with no command word (stray words): in the bus load, under no key."""
    seen_from_ns: int = np.iinfo(np.int64).max
    """Start of the first record seen, on any bus."""
    seen_to_ns: int = np.iinfo(np.int64).min
    """End of the last word seen (start + words x 20 µs), on any bus."""
    sides: tuple[frozenset[int] | None, frozenset[int] | None, bool | None] | None = None
    """Rows to show, when set: (terminals, subaddresses, transmit) of the sides a filter
    selects (:func:`drivers.mil1553.sides.side_matches`), so that ``--rt 2 --tr T --stats``
    lists ``RT02 T`` only, with as many messages as the same filter prints."""

    def __post_init__(self) -> None:
        if self.window_ns <= 0:
            raise ValueError(f"window must be positive, got {self.window_ns} ns")

    # --- accumulation ----------------------------------------------------------------------
    def add_batch(self, records: Sequence[MonitorRecord]) -> None:
        """Count a batch of records."""
        if records:
            self.add_arrays(record_arrays(records))

    def add_arrays(self, a: RecordArrays) -> None:
        """Count a batch already in columns."""
        self._add_load(a)
        rx = a.command >= 0
        self.unkeyed += int(np.count_nonzero(~rx))
        tx = a.command2 >= 0
        rt_rt = rx & tx
        # the primary command's response gap: the second one for an RT-RT transfer
        own_gap = np.where(rt_rt, a.gap1, a.gap0)
        keys = np.concatenate([key_of_command(a.command[rx]), key_of_command(a.command2[tx])])
        t = np.concatenate([a.t_ns[rx], a.t_ns[tx]])
        gap = np.concatenate([own_gap[rx], a.gap0[tx]])
        errs = np.concatenate([a.errors[rx], a.errors[tx]])
        wc = np.concatenate([a.command[rx] & 31, a.command2[tx] & 31])
        wc = np.where(wc == 0, 32, wc)
        if keys.size == 0:
            return
        self._add_keys(keys, t, gap, errs, wc)
        if rt_rt.any():
            pair = key_of_command(a.command[rt_rt]) << 16 | key_of_command(a.command2[rt_rt])
            pairs, counts = np.unique(pair, return_counts=True)
            for p, c in zip(pairs.tolist(), counts.tolist(), strict=True):
                k = (p >> 16, p & 0xFFFF)
                self.rt_rt[k] = self.rt_rt.get(k, 0) + c

    def _add_keys(self, keys: I64, t: I64, gap: I64, errs: I64, wc: I64) -> None:
        uniq, inv = np.unique(keys, return_inverse=True)
        self.messages[uniq] += np.bincount(inv, minlength=uniq.size)
        np.minimum.at(self.first_ns, keys, t)
        np.maximum.at(self.last_ns, keys, t)
        data = ((keys >> 5) & 31 != 0) & ((keys >> 5) & 31 != 31)
        np.minimum.at(self.wc_min, keys[data], wc[data])
        np.maximum.at(self.wc_max, keys[data], wc[data])
        has = gap >= 0
        if has.any():
            self.resp_n[uniq] += np.bincount(inv[has], minlength=uniq.size)
            self.resp_sum[uniq] += np.bincount(inv[has], weights=gap[has],
                                               minlength=uniq.size).astype(np.int64)
            np.minimum.at(self.resp_min, keys[has], gap[has])
            np.maximum.at(self.resp_max, keys[has], gap[has])
        present = int(np.bitwise_or.reduce(errs))
        if present:
            table = np.zeros((uniq.size, len(ERROR_CLASSES)), np.int64)
            for bit in range(len(ERROR_CLASSES)):
                if present >> bit & 1:
                    table[:, bit] = np.bincount(inv, weights=(errs >> bit) & 1,
                                                minlength=uniq.size)
            for row in np.flatnonzero(table.any(axis=1)).tolist():
                key = int(uniq[row])
                self.errors[key] = self.errors.get(key, np.zeros(len(ERROR_CLASSES),
                                                                 np.int64)) + table[row]

    def _add_load(self, a: RecordArrays) -> None:
        if a.t_ns.size == 0:
            return
        self.seen_from_ns = min(self.seen_from_ns, int(a.t_ns.min()))
        self.seen_to_ns = max(self.seen_to_ns, int((a.t_ns + a.words * WORD_TIME_NS).max()))
        buses, bus_index = np.unique(a.bus, return_inverse=True)
        window = a.t_ns // self.window_ns
        combo = window * buses.size + bus_index
        cells, inv = np.unique(combo, return_inverse=True)
        busy = np.bincount(inv, weights=a.words * WORD_TIME_NS, minlength=cells.size)
        for cell, ns in zip(cells.tolist(), busy.tolist(), strict=True):
            k = (str(buses[cell % buses.size]), cell // buses.size)
            self.busy[k] = self.busy.get(k, 0) + int(ns)

    # --- results ---------------------------------------------------------------------------
    def rows(self) -> list[RtSaRow]:
        """One row per key seen, by RT, then direction, then subaddress/mode code."""
        out: list[RtSaRow] = []
        seen = np.flatnonzero(self.messages)
        if seen.size == 0:
            return out
        span = int(self.last_ns[seen].max() - self.first_ns[seen].min())
        for key in seen.tolist():
            if self.sides is not None and not side_matches(key, *self.sides):
                continue
            rt, tr, sa = key >> 11, "T" if key >> 10 & 1 else "R", key >> 5 & 31
            mode = sa in (0, 31)
            n = int(self.messages[key])
            resp_n = int(self.resp_n[key])
            errs = self.errors.get(key)
            out.append(RtSaRow(
                rt=rt, tr=tr, sa=sa, mode_code=key & 31 if mode else None,
                wc=None if mode else int(self.wc_max[key]),
                wc_min=None if mode else int(self.wc_min[key]),
                messages=n, rate_hz=n * 1e9 / span if n > 1 and span > 0 else 0.0,
                errors={} if errs is None else
                {ERROR_CLASSES[i]: int(c) for i, c in enumerate(errs.tolist()) if c},
                responses=resp_n, response_sum_ns=int(self.resp_sum[key]),
                response_min_ns=int(self.resp_min[key]) if resp_n else None,
                response_max_ns=int(self.resp_max[key]) if resp_n else None,
                first_ns=int(self.first_ns[key]), last_ns=int(self.last_ns[key])))
        out.sort(key=lambda r: (r.rt, r.tr, r.mode_code is not None, r.sa, r.mode_code or 0))
        return out

    def windows(self) -> list[WindowLoad]:
        """Load per bus per window, in time order."""
        out = []
        for (bus, w), busy in sorted(self.busy.items(), key=lambda i: (i[0][1], i[0][0])):
            start = w * self.window_ns
            observed = (min(start + self.window_ns, self.seen_to_ns)
                        - max(start, self.seen_from_ns))
            out.append(WindowLoad(bus, start, self.window_ns, observed, busy))
        return out

    def table(self) -> str:
        """The per-RT/SA rows as a fixed-width table, then the load of each window."""
        head = (f"{'RT/SA':<13}{'wc':>3}{'messages':>10}{'rate Hz':>10}{'resp min':>9}"
                f"{'mean':>7}{'max µs':>8}  {'last seen s':>11}  errors")
        lines = [head]
        for r in self.rows():
            wc = "-" if r.wc is None else (str(r.wc) if r.wc == r.wc_min else f"{r.wc}*")
            errs = ", ".join(f"{k} {v}" for k, v in r.errors.items()) or "-"
            rate = f"{r.rate_hz:.2f}" if r.messages > 1 else "-"
            lines.append(f"{r.label:<13}{wc:>3}{r.messages:>10}{rate:>10}"
                         f"{_us(r.response_min_us):>9}{_us(r.response_mean_us):>7}"
                         f"{_us(r.response_max_us):>8}  {r.last_ns / 1e9:>11.3f}  {errs}")
        windows = self.windows()
        if windows:
            lines.append("")
            lines.append(f"{'window from s':>14}  {'bus':<4}{'load %':>7}  {'observed s':>10}")
            lines += [f"{w.start_ns / 1e9:>14.6f}  {w.bus:<4}{w.load_percent:>7.1f}  "
                      f"{w.observed_ns / 1e9:>10.6f}" for w in windows]
        return "\n".join(lines)

    def json_lines(self) -> list[dict[str, Any]]:
        """The rows (``"kind": "rtsa"``) then the windows (``"kind": "bus_load"``)."""
        return ([{"kind": "rtsa", **r.as_dict()} for r in self.rows()]
                + [{"kind": "bus_load", **w.as_dict()} for w in self.windows()])


def _us(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"
