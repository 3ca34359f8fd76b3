"""`mapr decode --words` and `mapr encode`: golden files, error lines and exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from mapr_daemon.cli.main import main

DATA = Path(__file__).parents[1] / "data" / "codec"
GOLDEN = (DATA / "golden.expected.jsonl").read_text().splitlines()


def run_mapr(*args: str, stdin: bytes | None = None) -> subprocess.CompletedProcess[bytes]:
    """Run the installed command as a user would."""
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], input=stdin,
                          capture_output=True, timeout=120, check=False)


def test_decode_raw_golden(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["decode", str(DATA / "golden-10MSps.bin"), "--samplerate", "10MHz",
                 "--words"]) == 0
    assert capsys.readouterr().out.splitlines() == GOLDEN


def test_decode_sigrok_golden_maps_channels_by_explicit_names(
        capsys: pytest.CaptureFixture[str]) -> None:
    path = str(DATA / "golden-10MSps.sr")
    assert main(["decode", path, "--words",
                 "--channels", "bus_a_rx,bus_a_rxb,bus_b_rx,bus_b_rxb"]) == 0
    assert capsys.readouterr().out.splitlines() == GOLDEN


def test_sigrok_without_our_channel_names_asks_for_channels() -> None:
    result = run_mapr("decode", str(DATA / "golden-10MSps.sr"), "--words")
    assert result.returncode == 2
    err = result.stderr.decode().strip()
    assert len(err.splitlines()) == 1 and "--channels" in err


def test_decode_from_stdin() -> None:
    result = run_mapr("decode", "-", "--samplerate", "10e6", "--words",
                      stdin=(DATA / "golden-10MSps.bin").read_bytes())
    assert result.returncode == 0
    assert result.stdout.decode().splitlines() == GOLDEN


def test_truncated_file_decodes_what_is_there_and_flags_the_cut_word(tmp_path: Path) -> None:
    data = (DATA / "golden-10MSps.bin").read_bytes()
    cut = tmp_path / "cut.bin"
    cut.write_bytes(data[: 1_900])  # 190 µs: inside the word that starts at 180 µs
    result = run_mapr("decode", str(cut), "--samplerate", "10e6", "--words")
    assert result.returncode == 0
    lines = [json.loads(line) for line in result.stdout.decode().splitlines()]
    assert [json.dumps(x) for x in lines[:-1]] == GOLDEN[:7]
    assert abs(lines[-1]["t_ns"] - 180_000) < 150 and "bit_count_low" in lines[-1]["errors"]


@pytest.mark.parametrize("args", [
    ["decode", "/nonexistent/capture.bin", "--samplerate", "10e6", "--words"],
    ["decode", str(DATA / "golden-10MSps.bin"), "--words"],
    ["decode", str(DATA / "golden-10MSps.bin"), "--samplerate", "fast", "--words"],
    ["decode", str(DATA / "golden-10MSps.bin"), "--samplerate", "1e3", "--words"],
    ["decode", str(DATA / "golden-10MSps.bin"), "--samplerate", "8e6", "--words"],
])
def test_bad_file_or_argument_is_one_line_and_exit_2(args: list[str]) -> None:
    result = run_mapr(*args)
    assert result.returncode == 2
    assert len(result.stderr.decode().strip().splitlines()) == 1, result.stderr.decode()
    assert result.stdout == b""


def test_corrupt_sigrok_file_is_one_line_and_exit_2(tmp_path: Path) -> None:
    bad = tmp_path / "bad.sr"
    bad.write_bytes(b"PK\x03\x04" + b"\x00" * 100)
    result = run_mapr("decode", str(bad), "--words")
    assert result.returncode == 2
    assert "bad.sr" in result.stderr.decode()


def test_encode_then_decode_round_trip_with_faults(tmp_path: Path) -> None:
    words = tmp_path / "words.jsonl"
    words.write_text(
        '{"t_ns": 1000, "bus": "A", "sync": "cmd", "value": 10274}\n'
        '# a comment line\n'
        '{"t_ns": 21100, "bus": "A", "sync": "data", "value": 4660, "fault": {"parity": true}}\n'
        '{"t_ns": 60000, "bus": "B", "sync": "data", "value": 65535}\n')
    out = tmp_path / "cap.sr"
    result = run_mapr("encode", str(words), "-o", str(out), "--samplerate", "24e6",
                      "--jitter-ns", "100", "--dead-band-ns", "50")
    assert result.returncode == 0, result.stderr
    decoded = run_mapr("decode", str(out), "--words")
    lines = [json.loads(x) for x in decoded.stdout.decode().splitlines()]
    assert [(x["bus"], x["sync"], x["value"], x["errors"]) for x in lines] == [
        ("A", "cmd", 10274, []), ("A", "data", 4660, ["parity"]), ("B", "data", 65535, [])]


@pytest.mark.parametrize(("line", "message"), [
    ('{"t_ns": 0, "bus": "C", "sync": "cmd", "value": 1}', "words.jsonl:2:"),
    ('{"t_ns": 0, "bus": "A", "sync": "cmd"}', "words.jsonl:2: missing field 'value'"),
    ('{"t_ns": 0, "bus": "A", "sync": "cmd", "value": 70000}', "words.jsonl:2: value 70000"),
    ('not json', "words.jsonl:2:"),
    ('{"t_ns": 0, "sync": "data", "value": 1, "fault": {"no_transition": 40}}', "words.jsonl:2:"),
])
def test_encode_bad_line_names_file_and_line(tmp_path: Path, line: str, message: str) -> None:
    words = tmp_path / "words.jsonl"
    words.write_text('{"t_ns": 50000, "bus": "A", "sync": "cmd", "value": 1}\n' + line + "\n")
    result = run_mapr("encode", str(words), "-o", str(tmp_path / "x.bin"))
    assert result.returncode == 2
    err = result.stderr.decode().strip()
    assert len(err.splitlines()) == 1 and message in err, err


def test_demo_flies_and_names_both_injected_bus_errors() -> None:
    result = run_mapr("demo", "--seconds", "1")
    assert result.returncode == 0, result.stderr
    text = result.stdout.decode()
    assert "ema_fast_block: " in text and "adc_air_data: " in text  # engineering values
    assert "both injected errors named: True" in text
    assert "DC bus 24" in text


def test_demo_rejects_a_bad_fault_with_one_line() -> None:
    result = run_mapr("demo", "--fault", "warp=9")
    assert result.returncode == 78
    assert len(result.stderr.decode().strip().splitlines()) == 1


def test_demo_runs_from_any_directory_and_names_a_missing_icd(tmp_path: Path) -> None:
    """The default message table is found wherever the user stands; a missing one is a line."""
    result = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "demo", "--seconds",
                             "0.2", "--icd", str(tmp_path / "absent.yaml")], cwd=tmp_path,
                            capture_output=True, timeout=120, check=False)
    err = result.stderr.decode().strip()
    assert result.returncode == 2 and len(err.splitlines()) == 1 and "absent.yaml" in err, err
    result = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "demo", "--seconds",
                             "0.2", "--word-level"], cwd=tmp_path, capture_output=True,
                            timeout=120, check=False)
    assert result.returncode == 0, result.stderr.decode()
