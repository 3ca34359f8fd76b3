"""``mapr completion bash|zsh``: the printed script completes what a bus engineer types, run
in a real bash (COMP_WORDS set as bash sets them on TAB)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

BASH = shutil.which("bash")


def script(shell: str) -> str:
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "completion", shell],
                          capture_output=True, text=True, timeout=300, check=True)
    return done.stdout


@pytest.fixture(scope="module")
def bash_script(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("completion") / "mapr.bash"
    path.write_text(script("bash"))
    return path


def complete(bash_script: Path, *words: str) -> list[str]:
    """What TAB offers after ``words`` (the last one being completed)."""
    if BASH is None:
        pytest.skip("bash is not installed")
    quoted = " ".join(f"'{w}'" for w in words)
    code = (f"source '{bash_script}'\nCOMP_WORDS=({quoted})\n"
            "COMP_CWORD=$((${#COMP_WORDS[@]} - 1))\n_mapr\nprintf '%s\\n' \"${COMPREPLY[@]}\"")
    done = subprocess.run([BASH, "--norc", "-c", code], capture_output=True, text=True,
                          timeout=30, check=True)
    return [w for w in done.stdout.splitlines() if w]


def test_commands_options_and_their_values(bash_script: Path) -> None:
    assert complete(bash_script, "mapr", "dec") == ["decode"]
    assert {"decode", "monitor", "record", "completion"} <= set(
        complete(bash_script, "mapr", ""))
    assert complete(bash_script, "mapr", "monitor", "--ba") == ["--backend"]
    assert complete(bash_script, "mapr", "monitor", "--backend", "") == [
        "capture", "chapter10", "loopback", "serial", "testbed", "usb"]
    assert complete(bash_script, "mapr", "monitor", "--error", "par") == ["parity"]
    assert "BC_RT" in complete(bash_script, "mapr", "monitor", "--rt", "5", "--format", "BC")


def test_nested_commands_and_positional_choices(bash_script: Path) -> None:
    assert "list" in complete(bash_script, "mapr", "catalog", "")
    assert "--min-severity" in complete(bash_script, "mapr", "catalog", "list", "--")
    assert complete(bash_script, "mapr", "catalog", "export", "--format", "") == [
        "csv", "json", "jsonl"]
    assert complete(bash_script, "mapr", "catalog", "export", "--what", "") == [
        "events", "bits", "episodes", "inflight"]
    assert complete(bash_script, "mapr", "completion", "") == ["bash", "zsh"]


def test_free_values_fall_back_to_file_names(bash_script: Path) -> None:
    """An option taking a file offers nothing of its own, so the shell completes file names
    (``complete -o default``)."""
    assert complete(bash_script, "mapr", "decode", "--icd", "") == []
    assert "complete -o default -F _mapr mapr" in bash_script.read_text()


def test_zsh_script_loads_bashcompinit_and_the_same_function() -> None:
    zsh = script("zsh")
    assert zsh.startswith("#compdef mapr\n")
    assert "bashcompinit" in zsh and "_mapr()" in zsh
