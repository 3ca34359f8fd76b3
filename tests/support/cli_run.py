"""``mapr ARGS`` run as a user runs it, for the tests that read its output and exit code."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def mapr(*args: str, stdin: bytes = b"") -> subprocess.CompletedProcess[str]:
    """``mapr ARGS`` in the repository, with ``stdin`` piped in (bytes: e.g. a Chapter 10
    stream) and only this checkout on the path; stdout and stderr as text."""
    run = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], input=stdin,
                         capture_output=True, cwd=ROOT, check=False,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    return subprocess.CompletedProcess(run.args, run.returncode, run.stdout.decode(),
                                       run.stderr.decode())
