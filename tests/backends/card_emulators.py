"""Card emulators for the hardware backends' tests, at the lowest seam only.

:class:`SerialCard` plays an open1553 card on the master side of a real pty pair (one pty per
bus): it runs the loopback :class:`BusController` and writes each word as the card's line.
The monitor opens the slave path with pyserial, as it would open /dev/ttyUSB0. ``unplug()``
closes the pty (the slave path disappears, reads fail) and ``replug()`` makes a new one behind
the same symlink, as udev's /dev/serial/by-id links behave.

Pacing: the backend frames from the card's report alone (drivers/backends/open1553_framer.py),
never from when lines arrive, so the emulator's timing is free. A real card's link runs
back-to-back while the bus is busy (its FIFO drains at line rate), so each stretch of busy bus is
written in one write, and an empty link only ever means an idle bus, as on the card. Between
stretches (bus idle longer than the no-response time-out) the emulator waits until the monitor
has read every line written (a condition it polls, without a time-out) and then keeps the
link quiet for ``pause_s`` (0: no pause at all).
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import usb.backend
import usb.core

from drivers.backends.loopback import BusController, Injector, Traffic
from drivers.backends.loopback.controller import BusWord
from drivers.backends.open1553 import LineWord, format_line

from .backtoback import Setup

IDLE_LINK_NS = 4_000
"""The card's gap flag: at least 4 µs of idle bus before the word."""
PAUSE_AFTER_NS = 14_000
"""Bus idle longer than this (the no-response time-out) becomes a quiet link."""


def line_for(word: BusWord, idle_before_ns: int | None) -> bytes:
    """The open1553 line for a loopback word. Faults the line cannot express (Manchester,
    bit count) are assumed reported as a parity failure (P0): the card's decoder fails the word."""
    fault = word.fault
    bad = fault.parity or fault.no_transition is not None or fault.bit_count != 0
    gap = idle_before_ns is None or idle_before_ns >= IDLE_LINK_NS
    return format_line(LineWord(word.sync ^ int(fault.inverted_sync), gap, not bad, False,
                                word.value))


def traffic_of(setup: Setup) -> Iterator[Traffic]:
    """The setup's frames from the loopback bus controller."""
    controller = BusController(setup.schedule, setup.terminals,
                               injector=Injector(list(setup.injections)))
    for _ in range(setup.frames):
        yield controller.run_frame()


