"""``mapr icd check`` and ``mapr icd dump``: summaries, exit codes and golden layout drawings.

To update a golden file after a deliberate change, run ``mapr icd dump FILE`` into it and
review the diff.
"""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from mapr_daemon.cli.main import main

GOLDEN = [("sample.yaml", "sample.dump.txt"), (None, "ema-testbed.dump.txt")]


@pytest.mark.parametrize(("table", "golden"), GOLDEN)
def test_dump_matches_the_golden_drawing(capsys, data_dir, ema_path, table, golden):
    path = data_dir / table if table else ema_path
    assert main(["icd", "dump", str(path)]) == 0
    assert capsys.readouterr().out == (data_dir / golden).read_text(encoding="utf-8")


def test_check_prints_a_summary_with_the_bus_load(capsys, data_dir):
    path = data_dir / "sample.yaml"
    assert main(["icd", "check", str(path)]) == 0
    out = capsys.readouterr().out
    assert out == (f"{path}: ok: 2 terminals, 3 messages, 12 parameters; "
                   "bus load 1.6 % (busiest minor frame 2.1 %)\n")


def test_check_reports_an_invalid_table_on_one_line_with_exit_78(capsys, data_dir):
    path = data_dir / "bad-overlap.yaml"
    assert main(["icd", "check", str(path)]) == 78
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == (f"mapr icd: {path}:14: nav_state.valid.bits: bit 15 of word 0 "
                            "overlaps 'heading' (line 13)\n")


def test_check_of_a_missing_file_is_a_usage_error(capsys, tmp_path):
    assert main(["icd", "check", str(tmp_path / "nope.yaml")]) == 2
    assert "cannot read" in capsys.readouterr().err


def test_the_console_script_exits_78_on_a_bad_table(data_dir):
    mapr = shutil.which("mapr")
    command = [mapr] if mapr else [sys.executable, "-m", "mapr_daemon.cli.main"]
    done = subprocess.run([*command, "icd", "check", str(data_dir / "bad-overlap.yaml")],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 78
    assert len(done.stderr.splitlines()) == 1
    assert ":14: nav_state.valid.bits: " in done.stderr


def test_the_bench_runs_and_reports_words_per_second(ema_path):
    bench = ema_path.parents[2] / "bench" / "icd.py"
    done = subprocess.run([sys.executable, str(bench), "--seconds", "1"], capture_output=True,
                          text=True, check=True)
    assert "22543 data words in 1282 records" in done.stdout     # one second of the schedule
    assert done.stdout.rstrip().endswith("M words/s (target >= 1 M words/s)")
