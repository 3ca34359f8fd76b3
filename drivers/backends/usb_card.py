"""The ``usb`` backend: an FX2 logic analyzer (fx2lafw) on the transceivers' RX/RXB outputs.

:mod:`drivers.backends.fx2` finds the device, loads the firmware when it is bare and starts
acquisition; a reader thread then loops on pyusb's synchronous bulk read of endpoint 0x82
into a bounded queue. pyusb has no asynchronous transfers, so "several transfers in flight" is
approximated by large reads (``transfer_bytes``, 64 KiB: 128 FX2 packets) issued back to back
by a thread that does nothing else; the FX2's own FIFO covers the time between two reads.
Samples go through :class:`~drivers.pipeline.SamplePipeline`, the chain every bit-level source
uses.

Time: the sample counter is the time base. Each stretch of unbroken samples (a *segment*)
is anchored to host wall time at its first block; :attr:`UsbMonitor.drift_ppm` reports how the
sample clock runs against the host's monotonic clock. Lost data — a failed or short transfer,
a full queue (the host fell behind), an unplug — is never silence: the segment ends (open
messages are flushed), a :class:`~drivers.backends.serial_card.Gap` is appended to
:attr:`UsbMonitor.gaps`, and a new segment starts at host time. After an unplug the reader
reopens the device with exponential backoff (``reconnect=False``: the stream ends instead).

Options: ``ids``/``bare_ids`` (``"1d50:608c,0925:3881"`` or lists of (vendor, product)),
``firmware`` (path),
``sample_rate`` (12e6, 16e6, 24e6), ``channels`` ({"A": (rx, rxb), "B": (rx, rxb)}: input
numbers, default A = 0/1, B = 2/3), ``inverted`` (transceivers with active-low outputs),
``transfer_bytes``, ``queue_blocks``, ``reconnect``, ``backoff_s``, ``backoff_max_s``,
``usb_backend`` (a pyusb backend object; default libusb).
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import queue
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import usb.core
import usb.util

from drivers.backends import fx2
from drivers.backends.attached import UDEV_HINT, AttachedCard, access_problem
from drivers.backends.serial_card import Gap
from drivers.errors import BackendError
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.monitor import BusMonitor, MonitorFilter
from drivers.pipeline import SamplePipeline

DEFAULT_CHANNELS = {"A": (0, 1), "B": (2, 3)}


def channel_table(channels: Mapping[str, Sequence[int]], inverted: bool) -> npt.NDArray[np.uint8]:
    """A 256-entry table from the analyzer's input byte to the pipeline's layout (bit0/1 =
    bus A RX/RXB, bit2/3 = bus B RX/RXB)."""
    raw = np.arange(256, dtype=np.uint16)
    if inverted:
        used = sum(1 << i for pair in channels.values() for i in pair)
        raw = (raw ^ used).astype(np.uint16)
    out = np.zeros(256, dtype=np.uint8)
    for bus, (rx, rxb) in channels.items():
        shift = 0 if bus.upper() == "A" else 2
        out |= (((raw >> rx) & 1) << shift | ((raw >> rxb) & 1) << (shift + 1)).astype(np.uint8)
    return out


class _Reader(threading.Thread):
    """Bulk reads in a loop; every failure becomes a queued event, never a dead thread."""

    def __init__(self, monitor: UsbMonitor, device: Any) -> None:
        super().__init__(name="mapr-usb", daemon=True)
        self.m, self.device = monitor, device
        self.stop = threading.Event()

    def _put(self, item: tuple[Any, ...]) -> None:
        try:
            self.m.blocks.put_nowait(item)
        except queue.Full:
            self.m.overflows += 1  # the consumer fell behind: this block is lost, a gap
            if item[0] == "data":
                self.m.pending_overflow = True

    def run(self) -> None:
        m = self.m
        delay = m.backoff_s
        while not self.stop.is_set():
            if self.device is None:
                try:
                    self.device = m.open_device()
                except BackendError as error:
                    m.last_error = str(error)
                    self.stop.wait(delay)
                    delay = min(2 * delay, m.backoff_max_s)
                    continue
                delay = m.backoff_s
            try:
                data = self.device.read(fx2.EP_IN, m.transfer_bytes, timeout=1000)
            except usb.core.USBTimeoutError:
                self._put(("lost", time.time_ns(), "bulk transfer timed out"))
                continue
            except usb.core.USBError as error:
                self._put(("lost", time.time_ns(), f"transfer failed: {error}"))
                self._release()
                if not m.reconnect:
                    self._put(("eof",))
                    return
                continue
            block = bytes(data)
            if len(block) % 512:
                self._put(("data", time.time_ns(), time.monotonic_ns(), block))
                self._put(("lost", time.time_ns(), f"short transfer ({len(block)} bytes)"))
                continue
            self._put(("data", time.time_ns(), time.monotonic_ns(), block))
        self._release()

    def _release(self) -> None:
        device, self.device = self.device, None
        if device is not None:
            with contextlib.suppress(usb.core.USBError):
                usb.util.dispose_resources(device)


class UsbMonitor(BusMonitor):
    """A monitor on an FX2 logic analyzer (see the module docstring for options)."""

    def __init__(self, *, filters: Sequence[MonitorFilter] | None = None,
                 ids: str | Iterable[Sequence[int] | str] = fx2.FX2LAFW_IDS,
                 bare_ids: str | Iterable[Sequence[int] | str] = fx2.BARE_IDS,
                 firmware: str | None = None, sample_rate: float = 24e6,
                 channels: dict[str, Sequence[int]] | None = None, inverted: bool = False,
                 transfer_bytes: int = 65536, queue_blocks: int = 256,
                 reconnect: bool = True, backoff_s: float = 0.1, backoff_max_s: float = 5.0,
                 timing: BusTiming | None = None, usb_backend: Any = None,
                 **config: Any) -> None:
        super().__init__(filters=filters, **config)
        self.ids = fx2.parse_ids(ids)
        self.bare_ids = fx2.parse_ids(bare_ids)
        self.firmware, self.usb_backend = firmware, usb_backend
        self.sample_rate = int(sample_rate)
        self.table = channel_table(channels or DEFAULT_CHANNELS, inverted)
        self.transfer_bytes = transfer_bytes
        self.reconnect, self.backoff_s, self.backoff_max_s = reconnect, backoff_s, backoff_max_s
        self.timing = timing
        self.gaps: list[Gap] = []
        """Lost data (host wall ns): failed/short transfers, overflow, unplug."""
        self.overflows = 0
        self.pending_overflow = False
        self.last_error: str | None = None
        self.samples = 0
        """Samples received in the current segment."""
        self.drift_ppm = 0.0
        """(sample time - host time) / host time over the current segment, in ppm."""
        self.blocks: queue.Queue[tuple[Any, ...]] = queue.Queue(maxsize=queue_blocks)
        self._pipeline = SamplePipeline(self.sample_rate, timing=timing)
        self._anchor: tuple[int, int] | None = None  # (wall ns, mono ns) of the segment start
        self._ended = False
        self._floor = 0
        self._reader = _Reader(self, self.open_device())
        self._reader.start()

    @classmethod
    def check_loadable(cls) -> None:
        """Raise :class:`~drivers.errors.BackendUnavailable` when this backend can never open
        a card here (no libusb), so a daemon says so once instead of retrying for ever."""
        fx2.require_libusb()

    def open_device(self) -> Any:
        """Find (loading firmware if bare) and start the analyzer."""
        device = fx2.open_card(self.ids, self.bare_ids, self.firmware, self.usb_backend)
        fx2.start(device, self.sample_rate)
        return device

    def _recv_internal(self, timeout: float | None) -> list[MonitorRecord] | None:
        if self._ended:
            return None
        wait = 0.1 if timeout is None else min(max(timeout, 0.0), 0.1)
        records: list[MonitorRecord] = []
        try:
            item: tuple[Any, ...] | None = self.blocks.get(timeout=wait)
        except queue.Empty:
            item = None
        while item is not None:
            if self.pending_overflow:
                self.pending_overflow = False
                records += self._break(time.time_ns(), "overflow: host fell behind")
            records += self._handle(item)
            if self._ended or records:
                return records  # one block's records at a time: recv() stays responsive
            try:
                item = self.blocks.get_nowait()
            except queue.Empty:
                item = None
        return records

    def _handle(self, item: tuple[Any, ...]) -> list[MonitorRecord]:
        kind = item[0]
        if kind == "data":
            _, wall, mono, block = item
            samples = self.table[np.frombuffer(block, dtype=np.uint8)]
            if self._anchor is None:
                start = wall - round(len(block) * 1e9 / self.sample_rate)
                self._anchor = (max(start, self._floor), mono)  # time never runs back
            self.samples += len(block)
            host = mono - self._anchor[1]
            if host > 0:
                self.drift_ppm = (self.samples * 1e9 / self.sample_rate - host) / host * 1e6
            return self._shift(self._pipeline.feed(samples))
        if kind == "lost":
            return self._break(item[1], item[2])
        self._ended = True  # "eof"
        return self._shift(self._pipeline.flush())

    def _break(self, wall: int, reason: str) -> list[MonitorRecord]:
        """End the segment: what was open is flushed, the gap recorded, time re-anchored."""
        records = self._shift(self._pipeline.flush())
        start = wall if self._anchor is None else \
            self._anchor[0] + round(self.samples * 1e9 / self.sample_rate)
        self.gaps.append(Gap("AB", start, max(start, wall), reason))
        self._floor = max(start, wall)
        self.last_error = reason
        self._pipeline = SamplePipeline(self.sample_rate, timing=self.timing)
        self._anchor, self.samples = None, 0
        return records

    def _shift(self, records: list[MonitorRecord]) -> list[MonitorRecord]:
        offset = 0 if self._anchor is None else self._anchor[0]
        return [dataclasses.replace(r, t_ns=r.t_ns + offset, end_ns=r.end_ns + offset,
                                    extra={**r.extra, "time_tags": "samples"})
                for r in records]

    def _close(self) -> None:
        self._reader.stop.set()
        self._reader.join(timeout=3.0)
        self._reader._release()


def usb_cards(backend: Any = None, *, ids: Iterable[tuple[int, int]] = fx2.FX2LAFW_IDS,
              bare_ids: Iterable[tuple[int, int]] = fx2.BARE_IDS,
              firmware: str | None = None) -> list[AttachedCard]:
    """Attached FX2 analyzers with ``ids`` (running fx2lafw, version read with request 0xB0)
    or ``bare_ids`` (no firmware yet), for ``mapr devices``. Raises
    :class:`~drivers.errors.BackendUnavailable` when libusb is missing (the caller says so).

    Bare devices are not talked to: the firmware is loaded only when the backend opens them.
    The options name the IDs and firmware only where they differ from the defaults."""
    ids, bare_ids = list(ids), list(bare_ids)
    options: dict[str, Any] = {}
    if ids != list(fx2.FX2LAFW_IDS):
        options["ids"] = fx2.format_ids(ids)
    if bare_ids != list(fx2.BARE_IDS):
        options["bare_ids"] = fx2.format_ids(bare_ids)
    if firmware is not None:
        options["firmware"] = firmware
    found = []
    for device in fx2.find(ids + [i for i in bare_ids if i not in ids], backend):
        usb_id = (device.idVendor, device.idProduct)
        node = f"/dev/bus/usb/{device.bus:03d}/{device.address:03d}"
        problem = access_problem(node)
        if usb_id in ids:
            state, error = _firmware_state(device, firmware)
            problem = problem or error
        else:
            state = "bare FX2: the firmware is loaded when the backend opens it"
            problem = problem or _firmware_problem(firmware)
        found.append(AttachedCard(
            backend="usb", device=f"usb bus {device.bus} address {device.address}",
            usb_id=f"{usb_id[0]:04x}:{usb_id[1]:04x}", description="FX2 logic analyzer",
            state=state, options=dict(options), problem=problem))
    return found


def _firmware_state(device: Any, firmware: str | None) -> tuple[str, str | None]:
    """(state, problem) of a device with fx2lafw's IDs, from its version request."""
    try:
        raw = device.ctrl_transfer(fx2.VENDOR_IN, fx2.REQ_GET_VERSION, 0, 0, 2, timeout=500)
    except usb.core.USBError as error:
        code = getattr(error, "errno", None)
        if code in (errno.EACCES, errno.EPERM):
            return "fx2lafw IDs (version unreadable)", f"permission denied: {UDEV_HINT}"
        if code == errno.EBUSY:
            return "fx2lafw IDs (version unreadable)", "busy: another program has claimed it"
        return ("fx2lafw IDs, firmware not answering: it is reloaded when the backend opens "
                "it", _firmware_problem(firmware))
    finally:
        with contextlib.suppress(usb.core.USBError):
            usb.util.dispose_resources(device)
    if len(raw) != 2:
        return "fx2lafw IDs, firmware version unreadable", None
    major, minor = int(raw[0]), int(raw[1])
    if major != 1:
        return f"fx2lafw {major}.{minor}", f"firmware major version {major}: need 1"
    return f"fx2lafw {major}.{minor} running", None


def _firmware_problem(firmware: str | None) -> str | None:
    if fx2.firmware_file(firmware) is not None:
        return None
    tried = firmware or ", ".join(fx2.FIRMWARE_PATHS)
    return (f"needs the fx2lafw firmware, not found (tried {tried}): install "
            "sigrok-firmware-fx2lafw or pass firmware=PATH")
