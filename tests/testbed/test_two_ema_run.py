"""``bench/two_ema_run.py`` on a short run: ``mapr run`` on the two-actuator testbed with a
seeded fault on the elevator and recording on, then ``mapr replay`` of its recording with the
same config into a second catalog (the bench's own checks, and its printed comparison)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_daemon_and_the_replay_of_its_recording_agree(tmp_path: Path,
                                                          small_models: Path) -> None:
    work = tmp_path / "run"
    done = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "two_ema_run.py"), "--seconds", "6", "--seed",
         "11", "--models", str(small_models), "--keep", str(work)],
        cwd=ROOT, capture_output=True, text=True, timeout=900,
        env={**os.environ, "PYTHONPATH": str(ROOT)})
    out = done.stdout
    assert done.returncode == 0, out + done.stderr
    assert "all checks passed" in out
    # BITs at 0, 2 and 4 s of bus time on each EMA; the elevator's three are one episode
    assert "EMA1: 3 BITs; open episodes none; last BIT's health: SoH " in out, out
    assert "EMA2: 3 BITs; open episodes ['esr']; last BIT's health: SoH " in out, out
    assert "events: daemon 3, replay 3; identical on (asset, fault, bus_ns): True" in out
    assert "EMA2: 3 events, faults ['esr'], bus time 0.033..4.033 s" in out, out
    (recording,) = (work / "recordings").iterdir()
    assert recording.suffix == ".ch10"