class SerialCard:
    """One open1553 card per bus on pty pairs; ``path(bus)`` is the stable (symlink) path."""

    def __init__(self, buses: int = 2, pause_s: float = 0.03) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="mapr-pty-")
        self.pause_s = pause_s
        self.lines_written = 0
        self._fds: dict[int, tuple[int, int]] = {}
        self._last_stop: dict[int, int] = {}
        self.thread: threading.Thread | None = None
        for bus in range(buses):
            self._make(bus)

    def _make(self, bus: int) -> None:
        master, slave = os.openpty()
        self._fds[bus] = (master, slave)
        link = Path(self._dir.name) / f"card{bus}"
        link.unlink(missing_ok=True)
        link.symlink_to(os.ttyname(slave))

    def path(self, bus: int) -> str:
        return str(Path(self._dir.name) / f"card{bus}")

    def write(self, bus: int, data: bytes) -> None:
        """Raw bytes onto the card's link (lines, or garbage)."""
        master = self._fds[bus][0]
        view = memoryview(data)
        while view:
            view = view[os.write(master, view):]
        self.lines_written += data.count(b"\r") + data.count(b"\n")

    def write_traffic(self, traffic: Traffic) -> list[list[tuple[int, bytes]]]:
        """The frame's lines, in bus time order, cut where the bus was idle long enough
        for a no-response: each chunk is a list of (bus, line)."""
        chunks: list[list[tuple[int, bytes]]] = [[]]
        last_any: int | None = None
        for word in traffic.words:
            if last_any is not None and word.t_ns - last_any > PAUSE_AFTER_NS and chunks[-1]:
                chunks.append([])
            previous = self._last_stop.get(word.bus)
            chunks[-1].append((word.bus, line_for(word, None if previous is None
                                                  else word.t_ns - previous)))
            self._last_stop[word.bus] = word.stop_ns or word.end_ns + 500
            last_any = max(last_any or 0, self._last_stop[word.bus])
        return [c for c in chunks if c]

    def wait(self, condition: Callable[[], bool], timeout_s: float | None = 20.0) -> bool:
        """Poll ``condition`` until true or the time-out (a condition, not a race).

        ``timeout_s=None`` waits as long as it takes: the player waits so for the monitor to
        read what was written (it reads in its own threads, or is closed), so a host slow
        enough to pass any fixed time-out cannot make the player give up half way and leave
        the stream open for ever."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while not condition():
            if deadline is not None and time.monotonic() > deadline:
                return False
            time.sleep(0.001)
        return True

    def play(self, setup: Setup, drained: Callable[[], bool], stopped: Callable[[], bool],
             end: bool = True) -> None:
        """Write the setup's traffic, pausing at idle bus; then unplug (the stream ends)."""
        for traffic in traffic_of(setup):
            for chunk in self.write_traffic(traffic):
                for bus in sorted({bus for bus, _ in chunk}):
                    self.write(bus, b"".join(line for b, line in chunk if b == bus))
                if not self.wait(lambda: drained() or stopped(), timeout_s=None) or stopped():
                    return
                if self.pause_s:
                    time.sleep(self.pause_s)  # a quiet link: the backend may read idle bus
        if end:
            self.unplug()

    def start(self, setup: Setup, drained: Callable[[], bool], stopped: Callable[[], bool]
              ) -> None:
        self.thread = threading.Thread(target=self.play, args=(setup, drained, stopped),
                                       daemon=True)
        self.thread.start()

    def unplug(self) -> None:
        """Close every pty: the slave paths vanish and the monitor's reads fail."""
        for master, slave in self._fds.values():
            os.close(master)
            os.close(slave)
        self._fds.clear()

    def replug(self, buses: int = 1) -> None:
        for bus in range(buses):
            self._make(bus)
        self._last_stop.clear()

    def close(self) -> None:
        if self._fds:
            self.unplug()
        self._dir.cleanup()


# --- the FX2 at pyusb's backend seam --------------------------------------------------------

class _Desc:
    """A descriptor: pyusb reads its fields as attributes."""

    def __init__(self, **fields: Any) -> None:
        self.__dict__.update(fields)


