"""``mapr devices`` at the lowest seams: pyserial's port listing (ListPortInfo entries, one of
them a real pty an open1553 emulator writes to) and pyusb's backend lookup (the FX2 emulated
as a ``usb.backend.IBackend``). What it prints must open the card it names."""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import usb.backend.libusb1
from serial.tools import list_ports
from serial.tools.list_ports_common import ListPortInfo

from drivers.backends.open1553 import LineWord, format_line
from drivers.backends.serial_card import serial_cards
from drivers.mil1553.wordbatch import SYNC_CMD, SYNC_DATA
from drivers.monitor import open_monitor
from mapr_daemon.cli.main import main
from mapr_daemon.icd.yamlsrc import load_text
from mapr_daemon.service.config import parse

from .card_emulators import Fx2Backend, SerialCard


def port(device: str, *, vid: int | None = 0x0403, pid: int = 0x6014,
         serial_number: str | None = None) -> ListPortInfo:
    """A port as pyserial's Linux listing describes it."""
    info = ListPortInfo(device, skip_link_detection=True)
    if vid is not None:
        info.vid, info.pid, info.serial_number = vid, pid, serial_number
        info.manufacturer, info.product = "FTDI", "FT232H"
        info.description = "FT232H - open1553"
    return info


@pytest.fixture
def ports(monkeypatch: pytest.MonkeyPatch) -> list[ListPortInfo]:
    """What ``list_ports.comports()`` returns (empty until the test adds entries)."""
    listed: list[ListPortInfo] = []
    monkeypatch.setattr(list_ports, "comports", lambda include_links=False: list(listed))
    return listed


@pytest.fixture
def usb_bus(monkeypatch: pytest.MonkeyPatch) -> list[Fx2Backend]:
    """pyusb's libusb lookup answers with the emulated FX2 the test puts here (none: an
    empty bus)."""
    plugged: list[Fx2Backend] = []

    def get_backend(*args: object, **kwargs: object) -> Fx2Backend:
        if plugged:
            return plugged[0]
        empty = Fx2Backend(b"")
        empty.unplugged = True
        return empty

    monkeypatch.setattr(usb.backend.libusb1, "get_backend", get_backend)
    return plugged


@pytest.fixture
def card() -> Iterator[SerialCard]:
    emulator = SerialCard(buses=1)
    yield emulator
    emulator.close()


def devices(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, list[dict[str, object]]]:
    assert main(["devices", "--json", *argv]) == 0
    found: dict[str, list[dict[str, object]]] = json.loads(capsys.readouterr().out)
    return found


