"""The simulated aircraft as a registered backend: opened by name like any backend, with the
daemon config's ``testbed:`` section, ICD and assets as options."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from drivers.monitor import available_backends, backend_class, open_monitor
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd import load_icd
from mapr_daemon.service import source
from mapr_daemon.service.config import Config
from mapr_daemon.testbed.config import TestbedActuator, TestbedConfig

ROOT = Path(__file__).resolve().parents[2]
TWO = ROOT / "configs" / "icd" / "ema-testbed-two-ema.yaml"
ELEVATOR = str(ROOT / "configs" / "actuators" / "elevator-uav.yaml")
AILERON = str(ROOT / "configs" / "actuators" / "aileron-uav.yaml")
QUICK = {"duration_s": 0.05, "realtime": False, "bit_level": False}


def test_the_testbed_is_a_registered_backend() -> None:
    assert "testbed" in available_backends()
    assert backend_class("testbed").__name__ == "TestbedMonitor"


def test_opened_by_name_with_plain_options_it_flies_the_aircraft() -> None:
    with open_monitor("testbed", testbed=QUICK) as monitor:   # the shipped single-EMA table
        records = list(monitor)
    assert {r.rt for r in records} == {5, 6}
    assert sum(r.rt == 5 and r.sa == 10 for r in records) == 25   # 50 ms of 2 ms frames


def test_the_daemon_opens_two_emas_through_the_registry() -> None:
    testbed = TestbedConfig(**QUICK, actuators=(
        TestbedActuator("EMA1", 5, AILERON), TestbedActuator("EMA2", 7, ELEVATOR, "esr=0.6")))
    config = dataclasses.replace(Config(), icd=str(TWO), testbed=dataclasses.asdict(testbed))
    source.check(config)
    assert config.backend.name == "testbed"   # the default
    with source.monitor_factory(config, load_icd(TWO))() as monitor:
        records = list(monitor)
    assert {r.rt for r in records} == {5, 6, 7}


@pytest.mark.parametrize(("actuators", "problem"), [
    ((TestbedActuator("EMA1", 5, AILERON, "esr=banana"),), "esr"),
    ((TestbedActuator("EMA2", 7, ELEVATOR),), "RT 7"),   # the single-EMA table has no RT 7
])
def test_a_bad_testbed_is_a_config_error_at_start(actuators: tuple[TestbedActuator, ...],
                                                  problem: str) -> None:
    config = dataclasses.replace(Config(), testbed=dict(**QUICK, actuators=actuators))
    with pytest.raises(ConfigError, match=problem):
        source.check(config)


def test_section_keys_are_options_of_their_own_and_bad_ones_are_config_errors() -> None:
    """What ``mapr monitor --backend testbed -O duration_s=0.05`` passes."""
    with open_monitor("testbed", duration_s=0.05, realtime=False, bit_level=False) as monitor:
        assert sum(1 for r in monitor if r.rt == 5 and r.sa == 10) == 25
    with pytest.raises(ConfigError, match="expected a mapping"):
        open_monitor("testbed", testbed=3)
    with pytest.raises(ConfigError, match="colour"):
        open_monitor("testbed", testbed={"profile": "bit", "colour": "red"})
