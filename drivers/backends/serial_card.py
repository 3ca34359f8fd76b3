"""The ``serial`` backend: the open1553 word-level card on a serial port (pyserial).

The card decodes the bus and sends one line per word (:mod:`drivers.backends.open1553`).
Words go through the same :class:`~drivers.mil1553.assembler.MessageAssembler` as every
other backend, built with ``time_tags=False``. Message boundaries come from what the card
reports (its gap flag and the 1553 grammar), never from when lines reach the host:
:class:`~drivers.backends.open1553_framer.LineFramer` places the words on a synthetic
timeline, so the framing is the same on an idle and on a saturated host. Consequences, stated
in every record (``record.extra["time_tags"] == "host"``): response times are never judged
(no ``early_response``/``late_response``), ``gaps_ns`` are nominal, and record times are host
arrival times of each message's first word (or a little later, to keep them in order).

Options: ``port`` (a path such as ``/dev/ttyUSB0`` or ``/dev/serial/by-id/...``) or
``serial_number`` (the USB adapter's serial number, looked up with
``serial.tools.list_ports``: stable across replugs and ports); ``bus`` (the bus the card
taps, ``"A"``); ``port_b``/``serial_number_b`` for a second card on bus B; ``idle_s``
(0.05: the read time-out; a read that stays empty that long means the card sent nothing, i.e.
the bus is idle: the last message is then complete); ``reconnect`` (True: after an unplug,
reopen with exponential backoff from ``backoff_s`` up to ``backoff_max_s``; False: the
stream ends at the unplug).

A reader thread per card reads without ever dying on a read error: an unplug or a read error
closes the port, appends a :class:`Gap` to :attr:`SerialMonitor.gaps` (the daemon reads it)
and reopens. Malformed lines become words flagged ``sync`` (stray ones an ``orphan_words``
record), a partial line cut by an unplug included; all are counted in ``malformed_lines``;
decoding goes on at the next line.
"""

from __future__ import annotations

import contextlib
import errno
import os
import queue
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import serial
from serial.tools import list_ports

from drivers.backends.attached import UDEV_HINT, AttachedCard, access_problem
from drivers.backends.open1553 import BAUD_RATE, LineSplitter, parse_line
from drivers.backends.open1553_framer import LineFramer, horizon
from drivers.errors import BackendError
from drivers.mil1553.assembler import MessageAssembler
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.mil1553.wordbatch import (
    BUS_NAMES,
    ERR_PARITY,
    ERR_SYNC,
    SYNC_DATA,
    WORD_TIME_NS,
    WordBatch,
    empty_words,
)
from drivers.monitor import BusMonitor, MonitorFilter


@dataclass
class Gap:
    """A stretch with no data from a card (unplugged, read error): never silence."""

    bus: str
    start_ns: int
    end_ns: int | None
    reason: str


def find_port(serial_number: str) -> str:
    """The device path of the USB serial adapter with this serial number."""
    for info in list_ports.comports():
        if info.serial_number == serial_number:
            return str(info.device)
    raise BackendError(f"no serial port with USB serial number {serial_number!r} "
                       "(see `mapr devices`)")


def explain(error: BaseException, port: str) -> str:
    """One line that tells the user what to do about a failed open."""
    code = getattr(error, "errno", None)
    if code in (errno.EACCES, errno.EPERM):
        return f"permission denied on {port}: {UDEV_HINT}"
    if code in (errno.EBUSY, errno.EAGAIN) or "lock" in str(error):
        return f"{port} is busy: another program (or another mapr) has it open"
    if code in (errno.ENOENT, errno.ENODEV, errno.ENXIO):
        return f"{port} does not exist: is the card plugged in? (see `mapr devices`)"
    return f"cannot open {port}: {error}"


def open_port(port: str, timeout_s: float = 0.05) -> serial.Serial:
    """Open the card's port (2 Mbaud, 8N1, exclusive, reads time out after ``timeout_s``), or
    raise BackendError explaining why."""
    try:
        return serial.Serial(port, BAUD_RATE, timeout=timeout_s, exclusive=True)
    except (serial.SerialException, OSError, ValueError) as error:
        raise BackendError(explain(error, port)) from error


