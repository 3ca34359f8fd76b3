"""`mapr decode --stats` and `mapr monitor --stats`: per-RT/SA statistics and windowed load."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

DATA = Path(__file__).parents[1] / "data" / "codec"
RAW = str(DATA / "golden-10MSps.bin")
SAMPLE = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "chapter10" / \
    "sample.c10"


def mapr(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args],
                          capture_output=True, text=True, timeout=120, check=False)


def test_decode_stats_counts_every_message_of_the_sample_recording() -> None:
    if not SAMPLE.is_file():
        pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
    messages = mapr("decode", str(SAMPLE))
    assert messages.returncode == 0, messages.stderr
    expected: Counter[tuple[int, int, str, int, int | None]] = Counter()
    errors: Counter[tuple[int, int, str, int, int | None]] = Counter()
    for line in messages.stdout.splitlines():
        m = json.loads(line)
        if m.get("kind") == "arinc429" or "rt" not in m:
            continue
        key = (m["channel"], m["rt"], m["tr"], m["sa"], m.get("mode_code"))
        expected[key] += 1
        errors[key] += len(m["errors"])
        if "rt2" in m:
            expected[(m["channel"], m["rt2"], "T", m["sa2"], None)] += 1
    result = mapr("decode", str(SAMPLE), "--stats", "json")
    assert result.returncode == 0, result.stderr
    lines = [json.loads(x) for x in result.stdout.splitlines()]
    rows = [x for x in lines if x["kind"] == "rtsa"]
    got = Counter({(r["channel"], r["rt"], r["tr"], r["sa"], r.get("mode_code")):
                   r["messages"] for r in rows})   # each 1553 channel a bus of its own
    assert got == expected
    assert sum(sum(r["errors"].values()) for r in rows) == sum(errors.values()) > 0
    loads = [x for x in lines if x["kind"] == "bus_load"]
    assert {x["bus"] for x in loads} == {"A", "B"}
    assert all(0 < x["load_percent"] < 100 for x in loads)


def test_decode_stats_table_of_a_capture() -> None:
    result = mapr("decode", RAW, "--samplerate", "10e6", "--stats")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].split()[:3] == ["RT/SA", "wc", "messages"]
    assert any(line.startswith("RT05 R SA01") for line in lines)
    assert "load %" in result.stdout


def test_decode_stats_window_must_be_positive() -> None:
    result = mapr("decode", RAW, "--stats", "--stats-window", "0")
    assert result.returncode == 2 and "--stats-window" in result.stderr


def test_monitor_stats_json_lines_follow_the_messages() -> None:
    result = mapr("monitor", "--backend", "capture", "-O", f"path={RAW}", "-O",
                  "sample_rate=10e6", "--json", "--stats")
    assert result.returncode == 0, result.stderr
    lines = [json.loads(x) for x in result.stdout.splitlines()]
    shown = [x for x in lines if "kind" not in x]
    rows = [x for x in lines if x.get("kind") == "rtsa"]
    assert shown and rows
    per_key = Counter((m["rt"], m["tr"], m["sa"], m.get("mode_code"))
                      for m in shown if "rt" in m)
    per_key.update((m["rt2"], "T", m["sa2"], None) for m in shown if "rt2" in m)
    assert {(r["rt"], r["tr"], r["sa"], r.get("mode_code")): r["messages"]
            for r in rows} == dict(per_key)
