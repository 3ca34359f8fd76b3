"""systemd/: the unit says what docs/service.md and the daemon rely on, and systemd agrees.

The static checks run everywhere; ``systemd-analyze verify`` and ``security`` run where
systemd is installed (skipped with the reason on a CI machine with only Python).
"""

from __future__ import annotations

import importlib.util
import re
import shutil
import sys
from pathlib import Path
from types import ModuleType

import pytest

from mapr_daemon.catalog import DEFAULT_CATALOG
from mapr_daemon.cli import exitcodes

SYSTEMD = Path(__file__).resolve().parents[2] / "systemd"


def unit() -> dict[str, list[str]]:
    """``key -> values`` of [Service] (repeatable keys keep every value)."""
    values: dict[str, list[str]] = {}
    section = ""
    for raw in (SYSTEMD / "mapr.service").read_text().splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("["):
            section = line.strip("[]")
            continue
        key, _, value = line.partition("=")
        values.setdefault(f"{section}.{key}", []).append(value)
    return values


def load_checker() -> ModuleType:
    spec = importlib.util.spec_from_file_location("check_unit", SYSTEMD / "check_unit.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_service_settings_the_daemon_relies_on() -> None:
    u = unit()
    assert u["Service.Type"] == ["notify"]
    assert u["Service.ExecStart"] == ["mapr run --config /etc/mapr/mapr.yaml"]
    assert u["Service.Restart"] == ["on-failure"]
    # a broken config, and a backend that can never load here: restarting would not help
    assert u["Service.RestartPreventExitStatus"] == [f"{exitcodes.CONFIG} {exitcodes.UNAVAILABLE}"]
    assert "Service.WatchdogSec" in u
    assert (u["Service.User"], u["Service.SupplementaryGroups"]) == (["mapr"], ["dialout"])
    assert "Service.DynamicUser" not in u and "Service.PrivateDevices" not in u
    assert u["Service.StateDirectory"] == [Path(DEFAULT_CATALOG).parent.name]
    assert Path(DEFAULT_CATALOG).parent == Path("/var/lib/mapr")


def test_devices_and_network_are_closed() -> None:
    u = unit()
    assert u["Service.DevicePolicy"] == ["closed"]
    assert sorted(u["Service.DeviceAllow"]) == ["char-ttyACM rw", "char-ttyUSB rw",
                                                "char-usb_device rw"]
    assert u["Service.ProtectSystem"] == ["strict"] and u["Service.NoNewPrivileges"] == ["yes"]
    assert u["Service.IPAddressDeny"] == ["any"] and u["Service.PrivateNetwork"] == ["yes"]
    families = u["Service.RestrictAddressFamilies"][0].split()
    assert "AF_INET" not in families and "AF_INET6" not in families


def test_udev_rule_gives_dialout_the_cards() -> None:
    rules = [x for x in (SYSTEMD / "60-mapr.rules").read_text().splitlines()
             if x and not x.startswith("#")]
    usb = {(m.group(1), m.group(2)) for x in rules
           if (m := re.search(r'idVendor}=="(\w+)".*idProduct}=="(\w+)"', x))}
    # every analyzer the usb backend looks for, bare ones included (it loads their firmware)
    from drivers.backends.fx2 import BARE_IDS, FX2LAFW_IDS
    assert usb == {(f"{v:04x}", f"{p:04x}") for v, p in FX2LAFW_IDS + BARE_IDS}
    assert all('GROUP="dialout"' in x and 'MODE="0660"' in x for x in rules)
    assert any("ttyUSB" in x for x in rules) and any("ttyACM" in x for x in rules)
    sysusers = (SYSTEMD / "mapr.sysusers").read_text()
    assert "m mapr dialout" in sysusers


@pytest.mark.skipif(shutil.which("systemd-analyze") is None,
                    reason="systemd-analyze not installed (apt-get install systemd)")
def test_systemd_analyze_verify_and_security(capsys: pytest.CaptureFixture[str]) -> None:
    checker = load_checker()
    verdict = checker.check()
    assert verdict.verify_problems == []
    if verdict.exposure is None:
        pytest.skip(f"{verdict.version} has no `security --offline` (needs v250+)")
    with capsys.disabled():
        print(f"\n[systemd] {verdict.version}: verify clean, "
              f"security exposure {verdict.exposure:.1f} (target <= 2.0)")
    assert verdict.exposure <= checker.TARGET_EXPOSURE
