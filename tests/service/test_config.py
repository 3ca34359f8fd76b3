"""The shipped configs/mapr.yaml documents the defaults, and validation names file:line."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import pytest

from mapr_daemon.errors import ConfigError
from mapr_daemon.icd.yamlsrc import load_text
from mapr_daemon.service.config import Config, load_config, parse
from mapr_daemon.testbed.config import TestbedConfig, parse_section

ROOT = Path(__file__).resolve().parents[2]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"

SHIPPED = ROOT / "configs" / "mapr.yaml"


def test_shipped_config_is_the_defaults() -> None:
    shipped = load_config(SHIPPED)
    assert Path(shipped.icd) == ICD
    assert dataclasses.replace(shipped, source=None, icd=Config().icd, testbed={}) == Config()
    # the testbed: section is the simulator's to read; it too shows the defaults
    assert parse_section(shipped.testbed, shipped.source) == TestbedConfig()


def test_check_accepts_the_shipped_config() -> None:
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "run", "--check",
                           "--config", str(SHIPPED)], cwd=ROOT, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "OK" in done.stderr


@pytest.mark.parametrize(("text", "where"), [
    ("backend:\n  name: usb9\n", ":2: backend.name: expected one of"),
    ("assets:\n  - {name: EMA1, rt: 31}\n", ":2: assets[0].rt: a remote-terminal address"),
    ("catalog: 3\n", ":1: catalog: expected a mapping"),
    ("backend:\n  retry_initial_s: 5\n  retry_max_s: 1\n", ":3: backend.retry_max_s"),
    ("status_interval_s: true\n", ":1: status_interval_s: expected float"),
    ("assets:\n  - name: EMA1\n    signals:\n      phase_current_a: phase_a_current_a\n"
     "      phase_current_b: phase_a_current_a\n",
     ":5: assets[0].signals.phase_current_b: 'phase_a_current_a' is already read from"),
    ("assets:\n  - name: EMA1\n    signals:\n      phase_current_a: phase_current\n",
     ":4: assets[0].signals.phase_current_a: 'phase_current' is not a reasoner channel"),
    ("assets:\n  - name: EMA1\n    signals: {phase_current_a: phase_a_current_a}\n",
     ":3: assets[0].signals: no signal for dc_link_current_a, phase_b_current_a"),
    ("assets:\n  - name: EMA1\n    expected_life_flights:\n      esr: 900\n"
     "      bearing: 300\n", ":5: assets[0].expected_life_flights.bearing: not an aging kind"),
    ("assets:\n  - name: EMA1\n    expected_life_flights: {esr: 0}\n",
     ":3: assets[0].expected_life_flights.esr: must be >= 1"),
    ("record: {path: rec}\naircraft:\n  tail: 'N1;2'\n",
     ":3: aircraft.tail: a recording (record.path) writes the tail into its TMATS record"),
])
def test_errors_name_file_line_and_field(text: str, where: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse(load_text(text, "x.yaml"), "x.yaml")
    assert f"x.yaml{where}" in str(caught.value)


def test_an_expected_life_per_aging_kind_is_read_in_flights() -> None:
    config = parse(load_text("assets:\n  - name: EMA1\n    expected_life_flights:\n"
                             "      esr: 900\n      capacitance: 1200.5\n", "x.yaml"), "x.yaml")
    assert config.assets[0].expected_life_flights == {"esr": 900.0, "capacitance": 1200.5}


def test_relative_paths_follow_the_file(tmp_path: Path) -> None:
    (tmp_path / "mapr.yaml").write_text("reasoner: {dictionary: d.npz}\n", encoding="utf-8")
    config = load_config(tmp_path / "mapr.yaml")
    assert config.reasoner.dictionary == str(tmp_path.resolve() / "d.npz")
    assert config.digest() != Config().digest()


def test_the_default_wiring_reads_what_the_testbed_aircraft_sends() -> None:
    """The default ``assets[0].signals`` names the shipped ICD's signals, and maps each
    sample-block signal to the plant channel the simulated EMA fills it from."""
    from mapr_daemon.icd import load_icd
    from mapr_daemon.pipeline.wiring import DEFAULT_SIGNALS, not_in_icd, problems
    from mapr_daemon.testbed.aircraft import FAST_CHANNELS, POWER_CHANNELS, SLOW_CHANNELS

    assert problems(DEFAULT_SIGNALS) == []
    assert not_in_icd(DEFAULT_SIGNALS, load_icd(ICD)) == []
    sent = {**FAST_CHANNELS, **POWER_CHANNELS, **SLOW_CHANNELS}
    assert {k: v for k, v in DEFAULT_SIGNALS.items() if k in sent} == sent


def test_signals_missing_from_the_icd_stop_the_daemon_at_start(tmp_path: Path) -> None:
    from mapr_daemon.pipeline.pipeline import build_pipeline
    from mapr_daemon.pipeline.wiring import DEFAULT_SIGNALS

    signals = {("phase_i_a" if k == "phase_current_a" else k): v
               for k, v in DEFAULT_SIGNALS.items()}
    config = dataclasses.replace(
        Config(), source="x.yaml",
        assets=(dataclasses.replace(Config().assets[0], signals=signals),),
        reasoner=dataclasses.replace(Config().reasoner, dictionary=str(tmp_path / "d.npz")))
    with pytest.raises(ConfigError) as caught:
        build_pipeline(config)
    assert str(caught.value) == ("x.yaml: assets[0].signals: not in the ICD ema-testbed: "
                                 "phase_i_a")


def test_the_old_name_of_the_testbed_is_read_as_it_with_a_deprecation_warning(
        tmp_path: Path, mapr_log: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "old.yaml"
    path.write_text(f"icd: {ICD}\nbackend:\n  name: loopback\n", encoding="utf-8")
    with mapr_log.at_level("WARNING", logger="mapr"):
        config = load_config(path)
    assert config.backend.name == "testbed"
    assert {r.getMessage() for r in mapr_log.records} == {
        f"{path}:3: backend.name: 'loopback' is deprecated in a daemon config, write 'testbed' "
        "(the simulated aircraft)"}


def test_the_testbed_section_is_checked_by_the_simulator_with_file_and_line(
        tmp_path: Path) -> None:
    from mapr_daemon.service import source

    path = tmp_path / "bad.yaml"
    path.write_text(f"icd: {ICD}\ntestbed:\n  profile: bit\n  actuators:\n"
                    "    - {name: EMA1, rt: 5, actuator: a.yaml}\n"
                    "    - {name: EMA2, rt: 5, actuator: b.yaml}\n", encoding="utf-8")
    config = load_config(path)   # the service does not read the simulator's section
    with pytest.raises(ConfigError) as error:
        source.check(config)
    assert str(error.value) == (f"{path}:6: testbed.actuators[1].rt: expected a free RT "
                                "address 0..30, got 5")