class _Reader(threading.Thread):
    """Reads one card into the monitor's queue; survives read errors by reopening."""

    def __init__(self, bus: int, port: str | None, serial_number: str | None,
                 out: queue.Queue[tuple[Any, ...]], *, reconnect: bool, backoff_s: float,
                 backoff_max_s: float, quiet_s: float) -> None:
        super().__init__(name=f"mapr-serial-{BUS_NAMES[bus]}", daemon=True)
        self.bus, self.port, self.serial_number = bus, port, serial_number
        self.out, self.reconnect = out, reconnect
        self.backoff_s, self.backoff_max_s = backoff_s, backoff_max_s
        self.stop = threading.Event()
        self.lines_read = 0
        self.bytes_read = 0
        self.quiet_s = quiet_s
        self.device: serial.Serial | None = open_port(self.path(), quiet_s)

    def path(self) -> str:
        return self.port if self.port is not None else find_port(str(self.serial_number))

    def _put(self, item: tuple[Any, ...]) -> None:
        while not self.stop.is_set():
            try:
                self.out.put(item, timeout=0.1)
                return
            except queue.Full:
                continue

    def run(self) -> None:
        delay = self.backoff_s
        while not self.stop.is_set():
            if self.device is None:
                try:
                    self.device = open_port(self.path(), self.quiet_s)
                except BackendError as error:
                    self.stop.wait(delay)
                    delay = min(delay * 2, self.backoff_max_s)
                    self._put(("retry", self.bus, str(error)))
                    continue
                delay = self.backoff_s
                self._put(("back", self.bus, time.time_ns()))
            try:
                data = self.device.read(max(1, self.device.in_waiting))
            except (serial.SerialException, OSError, TypeError) as error:
                self._drop(f"read failed: {error}")
                if not self.reconnect:
                    self._put(("eof", self.bus))
                    return
                continue
            if data:
                self.lines_read += data.count(b"\r") + data.count(b"\n")
                self.bytes_read += len(data)
                self._put(("data", self.bus, time.time_ns(), data))
            else:
                # The read waited quiet_s and the kernel held no byte: the card sent nothing
                # for that long, whatever this host was doing meanwhile.
                self._put(("quiet", self.bus))
        self._close_device()

    def _drop(self, reason: str) -> None:
        self._close_device()
        self._put(("gap", self.bus, time.time_ns(), reason))

    def _close_device(self) -> None:
        device, self.device = self.device, None
        if device is not None:
            with contextlib.suppress(serial.SerialException, OSError):
                device.close()


class SerialMonitor(BusMonitor):
    """A monitor on one or two open1553 cards (see the module docstring for options)."""

    def __init__(self, *, filters: Sequence[MonitorFilter] | None = None,
                 port: str | None = None, serial_number: str | None = None, bus: str = "A",
                 port_b: str | None = None, serial_number_b: str | None = None,
                 idle_s: float = 0.05, reconnect: bool = True, backoff_s: float = 0.1,
                 backoff_max_s: float = 5.0, timing: BusTiming | None = None,
                 queue_chunks: int = 4096, **config: Any) -> None:
        super().__init__(filters=filters, **config)
        cards: list[tuple[int, str | None, str | None]] = []
        if port is not None or serial_number is not None:
            cards.append((BUS_NAMES.index(bus.upper()), port, serial_number))
        if port_b is not None or serial_number_b is not None:
            cards.append((1, port_b, serial_number_b))
        if not cards:
            raise BackendError("the serial backend needs port=PATH or serial_number=SN")
        self.assembler = MessageAssembler(timing, time_tags=False)
        self.gaps: list[Gap] = []
        """Data lost to unplugs and read errors, per card, in host time (ns since epoch)."""
        self.malformed_lines = 0
        self.inverted_words = 0
        self.last_error: str | None = None
        self._chunks: queue.Queue[tuple[Any, ...]] = queue.Queue(maxsize=queue_chunks)
        if not 0.001 <= idle_s <= 10.0:
            raise BackendError(f"idle_s must be between 0.001 and 10 seconds, not {idle_s}")
        self._framers = {b: LineFramer() for b, _, _ in cards}
        self._poll_s = min(idle_s, 0.1)
        self._splitters = {b: LineSplitter() for b, _, _ in cards}
        self._readers: list[_Reader] = []
        try:
            for b, p, sn in cards:
                self._readers.append(_Reader(b, p, sn, self._chunks, reconnect=reconnect,
                                             backoff_s=backoff_s, backoff_max_s=backoff_max_s,
                                             quiet_s=idle_s))
        except BackendError:
            for reader in self._readers:
                reader._close_device()
            raise
        self._live = {r.bus for r in self._readers}
        self._flushed = False
        for reader in self._readers:
            reader.start()

    @property
    def lines_read(self) -> int:
        """Lines received from all cards so far (counted by the reader threads)."""
        return sum(r.lines_read for r in self._readers)

    @property
    def bytes_read(self) -> int:
        """Bytes received from all cards so far."""
        return sum(r.bytes_read for r in self._readers)

    def _recv_internal(self, timeout: float | None) -> list[MonitorRecord] | None:
        if self._flushed:
            return None
        rows: list[tuple[int, int, int, int, int]] = []
        try:
            wait = self._poll_s if timeout is None else min(max(timeout, 0.0), self._poll_s)
            item = self._chunks.get(timeout=wait)
        except queue.Empty:
            item = None
        while item is not None:
            self._handle(item, rows)
            try:
                item = self._chunks.get_nowait()
            except queue.Empty:
                item = None
        words = _batch(rows)
        if not self._live:
            self._flushed = True
            return self._mark(self.assembler.feed(words) + self.assembler.flush())
        known = horizon([self._framers[b] for b in sorted(self._live)])
        if not words.size and known is None:
            return []
        return self._mark(self.assembler.feed(words, horizon_ns=known))

    def _handle(self, item: tuple[Any, ...], rows: list[tuple[int, int, int, int, int]]
                ) -> None:
        kind, bus = item[0], item[1]
        if kind == "data":
            _, _, wall, data = item
            for line in self._splitters[bus].feed(data):
                rows.append(self._word(bus, line, wall))
        elif kind == "quiet":
            self._framers[bus].quiet()
        elif kind == "gap":
            self.gaps.append(Gap(BUS_NAMES[bus], item[2], None, item[3]))
            self.last_error = item[3]
            if self._splitters[bus].reset().strip(b" \t\0"):
                rows.append(self._word(bus, b"", item[2]))  # a line cut by the unplug
            self._framers[bus].restart()
        elif kind == "back":
            for gap in reversed(self.gaps):
                if gap.bus == BUS_NAMES[bus] and gap.end_ns is None:
                    gap.end_ns = item[2]
                    break
        elif kind == "retry":
            self.last_error = item[2]
        elif kind == "eof":
            self._live.discard(bus)

    def _word(self, bus: int, line: bytes, wall: int) -> tuple[int, int, int, int, int]:
        word = parse_line(line)
        if word is None:
            self.malformed_lines += 1
            t = self._framers[bus].place_unreadable(wall)
            return (t, bus, SYNC_DATA, 0, ERR_SYNC)
        self.inverted_words += word.inverted
        t = self._framers[bus].place(word.sync, word.gap, word.value, wall)
        return (t, bus, word.sync, word.value, 0 if word.parity_ok else ERR_PARITY)

    @staticmethod
    def _mark(records: list[MonitorRecord]) -> list[MonitorRecord]:
        for record in records:
            record.extra["time_tags"] = "host"
        return records

    def _close(self) -> None:
        for reader in self._readers:
            reader.stop.set()
        for reader in self._readers:
            reader.join(timeout=2.0)
            reader._close_device()


