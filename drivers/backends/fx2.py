"""Cypress FX2 with sigrok's fx2lafw firmware: find, load firmware, start acquisition (pyusb).

Facts (../shared/REFERENCE.md, from the fx2lafw sources): vendor request 0xB0 reads the
firmware version (2 bytes, major must be 1), 0xB1 starts acquisition (flags, delay high, delay
low; flag bit 6 = 48 MHz clock; delay = 48 MHz / rate - 1), 0xB2 reads the revision; samples
stream on bulk IN endpoint 0x82, one byte per sample.

Firmware loading follows the EZ-USB convention, which REFERENCE.md marks *uncertain*: vendor
request 0xA0 writes RAM at wValue; CPUCS (0xE600) is written 1 to hold the 8051 in reset,
the image is written, then CPUCS is written 0 to run it, after which the device disconnects
and re-enumerates with the firmware's IDs. This was checked only against our own emulation
of that behaviour, never against a real FX2 (docs/hardware.md says so).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import usb.core
import usb.util

from drivers.backends.attached import UDEV_HINT
from drivers.errors import BackendError, BackendUnavailable

FX2LAFW_IDS: tuple[tuple[int, int], ...] = ((0x1D50, 0x608C), (0x0925, 0x3881))
BARE_IDS: tuple[tuple[int, int], ...] = ((0x04B4, 0x8613),)
"""A Cypress FX2 without firmware (the chip's default IDs)."""
FIRMWARE_PATHS = ("/usr/share/sigrok-firmware/fx2lafw-sigrok-fx2-8ch.fw",
                  "/usr/local/share/sigrok-firmware/fx2lafw-sigrok-fx2-8ch.fw")
REQ_FIRMWARE_LOAD = 0xA0
REQ_GET_VERSION = 0xB0
REQ_START = 0xB1
REQ_GET_REVISION = 0xB2
CPUCS = 0xE600
EP_IN = 0x82
VENDOR_OUT = 0x40
VENDOR_IN = 0xC0
CHUNK = 4096
RATES = {24_000_000: (0x40, 0, 1), 16_000_000: (0x40, 0, 2), 12_000_000: (0x40, 0, 3)}
"""Samples per second -> the start request's (flags, delay high, delay low)."""

Device = Any
"""A ``usb.core.Device`` (pyusb ships no type hints)."""


def parse_ids(value: Any) -> list[tuple[int, int]]:
    """USB IDs from an option: ``"1d50:608c,0925:3881"`` (as ``-O ids=...`` gives it), a
    list of such strings, or a list of (vendor, product) integer pairs (as in YAML)."""
    items = value.split(",") if isinstance(value, str) else list(value)
    out = []
    for item in items:
        try:
            if isinstance(item, str):
                vendor, _, product = item.strip().partition(":")
                out.append((int(vendor, 16), int(product, 16)))
            else:
                vendor_id, product_id = item
                out.append((int(vendor_id), int(product_id)))
        except (TypeError, ValueError):
            raise BackendError(f"USB IDs: expected VVVV:PPPP (hex), got {item!r}") from None
    return out


def format_ids(ids: Iterable[tuple[int, int]]) -> str:
    """``"1d50:608c,0925:3881"``: the form :func:`parse_ids` reads back."""
    return ",".join(f"{vendor:04x}:{product:04x}" for vendor, product in ids)


NO_LIBUSB = ("the usb backend needs libusb-1.0, which is not installed "
             "(e.g. apt install libusb-1.0-0)")


def require_libusb(backend: Any = None) -> None:
    """Raise :class:`~drivers.errors.BackendUnavailable` when pyusb finds no libusb: the
    usb backend can then never open a card, whatever is plugged in."""
    if backend is not None:
        return
    import usb.backend.libusb1
    if usb.backend.libusb1.get_backend() is None:
        raise BackendUnavailable(NO_LIBUSB)


def find(ids: Iterable[tuple[int, int]], backend: Any = None) -> list[Device]:
    """Every attached device with one of ``ids``; no libusb raises
    :class:`~drivers.errors.BackendUnavailable`."""
    wanted = set(ids)
    try:
        found = usb.core.find(find_all=True, backend=backend,
                              custom_match=lambda d: (d.idVendor, d.idProduct) in wanted)
    except usb.core.NoBackendError as error:
        raise BackendUnavailable(NO_LIBUSB) from error
    return list(found or [])


def firmware_version(device: Device) -> tuple[int, int] | None:
    """(major, minor) from request 0xB0, or None when the device does not answer it."""
    try:
        raw = device.ctrl_transfer(VENDOR_IN, REQ_GET_VERSION, 0, 0, 2, timeout=500)
    except usb.core.USBError:
        return None
    return (int(raw[0]), int(raw[1])) if len(raw) == 2 else None


def firmware_file(path: str | None) -> Path | None:
    """The firmware file a load would use: ``path``, else the first of :data:`FIRMWARE_PATHS`
    that exists (None: none found)."""
    for candidate in [path] if path else FIRMWARE_PATHS:
        file = Path(candidate)
        if file.is_file():
            return file
    return None


def read_firmware(path: str | None) -> list[tuple[int, bytes]]:
    """The firmware image as (address, bytes) pieces: Intel HEX (.hex/.ihx) or a raw
    binary loaded at 0 (Debian's .fw files)."""
    file = firmware_file(path)
    if file is not None:
        if file.suffix.lower() in (".hex", ".ihx"):
            return _intel_hex(file.read_text())
        return [(0, file.read_bytes())]
    candidates = [path] if path else list(FIRMWARE_PATHS)
    raise BackendError(f"fx2lafw firmware not found (tried {', '.join(candidates)}): install "
                       "sigrok-firmware-fx2lafw or pass firmware=PATH")


def _intel_hex(text: str) -> list[tuple[int, bytes]]:
    pieces = []
    for line in text.split():
        if not line.startswith(":"):
            continue
        raw = bytes.fromhex(line[1:])
        count, address, kind = raw[0], raw[1] << 8 | raw[2], raw[3]
        if sum(raw) & 0xFF:
            raise BackendError(f"firmware: bad checksum in {line!r}")
        if kind == 0:
            pieces.append((address, raw[4:4 + count]))
    return pieces


def load_firmware(device: Device, image: list[tuple[int, bytes]]) -> None:
    """Write ``image`` into the FX2's RAM with the 8051 held in reset, then release it."""
    device.ctrl_transfer(VENDOR_OUT, REQ_FIRMWARE_LOAD, CPUCS, 0, b"\x01")
    for address, data in image:
        for offset in range(0, len(data), CHUNK):
            device.ctrl_transfer(VENDOR_OUT, REQ_FIRMWARE_LOAD, address + offset, 0,
                                 data[offset:offset + CHUNK])
    # The device may drop off the bus at once as it re-enumerates.
    with contextlib.suppress(usb.core.USBError):
        device.ctrl_transfer(VENDOR_OUT, REQ_FIRMWARE_LOAD, CPUCS, 0, b"\x00")


def open_card(ids: Iterable[tuple[int, int]], bare_ids: Iterable[tuple[int, int]],
              firmware: str | None, backend: Any = None, settle_s: float = 5.0) -> Device:
    """A device running fx2lafw: one already running it, or a bare one after a firmware
    load and its re-enumeration (waited for up to ``settle_s``)."""
    ids, bare_ids = list(ids), list(bare_ids)
    for device in find(ids, backend):
        version = firmware_version(device)
        if version is not None:
            check_version(version)
            return device
    bare = find(bare_ids + ids, backend)
    if not bare:
        raise BackendError("no FX2 logic analyzer found (IDs "
                           f"{', '.join(f'{v:04x}:{p:04x}' for v, p in ids + bare_ids)}); "
                           "see `mapr devices`")
    load_firmware(bare[0], read_firmware(firmware))
    deadline = time.monotonic() + settle_s
    while time.monotonic() < deadline:
        for device in find(ids, backend):
            version = firmware_version(device)
            if version is not None:
                check_version(version)
                return device
        time.sleep(0.05)  # the hardware takes ~1 s to re-enumerate; nothing to wait on
    raise BackendError("the FX2 did not come back with fx2lafw after the firmware load")


def check_version(version: tuple[int, int]) -> None:
    if version[0] != 1:
        raise BackendError(f"fx2lafw firmware version {version[0]}.{version[1]}: "
                           "need major version 1")


def start(device: Device, sample_rate: int) -> None:
    """Claim interface 0 and start sampling at ``sample_rate`` (12, 16 or 24 MS/s)."""
    if sample_rate not in RATES:
        raise BackendError(f"sample rate {sample_rate} not supported; use one of "
                           f"{', '.join(str(r) for r in RATES)}")
    try:
        device.set_configuration()
    except usb.core.USBError as error:
        if getattr(error, "errno", None) in (13, 1):
            raise BackendError(f"permission denied on the FX2: {UDEV_HINT}") from error
        if getattr(error, "errno", None) == 16:
            raise BackendError("the FX2 is busy: another program has claimed it") from error
        raise BackendError(f"cannot configure the FX2: {error}") from error
    usb.util.claim_interface(device, 0)
    device.ctrl_transfer(VENDOR_OUT, REQ_START, 0, 0, bytes(RATES[sample_rate]))

