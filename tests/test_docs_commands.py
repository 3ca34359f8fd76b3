"""The user pages stay true: every `$ mapr ...` line in their console blocks is run, and
what it prints must be what the page shows."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["docs/codec.md", "docs/monitor.md", "docs/testbed.md", "docs/bus-engineer.md"]


def sessions() -> list[tuple[str, str, str]]:
    found = []
    for page in PAGES:
        text = (ROOT / page).read_text(encoding="utf-8")
        for block in re.findall(r"```console\n(.*?)```", text, re.S):
            lines = block.splitlines()
            for i, line in enumerate(lines):
                if not line.startswith("$ "):
                    continue
                expected = []
                for following in lines[i + 1:]:
                    if following.startswith("$ "):
                        break
                    expected.append(following)
                found.append((page, line[2:], "\n".join(expected)))
    return found


@pytest.mark.parametrize(("page", "command", "expected"), sessions(),
                         ids=[f"{p}: {c[:60]}" for p, c, _ in sessions()])
def test_documented_command_prints_what_the_page_shows(page: str, command: str,
                                                       expected: str) -> None:
    argv = shlex.split(command)
    assert argv[0] == "mapr", f"{page}: only mapr commands are run"
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *argv[1:]],
                          cwd=ROOT, capture_output=True, text=True, timeout=300, check=False)
    shown = expected.strip().splitlines()
    printed = (done.stdout + done.stderr).strip().splitlines()
    assert printed[: len(shown)] == shown, f"{page}: {command}"