def _batch(rows: list[tuple[int, int, int, int, int]]) -> WordBatch:
    out = empty_words(len(rows))
    if rows:
        rows.sort(key=lambda r: r[0])
        for i, (t, bus, sync, value, errors) in enumerate(rows):
            out[i] = (t, bus, sync, value, errors, t + WORD_TIME_NS - 500)
    return out


BY_ID_DIR = "/dev/serial/by-id"
"""Where udev keeps the stable links of serial ports (named after maker, product and serial)."""


def stable_links(directory: str = BY_ID_DIR) -> dict[str, str]:
    """Device node -> its udev-stable link in ``directory`` (empty when there is none)."""
    links: dict[str, str] = {}
    with contextlib.suppress(OSError):
        for entry in sorted(os.scandir(directory), key=lambda e: e.name):
            if entry.is_symlink():
                links.setdefault(os.path.realpath(entry.path), entry.path)
    return links


def serial_cards(by_id_dir: str = BY_ID_DIR) -> list[AttachedCard]:
    """USB serial ports that may be open1553 cards, from pyserial's port listing.

    The card has no USB ID of its own (it sits behind an ordinary USB serial adapter), so
    every USB serial port is listed with what identifies it; ports without a USB identity
    (on-board ``ttyS*``) are not cards. The options open the card by its adapter's serial
    number when it has one (stable across replugs and ports), else by its udev-stable link,
    else by its device node."""
    links = stable_links(by_id_dir)
    found = []
    for info in list_ports.comports():
        if info.vid is None:
            continue
        device = str(info.device)
        serial_number = str(info.serial_number) if info.serial_number else None
        stable = links.get(os.path.realpath(device))
        options: dict[str, Any] = ({"serial_number": serial_number} if serial_number
                                   else {"port": stable or device})
        described = " ".join(str(part) for part in (info.manufacturer, info.product) if part)
        found.append(AttachedCard(
            backend="serial", device=device, usb_id=f"{info.vid:04x}:{info.pid or 0:04x}",
            description=described or str(info.description or ""),
            state="USB serial adapter (open1553 speaks at 2,000,000 baud)", options=options,
            serial_number=serial_number, stable_path=stable, problem=access_problem(device)))
    return found
