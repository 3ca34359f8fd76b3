"""`mapr decode` (messages) and `mapr monitor` on the capture backend."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

DATA = Path(__file__).parents[1] / "data" / "codec"
RAW = str(DATA / "golden-10MSps.bin")


def mapr(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args],
                          capture_output=True, text=True, timeout=120, check=False)


def test_decode_prints_one_json_object_per_message() -> None:
    result = mapr("decode", RAW, "--samplerate", "10e6")
    assert result.returncode == 0, result.stderr
    first = json.loads(result.stdout.splitlines()[0])
    assert first == {"t_ns": first["t_ns"], "bus": "A", "format": "BC_RT", "rt": 5, "tr": "R",
                     "sa": 1, "wc": 2, "data": [0x8000, 0x7FFF], "status": [0x2800],
                     "gaps_ns": first["gaps_ns"], "errors": []}
    assert abs(first["t_ns"] - 2_000) < 100 and abs(first["gaps_ns"][0] - 8_000) < 150


def test_monitor_text_filters_and_stats() -> None:
    result = mapr("monitor", "--backend", "capture", "-O", f"path={RAW}", "-O",
                  "sample_rate=10e6", "--error", "parity", "--stats")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len([x for x in lines if "! " in x]) == 1 and "parity" in lines[0]
    assert lines[1].split()[:4] == ["bus", "messages", "words", "load"]


def test_monitor_json_count() -> None:
    result = mapr("monitor", "--backend", "capture", "-O", f"path={RAW}", "-O",
                  "sample_rate=10e6", "--json", "--count", "2")
    assert result.returncode == 0, result.stderr
    assert [json.loads(x)["format"] for x in result.stdout.splitlines()] == ["BC_RT", "RT_BC"]


def test_monitor_unknown_backend_or_option() -> None:
    bad = mapr("monitor", "--backend", "nosuch")
    assert bad.returncode == 2 and "invalid choice: 'nosuch'" in bad.stderr  # a bad argument
    option = mapr("monitor", "--backend", "capture", "-O", "bogus=1")
    assert option.returncode == 2 and len(option.stderr.strip().splitlines()) == 1


EMA = str(DATA / "ema-cruise-20ms.sr")
ICD = str(Path(__file__).parents[2] / "configs" / "icd" / "ema-testbed.yaml")


def test_decode_with_the_message_table_adds_engineering_values() -> None:
    result = mapr("decode", EMA, "--icd", ICD)
    assert result.returncode == 0, result.stderr
    records = [json.loads(x) for x in result.stdout.splitlines()]
    assert len(records) == 29 and all(r["errors"] == [] for r in records)
    by_name = {r["values"]["message"]: r["values"] for r in records if "values" in r}
    assert set(by_name) >= {"ema_fast_block", "ema_power_block", "ema_position_command",
                            "ema_position_feedback", "adc_air_data", "ema_slow_block",
                            "ema_air_data"}
    air = by_name["adc_air_data"]
    assert air["pressure_altitude"] == 1500.0 and abs(air["true_airspeed"] - 55.0) < 0.01
    assert len(by_name["ema_fast_block"]["surface_position"]) == 4
    assert by_name["ema_position_command"]["command_mode"] == "POSITION"


def test_monitor_with_the_message_table_shows_values_with_units() -> None:
    result = mapr("monitor", "--backend", "capture", "-O", f"path={EMA}", "--icd", ICD,
                  "--rt", "6")
    assert result.returncode == 0, result.stderr
    assert "adc_air_data: pressure_altitude=1500.00000 m" in result.stdout
    assert "true_airspeed=55.000 m/s" in result.stdout


def test_an_invalid_message_table_is_exit_78_with_file_and_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("spec: 1\nname: x\nterminals:\n  - {address: 40, name: a}\n")
    result = mapr("decode", EMA, "--icd", str(bad))
    assert result.returncode == 78
    assert str(bad) in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_monitor_text_has_decodes_channel_column_for_a_recording_only(tmp_path: Path) -> None:
    """A recording's records carry their channel: the monitor's lines give it after the time,
    in ``decode --text``'s ``ch`` column; a capture (one bus, no channel) has no column."""
    from tests.support.multibus import RATE_HZ, SECONDS, write_recording

    path = write_recording(tmp_path / "two.c10", [2, 13])
    monitor = mapr("monitor", "--backend", "chapter10", "-O", f"path={path}")
    decode = mapr("decode", str(path), "--text")
    assert monitor.returncode == decode.returncode == 0, monitor.stderr + decode.stderr
    lines = monitor.stdout.splitlines()
    header, *rows = decode.stdout.splitlines()
    assert header[:18].split() == ["time_s", "ch"] and len(lines) == 2 * 3 * RATE_HZ * SECONDS
    assert sorted(line[:18] for line in lines) == sorted(row[:18] for row in rows)
    assert {line[12:18] for line in lines} == {"     2", "    13"}
    assert [line.split()[2:4] for line in lines[:3]] == [["A", "RT_BC"], ["A", "BC_RT"],
                                                          ["B", "RT_RT"]]
    live = mapr("monitor", "--backend", "capture", "-O", f"path={RAW}", "-O",
                "sample_rate=10e6", "--count", "1")
    assert live.stdout.split()[1:3] == ["A", "BC_RT"]
