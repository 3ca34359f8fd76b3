"""Every daemon config shipped in ``configs/`` passes ``mapr run --check`` as shipped, or the
check names the one thing missing, a fault dictionary (a built product, not a shipped file),
and prints the exact ``mapr dictionary build`` command line that makes it."""

from __future__ import annotations

import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from mapr_daemon.cli.dictionary_hint import build_command
from mapr_daemon.cli.main import build_parser

ROOT = Path(__file__).resolve().parents[2]


def daemon_configs() -> list[Path]:
    """YAML files under configs/ whose top level is a daemon config's (a backend, an ICD)."""
    found = []
    for path in sorted((ROOT / "configs").rglob("*.yaml")):
        raw = yaml.safe_load(path.read_text(encoding="utf-8"))
        if isinstance(raw, dict) and "backend" in raw and "icd" in raw:
            found.append(path)
    return found


def test_the_shipped_daemon_configs_are_found() -> None:
    names = {p.name for p in daemon_configs()}
    assert {"mapr.yaml", "mapr-two-ema.yaml"} <= names


@pytest.mark.parametrize("config", daemon_configs(), ids=lambda p: p.name)
def test_run_check_passes_or_says_what_to_build(config: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "run", "--check",
                           "--config", str(config.relative_to(ROOT))], cwd=ROOT,
                          capture_output=True, text=True, timeout=300, check=False)
    if done.returncode == 0:
        return
    assert done.returncode == 78, done.stderr
    lines = done.stderr.strip().splitlines()
    assert "dictionary: " in lines[0] and "no such file" in lines[0], done.stderr
    assert len(lines) == 2 and "mapr run: build it first: mapr dictionary build " in lines[1]
    argv = shlex.split(lines[1].split("build it first: ", 1)[1])
    args = build_parser(["dictionary"]).parse_args(argv[1:])   # a command mapr takes
    assert Path(ROOT / args.actuator).is_file()
    missing = lines[0].split(": no such file")[0].rsplit(": ", 1)[1]
    assert Path(ROOT / args.output).resolve() == Path(missing).resolve()


def test_each_asset_is_built_at_the_rate_its_sensors_carry_on_this_bus() -> None:
    """configs/mapr-two-ema.yaml: the elevator's blocks carry 1 kHz, the aileron's 2 kHz."""
    config = str(ROOT / "configs" / "mapr-two-ema.yaml")
    aileron = build_command(config, "x.yaml:33: assets[0].dictionary: a.npz: no such file")
    elevator = build_command(config, "x.yaml:38: assets[1].dictionary: e.npz: no such file")
    assert aileron is not None and elevator is not None
    assert "--actuator" in aileron and "aileron-uav.yaml --sample-rate 2000 " in aileron
    assert "elevator-uav.yaml --sample-rate 1000 -o " in elevator
    assert elevator.endswith("dictionaries/elevator-uav.npz")
    assert build_command(config, "x.yaml:3: icd: nothere.yaml: no such file") is None
