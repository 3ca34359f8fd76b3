"""``mapr --help`` and each subcommand's parser stay light: building them imports none of
the heavy numerical libraries, so a bus engineer's first command answers at once.

Checked in a fresh interpreter per case (``sys.modules`` after building the parser), never
by timing.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from mapr_daemon.cli.main import SUBCOMMANDS, build_parser

HEAVY = ("numba", "scipy", "filterpy", "matplotlib")

PROBE = """
import json, sys
from mapr_daemon.cli.main import build_parser
build_parser({commands!r})
print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & {heavy!r})))
"""


def _heavy_after(commands: list[str]) -> list[str]:
    code = PROBE.format(commands=commands, heavy=set(HEAVY))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    return list(json.loads(done.stdout))


def test_top_level_help_imports_no_subcommand_and_no_numpy() -> None:
    code = ("import sys\nfrom mapr_daemon.cli.main import build_parser\nbuild_parser([])\n"
            "print(sorted(m for m in sys.modules if m.startswith('mapr_daemon.cli.') "
            "or m.split('.')[0] in ('numpy', 'yaml')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    # notes: the commands' warnings (standard library only)
    assert done.stdout.strip() == ("['mapr_daemon.cli.exitcodes', 'mapr_daemon.cli.main', "
                                   "'mapr_daemon.cli.notes']")


@pytest.mark.parametrize("command", list(SUBCOMMANDS))
def test_subcommand_parser_imports_nothing_heavy(command: str) -> None:
    assert _heavy_after([command]) == []


def test_placeholder_help_matches_each_subcommand() -> None:
    """The one-line help ``mapr --help`` shows without importing a subcommand is the one the
    subcommand declares."""
    full = build_parser()
    sub = next(a for a in full._actions if a.dest == "command")
    declared = {c.dest: c.help for c in sub._choices_actions}  # type: ignore[attr-defined]
    assert declared == SUBCOMMANDS


def test_unknown_command_is_one_line_exit_2() -> None:
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "decod"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "invalid choice: 'decod'" in done.stderr
