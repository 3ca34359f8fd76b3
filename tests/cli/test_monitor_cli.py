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
    result = mapr("monitor", "--backend", "capture", "-o", f"path={RAW}", "-o",
                  "sample_rate=10e6", "--error", "parity", "--stats")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len([x for x in lines if "! " in x]) == 1 and "parity" in lines[0]
    assert lines[1].split()[:4] == ["bus", "messages", "words", "load"]


def test_monitor_json_count() -> None:
    result = mapr("monitor", "--backend", "capture", "-o", f"path={RAW}", "-o",
                  "sample_rate=10e6", "--json", "--count", "2")
    assert result.returncode == 0, result.stderr
    assert [json.loads(x)["format"] for x in result.stdout.splitlines()] == ["BC_RT", "RT_BC"]


def test_monitor_unknown_backend_or_option() -> None:
    bad = mapr("monitor", "--backend", "nosuch")
    assert bad.returncode == 69 and "unknown backend" in bad.stderr
    option = mapr("monitor", "--backend", "capture", "-o", "bogus=1")
    assert option.returncode == 2 and len(option.stderr.strip().splitlines()) == 1