class Fx2Backend(usb.backend.IBackend):  # type: ignore[misc]
    """A pyusb backend that behaves as an FX2 with fx2lafw would: bare (04b4:8613) until the
    firmware is written with request 0xA0 and CPUCS released, then re-enumerated as
    1d50:608c answering 0xB0/0xB2/0xB1 and streaming ``samples`` on endpoint 0x82.

    ``short_at``: read indices that return a short transfer; ``unplug_after``: bytes after
    which reads fail as an unplugged device (None: when the samples run out)."""

    def __init__(self, samples: bytes, *, bare: bool = True, short_at: Iterable[int] = (),
                 unplug_after: int | None = None, access_denied: bool = False,
                 version: tuple[int, int] = (1, 4)) -> None:
        self.samples = samples
        self.access_denied = access_denied
        """Opening fails as libusb fails without the udev rule (EACCES)."""
        self.version = version
        self.bare = bare
        self.ram: dict[int, bytes] = {}
        self.in_reset = False
        self.started: bytes | None = None
        self.position = 0
        self.reads = 0
        self.short_at = set(short_at)
        self.unplug_after = len(samples) if unplug_after is None else unplug_after
        self.unplugged = False

    def _ids(self) -> tuple[int, int]:
        return (0x04B4, 0x8613) if self.bare else (0x1D50, 0x608C)

    def enumerate_devices(self) -> Iterator[Any]:
        if not self.unplugged:
            yield ("fx2", self.bare)

    def get_device_descriptor(self, dev: Any) -> Any:
        vendor, product = (0x04B4, 0x8613) if dev[1] else (0x1D50, 0x608C)
        return _Desc(bLength=18, bDescriptorType=1, bcdUSB=0x200, bDeviceClass=0xFF,
                     bDeviceSubClass=0, bDeviceProtocol=0, bMaxPacketSize0=64,
                     idVendor=vendor, idProduct=product, bcdDevice=0, iManufacturer=0,
                     iProduct=0, iSerialNumber=0, bNumConfigurations=1, address=2, bus=1,
                     port_number=1, port_numbers=(1,), speed=3)

    def get_configuration_descriptor(self, dev: Any, config: int) -> Any:
        return _Desc(bLength=9, bDescriptorType=2, wTotalLength=32, bNumInterfaces=1,
                     bConfigurationValue=1, iConfiguration=0, bmAttributes=0x80, bMaxPower=50,
                     extra_descriptors=[])

    def get_interface_descriptor(self, dev: Any, intf: int, alt: int, config: int) -> Any:
        return _Desc(bLength=9, bDescriptorType=4, bInterfaceNumber=0, bAlternateSetting=0,
                     bNumEndpoints=1, bInterfaceClass=0xFF, bInterfaceSubClass=0,
                     bInterfaceProtocol=0, iInterface=0, extra_descriptors=[])

    def get_endpoint_descriptor(self, dev: Any, ep: int, intf: int, alt: int, config: int
                                ) -> Any:
        return _Desc(bLength=7, bDescriptorType=5, bEndpointAddress=0x82, bmAttributes=2,
                     wMaxPacketSize=512, bInterval=0, bRefresh=0, bSynchAddress=0,
                     extra_descriptors=[])

    def open_device(self, dev: Any) -> Any:
        if self.access_denied:
            raise usb.core.USBError("Access denied (insufficient permissions)", errno=13)
        if self.unplugged or dev[1] != self.bare:
            raise usb.core.USBError("No such device", errno=19)
        return dev

    def close_device(self, handle: Any) -> None:
        pass

    def set_configuration(self, handle: Any, value: int) -> None:
        pass

    def get_configuration(self, handle: Any) -> int:
        return 1

    def claim_interface(self, handle: Any, intf: int) -> None:
        pass

    def release_interface(self, handle: Any, intf: int) -> None:
        pass

    def ctrl_transfer(self, handle: Any, bmRequestType: int, bRequest: int, wValue: int,
                      wIndex: int, data: Any, timeout: int) -> int:
        if bRequest == 0xA0 and handle[1]:
            payload = bytes(data)
            if wValue == 0xE600:
                if payload == b"\x01":
                    self.in_reset = True
                elif payload == b"\x00" and self.in_reset and self.ram:
                    self.bare = False  # the firmware runs: re-enumerates with its IDs
            elif self.in_reset:
                self.ram[wValue] = payload
            return len(payload)
        if handle[1]:
            raise usb.core.USBError("Pipe error", errno=32)  # bare: only 0xA0 answers
        if bRequest == 0xB0:
            data[0], data[1] = self.version
            return 2
        if bRequest == 0xB2:
            data[0] = 1
            return 1
        if bRequest == 0xB1:
            self.started = bytes(data)
            return 3
        raise usb.core.USBError("Pipe error", errno=32)

    def bulk_read(self, handle: Any, ep: int, intf: int, buff: Any, timeout: int) -> int:
        if self.unplugged or self.started is None or ep != 0x82:
            raise usb.core.USBError("No such device", errno=19)
        self.reads += 1
        if self.position >= self.unplug_after:
            self.unplugged = True
            raise usb.core.USBError("No such device (it may have been disconnected)",
                                    errno=19)
        size = len(buff)
        if self.reads in self.short_at:
            size = 300  # not a whole packet: the FIFO overflowed on the device
        chunk = self.samples[self.position:min(self.position + size, self.unplug_after)]
        self.position += len(chunk)
        buff[:len(chunk)] = type(buff)("B", chunk)
        return len(chunk)
