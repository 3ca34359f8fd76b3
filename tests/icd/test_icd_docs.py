"""docs/icd.md stays true: its example table loads, its commands print what it shows."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from mapr_daemon.icd import loads_icd

DOC = Path(__file__).resolve().parents[2] / "docs" / "icd.md"


def _blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)


def test_the_example_table_is_valid():
    (example,) = _blocks("yaml")
    icd = loads_icd(example, "docs/icd.md")
    assert [m.name for m in icd.messages] == ["act_command", "act_samples"]
    assert icd.bus_load().load == pytest.approx((250 * (11 * 20 + 20) + 50 * (4 * 20 + 20)) / 1e6)


def _sessions() -> list[tuple[str, str]]:
    """(command, expected output) for each `$ mapr ...` line without a pipe."""
    out = []
    for block in _blocks("console"):
        lines = block.splitlines()
        for i, line in enumerate(lines):
            if line.startswith("$ ") and "|" not in line:
                expected = []
                for following in lines[i + 1:]:
                    if following.startswith("$ "):
                        break
                    expected.append(following)
                out.append((line[2:], "\n".join(expected)))
    return out


@pytest.mark.parametrize(("command", "expected"), _sessions())
def test_the_documented_commands_print_what_the_page_shows(command, expected):
    argv = shlex.split(command)
    assert argv[0] == "mapr"
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *argv[1:]],
                          cwd=DOC.parents[1], capture_output=True, text=True, check=False)
    assert (done.stdout + done.stderr).strip() == expected.strip()
