"""The ``usb`` backend against an FX2 emulated at pyusb's backend seam (card_emulators.Fx2Backend):
firmware load and re-enumeration, the vendor requests, samples from our encoder, channel
mapping, short transfers and unplugs as gaps, and the back-to-back suite."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from drivers.backends import fx2
from drivers.backends.loopback.line import SampleWriter
from drivers.backends.usb_card import UsbMonitor, channel_table, usb_cards
from drivers.errors import BackendError
from drivers.monitor import BusMonitor, backend_class

from .backtoback import FORMATS, SUITE, MonitorFactory, Setup, one_per_frame, reference_terminals
from .card_emulators import Fx2Backend, traffic_of

RATE = 24_000_000


def samples_for(setup: Setup, table: np.ndarray | None = None) -> bytes:
    """The setup's traffic as fx2lafw samples (whole 512-byte packets)."""
    writer = SampleWriter(RATE)
    raw = np.concatenate([writer.write(t) for t in traffic_of(setup)])
    raw = np.concatenate([raw, np.zeros(-raw.size % 512 + 512 * 4, dtype=np.uint8)])
    if table is not None:  # encode through the inverse of a channel mapping
        inverse = np.zeros(256, dtype=np.uint8)
        for byte in range(256)[::-1]:
            inverse[table[byte]] = byte
        raw = inverse[raw]
    return raw.tobytes()


@pytest.fixture
def firmware(tmp_path: Path) -> str:
    path = tmp_path / "fx2lafw.ihx"
    path.write_text(":0300000002000AF1\n:00000001FF\n")
    return str(path)


def usb_factory(firmware: str) -> MonitorFactory:
    def factory(setup: Setup) -> BusMonitor:
        backend = Fx2Backend(samples_for(setup))
        return UsbMonitor(usb_backend=backend, firmware=firmware, reconnect=False,
                          transfer_bytes=8192,
                          sample_rate=RATE, filters=setup.filters)
    return factory


@pytest.mark.parametrize("check", SUITE, ids=[c.__name__ for c in SUITE])
def test_usb_backtoback(check: Callable[[MonitorFactory], None], firmware: str) -> None:
    check(usb_factory(firmware))


def test_firmware_load_and_start(firmware: str) -> None:
    setup = Setup(one_per_frame(FORMATS), reference_terminals(), 10)
    backend = Fx2Backend(samples_for(setup))
    with UsbMonitor(usb_backend=backend, firmware=firmware, reconnect=False,
                    sample_rate=16e6) as monitor:
        assert backend.ram == {0: bytes([0x02, 0x00, 0x0A])}  # the image, written in reset
        assert not backend.bare and backend.started == bytes([0x40, 0, 2])
        monitor.close()
    assert usb_cards(Fx2Backend(b"", bare=False))[0].usb_id == "1d50:608c"


def test_missing_firmware_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(BackendError, match="sigrok-firmware-fx2lafw"):
        UsbMonitor(usb_backend=Fx2Backend(b""), firmware=str(tmp_path / "none.fw"))


def test_no_device_and_bad_rate(firmware: str) -> None:
    backend = Fx2Backend(b"")
    backend.unplugged = True
    with pytest.raises(BackendError, match="no FX2"):
        UsbMonitor(usb_backend=backend)
    with pytest.raises(BackendError, match="sample rate"):
        UsbMonitor(usb_backend=Fx2Backend(b"", bare=False), sample_rate=10e6)


def test_channel_mapping_and_inverted_outputs(firmware: str) -> None:
    channels = {"A": (5, 4), "B": (7, 6)}
    table = channel_table(channels, inverted=True)
    setup = Setup(one_per_frame(FORMATS), reference_terminals(), 10)
    backend = Fx2Backend(samples_for(setup, table), bare=False)
    with UsbMonitor(usb_backend=backend, channels=channels, inverted=True,
                    reconnect=False) as monitor:
        records = list(monitor)
    assert len(records) == 10 and all(r.ok for r in records)


def test_short_transfer_and_unplug_are_gaps(firmware: str) -> None:
    setup = Setup(one_per_frame(FORMATS), reference_terminals(), 10)
    data = samples_for(setup)
    backend = Fx2Backend(data, bare=False, short_at={3})
    monitor = UsbMonitor(usb_backend=backend, reconnect=False, transfer_bytes=512 * 64)
    records = list(monitor)
    monitor.close()
    reasons = [g.reason for g in monitor.gaps]
    assert reasons[0].startswith("short transfer") and "transfer failed" in reasons[-1]
    assert len(records) >= 8  # messages around the lost data may be cut, never invented
    times = [r.t_ns for r in records]
    assert times == sorted(times)
    assert all(r.extra["time_tags"] == "samples" for r in records)


def test_reconnects_after_unplug(firmware: str) -> None:
    setup = Setup(one_per_frame(FORMATS), reference_terminals(), 10)
    backend = Fx2Backend(samples_for(setup), bare=False, unplug_after=512 * 64)
    monitor = UsbMonitor(usb_backend=backend, backoff_s=0.01, transfer_bytes=512 * 64)
    first = monitor.recv(timeout=10)
    assert first is not None
    deadline_records = []
    # the device comes back (same backend object) and streams on
    backend.unplug_after = len(backend.samples)
    backend.unplugged = False
    while len(monitor.gaps) < 1:
        deadline_records.append(monitor.recv(timeout=0.1))
    monitor.close()
    assert "transfer failed" in monitor.gaps[0].reason
    assert np.isfinite(monitor.drift_ppm)


def test_registered_as_usb() -> None:
    assert backend_class("usb") is UsbMonitor
    assert fx2.RATES[24_000_000] == (0x40, 0, 1)
