"""``mapr decode FILE.c10``: the same JSON lines as for captures, plus ARINC 429 words."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main

ICD = Path(__file__).resolve().parents[2] / "configs" / "icd" / "ema-testbed.yaml"


def decode(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, list[dict[str, Any]],
                                                                    str]:
    code = main(["decode", *argv])
    out, err = capsys.readouterr()
    return code, [json.loads(line) for line in out.splitlines()], err


def test_the_sample_decodes_to_messages_and_arinc_words(sample_c10: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    # found by its sync pattern, not by its name
    renamed = tmp_path / "flight.bin"
    shutil.copyfile(sample_c10, renamed)
    code, lines, err = decode(capsys, str(renamed))
    assert code == exitcodes.OK
    messages = [x for x in lines if "kind" not in x]
    words = [x for x in lines if x.get("kind") == "arinc429"]
    assert (len(messages), len(words)) == (475, 4861)
    assert sum(x["format"] == "RT_RT" for x in messages) == 11
    assert sum(x["errors"] == ["no_response"] for x in messages) == 27
    assert sum(x["bus"] == "B" for x in messages) == 169
    assert all(not w["errors"] for w in words)
    assert {x["channel"] for x in messages} == {2, 3, 4, 5}
    first = messages[0]
    assert list(first)[:11] == ["t_ns", "bus", "format", "rt", "tr", "sa", "wc", "data",
                                "status", "gaps_ns", "errors"]
    assert first["time"].startswith("day 343 ")
    assert all(len(w["label"]) == 3 and 0 <= int(w["label"], 8) < 256 for w in words)
    assert err.strip() == (f"mapr decode: {renamed}: offset 1042864: truncated packet "
                           "(type 0x40, 5712 of 15636 bytes at the end of the file)")


def test_one_channel_only(sample_c10: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, lines, _ = decode(capsys, str(sample_c10), "--c10-channel", "9", "--year", "2019")
    assert code == exitcodes.OK
    assert {x.get("kind") for x in lines} == {"arinc429"}
    assert {x["channel"] for x in lines} == {9}


def test_icd_values_for_messages_the_table_describes(c10: Any, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    # ema_position_command: RT 5 receive SA 1, three words; 1.000 deg, enabled, POSITION
    words = (5 << 11 | 1 << 5 | 3, 1000, 0x9000, 1200, 5 << 11)
    other = (9 << 11 | 1 << 10 | 4 << 5 | 1, 9 << 11, 0x0042)  # not in the table
    path = tmp_path / "ema.c10"
    path.write_bytes(c10.ms1553([c10.Message(words, ipts=10, gap1=70),
                                 c10.Message(other, ipts=2000, gap1=70)]))
    code, lines, err = decode(capsys, str(path), "--icd", str(ICD))
    assert code == exitcodes.OK and err == ""
    assert lines[0]["values"]["message"] == "ema_position_command"
    assert "values" not in lines[1]
    assert lines[0]["data"] == [1000, 0x9000, 1200] and lines[0]["status"] == [5 << 11]


def test_words_is_refused_for_a_recording(sample_c10: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    code, lines, err = decode(capsys, str(sample_c10), "--words")
    assert code == exitcodes.USAGE and lines == []
    assert "--words applies to bit-level captures" in err


DECODE_PROBE = """
import contextlib, io, json, sys
from mapr_daemon.cli.main import main
with contextlib.redirect_stdout(io.StringIO()) as out:
    code = main(["decode", *{args!r}, {path!r}])
loaded = sorted({{m.split(".")[0] for m in sys.modules}} & {{"numba", "llvmlite", "scipy", "yaml"}}
                | set(sys.modules) & {{"numpy.ma", "mapr_daemon.icd.signals"}})
print(json.dumps([code, out.getvalue().count(chr(10)), loaded]))
"""


def test_decoding_a_recording_loads_no_compiler_and_no_icd_code(sample_c10: Path) -> None:
    """What makes ``mapr decode FILE.c10`` start slowly: numba (and the scipy its array
    functions pull in) or the ICD's YAML parser when no ``--icd`` is given. Checked in a
    fresh interpreter by what it imported, never by timing."""
    probe = DECODE_PROBE.format(args=[], path=str(sample_c10))
    done = subprocess.run([sys.executable, "-c", probe],
                          capture_output=True, text=True, timeout=120, check=True)
    assert json.loads(done.stdout) == [exitcodes.OK, 475 + 4861, []]


def test_a_short_decode_with_an_icd_loads_no_compiler(sample_c10: Path) -> None:
    """``decode --icd`` of a short recording writes its values without numba (loading it
    would cost more than it saves, see COMPILED_AFTER), nor numpy's masked arrays (which
    ``np.unique`` without indices imports) or the ICD's signal stream; checked by what a
    fresh interpreter imported."""
    done = subprocess.run([sys.executable, "-c", DECODE_PROBE.format(
        args=["--icd", str(ICD)], path=str(sample_c10))],
        capture_output=True, text=True, timeout=120, check=True)
    assert json.loads(done.stdout) == [exitcodes.OK, 475 + 4861, ["yaml"]]