def test_nothing_attached_is_exit_0_with_a_hint(ports: list[ListPortInfo],
                                                usb_bus: list[Fx2Backend],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    ports.append(port("/dev/ttyS0", vid=None))   # an on-board UART is not a card
    assert main(["devices"]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "no cards found" in captured.err and "60-mapr.rules" in captured.err
    assert devices(capsys)["cards"] == []


def test_a_serial_card_by_serial_number_opens_with_what_is_printed(
        ports: list[ListPortInfo], usb_bus: list[Fx2Backend], card: SerialCard,
        capsys: pytest.CaptureFixture[str]) -> None:
    pts = os.path.realpath(card.path(0))
    ports.append(port(pts, serial_number="FT4ZQ1"))
    (found,) = devices(capsys)["cards"]
    assert found["backend"] == "serial" and found["usb_id"] == "0403:6014"
    assert found["monitor_args"] == "--backend serial -O serial_number=FT4ZQ1"
    assert found["problem"] is None
    config = parse(load_text(f"{found['config_line']}\n", "mapr.yaml"), "mapr.yaml")
    assert config.backend.name == "serial"
    assert config.backend.options == {"serial_number": "FT4ZQ1"}
    # the printed options open this very card: find_port looks the number up in the listing
    with open_monitor("serial", **config.backend.options) as monitor:
        card.write(0, format_line(LineWord(SYNC_CMD, True, True, False, 5 << 11 | 1 << 5 | 1))
                   + format_line(LineWord(SYNC_DATA, False, True, False, 0x1234))
                   + format_line(LineWord(SYNC_CMD, True, True, False, 5 << 11)))
        record = monitor.recv(timeout=10)
    assert record is not None and record.rt == 5 and record.data == (0x1234,)


def test_a_serial_card_without_serial_number_is_opened_by_its_stable_path(
        ports: list[ListPortInfo], card: SerialCard) -> None:
    by_id = Path(card.path(0)).parent   # the emulator's symlink stands in for udev's by-id link
    ports.append(port(os.path.realpath(card.path(0))))
    (found,) = serial_cards(str(by_id))
    assert found.stable_path == card.path(0)
    assert found.options == {"port": card.path(0)}
    assert found.serial_number is None


@contextlib.contextmanager
def as_user(uid: int) -> Iterator[None]:
    """Run as ``uid`` (effective), as a user without the udev rule would."""
    os.seteuid(uid)
    try:
        yield
    finally:
        os.seteuid(0)


def test_a_port_the_user_may_not_open_names_the_udev_rule(ports: list[ListPortInfo]) -> None:
    folder = tempfile.mkdtemp(prefix="mapr-dev-")
    try:
        os.chmod(folder, 0o755)
        node = Path(folder) / "ttyUSB7"
        node.touch()
        os.chmod(node, stat.S_IRUSR | stat.S_IWUSR)   # crw------- root, as without the rule
        ports.append(port(str(node), serial_number="X1"))
        if os.geteuid() == 0:
            with as_user(65534):
                (found,) = serial_cards()
        else:
            os.chmod(node, 0)
            (found,) = serial_cards()
    finally:
        os.chmod(folder, 0o700)
        for child in Path(folder).iterdir():
            child.unlink()
        os.rmdir(folder)
    assert found.problem is not None
    assert "permission denied" in found.problem and "60-mapr.rules" in found.problem
    assert "dialout" in found.problem


def test_an_fx2_running_fx2lafw_shows_its_version_and_opens(
        ports: list[ListPortInfo], usb_bus: list[Fx2Backend],
        capsys: pytest.CaptureFixture[str]) -> None:
    usb_bus.append(Fx2Backend(b"\x00" * 512 * 8, bare=False, version=(1, 4)))
    (found,) = devices(capsys)["cards"]
    assert found["backend"] == "usb" and found["usb_id"] == "1d50:608c"
    assert found["state"] == "fx2lafw 1.4 running" and found["problem"] is None
    assert found["monitor_args"] == "--backend usb" and found["options"] == {}
    with open_monitor("usb", reconnect=False) as monitor:   # the defaults find it
        assert list(monitor) == []                         # idle bus: no records
    assert usb_bus[0].started is not None


def test_a_bare_fx2_needs_firmware(ports: list[ListPortInfo], usb_bus: list[Fx2Backend],
                                   capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    usb_bus.append(Fx2Backend(b""))
    (found,) = devices(capsys)["cards"]
    assert found["usb_id"] == "04b4:8613" and "bare FX2" in str(found["state"])
    if not any(Path(p).is_file() for p in ("/usr/share/sigrok-firmware/fx2lafw-sigrok-fx2-8ch.fw",
                                           "/usr/local/share/sigrok-firmware/"
                                           "fx2lafw-sigrok-fx2-8ch.fw")):
        assert "sigrok-firmware-fx2lafw" in str(found["problem"])
    image = tmp_path / "fx2lafw.ihx"
    image.write_text(":0300000002000AF1\n:00000001FF\n")
    (found,) = devices(capsys, "--firmware", str(image))["cards"]
    assert found["problem"] is None and found["options"] == {"firmware": str(image)}
    assert usb_bus[0].bare, "listing must not load firmware"


def test_configured_ids_and_permission_denied(ports: list[ListPortInfo],
                                             usb_bus: list[Fx2Backend],
                                             capsys: pytest.CaptureFixture[str],
                                             tmp_path: Path) -> None:
    usb_bus.append(Fx2Backend(b"", bare=False, access_denied=True))
    config = tmp_path / "mapr.yaml"
    config.write_text("backend:\n  name: usb\n  options: {ids: '1d50:608c'}\n")
    (found,) = devices(capsys, "--config", str(config))["cards"]
    assert found["options"] == {"ids": "1d50:608c"}
    assert "permission denied" in str(found["problem"]) and "dialout" in str(found["problem"])
    # IDs the analyzer does not have: not listed
    assert devices(capsys, "--usb-ids", "0925:3881", "--bare-ids", "0925:3881")["cards"] == []
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usb     usb bus 1 address 2  1d50:608c")
    assert "PROBLEM:   permission denied" in out


def test_libusb_missing_is_a_note_not_a_failure(ports: list[ListPortInfo],
                                                monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("libusb1", "libusb0", "openusb"):
        monkeypatch.setattr(getattr(usb.backend, name), "get_backend", lambda *a, **k: None)
    found = devices(capsys)
    assert found["cards"] == []
    assert any("libusb" in str(note) for note in found["notes"])
